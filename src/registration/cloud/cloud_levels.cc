// Voxel grids, point spacing and blunder marks of the cloud registration's levels.

#include "registration/cloud/cloud_levels.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/SVD>

#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

namespace {

// Voxel keys → dense indices in first-seen order: open addressing with linear probing at a
// load of at most 1/2. The voxel grids run over the whole input clouds (tens of millions of
// points for a terrestrial scan pair), where std::unordered_map would allocate and free a
// node per point (its emplace builds the node before it looks the key up).
class VoxelTable {
 public:
  // Dense index of `key`; a key not seen before gets the next index and sets *inserted.
  int Insert(const VoxelKey& key, bool* inserted) {
    if (2 * (keys_.size() + 1) > slots_.size()) Grow();
    for (size_t s = Hash(key) & mask_;; s = (s + 1) & mask_) {
      const int v = slots_[s];
      if (v < 0) {
        slots_[s] = static_cast<int>(keys_.size());
        keys_.push_back(key);
        *inserted = true;
        return slots_[s];
      }
      if (keys_[static_cast<size_t>(v)] == key) {
        *inserted = false;
        return v;
      }
    }
  }
  // Dense index of `key`, or -1 when it was never inserted.
  int Find(const VoxelKey& key) const {
    if (slots_.empty()) return -1;
    for (size_t s = Hash(key) & mask_;; s = (s + 1) & mask_) {
      const int v = slots_[s];
      if (v < 0 || keys_[static_cast<size_t>(v)] == key) return v;
    }
  }
  size_t size() const { return keys_.size(); }

 private:
  static size_t Hash(const VoxelKey& k) {
    uint64_t h = static_cast<uint64_t>(k.x) * 0x9E3779B97F4A7C15ULL ^
                 static_cast<uint64_t>(k.y) * 0xC2B2AE3D27D4EB4FULL ^
                 static_cast<uint64_t>(k.z) * 0x165667B19E3779F9ULL;
    h ^= h >> 31;  // splitmix64's finaliser: the low bits index the slots
    h *= 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 29;
    return static_cast<size_t>(h);
  }
  void Grow() {
    slots_.assign(std::max<size_t>(1024, 2 * slots_.size()), -1);
    mask_ = slots_.size() - 1;
    for (size_t i = 0; i < keys_.size(); ++i) {
      size_t s = Hash(keys_[i]) & mask_;
      while (slots_[s] >= 0) s = (s + 1) & mask_;
      slots_[s] = static_cast<int>(i);
    }
  }
  std::vector<int> slots_;  // -1 = empty
  std::vector<VoxelKey> keys_;
  size_t mask_ = 0;
};

VoxelKey KeyOf(const Eigen::Vector3d& p, double voxel) {
  return {static_cast<int64_t>(std::floor(p.x() / voxel)), static_cast<int64_t>(std::floor(p.y() / voxel)),
          static_cast<int64_t>(std::floor(p.z() / voxel))};
}

}  // namespace

size_t VoxelCount(const std::vector<Eigen::Vector3d>& points, double voxel) {
  if (voxel <= 0) return points.size();
  VoxelTable table;
  bool inserted;
  for (const Eigen::Vector3d& p : points) table.Insert(KeyOf(p, voxel), &inserted);
  return table.size();
}

Level VoxelDownsample(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<Eigen::Vector3d>& normals, double voxel) {
  Level out;
  if (voxel <= 0) {
    out.points = points;
    out.normals = normals;
    return out;
  }
  VoxelTable table;
  std::vector<int> count;
  bool inserted;
  for (size_t i = 0; i < points.size(); ++i) {
    const int k = table.Insert(KeyOf(points[i], voxel), &inserted);
    if (inserted) {
      out.points.push_back(points[i]);
      if (!normals.empty()) out.normals.push_back(normals[i]);
      count.push_back(1);
    } else {
      out.points[k] += points[i];
      if (!normals.empty()) {
        // Flip to agree with the voxel's first normal before summing.
        const Eigen::Vector3d& n = normals[i];
        out.normals[k] += n.dot(out.normals[k]) < 0 ? -n : n;
      }
      ++count[k];
    }
  }
  for (size_t i = 0; i < out.points.size(); ++i) {
    out.points[i] /= count[i];
    if (!out.normals.empty()) {
      const double norm = out.normals[i].norm();
      out.normals[i] = norm > 1e-12 ? Eigen::Vector3d(out.normals[i] / norm)
                                    : Eigen::Vector3d::Constant(std::nan(""));
    }
  }
  return out;
}

std::vector<double> SpacingQuantiles(const PointIndex& index,
                                     const std::vector<Eigen::Vector3d>& points,
                                     size_t max_samples, const std::vector<double>& quantiles) {
  std::vector<double> out(quantiles.size(), 0.0);
  if (points.size() < 2) return out;
  const size_t step = std::max<size_t>(1, points.size() / max_samples);
  std::vector<double> d;
  std::vector<int> idx;
  std::vector<float> sq;
  for (size_t i = 0; i < points.size(); i += step) {
    index.KNearest(points[i], 2, &idx, &sq);
    if (sq.size() == 2 && sq[1] <= 0.f) index.KNearest(points[i], 16, &idx, &sq);
    const auto other = std::find_if(sq.begin() + (sq.empty() ? 0 : 1), sq.end(),
                                    [](float v) { return v > 0.f; });
    if (other != sq.end()) d.push_back(std::sqrt(*other));
  }
  if (d.empty()) return out;
  for (size_t q = 0; q < quantiles.size(); ++q) {
    const size_t k =
        std::min(d.size() - 1, static_cast<size_t>(quantiles[q] * static_cast<double>(d.size())));
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k), d.end());
    out[q] = d[k];
  }
  return out;
}

