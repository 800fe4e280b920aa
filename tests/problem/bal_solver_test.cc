#include "mmba/problem/bal_solver.h"

#include <gtest/gtest.h>

#include "mmba/io/bal.h"

namespace mmba {
namespace {

const std::string kDubrovnik = std::string(MMBA_SOURCE_DIR) + "/data/bal/dubrovnik-3-7-pre.txt";

// The analytic Jacobian reaches the same minimum as Ceres' own autodiff functor.
TEST(BalSolver, AnalyticAndAutoDiffReachTheSameCost) {
  io::BalProblem a = io::ReadBal(kDubrovnik);
  io::BalProblem b = a;
  BalSolveOptions options;
  options.log_progress = false;
  const BalSolveResult analytic = SolveBal(&a, options);
  options.analytic_jacobian = false;
  const BalSolveResult autodiff = SolveBal(&b, options);
  ASSERT_NE(analytic.status, "failed");
  EXPECT_LT(analytic.final_cost, 0.1 * analytic.initial_cost);
  EXPECT_NEAR(analytic.final_cost, autodiff.final_cost, 1e-3 * autodiff.final_cost);
  EXPECT_EQ(analytic.num_residuals, 38);
  EXPECT_NEAR(analytic.initial_cost, autodiff.initial_cost, 1e-12 * autodiff.initial_cost);
}

}  // namespace
}  // namespace mmba
