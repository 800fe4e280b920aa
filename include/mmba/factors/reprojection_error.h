#pragma once

// Reprojection residuals (after Ceres' examples/snavely_reprojection_error.h and COLMAP's
// ReprojectionErrorCostFunctor): templated on the camera model, whitened by the a-priori σ.
//
// Parameter blocks, in this order:
//   cam_from_world rotation    4  Eigen quaternion coefficients [x, y, z, w]
//   cam_from_world translation 3
//   point_in_world             3
//   camera params              Model::kNumParams (COLMAP order)

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "mmba/factors/perspective_reprojection_cost.h"
#include "mmba/sensors/camera.h"
#include "mmba/sensors/camera_models.h"

namespace mmba::factors {

/// Perspective models: r = (ImgFromCam(params, cam_from_world · X) − x_observed) / σ_px.
template <typename CameraModel>
class ReprojectionError {
 public:
  ReprojectionError(const Eigen::Vector2d& observed_xy, double sigma_px)
      : observed_x_(observed_xy.x()),
        observed_y_(observed_xy.y()),
        inv_sigma_(1.0 / sigma_px) {}

  /// The residual with its Jacobian by the chain rule (perspective_reprojection_cost.h).
  static ceres::CostFunction* Create(const Eigen::Vector2d& observed_xy, double sigma_px) {
    return new PerspectiveReprojectionCost<CameraModel>(observed_xy, sigma_px);
  }

  /// The same residual differentiated by one Jet over all parameters (the reference of the
  /// chain rule in tests).
  static ceres::CostFunction* CreateAutoDiff(const Eigen::Vector2d& observed_xy, double sigma_px) {
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, 4, 3, 3, CameraModel::kNumParams>(
        new ReprojectionError(observed_xy, sigma_px));
  }