double MedianSpacing(const PointIndex& index, const std::vector<Eigen::Vector3d>& points,
                     size_t max_samples) {
  return SpacingQuantiles(index, points, max_samples, {0.5})[0];
}

std::vector<char> IsolatedPoints(const std::vector<Eigen::Vector3d>& points, double cell,
                                 int min_neighbours) {
  VoxelTable table;
  std::vector<int> cell_of(points.size());
  std::vector<int64_t> count;
  std::vector<VoxelKey> keys;
  for (size_t i = 0; i < points.size(); ++i) {
    const VoxelKey key = KeyOf(points[i], cell);
    bool inserted = false;
    cell_of[i] = table.Insert(key, &inserted);
    if (inserted) {
      count.push_back(0);
      keys.push_back(key);
    }
    ++count[static_cast<size_t>(cell_of[i])];
  }
  std::vector<char> cell_isolated(table.size());
  for (size_t c = 0; c < keys.size(); ++c) {
    int64_t around = -1;  // the point itself
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const int n = table.Find({keys[c].x + dx, keys[c].y + dy, keys[c].z + dz});
          if (n >= 0) around += count[static_cast<size_t>(n)];
        }
      }
    }
    cell_isolated[c] = around < min_neighbours;
  }
  std::vector<char> isolated(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    isolated[i] = cell_isolated[static_cast<size_t>(cell_of[i])];
  }
  return isolated;
}

std::vector<char> OffTheSurface(const PointIndex& index, const std::vector<Eigen::Vector3d>& points,
                                const std::vector<char>& candidates, int neighbours,
                                double max_thickness, double max_offset) {
  std::vector<char> off(points.size(), 0);
  std::vector<int> idx;
  std::vector<float> sq;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!candidates[i]) continue;
    index.KNearest(points[i], neighbours + 1, &idx, &sq);
    Eigen::MatrixXd q(3, static_cast<Eigen::Index>(idx.size()));
    Eigen::Index n = 0;
    for (const int j : idx) {
      if (static_cast<size_t>(j) != i) q.col(n++) = points[static_cast<size_t>(j)];
    }
    if (n < 3) {
      off[i] = 1;
      continue;
    }
    q.conservativeResize(3, n);
    const Eigen::Vector3d centre = q.rowwise().mean();
    q.colwise() -= centre;
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(q, Eigen::ComputeThinU);
    const Eigen::Vector3d sv = svd.singularValues();  // descending
    const double spread = sv(0) / std::sqrt(static_cast<double>(n));
    const double offset = std::abs(svd.matrixU().col(2).dot(points[i] - centre));
    off[i] = !(sv(0) > 0) || sv(2) > max_thickness * sv(0) || offset > max_offset * spread;
  }
  return off;
}

double MedianSpacing(const std::vector<Eigen::Vector3d>& points, size_t max_samples) {
  if (points.size() < 2) return 0.0;
  const PointIndex index(points);
  return MedianSpacing(index, points, max_samples);
}

double VoxelForBudget(const io::PointCloud& cloud, double voxel, size_t max_points,
                      double spacing_5000) {
  if (cloud.size() <= max_points && voxel <= 0) return 0.0;
  if (voxel <= 0) voxel = spacing_5000 > 0 ? spacing_5000 : MedianSpacing(cloud.points, 5000);
  // Surfaces: the count falls about as 1/voxel²; a few secant steps, then a safety margin.
  for (int k = 0; k < 8; ++k) {
    const size_t count = VoxelCount(cloud.points, voxel);
    if (count <= max_points) return voxel;
    voxel *= std::max(1.05, std::sqrt(static_cast<double>(count) / max_points) * 1.02);
  }
  return voxel;
}

std::string CheckCloud(const io::PointCloud& cloud, const std::string& which) {
  if (cloud.empty()) return which + " cloud is empty";
  if (cloud.size() < 10) {
    return which + " cloud has " + std::to_string(cloud.size()) + " points (need at least 10)";
  }
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points[i].allFinite()) {
      return which + " point " + std::to_string(i) + " is not finite (NaN/Inf)";
    }
  }
  return "";
}

void DropInvalidNormals(Level* level) {
  size_t j = 0;
  for (size_t i = 0; i < level->points.size(); ++i) {
    if (level->normals[i].allFinite()) {
      level->points[j] = level->points[i];
      level->normals[j] = level->normals[i];
      ++j;
    }
  }
  level->points.resize(j);
  level->normals.resize(j);
}

// Declared in pcl_backend.h.
double AreaSpacing(const std::vector<Eigen::Vector3d>& points, double voxel) {
  if (points.empty() || !(voxel > 0)) return 0.0;
  const double occupied = static_cast<double>(VoxelCount(points, voxel));
  return voxel * std::sqrt(occupied / (1.5 * static_cast<double>(points.size())));
}

}  // namespace mmba::registration::internal
