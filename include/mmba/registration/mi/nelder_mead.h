#pragma once

// Nelder–Mead downhill simplex (Nelder & Mead 1965; Lagarias et al. 1998 coefficients
// 1, 2, 0.5, 0.5) MAXIMISING a function inside box bounds (points outside are projected
// onto the box), with the stopping rules Wang et al. 2012 used: simplex diameter below a
// tolerance on the parameters and spread of the function values below a tolerance.

#include <functional>
#include <string>

#include <Eigen/Core>

namespace mmba::registration::mi {

using Vector6d = Eigen::Matrix<double, 6, 1>;

struct NelderMeadOptions {
  Vector6d initial_step = Vector6d::Ones();  ///< simplex edge per parameter (paper: 1 unit)
  double parameter_tolerance = 0.1;          ///< max |x_i − x_best| over the simplex (paper)
  double function_tolerance = 0.001;         ///< max |f_i − f_best| (paper: 0.001 bit)
  int max_iterations = 200;                  ///< paper: 200
  Vector6d lower = Vector6d::Constant(-1e300);
  Vector6d upper = Vector6d::Constant(1e300);
};

struct NelderMeadResult {
  Vector6d x = Vector6d::Zero();
  double value = 0;
  int iterations = 0;
  int evaluations = 0;
  bool converged = false;  ///< false when max_iterations was reached
};

/// Maximises f from x0 (projected into the bounds).
NelderMeadResult MaximizeNelderMead(const std::function<double(const Vector6d&)>& f,
                                    const Vector6d& x0, const NelderMeadOptions& options);

}  // namespace mmba::registration::mi