  template <typename T>
  bool operator()(const T* cam_from_world_rotation, const T* cam_from_world_translation,
                  const T* point_in_world, const T* camera_params, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(cam_from_world_rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(cam_from_world_translation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> point(point_in_world);
    const Eigen::Matrix<T, 3, 1> point_in_cam = rotation * point + translation;
    T xy[2];
    // A point that moved behind the camera makes this step invalid; Ceres rejects it.
    if (!CameraModel::ImgFromCam(camera_params, point_in_cam.data(), xy)) return false;
    residuals[0] = (xy[0] - T(observed_x_)) * T(inv_sigma_);
    residuals[1] = (xy[1] - T(observed_y_)) * T(inv_sigma_);
    return true;
  }

 private:
  double observed_x_;
  double observed_y_;
  double inv_sigma_;
};

/// Spherical models (EQUIRECTANGULAR): the residual is the angle on the sphere between the
/// observed bearing b = CamFromImg(x_observed) and the direction to the point p, as a 2-D
/// vector in the tangent plane at b, scaled to pixels by the model's f (pixels per radian)
/// and whitened by σ_px:
///   t = (e1·p, e2·p),  d = b·p,  α = atan2(‖t‖, d),  r = f · α · t/‖t‖ / σ_px.
/// It is exact for any angle up to 180°, with no discontinuity at the ±180° seam of the
/// panorama or at the poles (DESIGN.md, "Equirectangular").
/// (e1, e2) is a fixed orthonormal basis of the tangent plane built from b and one
/// coordinate axis chosen once from the observation, so it is smooth in the parameters.
template <typename CameraModel>
class SphericalReprojectionError {
 public:
  SphericalReprojectionError(const Eigen::Vector2d& observed_xy, double sigma_px,
                             const double* initial_params)
      : observed_x_(observed_xy.x()), observed_y_(observed_xy.y()), inv_sigma_(1.0 / sigma_px) {
    double ray[3];
    CameraModel::CamFromImg(initial_params, observed_x_, observed_y_, ray);
    // The axis least aligned with the bearing keeps the cross product well conditioned.
    int axis = 0;
    for (int i = 1; i < 3; ++i) {
      if (std::abs(ray[i]) < std::abs(ray[axis])) axis = i;
    }
    axis_ = axis;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& observed_xy, double sigma_px,
                                     const double* initial_params) {
    return new ceres::AutoDiffCostFunction<SphericalReprojectionError, 2, 4, 3, 3,
                                           CameraModel::kNumParams>(
        new SphericalReprojectionError(observed_xy, sigma_px, initial_params));
  }

  template <typename T>
  bool operator()(const T* cam_from_world_rotation, const T* cam_from_world_translation,
                  const T* point_in_world, const T* camera_params, T* residuals) const {
    using std::atan2;
    using std::sqrt;
    using ceres::atan2;
    using ceres::sqrt;
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(cam_from_world_rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(cam_from_world_translation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> point(point_in_world);
    const Eigen::Matrix<T, 3, 1> p = rotation * point + translation;

    Eigen::Matrix<T, 3, 1> b;
    CameraModel::CamFromImg(camera_params, T(observed_x_), T(observed_y_), b.data());
    Eigen::Matrix<T, 3, 1> axis = Eigen::Matrix<T, 3, 1>::Zero();
    axis[axis_] = T(1);
    Eigen::Matrix<T, 3, 1> e1 = axis.cross(b);
    e1 /= e1.norm();
    const Eigen::Matrix<T, 3, 1> e2 = b.cross(e1);

    const T t1 = e1.dot(p);
    const T t2 = e2.dot(p);
    const T d = b.dot(p);
    const T s2 = t1 * t1 + t2 * t2;
    const T p2 = s2 + d * d;
    if (!(p2 > T(0))) return false;  // the point sits at the projection centre
    T factor;
    if (s2 < T(1e-16) * p2) {
      // α/‖t‖ → 1/d as ‖t‖ → 0 in front; exactly behind, the direction is undefined.
      if (!(d > T(0))) return false;
      factor = T(1) / d;
    } else {
      const T s = sqrt(s2);
      factor = atan2(s, d) / s;
    }
    const T scale = camera_params[CameraModel::kFocalIdxs[0]] * factor * T(inv_sigma_);
    residuals[0] = scale * t1;
    residuals[1] = scale * t2;
    return true;
  }

 private:
  double observed_x_;
  double observed_y_;
  double inv_sigma_;
  int axis_ = 0;
};

/// The right residual for a runtime model id: spherical models get the angular residual.
/// `params` are the camera's current parameters (the spherical residual picks its tangent
/// basis from them). Returns nullptr for an unknown model.
inline ceres::CostFunction* CreateReprojectionCost(sensors::CameraModelId model_id,
                                                   const Eigen::Vector2d& observed_xy,
                                                   double sigma_px, const double* params) {
  using sensors::CameraModelId;
  switch (model_id) {
    case CameraModelId::kEquirectangular:
      return SphericalReprojectionError<sensors::EquirectangularModel>::Create(observed_xy,
                                                                               sigma_px, params);
#define MMBA_CASE(Model) \
  case Model::kModelId:  \
    return ReprojectionError<Model>::Create(observed_xy, sigma_px);
      MMBA_CASE(sensors::SimplePinholeModel)
      MMBA_CASE(sensors::PinholeModel)
      MMBA_CASE(sensors::SimpleRadialModel)
      MMBA_CASE(sensors::RadialModel)
      MMBA_CASE(sensors::OpenCVModel)
      MMBA_CASE(sensors::OpenCVFisheyeModel)
      MMBA_CASE(sensors::FullOpenCVModel)
      MMBA_CASE(sensors::FOVModel)
      MMBA_CASE(sensors::SimpleRadialFisheyeModel)
      MMBA_CASE(sensors::RadialFisheyeModel)
      MMBA_CASE(sensors::ThinPrismFisheyeModel)
      MMBA_CASE(sensors::PhotogrammetricModel)
#undef MMBA_CASE
    default:
      return nullptr;
  }
}

}  // namespace mmba::factors
