#pragma once

// The levels of the coarse-to-fine registration: voxel-grid downsampling, point spacing,
// the scattered blunders of a cloud, and small helpers over point sets.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/point_index.h"
#include "mmba/io_cloud/point_cloud.h"

namespace mmba::registration::internal {

/// Why `cloud` (the "source" or "target", `which`) cannot be registered — empty, fewer than
/// 10 points, a non-finite point — or "" when it can.
std::string CheckCloud(const io::PointCloud& cloud, const std::string& which);

/// One level of the coarse-to-fine registration: points (a voxel-grid thinning of a cloud),
/// their normals and the median nearest-neighbour spacing (metres; 0 when not measured).
struct Level {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;  // empty or one per point
  double spacing = 0.0;
};

/// A voxel (or block) of a regular grid: floor(coordinate / cell size) per axis.
struct VoxelKey {
  int64_t x, y, z;
  bool operator==(const VoxelKey& o) const { return x == o.x && y == o.y && z == o.z; }
};

struct VoxelKeyHash {
  size_t operator()(const VoxelKey& k) const {
    return static_cast<size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};

/// Number of occupied voxels (what VoxelDownsample would keep), without building the level.
size_t VoxelCount(const std::vector<Eigen::Vector3d>& points, double voxel);

/// Voxel-grid downsampling to the centroid of each occupied voxel (normals averaged).
Level VoxelDownsample(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<Eigen::Vector3d>& normals, double voxel);

/// The `quantiles` (ascending) of the distance to the nearest other point over every
/// (size / max_samples)-th point, on `index` (built on `points`); 0.5: the median spacing.
/// Points at the same place count once (a tiled LAS or a mesh export repeats its points: the
/// nearest other point is then a copy at distance 0, and the median of every point written
/// twice would be 0); a sample whose 16 nearest are all copies of it is left out.
std::vector<double> SpacingQuantiles(const PointIndex& index,
                                     const std::vector<Eigen::Vector3d>& points,
                                     size_t max_samples, const std::vector<double>& quantiles);

/// SpacingQuantiles' median.
double MedianSpacing(const PointIndex& index, const std::vector<Eigen::Vector3d>& points,
                     size_t max_samples);

/// Marks the isolated points of `points`: fewer than `min_neighbours` other points in the
/// 3 × 3 × 3 cells of size `cell` around the point's own cell (so its min_neighbours-th
/// nearest other point lies farther than `cell`). Counted per occupied cell, not per point.
std::vector<char> IsolatedPoints(const std::vector<Eigen::Vector3d>& points, double cell,
                                 int min_neighbours);

/// Of the `candidates` (IsolatedPoints), those that do not lie on a surface: the point's
/// `neighbours` nearest others either do not form a surface (the smallest singular value of
/// their centred coordinates above max_thickness × the largest) or the point lies off their
/// plane by more than max_offset × their spread along it (the largest singular value / √k).
/// A clean model's sparse far points (a far wall, grazing ground) lie on the surface their
/// neighbours form; blunders floating in space do not.
std::vector<char> OffTheSurface(const PointIndex& index, const std::vector<Eigen::Vector3d>& points,
                                const std::vector<char>& candidates, int neighbours,
                                double max_thickness, double max_offset);

/// The same with a kd-tree built here; 0 for fewer than 2 points.
double MedianSpacing(const std::vector<Eigen::Vector3d>& points, size_t max_samples);

/// Smallest voxel >= `voxel` that leaves at most `max_points` (0 = keep the cloud as is when
/// it is small enough).
/// `spacing_5000`: MedianSpacing(cloud.points, 5000) when the caller has it (0: computed here).
double VoxelForBudget(const io::PointCloud& cloud, double voxel, size_t max_points,
                      double spacing_5000 = 0.0);

/// t · p for a 4 × 4 homogeneous transform t.
inline Eigen::Vector3d Apply(const Eigen::Matrix4d& t, const Eigen::Vector3d& p) {
  return t.topLeftCorner<3, 3>() * p + t.topRightCorner<3, 1>();
}

/// Removes points whose normal is not finite.
void DropInvalidNormals(Level* level);

/// The elements `idx` of `v`, in that order (empty when `v` is empty).
template <typename T>
std::vector<T> Pick(const std::vector<T>& v, const std::vector<size_t>& idx) {
  std::vector<T> out;
  if (v.empty()) return out;
  out.reserve(idx.size());
  for (size_t i : idx) out.push_back(v[i]);
  return out;
}

}  // namespace mmba::registration::internal
