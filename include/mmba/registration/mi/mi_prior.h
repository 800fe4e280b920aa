#pragma once

// A weighted 6-DoF pose prior from an MI registration for the joint adjustment:
// the camera pose found by RegisterFrames (`cam_from_lidar_mi`) with the 6×6 covariance of
// its correction, as a Ceres residual on the pose blocks of the camera.
//
// Parameter blocks, in this order (the layout of factors/reprojection_error.h):
//   cam_from_lidar rotation     4  Eigen quaternion coefficients [x, y, z, w]
//   cam_from_lidar translation  3
// When the cloud is given in the world frame (a georeferenced survey), cam_from_lidar IS the
// camera's cam_from_world and these are its pose blocks.
//
// Residual, in the convention of RegistrationResult::correction (mi_registration.h: about the
// camera centre, axes of the LiDAR frame, metres and degrees):
//   e = [ c − c_mi ;  (180/π) · AngleAxis(R_lidar_from_cam · R_lidar_from_cam_miᵀ) ]
//   r = L⁻¹ · e,   Σ = L·Lᵀ (Cholesky of the covariance),   so ‖r‖² = eᵀ Σ⁻¹ e.
// c = the camera centre in the LiDAR frame. For small angles the rotation vector equals the
// (roll, pitch, yaw) of the correction to first order, the order in which Σ is given.

#include <memory>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "mmba/geometry/rigid3d.h"

namespace mmba::registration::mi {

class MiPosePrior {
 public:
  /// `covariance`: 6×6 in m², deg² (order tx, ty, tz, roll, pitch, yaw), symmetric positive
  /// definite; `sqrt_information` = L⁻¹ (see SqrtInformation).
  MiPosePrior(const Rigid3d& cam_from_lidar_mi,
              const Eigen::Matrix<double, 6, 6>& sqrt_information)
      : sqrt_information_(sqrt_information) {
    const Rigid3d lidar_from_cam = cam_from_lidar_mi.Inverse();
    centre_mi_ = lidar_from_cam.translation;
    lidar_from_cam_mi_ = lidar_from_cam.rotation;
  }

  /// L⁻¹ for Σ = L·Lᵀ; false (and `out` untouched) when Σ is not symmetric positive definite.
  static bool SqrtInformation(const Eigen::Matrix<double, 6, 6>& covariance,
                              Eigen::Matrix<double, 6, 6>* out) {
    if (!covariance.allFinite() ||
        !covariance.isApprox(covariance.transpose(), 1e-9 * covariance.norm() + 1e-300)) {
      return false;
    }
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(covariance);
    if (llt.info() != Eigen::Success) return false;
    const Eigen::Matrix<double, 6, 6> l = llt.matrixL();
    if (!(l.diagonal().minCoeff() > 0)) return false;
    *out = l.triangularView<Eigen::Lower>().solve(Eigen::Matrix<double, 6, 6>::Identity());
    return true;
  }

  /// The cost function, or nullptr when the covariance is not symmetric positive definite
  /// (e.g. a result with `covariance_valid` false: use no prior then).
  static ceres::CostFunction* Create(const Rigid3d& cam_from_lidar_mi,
                                     const Eigen::Matrix<double, 6, 6>& covariance) {
    Eigen::Matrix<double, 6, 6> sqrt_information;
    if (!SqrtInformation(covariance, &sqrt_information)) return nullptr;
    return new ceres::AutoDiffCostFunction<MiPosePrior, 6, 4, 3>(
        new MiPosePrior(cam_from_lidar_mi, sqrt_information));
  }

  template <typename T>
  bool operator()(const T* cam_from_lidar_rotation, const T* cam_from_lidar_translation,
                  T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> cam_from_lidar(cam_from_lidar_rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(cam_from_lidar_translation);
    const Eigen::Quaternion<T> lidar_from_cam = cam_from_lidar.conjugate();
    // Camera centre in the LiDAR frame: c = −R_cam_from_lidarᵀ · t.
    const Eigen::Matrix<T, 3, 1> centre = -(lidar_from_cam * translation);
    // Rotation correction in LiDAR axes: delta = R_lidar_from_cam · R_lidar_from_cam_miᵀ.
    const Eigen::Quaternion<T> delta = lidar_from_cam * lidar_from_cam_mi_.conjugate().cast<T>();
    const T delta_wxyz[4] = {delta.w(), delta.x(), delta.y(), delta.z()};
    T angle_axis[3];
    ceres::QuaternionToAngleAxis(delta_wxyz, angle_axis);
    Eigen::Matrix<T, 6, 1> error;
    const T deg_per_rad = T(180.0 / M_PI);
    error << centre - centre_mi_.cast<T>(), angle_axis[0] * deg_per_rad,
        angle_axis[1] * deg_per_rad, angle_axis[2] * deg_per_rad;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residuals);
    r = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  Eigen::Matrix<double, 6, 6> sqrt_information_;
  Eigen::Vector3d centre_mi_;
  Eigen::Quaterniond lidar_from_cam_mi_;
};

}  // namespace mmba::registration::mi
