#include "mmba/problem/solve.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "logging_callback.h"
#include "mmba/core/logging.h"

namespace mmba {

bool SolveOptions::Check(std::string* error) const {
  if (max_iterations < 0) {
    *error = "max_iterations: found " + std::to_string(max_iterations) + ", expected >= 0";
    return false;
  }
  if (num_threads < 1) {
    *error = "threads: found " + std::to_string(num_threads) + ", expected >= 1";
    return false;
  }
  if (!(function_tolerance > 0) || !(gradient_tolerance > 0) || !(parameter_tolerance > 0)) {
    *error = "tolerances: expected > 0";
    return false;
  }
  return true;
}

std::string SolveResult::BriefReport() const {
  std::ostringstream s;
  s << "status: " << status << " (" << reason << ")\n";
  s << "iterations: " << iterations << ", solve time: " << solve_seconds << " s\n";
  s << "cost: " << initial_cost << " -> " << final_cost << " (Ceres ½Σρ(r²))\n";
  s << "gauge: " << gauge << "\n";
  for (size_t i = 0; i < after.size(); ++i) {
    const GroupEvaluation& b = before[i];
    const GroupEvaluation& a = after[i];
    s << "group '" << a.name << "': " << a.num_observations << " observations";
    if (a.num_skipped) s << " (" << a.num_skipped << " skipped)";
    s << ", RMS " << b.rms_units << " -> " << a.rms_units << " " << a.unit << ", "
      << a.num_outliers << " beyond " << a.outlier_threshold << " sigma\n";
  }
  return s.str();
}

SolveResult Solve(ProblemBuilder& builder, const SolveOptions& options) {
  ceres::Problem& problem = builder.Build();
  SolveResult result;
  result.gauge = builder.gauge_description();
  for (const auto& group : builder.groups()) result.before.push_back(group->Evaluate());

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = options.linear_solver;
  if (options.auto_linear_solver) {
    size_t num_images = 0;
    for (const auto& [id, image] : builder.scene().images()) {
      num_images += problem.HasParameterBlock(image.cam_from_world.translation.data()) ? 1 : 0;
    }
    if (num_images < 50) {
      solver_options.linear_solver_type = ceres::DENSE_SCHUR;
    } else if (num_images < 1000) {
      solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
    } else {
      solver_options.linear_solver_type = ceres::ITERATIVE_SCHUR;
      solver_options.preconditioner_type = ceres::SCHUR_JACOBI;
    }
  }
  solver_options.linear_solver_ordering = builder.ordering();
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.logging_type = ceres::SILENT;
  internal::LoggingCallback callback;
  if (options.log_progress) solver_options.callbacks.push_back(&callback);

  ceres::Solve(solver_options, &problem, &result.summary);
  spdlog::debug("{}", result.summary.FullReport());
  builder.Finish();

  const ceres::Solver::Summary& summary = result.summary;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  result.solve_seconds = summary.total_time_in_seconds;
  result.num_residuals = summary.num_residuals;
  result.num_parameter_blocks = summary.num_parameter_blocks;
  result.num_effective_parameters = summary.num_effective_parameters;
  result.reason = summary.message;
  if (summary.termination_type == ceres::CONVERGENCE) {
    result.converged = true;
    result.status = "converged";
  } else if (summary.termination_type == ceres::NO_CONVERGENCE) {
    result.status = "no_convergence";
  } else {
    result.status = "failed";
  }
  if (!std::isfinite(summary.final_cost)) {
    result.converged = false;
    result.status = "failed";
    result.reason = "final cost is not finite";
  }
  for (const auto& group : builder.groups()) result.after.push_back(group->Evaluate());
  return result;
}

}  // namespace mmba
