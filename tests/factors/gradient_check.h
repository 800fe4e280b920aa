#pragma once

// ceres::GradientChecker on a cost function at one point, with the Eigen quaternion manifold
// on the listed blocks (Eigen coefficient order [x, y, z, w]).

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <gtest/gtest.h>

namespace mmba::factors {

inline void ExpectGradientsMatch(const ceres::CostFunction& cost, const std::vector<const double*>& blocks,
                                 const std::set<int>& quaternion_blocks = {}) {
  ASSERT_EQ(blocks.size(), cost.parameter_block_sizes().size());
  ceres::EigenQuaternionManifold quaternion;
  std::vector<const ceres::Manifold*> manifolds(blocks.size(), nullptr);
  for (int b : quaternion_blocks) manifolds[b] = &quaternion;
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  if (checker.Probe(blocks.data(), 1e-6, &results)) return;
  // Probe's test is relative per entry: entries that are zero analytically (the diagonal of
  // −[R·x]× on a quaternion block's tangent space) come out near 1e-13 on both sides and
  // fail it. Accept |J − J_numeric| ≤ 1e-6·max(1, |J_numeric|) on the tangent-space
  // Jacobians instead, with the same residual with and without Jacobians.
  ASSERT_TRUE(results.return_value) << results.error_log;
  std::vector<double> residuals(cost.num_residuals());
  ASSERT_TRUE(cost.Evaluate(blocks.data(), residuals.data(), nullptr));
  for (int i = 0; i < cost.num_residuals(); ++i) {
    EXPECT_NEAR(residuals[i], results.residuals[i], 1e-12 * std::max(1.0, std::abs(residuals[i]))) << i;
  }
  for (size_t b = 0; b < blocks.size(); ++b) {
    const auto& user = results.local_jacobians[b];
    const auto& numeric = results.local_numeric_jacobians[b];
    for (int row = 0; row < user.rows(); ++row) {
      for (int col = 0; col < user.cols(); ++col) {
        EXPECT_NEAR(user(row, col), numeric(row, col), 1e-6 * std::max(1.0, std::abs(numeric(row, col))))
            << "block " << b << " row " << row << " col " << col << "\n" << results.error_log;
      }
    }
  }
}

/// Evaluates `cost` at `blocks` into `residuals` (sized to the cost's residual count).
inline bool EvaluateCost(const ceres::CostFunction& cost, const std::vector<const double*>& blocks,
                         std::vector<double>* residuals) {
  residuals->assign(cost.num_residuals(), 0.0);
  return cost.Evaluate(blocks.data(), residuals->data(), nullptr);
}

}  // namespace mmba::factors
