#pragma once

// The smooth correction of a GNSS/INS trajectory: nodes in time, each a 6-vector block
//   c = [ωx, ωy, ωz (rad), δx, δy, δz (m)],
// a small rotation (angle-axis, world axes) and a shift, linearly interpolated between two
// nodes and applied to the GNSS/INS pose (R, p) of world_from_body:
//   world_from_body = (Exp(ω)·R, p + δ).
// The residuals here are the correction's stochastic model: a prior on each node, the
// innovation of a first-order Gauss–Markov process between nodes, and a second-difference
// smoothness. All are whitened; rotation components come first (unlike PosePriorCost).

#include <cmath>

#include <Eigen/Core>
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "mmba/geometry/rigid3d.h"

namespace mmba::factors {

/// Interpolated correction c = (1 − α)·a + α·b (α ∈ [0, 1] the weight of node b), applied to
/// the GNSS/INS pose `ins` (world_from_body): returns Exp(ω)·(R·x_body) + p + δ [m].
template <typename T>
Eigen::Matrix<T, 3, 1> CorrectedWorldPoint(const T* a, const T* b, double alpha, const Rigid3d& ins,
                                           const Eigen::Matrix<T, 3, 1>& x_body) {
  T omega[3], delta[3];
  for (int k = 0; k < 3; ++k) {
    omega[k] = (1.0 - alpha) * a[k] + alpha * b[k];
    delta[k] = (1.0 - alpha) * a[3 + k] + alpha * b[3 + k];
  }
  // Exp(ω)·(R·x): the GNSS/INS attitude applied first, then the correction.
  const Eigen::Matrix<T, 3, 1> rotated = ins.rotation.cast<T>() * x_body;
  T turned[3];
  const T in[3] = {rotated[0], rotated[1], rotated[2]};
  ceres::AngleAxisRotatePoint(omega, in, turned);
  Eigen::Matrix<T, 3, 1> out;
  for (int k = 0; k < 3; ++k) out[k] = turned[k] + T(ins.translation[k]) + delta[k];
  return out;
}

/// Zero-mean prior on one node: r = [ω/σ_rad, δ/σ_m]. Block: the node (6).
struct NodePriorCost {
  NodePriorCost(double sigma_m, double sigma_rad) : w_m(1 / sigma_m), w_rad(1 / sigma_rad) {}

  static ceres::CostFunction* Create(double sigma_m, double sigma_rad) {
    return new ceres::AutoDiffCostFunction<NodePriorCost, 6, 6>(new NodePriorCost(sigma_m, sigma_rad));
  }

  template <typename T>
  bool operator()(const T* c, T* r) const {
    for (int k = 0; k < 3; ++k) {
      r[k] = c[k] * T(w_rad);
      r[3 + k] = c[3 + k] * T(w_m);
    }
    return true;
  }

  double w_m, w_rad;  ///< 1/σ_m [1/m], 1/σ_rad [1/rad]
};

/// The innovation of a first-order Gauss–Markov process between consecutive nodes:
///   r = (c_k − φ·c_{k−1}) / (σ·√(1 − φ²)),   φ = exp(−Δt/τ) ∈ [0, 1),
/// so that each node has the stationary σ and neighbours the correlation φ.
/// Blocks: previous node (6), this node (6).
struct GaussMarkovNodeCost {
  GaussMarkovNodeCost(double phi, double sigma_m, double sigma_rad)
      : phi(phi), w_m(1 / (sigma_m * std::sqrt(1 - phi * phi))), w_rad(1 / (sigma_rad * std::sqrt(1 - phi * phi))) {}

  static ceres::CostFunction* Create(double phi, double sigma_m, double sigma_rad) {
    return new ceres::AutoDiffCostFunction<GaussMarkovNodeCost, 6, 6, 6>(
        new GaussMarkovNodeCost(phi, sigma_m, sigma_rad));
  }

  template <typename T>
  bool operator()(const T* previous, const T* c, T* r) const {
    for (int k = 0; k < 6; ++k) r[k] = (c[k] - T(phi) * previous[k]) * T(k < 3 ? w_rad : w_m);
    return true;
  }

  double phi, w_m, w_rad;
};

/// Smoothness of three consecutive nodes: r = (a − 2b + c)/σ per component (the second
/// difference, zero for a correction linear in the node index). σ = 0 leaves that part
/// (rotation or shift) unconstrained. Blocks: nodes a, b, c (6 each).
struct SecondDifferenceCost {
  SecondDifferenceCost(double sigma_m, double sigma_rad)
      : w_m(sigma_m > 0 ? 1 / sigma_m : 0.0), w_rad(sigma_rad > 0 ? 1 / sigma_rad : 0.0) {}

  static ceres::CostFunction* Create(double sigma_m, double sigma_rad) {
    return new ceres::AutoDiffCostFunction<SecondDifferenceCost, 6, 6, 6, 6>(
        new SecondDifferenceCost(sigma_m, sigma_rad));
  }

  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    for (int k = 0; k < 6; ++k) r[k] = (a[k] - 2.0 * b[k] + c[k]) * T(k < 3 ? w_rad : w_m);
    return true;
  }

  double w_m, w_rad;
};

}  // namespace mmba::factors
