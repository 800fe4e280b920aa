#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mmba {

/// A rigid transform `target_from_source`: x_target = rotation * x_source + translation.
/// Name variables after the frames they connect (`cam_from_world`, `world_from_scan`).
/// The quaternion is kept normalised by every operation here.
struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
      : rotation(rotation.normalized()), translation(translation) {}

  /// From a 3×4 [R | t] or 4×4 homogeneous matrix (R orthonormalised through a quaternion).
  static Rigid3d FromMatrix(const Eigen::Matrix<double, 3, 4>& matrix);

  /// 3×4 [R | t].
  Eigen::Matrix<double, 3, 4> ToMatrix3x4() const;
  /// 4×4 homogeneous.
  Eigen::Matrix4d ToMatrix4() const;

  /// source_from_target.
  Rigid3d Inverse() const;

  /// The target frame's origin expressed in the source frame: for `cam_from_world` this is
  /// the projection centre in world coordinates.
  Eigen::Vector3d TargetOriginInSource() const {
    return -(rotation.inverse() * translation);
  }
};

/// Transforms a point: point_in_target = target_from_source * point_in_source.
inline Eigen::Vector3d operator*(const Rigid3d& target_from_source,
                                 const Eigen::Vector3d& point_in_source) {
  return target_from_source.rotation * point_in_source + target_from_source.translation;
}

/// Composition: c_from_a = c_from_b * b_from_a.
inline Rigid3d operator*(const Rigid3d& c_from_b, const Rigid3d& b_from_a) {
  Rigid3d c_from_a;
  c_from_a.rotation = (c_from_b.rotation * b_from_a.rotation).normalized();
  c_from_a.translation = c_from_b.rotation * b_from_a.translation + c_from_b.translation;
  return c_from_a;
}

/// Rotation angle (rad) and translation distance between two transforms of the same frames.
double RotationDifferenceRad(const Rigid3d& a, const Rigid3d& b);
double TranslationDifference(const Rigid3d& a, const Rigid3d& b);

}  // namespace mmba
