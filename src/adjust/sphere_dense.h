#pragma once

// Private to mmba_adjust: the dense cloud of a vertical-baseline spherical stereo pair.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/io_cloud/point_cloud.h"
#include "mmba/sensors/camera.h"

namespace mmba::adjust::internal {

struct DenseStereoOptions {
  int max_width = 2048;        ///< panoramas wider than this are matched at this width
  double min_range_m = 1.0;    ///< sets the disparity search range
  double max_range_m = 80.0;
  double disparity_sigma_px = 0.5;   ///< at the matching resolution
  double max_relative_sigma = 0.1;   ///< points with σ_range / range above this are dropped
  double min_texture = 8.0;          ///< mean |Sobel| along the column over the block (grey levels)
};

struct DenseStereoCloud {
  io::PointCloud cloud;               ///< lower sphere's camera frame; intensity 0..1 from the lower image
  std::vector<double> range_sigma_m;  ///< per point
  int match_width = 0;                ///< the width the pair was matched at
  size_t matched_pixels = 0;          ///< pixels with a disparity, before the range/σ cut
};

/// Dense cloud of one station. The pair shares its orientation and the upper centre is at
/// `baseline` in the lower frame (vertical: the epipolar lines are the image columns). The
/// upper panorama is resampled onto the lower's intrinsics, both are transposed so the
/// columns become rows, matched by OpenCV's semi-global matching (Hirschmüller, PAMI 2008),
/// and each disparity is triangulated as the midpoint of the two rays. Throws InputError
/// naming the file when an image cannot be read or does not have the calibrated size.
DenseStereoCloud DenseSphericalStereo(const std::string& lower_path, const std::string& upper_path,
                                      const sensors::Camera& lower, const sensors::Camera& upper,
                                      const Eigen::Vector3d& baseline, const DenseStereoOptions& options = {});

/// The midpoint of two rays: origin + s·a and `c` + t·b (a, b unit). False when the rays
/// are parallel or the point lies behind either centre.
bool TriangulateMidpoint(const Eigen::Vector3d& a, const Eigen::Vector3d& c, const Eigen::Vector3d& b,
                         Eigen::Vector3d* point);

}  // namespace mmba::adjust::internal
