#pragma once

// The perspective reprojection residual of ReprojectionError (reprojection_error.h) with its
// Jacobian by the chain rule instead of one Jet over all 10 + N parameters:
//
//   p = R(q)·X + t                      (point in the camera frame)
//   r = (ImgFromCam(params, p) − x_obs) / σ_px
//
//   ∂r/∂q = ∂r/∂p · ∂p/∂q     ∂r/∂t = ∂r/∂p     ∂r/∂X = ∂r/∂p · R(q)     ∂r/∂params
//
// ∂p/∂q comes from a Jet of the 4 quaternion coefficients; R(q) is the linear map X ↦ q·X
// that Eigen applies (so the Jacobian equals autodiff of the functor also for a quaternion
// that is not of unit norm); ∂r/∂p and ∂r/∂params from one Jet of 3 + N dimensions, or of 3
// when Ceres asks for no camera Jacobian (a held camera). The camera model, the expensive
// part, is differentiated in 3 + N dimensions instead of 10 + N: for the 12-parameter
// PHOTOGRAMMETRIC model 15 instead of 22, for a held camera 3. Same parameter blocks as
// ReprojectionError: quaternion [x, y, z, w] 4, translation 3, point 3, camera N.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/jet.h>
#include <ceres/sized_cost_function.h>

namespace mmba::factors {

template <typename CameraModel>
class PerspectiveReprojectionCost final : public ceres::SizedCostFunction<2, 4, 3, 3, CameraModel::kNumParams> {
 public:
  static constexpr int kN = CameraModel::kNumParams;

  PerspectiveReprojectionCost(const Eigen::Vector2d& observed_xy, double sigma_px)
      : observed_(observed_xy), inv_sigma_(1.0 / sigma_px) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* q = parameters[0];
    const double* t = parameters[1];
    const double* x = parameters[2];
    const double* camera = parameters[3];
    const Eigen::Map<const Eigen::Quaterniond> rotation(q);
    const Eigen::Map<const Eigen::Vector3d> point(x);
    const Eigen::Vector3d p = rotation * point + Eigen::Map<const Eigen::Vector3d>(t);
    if (jacobians == nullptr) {
      double xy[2];
      if (!CameraModel::ImgFromCam(camera, p.data(), xy)) return false;
      residuals[0] = (xy[0] - observed_.x()) * inv_sigma_;
      residuals[1] = (xy[1] - observed_.y()) * inv_sigma_;
      return true;
    }
    Eigen::Matrix<double, 2, 3> dr_dp;
    Eigen::Matrix<double, 2, kN> dr_dcamera;
    const bool projected = jacobians[3] != nullptr ? Project<3 + kN>(camera, p, residuals, &dr_dp, &dr_dcamera)
                                                   : Project<3>(camera, p, residuals, &dr_dp, nullptr);
    if (!projected) return false;
    if (jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 4, Eigen::RowMajor>> dr_dq(jacobians[0]);
      dr_dq = dr_dp * PointByQuaternion(q, point);
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> dr_dt(jacobians[1]);
      dr_dt = dr_dp;
    }
    if (jacobians[2] != nullptr) {
      Eigen::Matrix3d linear;
      for (int k = 0; k < 3; ++k) linear.col(k) = rotation * Eigen::Vector3d::Unit(k);
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> dr_dx(jacobians[2]);
      dr_dx = dr_dp * linear;
    }
    if (jacobians[3] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, kN, Eigen::RowMajor>> dr_dc(jacobians[3]);
      dr_dc = dr_dcamera;
    }
    return true;
  }

 private:
  /// ∂(q·X)/∂q, 3 × 4, from a Jet of the quaternion's coefficients.
  static Eigen::Matrix<double, 3, 4> PointByQuaternion(const double* q, const Eigen::Vector3d& point) {
    using J = ceres::Jet<double, 4>;
    J qj[4];
    for (int i = 0; i < 4; ++i) qj[i] = J(q[i], i);
    const Eigen::Map<const Eigen::Quaternion<J>> rotation(qj);
    const Eigen::Matrix<J, 3, 1> rotated = rotation * point.cast<J>();
    Eigen::Matrix<double, 3, 4> d;
    for (int r = 0; r < 3; ++r) d.row(r) = rotated[r].v.transpose();
    return d;
  }

  /// The whitened residual at the camera-frame point p, its Jacobian with respect to p and,
  /// when kDim = 3 + N, with respect to the camera parameters, from one Jet of kDim.
  template <int kDim>
  bool Project(const double* camera, const Eigen::Vector3d& p, double* residuals, Eigen::Matrix<double, 2, 3>* dr_dp,
               Eigen::Matrix<double, 2, kN>* dr_dcamera) const {
    using J = ceres::Jet<double, kDim>;
    J pj[3], cj[kN], xy[2];
    for (int i = 0; i < 3; ++i) pj[i] = J(p[i], i);
    for (int i = 0; i < kN; ++i) {
      if constexpr (kDim == 3 + kN) {
        cj[i] = J(camera[i], 3 + i);
      } else {
        cj[i] = J(camera[i]);
      }
    }
    if (!CameraModel::ImgFromCam(cj, pj, xy)) return false;
    for (int r = 0; r < 2; ++r) {
      residuals[r] = (xy[r].a - observed_[r]) * inv_sigma_;
      dr_dp->row(r) = xy[r].v.template head<3>().transpose() * inv_sigma_;
      if constexpr (kDim == 3 + kN) dr_dcamera->row(r) = xy[r].v.template tail<kN>().transpose() * inv_sigma_;
    }
    return true;
  }

  Eigen::Vector2d observed_;
  double inv_sigma_;
};

}  // namespace mmba::factors
