#include "mmba/geometry/opk.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace mmba {
namespace {

/// Turns the photogrammetric camera frame (y up, z back) into mmba's (y down, z forward).
Eigen::Matrix3d FlipYZ() { return Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal(); }

}  // namespace

Eigen::Matrix3d WorldFromPhotoCamRotation(double omega_rad, double phi_rad, double kappa_rad) {
  return (Eigen::AngleAxisd(omega_rad, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(phi_rad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(kappa_rad, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Rigid3d CamFromWorldFromOpk(const OpkPose& opk) {
  const Eigen::Matrix3d cam_from_world =
      FlipYZ() * WorldFromPhotoCamRotation(opk.omega_rad, opk.phi_rad, opk.kappa_rad).transpose();
  const Eigen::Quaterniond rotation(cam_from_world);
  return Rigid3d(rotation, -(cam_from_world * opk.center_in_world));
}

OpkPose OpkFromCamFromWorld(const Rigid3d& cam_from_world) {
  // R = R1(ω) R2(φ) R3(κ) has first row (cφcκ, −cφsκ, sφ) and last column (sφ, −sωcφ, cωcφ).
  const Eigen::Matrix3d r = (FlipYZ() * cam_from_world.rotation.toRotationMatrix()).transpose();
  OpkPose opk;
  opk.phi_rad = std::asin(std::max(-1.0, std::min(1.0, r(0, 2))));
  if (std::abs(r(0, 2)) < 1.0 - 1e-12) {
    opk.omega_rad = std::atan2(-r(1, 2), r(2, 2));
    opk.kappa_rad = std::atan2(-r(0, 1), r(0, 0));
  } else {
    // cφ = 0: R = R1(ω) R2(±90°) R3(κ) depends on κ ± ω only; take ω = 0, then R(1, 0) = sκ,
    // R(1, 1) = cκ.
    opk.omega_rad = 0.0;
    opk.kappa_rad = std::atan2(r(1, 0), r(1, 1));
  }
  opk.center_in_world = cam_from_world.TargetOriginInSource();
  return opk;
}

}  // namespace mmba
