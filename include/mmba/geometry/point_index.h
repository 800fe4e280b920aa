#pragma once

// Exact nearest-neighbour search over 3-D points (a kd-tree). PCL-free: nanoflann, header-only,
// inside the implementation.

#include <memory>
#include <vector>

#include <Eigen/Core>

namespace mmba {

/// Exact kd-tree over 3-D points (nanoflann). Coordinates are stored as floats relative to a
/// local origin — the median of each coordinate over at most 100,000 evenly strided points,
/// rounded to whole kilometres (the rule of io::LocalOrigin; zero for a cloud whose centre is
/// within 500 m of (0, 0, 0)) — so that clouds in map-grid coordinates keep ~0.1 mm. Squared
/// distances are those of the float coordinates. Indices are into the `points` given to the
/// constructor; the index keeps no reference to them.
class PointIndex {
 public:
  explicit PointIndex(const std::vector<Eigen::Vector3d>& points);
  ~PointIndex();
  PointIndex(const PointIndex&) = delete;
  PointIndex& operator=(const PointIndex&) = delete;
  /// Nearest point; false if the tree is empty.
  bool Nearest(const Eigen::Vector3d& query, int* index, double* squared_distance) const;
  /// Nearest point within `max_squared_distance` (inclusive); false if there is none. Same
  /// answer as Nearest() followed by the distance test, but the search is pruned at the
  /// bound: far queries cost little.
  bool NearestWithin(const Eigen::Vector3d& query, double max_squared_distance, int* index,
                     double* squared_distance) const;
  /// The `k` nearest points, nearest first (fewer when the tree holds fewer).
  void KNearest(const Eigen::Vector3d& query, int k, std::vector<int>* indices,
                std::vector<float>* squared_distances) const;
  /// Points within `radius` (strictly), in the tree's order.
  void Radius(const Eigen::Vector3d& query, double radius, std::vector<int>* indices) const;
  /// Points within `radius` (strictly) with their squared distances; nearest first when
  /// `sorted`, else in the tree's order.
  void RadiusWithDistances(const Eigen::Vector3d& query, double radius, std::vector<int>* indices,
                           std::vector<float>* squared_distances, bool sorted = true) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mmba
