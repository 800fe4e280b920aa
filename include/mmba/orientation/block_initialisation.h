// Initial exterior orientation of an image block from image measurements, without COLMAP: the
// block is grown image by image (the next image is the one that measures the most points of
// known coordinates, as COLMAP's incremental mapper chooses), each image by space resection,
// each newly seen point by forward intersection. The seed is the control (resection of the
// image that sees the most control points) or, when no image sees enough control, the relative
// orientation of the pair with the most common points, moved onto the control by a similarity
// when 3 or more control points are intersected. Prior poses, when given, are used instead.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/orientation/resection.h"
#include "mmba/sensors/camera.h"

namespace mmba::orientation {

struct BlockMeasurement {
  std::string image_id;
  std::string point_id;
  Eigen::Vector2d xy_px = Eigen::Vector2d::Zero();
};

struct BlockInput {
  const sensors::Camera* camera = nullptr;            ///< of every image
  std::vector<std::string> images;                    ///< ids, in the order reported
  std::vector<BlockMeasurement> measurements;
  std::map<std::string, Eigen::Vector3d> control;     ///< world coordinates of control points
  std::map<std::string, Rigid3d> prior_cam_from_world;  ///< prior EO (used instead of a seed)
};

struct BlockOptions {
  ResectionOptions resection;
  double min_angle_deg = 2.0;         ///< a point is intersected when two rays meet at ≥ this
  double max_error_px = 8.0;          ///< largest reprojection error of an intersected point's rays
  double relative_max_error_px = 4.0; ///< RANSAC threshold of the relative orientation
  /// Intersection gate with prior EO: prior poses are approximate (DBAT's Roma prior is off
  /// by tens of pixels), the bundle refines them.
  double prior_max_error_px = 100.0;
  /// Smallest intersection angle with prior EO: the poses do not grow from the points, so a
  /// weak point cannot bend the block; DBAT's Roma network holds points seen at 1.05°.
  double prior_min_angle_deg = 0.5;
  bool Check(std::string* error) const;
};

/// A measurement left out of the initial block (and of the adjustment): a RANSAC outlier of a
/// resection or a ray that misses its intersected point.
struct InitialOutlier {
  std::string image_id;
  std::string point_id;
  double error_px = 0.0;
  std::string stage;  ///< "resection" or "intersection"
};

struct BlockResult {
  std::map<std::string, Rigid3d> cam_from_world;   ///< oriented images
  std::map<std::string, Eigen::Vector3d> points;   ///< every point with coordinates (control too)
  std::vector<std::string> log;                    ///< one line per step, in order
  std::vector<InitialOutlier> outliers;
  std::map<std::string, std::string> failed_images;  ///< image → why it is not oriented
  std::map<std::string, std::string> failed_points;  ///< point → why it has no coordinates
  /// How the block reached the world frame: "control", "prior EO", "relative orientation,
  /// similarity on N control points" or "relative orientation (arbitrary frame, unit base)".
  std::string frame;
};

BlockResult InitialiseBlock(const BlockInput& input, const BlockOptions& options);

}  // namespace mmba::orientation
