#pragma once

// Keypoints: 3D Kanade–Tomasi (Kim & Hilton Sec. 3.1), evenly distributed by a grid.

#include <string>
#include <vector>

#include "mmba/registration/cloud/feature_registration.h"
#include "registration/cloud/cloud_levels.h"

namespace mmba::registration::internal {

/// Keypoints of `level` (indices into its points): the strongest Kanade–Tomasi response
/// (normals within `normal_radius`) above F_t = options.keypoint_threshold in each cell of
/// keypoint_grid_spacing × `normal_radius`. Fewer than min_keypoints (planar proxy models have
/// few corners, Kim & Hilton Sec. 5): F_t is lowered, then a uniform grid is used; more than
/// `max_keypoints`: the cells are coarsened. Each fallback adds a note naming `which` cloud.
std::vector<int> SelectKeypoints(const Level& level, double normal_radius,
                                 const CloudRegistrationOptions& options, int max_keypoints,
                                 const std::string& which, std::vector<std::string>* notes);

}  // namespace mmba::registration::internal
