// Relative orientation of an image pair from their common measurements: the essential matrix
// (OpenCV's five-point solver, Nistér 2004, inside RANSAC on normalised coordinates) and the
// pose it implies (cv::recoverPose's cheirality test).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"

namespace mmba::orientation {

struct RelativeOrientationResult {
  bool ok = false;
  std::string reason;
  /// The second image's pose in the first's camera frame, |translation| = 1 (unknown scale).
  Rigid3d cam2_from_cam1;
  std::vector<bool> inlier;  ///< per correspondence
};

/// `xy1_px[i]` in the first image and `xy2_px[i]` in the second measure the same point.
/// `max_error_px`: RANSAC threshold (epipolar distance) in pixels; needs ≥ 8 correspondences
/// of which ≥ 5 inliers in front of both cameras.
RelativeOrientationResult RelativeOrientation(const sensors::Camera& camera1, const sensors::Camera& camera2,
                                              const std::vector<Eigen::Vector2d>& xy1_px,
                                              const std::vector<Eigen::Vector2d>& xy2_px, double max_error_px);

}  // namespace mmba::orientation
