#pragma once

// Reprojection costs on other parameterisations: each wraps a reprojection cost of
// factors/reprojection_error.h (blocks: cam_from_world rotation 4, translation 3,
// point_in_world 3, camera params) and maps its blocks and Jacobians, so that the residual
// (whitened, in pixels / σ_px) is the same and only the parameters differ. Each takes
// ownership of the wrapped cost.

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/cost_function.h>

namespace mmba::factors {

/// The point as a survey point's two blocks: (rotation, translation, east-north 2, up 1,
/// camera params); X = (east, north, up).
class NetworkPointReprojectionCost : public ceres::CostFunction {
 public:
  explicit NetworkPointReprojectionCost(ceres::CostFunction* inner) : inner_(inner) {
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    set_num_residuals(inner_->num_residuals());
    *mutable_parameter_block_sizes() = {sizes[0], sizes[1], 2, 1, sizes[3]};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double point[3] = {parameters[2][0], parameters[2][1], parameters[3][0]};
    const double* inner_parameters[4] = {parameters[0], parameters[1], point, parameters[4]};
    if (jacobians == nullptr) return inner_->Evaluate(inner_parameters, residuals, nullptr);
    const int m = num_residuals();
    std::vector<double> j_point(m * 3);
    double* inner_jacobians[4] = {jacobians[0], jacobians[1],
                                  (jacobians[2] || jacobians[3]) ? j_point.data() : nullptr,
                                  jacobians[4]};
    if (!inner_->Evaluate(inner_parameters, residuals, inner_jacobians)) return false;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const Eigen::Map<const RowMajor> jp(j_point.data(), m, 3);
    if (jacobians[2]) Eigen::Map<RowMajor>(jacobians[2], m, 2) = jp.leftCols(2);
    if (jacobians[3]) Eigen::Map<RowMajor>(jacobians[3], m, 1) = jp.col(2);
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
};

/// A baseline b subtracted from the translation (the upper sphere of a vertical stereo pair
/// seen from the lower sphere's pose): (rotation, translation, baseline 3, point, camera
/// params); t' = t − b [m], so ∂r/∂b = −∂r/∂t.
class BaselineReprojectionCost : public ceres::CostFunction {
 public:
  explicit BaselineReprojectionCost(ceres::CostFunction* inner) : inner_(inner) {
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    set_num_residuals(inner_->num_residuals());
    *mutable_parameter_block_sizes() = {sizes[0], sizes[1], 3, sizes[2], sizes[3]};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double t[3] = {parameters[1][0] - parameters[2][0], parameters[1][1] - parameters[2][1],
                         parameters[1][2] - parameters[2][2]};
    const double* inner_parameters[4] = {parameters[0], t, parameters[3], parameters[4]};
    if (jacobians == nullptr) return inner_->Evaluate(inner_parameters, residuals, nullptr);
    const int m = num_residuals();
    std::vector<double> j_t(m * 3);
    double* inner_jacobians[4] = {jacobians[0], (jacobians[1] || jacobians[2]) ? j_t.data() : nullptr,
                                  jacobians[3], jacobians[4]};
    if (!inner_->Evaluate(inner_parameters, residuals, inner_jacobians)) return false;
    for (int k = 0; k < m * 3; ++k) {
      if (jacobians[1]) jacobians[1][k] = j_t[k];
      if (jacobians[2]) jacobians[2][k] = -j_t[k];
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
};

/// cam_from_world = cam_from_rig ∘ rig_from_world:
///   q_cw = q_cr·q_rw,   t_cw = R_cr·t_rw + t_cr.
/// Inputs (q_rw 4, t_rw 3, q_cr 4, t_cr 3); output [q_cw (x, y, z, w), t_cw] (7).
struct ComposePoses {
  template <typename T>
  bool operator()(const T* q_rw, const T* t_rw, const T* q_cr, const T* t_cr, T* out) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rw(q_rw), cr(q_cr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> trw(t_rw), tcr(t_cr);
    const Eigen::Quaternion<T> cw = cr * rw;
    const Eigen::Matrix<T, 3, 1> tcw = cr * trw + tcr;
    out[0] = cw.x();
    out[1] = cw.y();
    out[2] = cw.z();
    out[3] = cw.w();
    out[4] = tcw.x();
    out[5] = tcw.y();
    out[6] = tcw.z();
    return true;
  }
};

/// A rig camera (COLMAP's RigReprojErrorCostFunctor): blocks (rig_from_world q 4, t 3,
/// cam_from_rig q 4, t 3, point, camera params). The wrapped cost is evaluated on the composed
/// pose and chained with the Jacobian of ComposePoses (automatic differentiation):
///   ∂r/∂block = J_q·∂q_cw/∂block + J_t·∂t_cw/∂block.
class RigReprojectionCost : public ceres::CostFunction {
 public:
  explicit RigReprojectionCost(ceres::CostFunction* inner)
      : inner_(inner), compose_(new ComposePoses) {
    const std::vector<int32_t>& sizes = inner_->parameter_block_sizes();
    set_num_residuals(inner_->num_residuals());
    *mutable_parameter_block_sizes() = {4, 3, 4, 3, sizes[2], sizes[3]};
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    double composed[7];
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    RowMajor jc[4] = {RowMajor(7, 4), RowMajor(7, 3), RowMajor(7, 4), RowMajor(7, 3)};
    double* jc_data[4] = {jc[0].data(), jc[1].data(), jc[2].data(), jc[3].data()};
    const bool want_pose = jacobians && (jacobians[0] || jacobians[1] || jacobians[2] || jacobians[3]);
    if (!compose_.Evaluate(parameters, composed, want_pose ? jc_data : nullptr)) return false;
    const double* inner_parameters[4] = {composed, composed + 4, parameters[4], parameters[5]};
    if (jacobians == nullptr) return inner_->Evaluate(inner_parameters, residuals, nullptr);
    const int m = num_residuals();
    RowMajor jq(m, 4), jt(m, 3);
    double* inner_jacobians[4] = {want_pose ? jq.data() : nullptr, want_pose ? jt.data() : nullptr, jacobians[4],
                                  jacobians[5]};
    if (!inner_->Evaluate(inner_parameters, residuals, inner_jacobians)) return false;
    if (!want_pose) return true;
    for (int b = 0; b < 4; ++b) {
      if (!jacobians[b]) continue;
      const int n = b % 2 == 0 ? 4 : 3;
      Eigen::Map<RowMajor>(jacobians[b], m, n) = jq * jc[b].topRows(4) + jt * jc[b].bottomRows(3);
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  ceres::AutoDiffCostFunction<ComposePoses, 7, 4, 3, 4, 3> compose_;
};

}  // namespace mmba::factors
