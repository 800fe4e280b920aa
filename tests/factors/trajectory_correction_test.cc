#include "mmba/factors/trajectory_correction.h"

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "gradient_check.h"

namespace mmba::factors {
namespace {

TEST(CorrectedWorldPoint, InterpolatedRotationThenShift) {
  // Halfway between nodes turning 90° about z with shifts 1 m and 3 m in x: ω = (0, 0, π/2),
  // δ = (2, 0, 0). GNSS/INS pose (I, (10, 0, 0)); body point (1, 0, 0) turns to (0, 1, 0):
  // world (12, 1, 0).
  const double a[6] = {0, 0, M_PI / 2, 1, 0, 0}, b[6] = {0, 0, M_PI / 2, 3, 0, 0};
  const Rigid3d ins(Eigen::Quaterniond::Identity(), Eigen::Vector3d(10, 0, 0));
  const Eigen::Vector3d x = CorrectedWorldPoint<double>(a, b, 0.5, ins, Eigen::Vector3d(1, 0, 0));
  EXPECT_NEAR(x.x(), 12.0, 1e-12);
  EXPECT_NEAR(x.y(), 1.0, 1e-12);
  EXPECT_NEAR(x.z(), 0.0, 1e-12);
}

TEST(NodePriorCost, RotationFirstThenShift) {
  // ω_x = 0.01 rad with σ_rad = 0.01, δ_z = 0.2 m with σ_m = 0.1 → r = (1, 0, 0, 0, 0, 2).
  std::unique_ptr<ceres::CostFunction> cost(NodePriorCost::Create(0.1, 0.01));
  const double c[6] = {0.01, 0, 0, 0, 0, 0.2};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {c}, &r));
  const double expected[6] = {1, 0, 0, 0, 0, 2};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(r[k], expected[k], 1e-12) << k;
  const double generic[6] = {0.01, -0.02, 0.005, 0.3, -0.1, 0.2};
  ExpectGradientsMatch(*cost, {generic});
}

TEST(GaussMarkovNodeCost, HandComputedInnovation) {
  // φ = 0.6 (√(1 − φ²) = 0.8), σ_m = 0.5: δ_z from 1 to 2 → (2 − 0.6)/(0.5·0.8) = 3.5.
  std::unique_ptr<ceres::CostFunction> cost(GaussMarkovNodeCost::Create(0.6, 0.5, 0.01));
  const double previous[6] = {0, 0, 0, 0, 0, 1}, c[6] = {0, 0, 0, 0, 0, 2};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {previous, c}, &r));
  EXPECT_NEAR(r[5], 3.5, 1e-12);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(r[k], 0.0, 1e-12) << k;
}

TEST(GaussMarkovNodeCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(GaussMarkovNodeCost::Create(0.8, 0.05, 0.002));
  const double previous[6] = {0.01, -0.02, 0.005, 0.3, -0.1, 0.2}, c[6] = {0.012, -0.01, 0.004, 0.25, -0.2, 0.3};
  ExpectGradientsMatch(*cost, {previous, c});
}

TEST(SecondDifferenceCost, HandComputedAndUnconstrainedPart) {
  // δ_z = 1, 2, 4: second difference 1 m, σ_m = 0.25 → 4. σ_rad = 0 leaves the rotation
  // free: a rotation second difference gives no residual.
  std::unique_ptr<ceres::CostFunction> cost(SecondDifferenceCost::Create(0.25, 0.0));
  const double a[6] = {0.1, 0, 0, 0, 0, 1}, b[6] = {0, 0, 0, 0, 0, 2}, c[6] = {0.3, 0, 0, 0, 0, 4};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {a, b, c}, &r));
  EXPECT_NEAR(r[5], 4.0, 1e-12);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(r[k], 0.0, 1e-12) << k;
}

TEST(SecondDifferenceCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(SecondDifferenceCost::Create(0.05, 0.002));
  const double a[6] = {0.01, -0.02, 0.005, 0.3, -0.1, 0.2}, b[6] = {0.012, -0.01, 0.004, 0.25, -0.2, 0.3},
               c[6] = {0.02, 0.01, -0.004, 0.1, -0.3, 0.35};
  ExpectGradientsMatch(*cost, {a, b, c});
}

}  // namespace
}  // namespace mmba::factors
