// Space resection: the pose of one image from points of known world coordinates that it
// measures (OpenCV's P3P inside RANSAC on normalised image coordinates from the camera model,
// then a least-squares refinement of the pose in pixels through the full model).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"

namespace mmba::orientation {

struct ResectionOptions {
  /// RANSAC inlier threshold in pixels (reprojection error); a blunder larger than this is
  /// found. Range (0, 1000].
  double max_error_px = 8.0;
  int max_iterations = 2000;  ///< RANSAC iterations, ≥ 1
  /// Fewest inliers for a pose: 4 (P3P and one point to choose among its solutions), ≥ 4.
  int min_inliers = 4;
  bool Check(std::string* error) const;
};

struct ResectionResult {
  bool ok = false;
  std::string reason;              ///< why not, when !ok
  Rigid3d cam_from_world;
  std::vector<bool> inlier;        ///< per input point
  double rms_px = 0.0;             ///< of the inliers after refinement
  size_t num_inliers() const;
};

/// The pose of an image of `camera` measuring `xy_px[i]` (mmba pixels) of `point_in_world[i]`.
/// Points with a pixel the model cannot map to a ray are outliers.
ResectionResult Resect(const sensors::Camera& camera, const std::vector<Eigen::Vector2d>& xy_px,
                       const std::vector<Eigen::Vector3d>& point_in_world, const ResectionOptions& options);

/// Least-squares refinement of `cam_from_world` on the pixel residuals of the given points
/// (camera and points held); returns the RMS error in pixels.
double RefinePose(const sensors::Camera& camera, const std::vector<Eigen::Vector2d>& xy_px,
                  const std::vector<Eigen::Vector3d>& point_in_world, Rigid3d* cam_from_world);

/// Pixel reprojection error of a point; infinity when the model cannot image it.
double ReprojectionErrorPx(const sensors::Camera& camera, const Rigid3d& cam_from_world, const Eigen::Vector2d& xy_px,
                           const Eigen::Vector3d& point_in_world);

}  // namespace mmba::orientation
