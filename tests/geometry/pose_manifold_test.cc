#include "mmba/geometry/pose_manifold.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace mmba {
namespace {

TEST(PoseManifold, PlusKeepsUnitQuaternionAndMovesTranslation) {
  auto manifold = CreatePoseManifold();
  EXPECT_EQ(manifold->AmbientSize(), 7);
  EXPECT_EQ(manifold->TangentSize(), 6);
  const Eigen::Quaterniond q = Eigen::Quaterniond::UnitRandom();
  double x[7] = {q.x(), q.y(), q.z(), q.w(), 1.0, 2.0, 3.0};
  const double delta[6] = {0.1, -0.2, 0.05, 0.5, 0.0, -1.0};
  double y[7];
  ASSERT_TRUE(manifold->Plus(x, delta, y));
  EXPECT_NEAR(Eigen::Map<const Eigen::Vector4d>(y).norm(), 1.0, 1e-12);
  EXPECT_NEAR(y[4], 1.5, 1e-12);
  EXPECT_NEAR(y[6], 2.0, 1e-12);
  double back[6];
  ASSERT_TRUE(manifold->Minus(y, x, back));
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(back[i], delta[i], 1e-9);
}

TEST(FixedNormManifold, KeepsTheNormOfAnyVector) {
  auto manifold = CreateFixedNormManifold();
  EXPECT_EQ(manifold->TangentSize(), 2);
  const double x[3] = {3.0, 4.0, 12.0};  // norm 13
  const double delta[2] = {0.3, -0.2};
  double y[3];
  ASSERT_TRUE(manifold->Plus(x, delta, y));
  EXPECT_NEAR(Eigen::Map<const Eigen::Vector3d>(y).norm(), 13.0, 1e-12);
  EXPECT_GT((Eigen::Map<const Eigen::Vector3d>(y) - Eigen::Map<const Eigen::Vector3d>(x)).norm(),
            0.1);
}

}  // namespace
}  // namespace mmba
