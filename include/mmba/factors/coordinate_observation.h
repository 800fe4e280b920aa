#pragma once

// Coordinate observations: one coordinate of a parameter block observed directly (a prior on
// a vector, a GNSS coordinate of a survey point or of a camera's antenna), and a survey
// target's position measured in a scan's frame. Whitened by the a-priori σ in metres.
//
// A survey point is two blocks: east-north (2) and up (1), local tangent plane, metres.
// Quaternion blocks are Eigen coefficients [x, y, z, w].

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/cost_function.h>
#include <ceres/sized_cost_function.h>

namespace mmba::factors {

/// One component of a 3-vector block against a prior value: r = (x[index] − prior)/σ,
/// analytic Jacobian. Block: the 3-vector.
class ScalarPriorCost : public ceres::SizedCostFunction<1, 3> {
 public:
  /// `index` in [0, 3); σ > 0 in the vector's unit.
  ScalarPriorCost(int index, double prior, double sigma) : index_(index), prior_(prior), sigma_(sigma) {}
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    r[0] = (p[0][index_] - prior_) / sigma_;
    if (j && j[0]) {
      for (int k = 0; k < 3; ++k) j[0][k] = k == index_ ? 1.0 / sigma_ : 0.0;
    }
    return true;
  }

 private:
  int index_;
  double prior_, sigma_;
};

/// One GNSS coordinate of a survey point: r = (x_axis − value)/σ_m on the point's
/// east-north block (axis 0 east, 1 north; block size 2) or up block (axis 2; block size 1).
class GnssAxisCost : public ceres::CostFunction {
 public:
  GnssAxisCost(int axis, double value, double sigma) : index_(axis < 2 ? axis : 0), value_(value), sigma_(sigma) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(axis < 2 ? 2 : 1);
  }
  bool Evaluate(double const* const* p, double* r, double** j) const override {
    r[0] = (p[0][index_] - value_) / sigma_;
    if (j && j[0]) {
      const int size = parameter_block_sizes()[0];
      for (int k = 0; k < size; ++k) j[0][k] = k == index_ ? 1.0 / sigma_ : 0.0;
    }
    return true;
  }

 private:
  int index_;  ///< component within the block
  double value_, sigma_;
};

/// One GNSS coordinate of a camera's antenna, the antenna at `lever` in the camera frame:
///   a = Rᵀ·(lever − t)  (the antenna in the world, R normalised),
///   r = (a[axis] − value)/σ_m.
/// Blocks: cam_from_world rotation 4, translation 3.
struct GnssCameraAxisCost {
  GnssCameraAxisCost(int axis, const Eigen::Vector3d& lever, double value, double sigma)
      : axis(axis), lever(lever), value(value), sigma(sigma) {}

  static ceres::CostFunction* Create(int axis, const Eigen::Vector3d& lever, double value, double sigma) {
    return new ceres::AutoDiffCostFunction<GnssCameraAxisCost, 1, 4, 3>(
        new GnssCameraAxisCost(axis, lever, value, sigma));
  }

  template <typename T>
  bool operator()(const T* q_xyzw, const T* t, T* r) const {
    const Eigen::Quaternion<T> q = Eigen::Quaternion<T>(q_xyzw[3], q_xyzw[0], q_xyzw[1], q_xyzw[2]).normalized();
    const Eigen::Matrix<T, 3, 1> d = lever.cast<T>() - Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
    const Eigen::Matrix<T, 3, 1> antenna = q.conjugate() * d;
    r[0] = (antenna[axis] - T(value)) / T(sigma);
    return true;
  }

  int axis;               ///< 0 east, 1 north, 2 up
  Eigen::Vector3d lever;  ///< antenna in the camera frame [m]
  double value, sigma;    ///< observed coordinate and its σ [m]
};

/// A survey target X measured at x in a scan's frame: r = (scan_from_world·X − x)/σ_m,
/// X = (east, north, up) from the point's two blocks.
/// Blocks: scan_from_world rotation 4, translation 3, east-north 2, up 1.
struct ScanTargetCost {
  ScanTargetCost(const Eigen::Vector3d& measured, double sigma) : x(measured), w(1 / sigma) {}

  static ceres::CostFunction* Create(const Eigen::Vector3d& measured, double sigma) {
    return new ceres::AutoDiffCostFunction<ScanTargetCost, 3, 4, 3, 2, 1>(new ScanTargetCost(measured, sigma));
  }

  template <typename T>
  bool operator()(const T* q_sw, const T* t_sw, const T* en, const T* up, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q_sw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t_sw);
    const Eigen::Matrix<T, 3, 1> world(en[0], en[1], up[0]);
    const Eigen::Matrix<T, 3, 1> d = rotation * world + translation - x.cast<T>();
    for (int k = 0; k < 3; ++k) r[k] = d[k] * T(w);
    return true;
  }

  Eigen::Vector3d x;  ///< measured position in the scan frame [m]
  double w;           ///< 1/σ [1/m]
};

}  // namespace mmba::factors
