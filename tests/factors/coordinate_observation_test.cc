#include "mmba/factors/coordinate_observation.h"

#include <memory>

#include <gtest/gtest.h>

#include "gradient_check.h"

namespace mmba::factors {
namespace {

TEST(ScalarPriorCost, HandComputedComponent) {
  // Component 1 of (0, 3, 0) against 2 with σ = 0.5 → 2.
  const ScalarPriorCost cost(1, 2.0, 0.5);
  const double x[3] = {0, 3, 0};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(cost, {x}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
  ExpectGradientsMatch(cost, {x});
}

TEST(GnssAxisCost, EastNorthAndUpBlocks) {
  // North (axis 1) of the east-north block (0, 2) against 1, σ = 0.5 → 2.
  const GnssAxisCost north(1, 1.0, 0.5);
  ASSERT_EQ(north.parameter_block_sizes(), std::vector<int32_t>({2}));
  const double en[2] = {0.0, 2.0};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(north, {en}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
  ExpectGradientsMatch(north, {en});

  // Up (axis 2) is the one-value up block: 5 against 4, σ = 0.25 → 4.
  const GnssAxisCost up(2, 4.0, 0.25);
  ASSERT_EQ(up.parameter_block_sizes(), std::vector<int32_t>({1}));
  const double z[1] = {5.0};
  ASSERT_TRUE(EvaluateCost(up, {z}, &r));
  EXPECT_NEAR(r[0], 4.0, 1e-12);
  ExpectGradientsMatch(up, {z});
}

TEST(GnssCameraAxisCost, HandComputedAntennaHeight) {
  // cam_from_world = (I, (1, 2, 3)), antenna at (0, 0, 1) in the camera: the antenna in the
  // world is lever − t = (−1, −2, −2). Up observed −3, σ = 0.5 → 2. The quaternion block is
  // normalised: twice the identity gives the same residual.
  std::unique_ptr<ceres::CostFunction> cost(GnssCameraAxisCost::Create(2, Eigen::Vector3d(0, 0, 1), -3.0, 0.5));
  const double t[3] = {1, 2, 3};
  for (double scale : {1.0, 2.0}) {
    const double q[4] = {0, 0, 0, scale};
    std::vector<double> r;
    ASSERT_TRUE(EvaluateCost(*cost, {q, t}, &r));
    EXPECT_NEAR(r[0], 2.0, 1e-12) << scale;
  }
}

TEST(GnssCameraAxisCost, GradientCheck) {
  for (int axis = 0; axis < 3; ++axis) {
    std::unique_ptr<ceres::CostFunction> cost(
        GnssCameraAxisCost::Create(axis, Eigen::Vector3d(0.1, -0.3, 0.2), 1.5, 0.02));
    const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized();
    const double t[3] = {1, -2, 0.5};
    ExpectGradientsMatch(*cost, {q.coeffs().data(), t}, {0});
  }
}

TEST(ScanTargetCost, HandComputedOffset) {
  // scan_from_world = (I, (0, 0, 1)); the point (1, 2, 3) is (1, 2, 4) in the scan, measured
  // at (1, 2, 3); σ = 0.5 m → r = (0, 0, 2).
  std::unique_ptr<ceres::CostFunction> cost(ScanTargetCost::Create(Eigen::Vector3d(1, 2, 3), 0.5));
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 1}, en[2] = {1, 2}, up[1] = {3};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {q, t, en, up}, &r));
  EXPECT_NEAR(r[0], 0.0, 1e-12);
  EXPECT_NEAR(r[1], 0.0, 1e-12);
  EXPECT_NEAR(r[2], 2.0, 1e-12);
}

TEST(ScanTargetCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(ScanTargetCost::Create(Eigen::Vector3d(5, -2, 1), 0.003));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized();
  const double t[3] = {1, -2, 0.5}, en[2] = {3, 4}, up[1] = {-1};
  ExpectGradientsMatch(*cost, {q.coeffs().data(), t, en, up}, {0});
}

}  // namespace
}  // namespace mmba::factors
