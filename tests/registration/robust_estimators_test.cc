#include "mmba/registration/cloud/robust_estimators.h"

#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace mmba::registration {
namespace {

Eigen::Matrix4d MakeTransform(double angle_rad, const Eigen::Vector3d& axis,
                              const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

Eigen::Vector3d Apply(const Eigen::Matrix4d& m, const Eigen::Vector3d& p) {
  return m.topLeftCorner<3, 3>() * p + m.topRightCorner<3, 1>();
}

TEST(EstimateRigid, RecoversExactTransform) {
  const Eigen::Matrix4d truth = MakeTransform(2.5, {0.3, -1, 0.2}, {1, -2, 3});
  std::vector<Eigen::Vector3d> src = {{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {0, 0, 3}, {1, 1, 1}};
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(Apply(truth, p));
  EXPECT_LT((EstimateRigid(src, dst) - truth).norm(), 1e-9);
}

TEST(EstimateRigid, ReflectionIsNotReturned) {
  // Mirror-image data: the best rotation must still be a proper rotation (det +1).
  std::vector<Eigen::Vector3d> src = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
  std::vector<Eigen::Vector3d> dst = {{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
  const Eigen::Matrix4d m = EstimateRigid(src, dst);
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  EXPECT_NEAR(r.determinant(), 1.0, 1e-9);
}

TEST(EstimateRigid, GravityConstrainedYawOnly) {
  const Eigen::Vector3d up(0, 0, 1);
  const Eigen::Matrix4d truth = MakeTransform(-1.2, up, {5, 6, -1});
  std::vector<Eigen::Vector3d> src = {{0, 0, 0}, {3, 1, 0.5}, {-2, 4, 1}};
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(Apply(truth, p));
  EXPECT_LT((EstimateRigid(src, dst, &up) - truth).norm(), 1e-9);
  // Two points suffice when the rotation is about up only.
  src.resize(2);
  dst.resize(2);
  EXPECT_LT((EstimateRigid(src, dst, &up) - truth).norm(), 1e-9);
}

TEST(MaxConsistentClique, FindsInliersAmongOutliers) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-10, 10);
  const Eigen::Matrix4d truth = MakeTransform(0.7, {1, 1, 0}, {2, 0, -1});
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<bool> inlier;
  for (int i = 0; i < 120; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    src.push_back(p);
    const bool good = i % 4 == 0;  // 25 % inliers
    inlier.push_back(good);
    dst.push_back(good ? Apply(truth, p) : Eigen::Vector3d(u(rng), u(rng), u(rng)));
  }
  CliqueOptions options;
  options.tolerance_m = 0.05;
  bool exact = false;
  const std::vector<int> clique = MaxConsistentClique(src, dst, options, &exact);
  ASSERT_GE(clique.size(), 30u);
  for (int i : clique) EXPECT_TRUE(inlier[i]) << i;
  std::vector<Eigen::Vector3d> cs, cd;
  for (int i : clique) {
    cs.push_back(src[i]);
    cd.push_back(dst[i]);
  }
  EXPECT_LT((EstimateRigid(cs, cd) - truth).norm(), 1e-9);
}

TEST(RotationAngleDeg, KnownAngle) {
  EXPECT_NEAR(RotationAngleDeg(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()).toRotationMatrix()),
              0.5 * 180 / M_PI, 1e-9);
}

}  // namespace
}  // namespace mmba::registration
