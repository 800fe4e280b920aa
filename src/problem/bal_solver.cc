#include "mmba/problem/bal_solver.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "logging_callback.h"
#include "mmba/core/logging.h"
#include "mmba/factors/snavely_reprojection_error.h"

namespace mmba {

bool BalSolveOptions::Check(std::string* error) const {
  if (num_threads < 1) {
    *error = "--threads: found " + std::to_string(num_threads) + ", expected >= 1";
    return false;
  }
  if (max_iterations < 0) {
    *error = "--max-iterations: found " + std::to_string(max_iterations) + ", expected >= 0";
    return false;
  }
  return true;
}

BalSolveResult SolveBal(io::BalProblem* bal, const BalSolveOptions& options) {
  ceres::Problem problem;
  for (const io::BalObservation& obs : bal->observations) {
    ceres::CostFunction* cost =
        options.analytic_jacobian
            ? factors::SnavelyReprojectionError::Create(obs.x, obs.y)
            : factors::SnavelyReprojectionErrorAutoDiff::Create(obs.x, obs.y);
    problem.AddResidualBlock(cost, nullptr, bal->mutable_camera(obs.camera_index),
                             bal->mutable_point(obs.point_index));
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  solver_options.preconditioner_type = ceres::JACOBI;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = ceres::SILENT;
  if (options.explicit_ordering) {
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (int i = 0; i < bal->num_points; ++i) {
      if (problem.HasParameterBlock(bal->mutable_point(i))) {
        ordering->AddElementToGroup(bal->mutable_point(i), 0);
      }
    }
    for (int i = 0; i < bal->num_cameras; ++i) {
      if (problem.HasParameterBlock(bal->mutable_camera(i))) {
        ordering->AddElementToGroup(bal->mutable_camera(i), 1);
      }
    }
    solver_options.linear_solver_ordering = ordering;
  }
  internal::LoggingCallback callback;
  if (options.log_progress) solver_options.callbacks.push_back(&callback);

  BalSolveResult result;
  result.num_cameras = bal->num_cameras;
  result.num_points = bal->num_points;
  result.num_observations = static_cast<int>(bal->observations.size());
  ceres::Solve(solver_options, &problem, &result.summary);
  const ceres::Solver::Summary& summary = result.summary;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  result.solve_seconds = summary.total_time_in_seconds;
  result.num_residuals = summary.num_residuals;
  result.reason = summary.message;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.status = result.converged ? "converged"
                  : summary.termination_type == ceres::NO_CONVERGENCE ? "no_convergence"
                                                                      : "failed";
  if (!std::isfinite(summary.final_cost)) {
    result.converged = false;
    result.status = "failed";
    result.reason = "final cost is not finite";
  }
  // cost = ½Σ‖r‖², so RMS of ‖r‖ per observation is sqrt(2·cost / N).
  const double n = std::max<double>(1.0, result.num_observations);
  result.initial_rms = std::sqrt(2.0 * result.initial_cost / n);
  result.final_rms = std::sqrt(2.0 * result.final_cost / n);
  return result;
}

}  // namespace mmba
