#include "registration/cloud/free_space.h"

#include <algorithm>
#include <cmath>

namespace mmba::registration::internal {
namespace {

int Columns(double cell, int ring) {
  // Ring `ring` spans elevations [ring·cell − π/2, (ring + 1)·cell − π/2); its columns are
  // about `cell` wide at the ring's widest parallel (equal-area-ish cells).
  const double lo = ring * cell - M_PI / 2, hi = lo + cell;
  const double widest = (lo <= 0 && hi >= 0) ? 1.0 : std::max(std::cos(lo), std::cos(hi));
  return std::max(1, static_cast<int>(std::ceil(2.0 * M_PI * widest / cell)));
}

}  // namespace

bool FreeSpace::Cell(const View& v, const Eigen::Vector3d& d, int* ring, int* column,
                     int* columns) {
  const double r = d.norm();
  if (!(r > 0)) return false;
  const double elevation = std::asin(std::clamp(d.z() / r, -1.0, 1.0));
  *ring = static_cast<int>(std::floor((elevation + M_PI / 2) / v.cell));
  *columns = Columns(v.cell, *ring);
  const double azimuth = std::atan2(d.y(), d.x()) + M_PI;  // [0, 2π]
  *column = std::min(*columns - 1, static_cast<int>(std::floor(azimuth / (2 * M_PI) * *columns)));
  return true;
}

FreeSpace::FreeSpace(const std::vector<Eigen::Vector3d>& points,
                     const std::vector<Eigen::Vector3d>& sensors, double spacing,
                     double cell_spacings) {
  if (points.empty() || !(spacing > 0)) return;
  for (const Eigen::Vector3d& s : sensors) {
    View v;
    v.origin = s;
    std::vector<double> ranges;
    ranges.reserve(points.size());
    for (const Eigen::Vector3d& p : points) ranges.push_back((p - s).norm());
    std::vector<double> sorted = ranges;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double median = sorted[sorted.size() / 2];
    if (!(median > 0)) continue;
    v.cell = std::min(0.1, cell_spacings * spacing / median);
    for (size_t i = 0; i < points.size(); ++i) {
      int ring, column, columns;
      if (!Cell(v, points[i] - s, &ring, &column, &columns)) continue;
      auto [it, inserted] = v.first.try_emplace(Key(ring, column), static_cast<float>(ranges[i]),
                                                static_cast<int>(i));
      if (!inserted && ranges[i] < it->second.first) {
        it->second = {static_cast<float>(ranges[i]), static_cast<int>(i)};
      }
    }
    views_.push_back(std::move(v));
  }
}

bool FreeSpace::Violates(const Eigen::Vector3d& q, double margin, int* surface,
                         Eigen::Vector3d* hit) const {
  for (const View& v : views_) {
    const Eigen::Vector3d d = q - v.origin;
    int ring, column, columns;
    if (!Cell(v, d, &ring, &column, &columns)) continue;
    const auto own = v.first.find(Key(ring, column));
    if (own == v.first.end()) continue;  // the sensor saw nothing along this ray
    double nearest = own->second.first;
    const double azimuth_fraction = (column + 0.5) / columns;
    for (int dr = -1; dr <= 1; ++dr) {
      const int rr = ring + dr;
      if (rr < 0) continue;
      const int n = Columns(v.cell, rr);
      const int centre = std::min(n - 1, static_cast<int>(std::floor(azimuth_fraction * n)));
      for (int dc = -1; dc <= 1; ++dc) {
        const int cc = ((centre + dc) % n + n) % n;
        const auto it = v.first.find(Key(rr, cc));
        if (it != v.first.end()) nearest = std::min(nearest, static_cast<double>(it->second.first));
      }
    }
    if (d.norm() < nearest - margin) {
      if (surface != nullptr) *surface = own->second.second;
      if (hit != nullptr) *hit = v.origin + d.normalized() * own->second.first;
      return true;
    }
  }
  return false;
}

}  // namespace mmba::registration::internal
