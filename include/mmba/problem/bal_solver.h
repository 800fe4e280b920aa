#pragma once

#include <string>

#include <ceres/ceres.h>

#include "mmba/io/bal.h"

namespace mmba {

/// Settings of Ceres' own examples/bundle_adjuster (Ceres 2.1): Levenberg–Marquardt,
/// SPARSE_SCHUR with SuiteSparse, JACOBI preconditioner, no robust loss, default
/// tolerances; defaults here: 2 threads, 50 iterations.
struct BalSolveOptions {
  int num_threads = 2;       ///< >= 1
  int max_iterations = 50;   ///< >= 0
  bool analytic_jacobian = true;   ///< false: autodiff, exactly Ceres' example functor
  bool explicit_ordering = true;   ///< points eliminated first, set here (not by Ceres' search)
  bool log_progress = true;

  bool Check(std::string* error) const;
};

struct BalSolveResult {
  bool converged = false;
  std::string status;  ///< "converged", "no_convergence", "failed"
  std::string reason;
  double initial_cost = 0.0;  ///< ½Σr², Ceres' definition
  double final_cost = 0.0;
  int iterations = 0;
  double solve_seconds = 0.0;  ///< Ceres' total time
  int num_residuals = 0;
  int num_cameras = 0;
  int num_points = 0;
  int num_observations = 0;
  /// RMS of the 2-D residual norm per observation, before/after (BAL image units).
  double initial_rms = 0.0;
  double final_rms = 0.0;
  ceres::Solver::Summary summary;
};

/// Solves a BAL problem in place (cameras and points are updated).
BalSolveResult SolveBal(io::BalProblem* problem, const BalSolveOptions& options);

}  // namespace mmba
