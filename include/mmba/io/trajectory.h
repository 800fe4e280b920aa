// GNSS/INS trajectories of a vehicle body: CSV rows time_s, x_east_m, y_north_m, z_up_m,
// qw, qx, qy, qz (world_from_body; body x forward, y left, z up), as `mmba simulate` writes
// them and `mmba adjust` and `mmba register-mi` read them.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "mmba/geometry/rigid3d.h"

namespace mmba::io {

/// The rows of a trajectory CSV (at least 2, strictly increasing times, unit quaternions);
/// InputError naming the file, line and column otherwise.
std::vector<std::pair<double, Rigid3d>> ReadTrajectory(const std::string& path);

/// world_from_body at `time` from the trajectory rows (linear position, slerp rotation; the
/// first or last row outside their span).
Rigid3d InterpolateTrajectory(const std::vector<std::pair<double, Rigid3d>>& rows, double time);

}  // namespace mmba::io
