#include "mmba/factors/snavely_reprojection_error.h"

#include <memory>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

namespace mmba::factors {
namespace {

// The analytic Jacobian equals the autodiff one of Ceres' example functor, also for
// near-zero rotations (the Taylor branch).
TEST(SnavelyReprojectionError, AnalyticMatchesAutoDiff) {
  std::unique_ptr<ceres::CostFunction> analytic(SnavelyReprojectionError::Create(12.5, -30.0));
  std::unique_ptr<ceres::CostFunction> autodiff(
      SnavelyReprojectionErrorAutoDiff::Create(12.5, -30.0));
  for (double rotation_scale : {0.3, 1e-9, 0.0, 2.5}) {
    const double camera[9] = {rotation_scale * 0.2, -rotation_scale * 0.5, rotation_scale * 0.1,
                              0.3, -0.2, -8.0, 800.0, -0.05, 0.002};
    const double point[3] = {0.5, -1.0, 2.0};
    const double* blocks[2] = {camera, point};
    double r1[2], r2[2], j1c[18], j1p[6], j2c[18], j2p[6];
    double* j1[2] = {j1c, j1p};
    double* j2[2] = {j2c, j2p};
    ASSERT_TRUE(analytic->Evaluate(blocks, r1, j1));
    ASSERT_TRUE(autodiff->Evaluate(blocks, r2, j2));
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(r1[i], r2[i], 1e-9);
    for (int i = 0; i < 18; ++i) EXPECT_NEAR(j1c[i], j2c[i], 1e-7 * (1 + std::abs(j2c[i])));
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(j1p[i], j2p[i], 1e-7 * (1 + std::abs(j2p[i])));
  }
}

TEST(SnavelyReprojectionError, GradientChecker) {
  std::unique_ptr<ceres::CostFunction> analytic(SnavelyReprojectionError::Create(1.0, 2.0));
  const double camera[9] = {0.1, 0.2, -0.3, 0.3, -0.2, -8.0, 800.0, -0.05, 0.002};
  const double point[3] = {0.5, -1.0, 2.0};
  const double* blocks[2] = {camera, point};
  ceres::NumericDiffOptions numeric;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(analytic.get(), no_manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(blocks, 1e-6, &results)) << results.error_log;
}

TEST(SnavelyReprojectionError, HandComputedResidual) {
  // ω = 0, t = 0, point (1, 2, -4): p = -(x/z, y/z) = (0.25, 0.5), r² = 0.3125,
  // f·(1 + k1 r²)·p with f = 100, k1 = 0.1: 100·1.03125·(0.25, 0.5).
  std::unique_ptr<ceres::CostFunction> cost(SnavelyReprojectionError::Create(25.0, 50.0));
  const double camera[9] = {0, 0, 0, 0, 0, 0, 100, 0.1, 0};
  const double point[3] = {1, 2, -4};
  const double* blocks[2] = {camera, point};
  double r[2];
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], 100 * 1.03125 * 0.25 - 25.0, 1e-12);
  EXPECT_NEAR(r[1], 100 * 1.03125 * 0.5 - 50.0, 1e-12);
}

}  // namespace
}  // namespace mmba::factors
