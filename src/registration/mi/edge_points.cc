// LiDAR edge points along the scan rings (Levinson & Thrun, RSS 2013, Sec. IV-A).

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "mmba/registration/mi/edges.h"

namespace mmba::registration::mi {

bool EdgeOptions::Check(std::string* error) const {
  std::ostringstream out;
  if (!(cell_deg > 0 && cell_deg <= 5)) out << "edge_cell_deg = " << cell_deg << " not in (0, 5]";
  else if (neighbour_cells < 1) out << "edge_neighbour_cells = " << neighbour_cells << " < 1";
  else if (!(min_jump_m > 0)) out << "edge_min_jump_m = " << min_jump_m << " not > 0";
  else if (!(jump_fraction >= 0)) out << "edge_jump_fraction = " << jump_fraction << " < 0";
  else if (!(intensity_quantile > 0 && intensity_quantile <= 1))
    out << "edge_intensity_quantile = " << intensity_quantile << " not in (0, 1]";
  else if (!(alpha >= 0 && alpha <= 1)) out << "edge_alpha = " << alpha << " not in [0, 1]";
  else if (!(gamma > 0 && gamma < 1)) out << "edge_gamma = " << gamma << " not in (0, 1)";
  else if (!(blur_px >= 0)) out << "edge_blur_px = " << blur_px << " < 0";
  else if (!(level_blur_factor >= 1)) out << "edge_level_blur_factor = " << level_blur_factor << " < 1";
  else if (levels < 1 || levels > 6) out << "edge_levels = " << levels << " not in 1..6";
  if (out.str().empty()) return true;
  if (error != nullptr) *error = out.str();
  return false;
}

namespace {

// The scan grid: per cell (row = elevation, column = azimuth) the index of its nearest point.
struct ScanGrid {
  int rows = 0, cols = 0;
  std::vector<int> nearest;
  std::vector<float> range;  ///< per point
  int at(int r, int c) const { return nearest[static_cast<size_t>(r) * cols + c]; }
};

ScanGrid BuildGrid(const LidarPoints& points, const Eigen::Vector3f& centre, double cell_deg) {
  ScanGrid grid;
  const double cell = cell_deg * M_PI / 180.0;
  grid.cols = static_cast<int>(std::ceil(2 * M_PI / cell));
  grid.rows = static_cast<int>(std::ceil(M_PI / cell)) + 1;
  grid.nearest.assign(static_cast<size_t>(grid.rows) * grid.cols, -1);
  grid.range.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f v = points.points_in_lidar[i] - centre;
    const float r = v.norm();
    grid.range[i] = r;
    if (!(r > 0)) continue;
    const double azimuth = std::atan2(v.y(), v.x()) + M_PI;           // 0 .. 2π
    const double elevation = std::asin(std::clamp(v.z() / r, -1.f, 1.f)) + M_PI / 2;  // 0 .. π
    const int c = std::min(grid.cols - 1, static_cast<int>(azimuth / cell));
    const int row = std::min(grid.rows - 1, static_cast<int>(elevation / cell));
    int& cell_point = grid.nearest[static_cast<size_t>(row) * grid.cols + c];
    if (cell_point < 0 || r < grid.range[cell_point]) cell_point = static_cast<int>(i);
  }
  return grid;
}

// The nearest occupied cell of row r from column c in direction step (±1), within `reach`
// cells (azimuth wraps); -1 if none.
int RingNeighbour(const ScanGrid& grid, int r, int c, int step, int reach) {
  for (int k = 1; k <= reach; ++k) {
    const int column = ((c + step * k) % grid.cols + grid.cols) % grid.cols;
    const int index = grid.at(r, column);
    if (index >= 0) return index;
  }
  return -1;
}

float IntensityOf(const LidarPoints& points, int i) {
  const float v = points.intensity01[i];
  return v - std::floor(v);  // without a surface class (class + fraction)
}

}  // namespace

std::vector<EdgePoint> DetectLidarEdges(const LidarPoints& points, const Eigen::Vector3f& centre,
                                        const EdgeOptions& options) {
  const ScanGrid grid = BuildGrid(points, centre, options.cell_deg);
  const bool intensity = points.has_intensity() && options.intensity_quantile < 1;
  std::vector<EdgePoint> edges;
  std::vector<std::pair<float, int>> differences;  // intensity difference, point
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const int i = grid.at(r, c);
      if (i < 0) continue;
      const float range = grid.range[i];
      const float threshold =
          std::max(static_cast<float>(options.min_jump_m), static_cast<float>(options.jump_fraction) * range);
      float jump = 0, difference = 0;
      int continuous = 0;  // neighbours on the same surface (depth within the threshold)
      for (int step : {-1, 1}) {
        const int j = RingNeighbour(grid, r, c, step, options.neighbour_cells);
        if (j < 0) continue;
        const float dr = grid.range[j] - range;
        jump = std::max(jump, dr);  // farther neighbours only: the near side of the edge
        if (std::abs(dr) < threshold) {
          ++continuous;
          if (intensity) difference = std::max(difference, std::abs(IntensityOf(points, j) - IntensityOf(points, i)));
        }
      }
      // A depth edge ends a surface: one neighbour behind the jump, the other on the point's
      // own surface (foliage, whose ranges jump at every step, has no such ends).
      if (jump >= threshold && continuous == 1) {
        edges.push_back({points.points_in_lidar[i], std::sqrt(jump), 0});
      } else if (difference > 0) {
        differences.emplace_back(difference, i);
      }
    }
  }
  if (intensity && !differences.empty()) {
    std::vector<float> values(differences.size());
    for (size_t k = 0; k < differences.size(); ++k) values[k] = differences[k].first;
    const size_t q = std::min(values.size() - 1,
                              static_cast<size_t>(options.intensity_quantile * values.size()));
    std::nth_element(values.begin(), values.begin() + q, values.end());
    const float cut = values[q];
    for (const auto& [difference, i] : differences) {
      if (difference > cut) edges.push_back({points.points_in_lidar[i], difference, 1});
    }
  }
  return edges;
}

LidarPoints EdgeCloud(const LidarPoints& points, const EdgeOptions& options) {
  LidarPoints cloud;
  for (const EdgePoint& edge : DetectLidarEdges(points, Eigen::Vector3f::Zero(), options)) {
    cloud.points_in_lidar.push_back(edge.point_in_lidar);
  }
  cloud.intensity01.assign(cloud.size(), 1.f);
  return cloud;
}

}  // namespace mmba::registration::mi
