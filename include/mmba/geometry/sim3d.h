#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mmba/geometry/rigid3d.h"

namespace mmba {

/// A similarity `target_from_source`: x_target = scale * rotation * x_source + translation.
struct Sim3d {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Sim3d() = default;
  Sim3d(double scale, const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
      : scale(scale), rotation(rotation.normalized()), translation(translation) {}
  explicit Sim3d(const Rigid3d& rigid)
      : scale(1.0), rotation(rigid.rotation), translation(rigid.translation) {}

  /// source_from_target.
  Sim3d Inverse() const;
  /// 3×4 [sR | t].
  Eigen::Matrix<double, 3, 4> ToMatrix3x4() const;

  /// Transforms a camera pose `cam_from_source` into `cam_from_target` for this
  /// target_from_source similarity (the camera keeps its orientation relative to the scene;
  /// its projection centre moves with the points).
  Rigid3d TransformCamFromSource(const Rigid3d& cam_from_source) const;
};

inline Eigen::Vector3d operator*(const Sim3d& target_from_source,
                                 const Eigen::Vector3d& point_in_source) {
  return target_from_source.scale * (target_from_source.rotation * point_in_source) +
         target_from_source.translation;
}

/// c_from_a = c_from_b * b_from_a.
inline Sim3d operator*(const Sim3d& c_from_b, const Sim3d& b_from_a) {
  Sim3d c_from_a;
  c_from_a.scale = c_from_b.scale * b_from_a.scale;
  c_from_a.rotation = (c_from_b.rotation * b_from_a.rotation).normalized();
  c_from_a.translation =
      c_from_b.scale * (c_from_b.rotation * b_from_a.translation) + c_from_b.translation;
  return c_from_a;
}

}  // namespace mmba
