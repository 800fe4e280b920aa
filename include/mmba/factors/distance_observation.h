#pragma once

// A measured spatial distance between two points (a calibrated scale bar of a close-range
// network): r = (‖X_b − X_a‖ − d)/σ_m, analytic Jacobian ±(X_b − X_a)ᵀ/(‖X_b − X_a‖·σ).
// Blocks: X_a (3), X_b (3), world metres.

#include <cmath>

#include <Eigen/Core>
#include <ceres/sized_cost_function.h>

namespace mmba::factors {

class DistanceCost : public ceres::SizedCostFunction<1, 3, 3> {
 public:
  /// `distance_m` > 0, `sigma_m` > 0.
  DistanceCost(double distance_m, double sigma_m) : distance_m_(distance_m), sigma_m_(sigma_m) {}

  bool Evaluate(double const* const* p, double* r, double** j) const override {
    const Eigen::Map<const Eigen::Vector3d> a(p[0]), b(p[1]);
    const Eigen::Vector3d d = b - a;
    const double length = d.norm();
    if (!(length > 0)) return false;  // coincident points: the direction is undefined
    r[0] = (length - distance_m_) / sigma_m_;
    const Eigen::Vector3d g = d / (length * sigma_m_);
    for (int k = 0; k < 3; ++k) {
      if (j && j[0]) j[0][k] = -g[k];
      if (j && j[1]) j[1][k] = g[k];
    }
    return true;
  }

 private:
  double distance_m_, sigma_m_;
};

}  // namespace mmba::factors
