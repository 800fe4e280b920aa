#include "mmba/geometry/rigid3d.h"

#include <cmath>

#include "mmba/geometry/sim3d.h"

namespace mmba {

Rigid3d Rigid3d::FromMatrix(const Eigen::Matrix<double, 3, 4>& matrix) {
  const Eigen::Matrix3d r = matrix.leftCols<3>();
  // Nearest rotation (polar decomposition via SVD), then a quaternion.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d rotation = svd.matrixU() * svd.matrixV().transpose();
  if (rotation.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1.0;
    rotation = u * svd.matrixV().transpose();
  }
  return Rigid3d(Eigen::Quaterniond(rotation), matrix.col(3));
}

Eigen::Matrix<double, 3, 4> Rigid3d::ToMatrix3x4() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = rotation.toRotationMatrix();
  m.col(3) = translation;
  return m;
}

Eigen::Matrix4d Rigid3d::ToMatrix4() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = ToMatrix3x4();
  return m;
}

Rigid3d Rigid3d::Inverse() const {
  Rigid3d inverse;
  inverse.rotation = rotation.inverse();
  inverse.translation = -(inverse.rotation * translation);
  return inverse;
}

double RotationDifferenceRad(const Rigid3d& a, const Rigid3d& b) {
  return a.rotation.angularDistance(b.rotation);
}

double TranslationDifference(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm();
}

Sim3d Sim3d::Inverse() const {
  Sim3d inverse;
  inverse.scale = 1.0 / scale;
  inverse.rotation = rotation.inverse();
  inverse.translation = -(inverse.scale * (inverse.rotation * translation));
  return inverse;
}

Eigen::Matrix<double, 3, 4> Sim3d::ToMatrix3x4() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = scale * rotation.toRotationMatrix();
  m.col(3) = translation;
  return m;
}

Rigid3d Sim3d::TransformCamFromSource(const Rigid3d& cam_from_source) const {
  // x_cam = R_c x_s + t_c and x_s = (R^T (x_t - t)) / s, so
  // x_cam = R_c R^T x_t / s - R_c R^T t / s + t_c. Scaling camera coordinates by s keeps
  // the same image: x_cam' = R_c R^T x_t - R_c R^T t + s t_c.
  Rigid3d cam_from_target;
  cam_from_target.rotation = (cam_from_source.rotation * rotation.inverse()).normalized();
  cam_from_target.translation =
      scale * cam_from_source.translation - cam_from_target.rotation * translation;
  return cam_from_target;
}

}  // namespace mmba
