#pragma once

// Pose priors: a pose `X_from_world` observed directly (GNSS/INS, a previous solution), as
// its projection centre in the world and its rotation, and the time-correlated form of the
// same prior along a sequence of poses.
//
// Parameter blocks of PosePriorCost, in this order:
//   X_from_world rotation    4  Eigen quaternion coefficients [x, y, z, w]
//   X_from_world translation 3
// Residuals (6): centre difference [m] / σ_m (3), then the angle-axis of the rotation
// difference [rad] / σ_rad (3).

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "mmba/geometry/rigid3d.h"

namespace mmba::factors {

/// Pose prior on X_from_world = (R, t) with the prior pose (R_p, t_p):
///   c = −Rᵀt  (the centre of X in the world),  c_p = −R_pᵀt_p,
///   r[0..2] = (c − c_p) / σ_m,   r[3..5] = AngleAxis(R_pᵀ·R) / σ_rad.
/// σ_m in metres, σ_rad in radians, both > 0.
struct PosePriorCost {
  PosePriorCost(const Rigid3d& prior, double sigma_m, double sigma_rad)
      : prior_centre(prior.Inverse().translation),
        prior_rotation(prior.rotation),
        w_m(1 / sigma_m),
        w_rad(1 / sigma_rad) {}

  static ceres::CostFunction* Create(const Rigid3d& prior, double sigma_m, double sigma_rad) {
    return new ceres::AutoDiffCostFunction<PosePriorCost, 6, 4, 3>(
        new PosePriorCost(prior, sigma_m, sigma_rad));
  }

  template <typename T>
  bool operator()(const T* q, const T* t, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    // For a pose X_from_world the centre of X in the world is −Rᵀt.
    const Eigen::Matrix<T, 3, 1> centre = -(rotation.conjugate() * translation);
    for (int k = 0; k < 3; ++k) r[k] = (centre[k] - T(prior_centre[k])) * T(w_m);
    const Eigen::Quaternion<T> delta = prior_rotation.cast<T>().conjugate() * rotation;
    T angle_axis[3];
    const T quaternion[4] = {delta.w(), delta.x(), delta.y(), delta.z()};
    ceres::QuaternionToAngleAxis(quaternion, angle_axis);
    for (int k = 0; k < 3; ++k) r[3 + k] = angle_axis[k] * T(w_rad);
    return true;
  }

  Eigen::Vector3d prior_centre;       ///< c_p [m]
  Eigen::Quaterniond prior_rotation;  ///< R_p
  double w_m, w_rad;                  ///< 1/σ_m [1/m], 1/σ_rad [1/rad]
};

/// Time-correlated pose prior: the innovation of a first-order Gauss–Markov process on the
/// prior errors e (PosePriorCost with unit σ) of two consecutive poses,
///   r = (e_k − φ·e_{k−1}) / (σ·√(1 − φ²)),   φ = exp(−Δt/τ) ∈ [0, 1),
/// the discrete form x_k = φ·x_{k−1} + w_k with Var(w_k) = σ²(1 − φ²) of a process of
/// stationary variance σ². Blocks: previous pose (q 4, t 3), then this pose (q 4, t 3).
struct GaussMarkovPosePriorCost {
  GaussMarkovPosePriorCost(const Rigid3d& previous, const Rigid3d& current, double phi, double sigma_m,
                           double sigma_rad)
      : previous(previous, 1.0, 1.0),
        current(current, 1.0, 1.0),
        phi(phi),
        w_m(1 / (sigma_m * std::sqrt(1 - phi * phi))),
        w_rad(1 / (sigma_rad * std::sqrt(1 - phi * phi))) {}

  static ceres::CostFunction* Create(const Rigid3d& previous, const Rigid3d& current, double phi,
                                     double sigma_m, double sigma_rad) {
    return new ceres::AutoDiffCostFunction<GaussMarkovPosePriorCost, 6, 4, 3, 4, 3>(
        new GaussMarkovPosePriorCost(previous, current, phi, sigma_m, sigma_rad));
  }

  template <typename T>
  bool operator()(const T* q_previous, const T* t_previous, const T* q, const T* t, T* r) const {
    T e_previous[6], e[6];
    if (!previous(q_previous, t_previous, e_previous) || !current(q, t, e)) return false;
    for (int k = 0; k < 6; ++k) r[k] = (e[k] - T(phi) * e_previous[k]) * T(k < 3 ? w_m : w_rad);
    return true;
  }

  PosePriorCost previous, current;
  double phi, w_m, w_rad;
};

}  // namespace mmba::factors
