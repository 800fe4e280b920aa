#include "mmba/geometry/rigid3d.h"

#include <gtest/gtest.h>

#include "mmba/geometry/sim3d.h"

namespace mmba {
namespace {

Rigid3d RandomRigid(int seed) {
  std::srand(seed);
  return Rigid3d(Eigen::Quaterniond::UnitRandom(), Eigen::Vector3d::Random() * 10);
}

TEST(Rigid3d, InverseComposesToIdentity) {
  const Rigid3d b_from_a = RandomRigid(1);
  const Rigid3d a_from_a = b_from_a.Inverse() * b_from_a;
  EXPECT_LT(a_from_a.rotation.angularDistance(Eigen::Quaterniond::Identity()), 1e-12);
  EXPECT_LT(a_from_a.translation.norm(), 1e-12);
}

TEST(Rigid3d, CompositionMatchesMatrices) {
  const Rigid3d c_from_b = RandomRigid(2);
  const Rigid3d b_from_a = RandomRigid(3);
  const Eigen::Vector3d point_in_a(1.0, -2.0, 3.0);
  const Eigen::Vector3d expected =
      (c_from_b.ToMatrix4() * b_from_a.ToMatrix4() * point_in_a.homogeneous()).head<3>();
  EXPECT_LT(((c_from_b * b_from_a) * point_in_a - expected).norm(), 1e-12);
  EXPECT_LT((c_from_b * (b_from_a * point_in_a) - expected).norm(), 1e-12);
}

TEST(Rigid3d, FromMatrixRoundTripAndCentre) {
  const Rigid3d cam_from_world = RandomRigid(4);
  const Rigid3d back = Rigid3d::FromMatrix(cam_from_world.ToMatrix3x4());
  EXPECT_LT(RotationDifferenceRad(back, cam_from_world), 1e-12);
  EXPECT_LT(TranslationDifference(back, cam_from_world), 1e-12);
  // The projection centre maps to the camera origin.
  EXPECT_LT((cam_from_world * cam_from_world.TargetOriginInSource()).norm(), 1e-12);
}

TEST(Sim3d, InverseAndComposition) {
  const Sim3d b_from_a(2.5, Eigen::Quaterniond::UnitRandom(), Eigen::Vector3d(1, 2, 3));
  const Eigen::Vector3d p(0.3, -0.7, 4.0);
  EXPECT_LT((b_from_a.Inverse() * (b_from_a * p) - p).norm(), 1e-12);
  const Sim3d c_from_b(0.5, Eigen::Quaterniond::UnitRandom(), Eigen::Vector3d(-1, 0, 2));
  EXPECT_LT(((c_from_b * b_from_a) * p - c_from_b * (b_from_a * p)).norm(), 1e-12);
}

TEST(Sim3d, TransformedCameraSeesTheSameImage) {
  // A camera and a point moved together by a similarity give the same normalised
  // image coordinates.
  const Rigid3d cam_from_world = RandomRigid(5);
  const Eigen::Vector3d point_in_world(0.5, 0.2, 12.0);
  const Sim3d new_from_world(3.0, Eigen::Quaterniond::UnitRandom(), Eigen::Vector3d(4, 5, 6));
  const Rigid3d cam_from_new = new_from_world.TransformCamFromSource(cam_from_world);
  const Eigen::Vector3d a = cam_from_world * point_in_world;
  const Eigen::Vector3d b = cam_from_new * (new_from_world * point_in_world);
  EXPECT_LT((a.hnormalized() - b.hnormalized()).norm(), 1e-12);
  EXPECT_NEAR(b.norm() / a.norm(), 3.0, 1e-12);
}

}  // namespace
}  // namespace mmba
