#pragma once

#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "mmba/problem/factor_group.h"
#include "mmba/problem/problem_builder.h"

namespace mmba {

/// Options of the nonlinear solve (Levenberg–Marquardt with a sparse Schur complement).
struct SolveOptions {
  int max_iterations = 100;                  ///< >= 0
  int num_threads = 2;                       ///< >= 1
  double function_tolerance = 1e-6;          ///< relative cost change to stop, > 0
  double gradient_tolerance = 1e-10;         ///< > 0
  double parameter_tolerance = 1e-8;         ///< > 0
  /// Linear solver; with `auto_linear_solver` it is chosen from the number of images as
  /// COLMAP's bundle adjuster does: DENSE_SCHUR below 50 images, SPARSE_SCHUR below 1000,
  /// ITERATIVE_SCHUR (SCHUR_JACOBI) above.
  bool auto_linear_solver = true;
  ceres::LinearSolverType linear_solver = ceres::SPARSE_SCHUR;
  bool log_progress = true;                  ///< one log line per iteration (info level)

  bool Check(std::string* error) const;
};

/// Result of an adjustment: Ceres' own numbers plus the evaluation of every group before
/// and after. `converged` is false when Ceres failed or hit the iteration limit without
/// meeting a tolerance; `status`/`reason` then say why.
struct SolveResult {
  bool converged = false;
  std::string status;   ///< "converged", "no_convergence", "failed"
  std::string reason;   ///< Ceres' message
  double initial_cost = 0.0;  ///< ½Σρ(‖r‖²), Ceres' definition
  double final_cost = 0.0;
  int iterations = 0;
  double solve_seconds = 0.0;   ///< Ceres' total time
  int num_residuals = 0;
  int num_parameter_blocks = 0;
  int num_effective_parameters = 0;
  std::string gauge;
  std::vector<GroupEvaluation> before;
  std::vector<GroupEvaluation> after;
  ceres::Solver::Summary summary;

  std::string BriefReport() const;
};

/// Builds (if not yet built; see ProblemBuilder::Build), solves, undoes the gauge transform
/// and evaluates every group before and after.
SolveResult Solve(ProblemBuilder& builder, const SolveOptions& options);

}  // namespace mmba
