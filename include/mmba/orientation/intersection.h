// Forward intersection of a point from its measurements in oriented images: the linear
// (homogeneous DLT) solution on normalised image coordinates, then a least-squares refinement
// of the point in pixels through the full camera model.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"

namespace mmba::orientation {

/// One measurement of the point: its image's pose and camera, the pixel.
struct Ray {
  const sensors::Camera* camera = nullptr;
  Rigid3d cam_from_world;
  Eigen::Vector2d xy_px = Eigen::Vector2d::Zero();
};

struct IntersectionResult {
  bool ok = false;
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
  double max_angle_deg = 0.0;   ///< largest angle between two of its rays at the point
  double max_error_px = 0.0;    ///< largest reprojection error after refinement
};

/// Intersects ≥ 2 rays. ok when the point lies in front of every camera and the largest
/// angle between rays is at least `min_angle_deg` (a weaker geometry gives an unstable depth).
IntersectionResult Intersect(const std::vector<Ray>& rays, double min_angle_deg);

}  // namespace mmba::orientation
