// Keypoint selection of the cloud registration (Kim & Hilton 3DV 2013, Sec. 3.1).

#include "registration/cloud/keypoints.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

namespace {

// Keypoints: 3D Kanade–Tomasi (Kim & Hilton Sec. 3.1), evenly distributed by a grid: the
// strongest response above F_t in each cell.
std::vector<int> GridMaxima(const std::vector<Eigen::Vector3d>& points,
                            const std::vector<float>& response, double threshold, double cell) {
  std::unordered_map<VoxelKey, int, VoxelKeyHash> best;
  for (size_t i = 0; i < points.size(); ++i) {
    if (response[i] < threshold) continue;
    const VoxelKey key{static_cast<int64_t>(std::floor(points[i].x() / cell)),
                       static_cast<int64_t>(std::floor(points[i].y() / cell)),
                       static_cast<int64_t>(std::floor(points[i].z() / cell))};
    auto [it, inserted] = best.emplace(key, static_cast<int>(i));
    if (!inserted && response[i] > response[it->second]) it->second = static_cast<int>(i);
  }
  std::vector<int> out;
  out.reserve(best.size());
  for (const auto& [key, i] : best) out.push_back(i);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

std::vector<int> SelectKeypoints(const Level& level, double normal_radius,
                                 const CloudRegistrationOptions& options, int max_keypoints,
                                 const std::string& which, std::vector<std::string>* notes) {
  const std::vector<float> response =
      internal::TomasiResponse(level.points, level.normals, normal_radius);
  const double cell = options.keypoint_grid_spacing * normal_radius;
  std::vector<int> keypoints = GridMaxima(level.points, response, options.keypoint_threshold, cell);
  // Planar proxy models have too few corners (Kim & Hilton Sec. 5): lower F_t, then take a
  // uniform grid of points.
  double threshold = options.keypoint_threshold;
  while (static_cast<int>(keypoints.size()) < options.min_keypoints && threshold > 1e-3) {
    threshold /= 4.0;
    keypoints = GridMaxima(level.points, response, threshold, cell);
    if (static_cast<int>(keypoints.size()) >= options.min_keypoints) {
      std::ostringstream s;
      s << which << ": only few keypoints at F_t = " << options.keypoint_threshold
        << ", lowered to " << threshold;
      notes->push_back(s.str());
    }
  }
  if (static_cast<int>(keypoints.size()) < options.min_keypoints) {
    keypoints = GridMaxima(level.points, std::vector<float>(level.points.size(), 1.0f), 0.0,
                           cell);
    notes->push_back(which + ": too few Kanade–Tomasi keypoints, used a uniform grid");
  }
  // Bound the descriptor cost: coarser grid cells until at most max_keypoints remain.
  double coarser = cell;
  for (int k = 0; k < 10 && static_cast<int>(keypoints.size()) > max_keypoints; ++k) {
    coarser *= std::max(1.1, std::sqrt(static_cast<double>(keypoints.size()) / max_keypoints));
    keypoints = GridMaxima(level.points, response, threshold, coarser);
  }
  return keypoints;
}

}  // namespace mmba::registration::internal
