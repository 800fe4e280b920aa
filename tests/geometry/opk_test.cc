#include "mmba/geometry/opk.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mmba {
namespace {

constexpr double kDeg = M_PI / 180.0;

// ω = φ = κ = 0: the camera looks down (−Z of the world), its x along world X and its image
// y (down) along world −Y.
TEST(Opk, LevelCameraLooksDown) {
  OpkPose opk;
  opk.center_in_world = Eigen::Vector3d(10, 20, 100);
  const Rigid3d cam_from_world = CamFromWorldFromOpk(opk);
  const Eigen::Vector3d below = cam_from_world * Eigen::Vector3d(10, 20, 40);
  EXPECT_NEAR((below - Eigen::Vector3d(0, 0, 60)).norm(), 0.0, 1e-12);
  const Eigen::Vector3d east_north = cam_from_world * Eigen::Vector3d(11, 22, 40);
  EXPECT_NEAR((east_north - Eigen::Vector3d(1, -2, 60)).norm(), 0.0, 1e-12);
}

// ω = 90°: R1(90°) turns the camera's back axis to world −Y, so it looks north (+Y) with its
// image up along world +Z.
TEST(Opk, HandComputedRotations) {
  OpkPose opk;
  opk.omega_rad = 90 * kDeg;
  Rigid3d cam_from_world = CamFromWorldFromOpk(opk);
  EXPECT_NEAR((cam_from_world * Eigen::Vector3d(0, 10, 0) - Eigen::Vector3d(0, 0, 10)).norm(), 0, 1e-12);
  EXPECT_NEAR((cam_from_world * Eigen::Vector3d(0, 10, 3) - Eigen::Vector3d(0, -3, 10)).norm(), 0, 1e-12);
  // κ = 90° alone: R = R3(90°) takes the camera's x to world +Y; looking down, a point at
  // world +Y is to the right of the image.
  opk = OpkPose();
  opk.kappa_rad = 90 * kDeg;
  cam_from_world = CamFromWorldFromOpk(opk);
  EXPECT_NEAR((cam_from_world * Eigen::Vector3d(0, 1, -10) - Eigen::Vector3d(1, 0, 10)).norm(), 0, 1e-12);
  // φ = 90° alone: R2(90°) takes the camera's back axis to world +X: it looks along −X.
  opk = OpkPose();
  opk.phi_rad = 90 * kDeg;
  cam_from_world = CamFromWorldFromOpk(opk);
  EXPECT_NEAR((cam_from_world * Eigen::Vector3d(-5, 0, 0) - Eigen::Vector3d(0, 0, 5)).norm(), 0, 1e-12);
}

TEST(Opk, RoundTripOverAGrid) {
  int checked = 0;
  for (double omega = -170; omega <= 170; omega += 34) {
    for (double phi = -85; phi <= 85; phi += 17) {
      for (double kappa = -175; kappa <= 175; kappa += 35) {
        OpkPose opk;
        opk.omega_rad = omega * kDeg;
        opk.phi_rad = phi * kDeg;
        opk.kappa_rad = kappa * kDeg;
        opk.center_in_world = Eigen::Vector3d(omega, phi, kappa) * 0.1;
        const OpkPose back = OpkFromCamFromWorld(CamFromWorldFromOpk(opk));
        EXPECT_NEAR(back.omega_rad, opk.omega_rad, 1e-9) << omega << " " << phi << " " << kappa;
        EXPECT_NEAR(back.phi_rad, opk.phi_rad, 1e-9);
        EXPECT_NEAR(back.kappa_rad, opk.kappa_rad, 1e-9);
        EXPECT_NEAR((back.center_in_world - opk.center_in_world).norm(), 0.0, 1e-9);
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 11 * 11 * 11);
}

// At φ = ±90° only κ ∓ ω is defined: the decomposition gives ω = 0 and the same rotation.
TEST(Opk, GimbalLockKeepsTheRotation) {
  for (double phi : {90.0, -90.0}) {
    OpkPose opk;
    opk.omega_rad = 30 * kDeg;
    opk.phi_rad = phi * kDeg;
    opk.kappa_rad = -50 * kDeg;
    const Rigid3d cam_from_world = CamFromWorldFromOpk(opk);
    const OpkPose back = OpkFromCamFromWorld(cam_from_world);
    EXPECT_EQ(back.omega_rad, 0.0);
    EXPECT_NEAR(RotationDifferenceRad(CamFromWorldFromOpk(back), cam_from_world), 0.0, 1e-7);
  }
}

}  // namespace
}  // namespace mmba
