#pragma once

// Bundle Adjustment in the Large (BAL) problems (Agarwal et al. 2010,
// https://grail.cs.washington.edu/projects/bal/):
//   <num_cameras> <num_points> <num_observations>
//   <camera_index> <point_index> <x> <y>          (num_observations lines)
//   <9 camera parameters> × num_cameras           (ω[3] angle-axis, t[3], f, k1, k2)
//   <3 point coordinates> × num_points
// Observations have the image centre at the origin and y up (Snavely camera,
// factors/snavely_reprojection_error.h).

#include <string>
#include <vector>

namespace mmba::io {

struct BalObservation {
  int camera_index = 0;
  int point_index = 0;
  double x = 0.0;
  double y = 0.0;
};

struct BalProblem {
  int num_cameras = 0;
  int num_points = 0;
  std::vector<BalObservation> observations;
  std::vector<double> cameras;  ///< 9 per camera
  std::vector<double> points;   ///< 3 per point

  double* mutable_camera(int i) { return cameras.data() + 9 * i; }
  double* mutable_point(int i) { return points.data() + 3 * i; }
};

/// Reads a BAL file. Throws InputError (file:line, field, value, expectation) on a missing
/// file, wrong or negative counts, indices out of range, non-numeric / NaN / Inf values,
/// a truncated file or data after the last point.
BalProblem ReadBal(const std::string& path);

}  // namespace mmba::io
