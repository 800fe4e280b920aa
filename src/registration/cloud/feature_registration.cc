// Feature-based registration pipeline (Kim & Hilton 3DV 2013, Sec. 3) and its robust
// extensions; see include/mmba/registration/cloud/feature_registration.h.

#include "mmba/registration/cloud/feature_registration.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <exception>
#include <iomanip>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/registration/cloud/robust_estimators.h"
#include "registration/cloud/free_space.h"
#include "registration/cloud/intensity_test.h"
#include "registration/cloud/normal_orientation.h"
#include "registration/cloud/pcl_backend.h"
#include "registration/cloud/score_significance.h"

namespace mmba::registration {

using internal::Descriptors;
using internal::FeatureIndex;
using internal::PointIndex;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

bool ParseDescriptor(const std::string& name, Descriptor* descriptor) {
  if (name == "fpfh") *descriptor = Descriptor::kFpfh;
  else if (name == "shot") *descriptor = Descriptor::kShot;
  else if (name == "si" || name == "spin") *descriptor = Descriptor::kSpinImage;
  else if (name == "sc3d" || name == "3dsc") *descriptor = Descriptor::kShapeContext;
  else if (name == "auto") *descriptor = Descriptor::kAuto;
  else return false;
  return true;
}

bool ParseNormalOrientation(const std::string& name, NormalOrientation* orientation) {
  if (name == "viewpoint") *orientation = NormalOrientation::kViewpoint;
  else if (name == "consistent") *orientation = NormalOrientation::kConsistent;
  else if (name == "consistent-turned") *orientation = NormalOrientation::kConsistentTurned;
  else if (name == "auto") *orientation = NormalOrientation::kAuto;
  else return false;
  return true;
}

std::string DescriptorName(Descriptor descriptor) {
  switch (descriptor) {
    case Descriptor::kFpfh: return "fpfh";
    case Descriptor::kShot: return "shot";
    case Descriptor::kSpinImage: return "si";
    case Descriptor::kShapeContext: return "sc3d";
    case Descriptor::kAuto: return "auto";
  }
  return "?";
}

bool CloudRegistrationOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& field, double value, const std::string& rule) {
    std::ostringstream s;
    s << "option '" << field << "' = " << value << " violates " << rule;
    *error = s.str();
    return false;
  };
  if (!(normal_radius_m >= 0)) return fail("normal_radius_m", normal_radius_m, ">= 0");
  if (!(support_radius_m >= 0)) return fail("support_radius_m", support_radius_m, ">= 0");
  if (normal_radius_m > 0 && support_radius_m > 0 && support_radius_m < normal_radius_m) {
    return fail("support_radius_m", support_radius_m, ">= normal_radius_m");
  }
  if (!(normal_radius_spacing > 0)) return fail("normal_radius_spacing", normal_radius_spacing, "> 0");
  if (!(support_radius_spacing > 0)) return fail("support_radius_spacing", support_radius_spacing, "> 0");
  if (!(keypoint_threshold >= 0 && keypoint_threshold <= 1.0 / 3.0)) {
    return fail("keypoint_threshold", keypoint_threshold, "0 <= F_t <= 1/3");
  }
  if (!(keypoint_grid_spacing > 0)) return fail("keypoint_grid_spacing", keypoint_grid_spacing, "> 0");
  if (min_keypoints < 3) return fail("min_keypoints", min_keypoints, ">= 3");
  if (max_keypoints < min_keypoints) return fail("max_keypoints", max_keypoints, ">= min_keypoints");
  if (max_points_features < 1000) return fail("max_points_features", max_points_features, ">= 1000");
  if (max_points_icp < 1000) return fail("max_points_icp", max_points_icp, ">= 1000");
  if (!(coarse_voxel_spacing >= 1)) return fail("coarse_voxel_spacing", coarse_voxel_spacing, ">= 1");
  if (min_points_coarse < 10) return fail("min_points_coarse", min_points_coarse, ">= 10");
  if (!(larger_cloud_factor >= 1)) return fail("larger_cloud_factor", larger_cloud_factor, ">= 1");
  if (!(isolated_cell_spacing > 0)) return fail("isolated_cell_spacing", isolated_cell_spacing, "> 0");
  if (isolated_min_neighbours < 1) return fail("isolated_min_neighbours", isolated_min_neighbours, ">= 1");
  if (!(isolated_min_fraction >= 0 && isolated_min_fraction <= 1)) {
    return fail("isolated_min_fraction", isolated_min_fraction, "0 <= x <= 1");
  }
  if (!(inlier_sigma > 0)) return fail("inlier_sigma", inlier_sigma, "> 0");
  if (sac_ia_iterations < 1) return fail("sac_ia_iterations", sac_ia_iterations, ">= 1");
  if (sac_ia_draws_per_iteration < 1) {
    return fail("sac_ia_draws_per_iteration", sac_ia_draws_per_iteration, ">= 1");
  }
  if (num_cliques < 1) return fail("num_cliques", num_cliques, ">= 1");
  if (sac_ia_randomness < 1) return fail("sac_ia_randomness", sac_ia_randomness, ">= 1");
  if (!(sac_ia_confidence > 0 && sac_ia_confidence <= 1)) {
    return fail("sac_ia_confidence", sac_ia_confidence, "0 < x <= 1");
  }
  if (!(sac_ia_alternative_ratio > 0 && sac_ia_alternative_ratio <= 1)) {
    return fail("sac_ia_alternative_ratio", sac_ia_alternative_ratio, "0 < x <= 1");
  }
  if (num_hypotheses < 1) return fail("num_hypotheses", num_hypotheses, ">= 1");
  if (!(search_window_m >= 0.0)) return fail("search_window_m", search_window_m, ">= 0");
  if (search_window_m > 0.0 && !(search_window_deg > 0.0 && search_window_deg <= 180.0)) {
    return fail("search_window_deg", search_window_deg, "(0, 180] with a search window");
  }
  if (!(consistency_spacing > 0)) return fail("consistency_spacing", consistency_spacing, "> 0");
  if (max_correspondences < 3) return fail("max_correspondences", max_correspondences, ">= 3");
  if (!(std::abs(up.norm() - 1.0) < 1e-6)) return fail("up (norm)", up.norm(), "a unit vector");
  if (icp_iterations < 1) return fail("icp_iterations", icp_iterations, ">= 1");
  if (!(icp_distance_spacing > 0)) return fail("icp_distance_spacing", icp_distance_spacing, "> 0");
  if (!(icp_plane_distance_spacing > 0)) {
    return fail("icp_plane_distance_spacing", icp_plane_distance_spacing, "> 0");
  }
  if (!(icp_noise_sigmas >= 0)) return fail("icp_noise_sigmas", icp_noise_sigmas, ">= 0");
  if (!(inlier_distance_spacing > 0)) {
    return fail("inlier_distance_spacing", inlier_distance_spacing, "> 0");
  }
  if (!(min_fitness > 0 && min_fitness <= 1)) return fail("min_fitness", min_fitness, "0 < x <= 1");
  if (!(min_normal_agreement >= 0 && min_normal_agreement <= 1)) {
    return fail("min_normal_agreement", min_normal_agreement, "0 <= x <= 1");
  }
  if (!(min_significance >= 0)) return fail("min_significance", min_significance, ">= 0");
  if (num_period_shifts < 0) return fail("num_period_shifts", num_period_shifts, ">= 0");
  if (!(symmetry_cone_deg >= 0 && symmetry_cone_deg <= 90)) {
    return fail("symmetry_cone_deg", symmetry_cone_deg, "0 <= x <= 90");
  }
  if (!(symmetry_cone_step_deg > 0)) {
    return fail("symmetry_cone_step_deg", symmetry_cone_step_deg, "> 0");
  }
  if (!(resolution_t > 0)) return fail("resolution_t", resolution_t, "> 0");
  if (!(max_resolution_spacing > 0)) {
    return fail("max_resolution_spacing", max_resolution_spacing, "> 0");
  }
  if (!(max_weak_motion_resolution_spacing > 0)) {
    return fail("max_weak_motion_resolution_spacing", max_weak_motion_resolution_spacing, "> 0");
  }
  if (!(min_coarse_agreement >= 0 && min_coarse_agreement <= 1)) {
    return fail("min_coarse_agreement", min_coarse_agreement, "0 <= x <= 1");
  }
  if (!(max_ambiguity >= 0 && max_ambiguity <= 1)) {
    return fail("max_ambiguity", max_ambiguity, "0 <= x <= 1");
  }
  if (!(max_violation_ratio >= 0)) return fail("max_violation_ratio", max_violation_ratio, ">= 0");
  if (!(min_fitness_visible > 0 && min_fitness_visible <= 1)) {
    return fail("min_fitness_visible", min_fitness_visible, "0 < x <= 1");
  }
  for (const auto* v : {&source_viewpoints, &target_viewpoints}) {
    for (size_t i = 0; i < v->size(); ++i) {
      if (!(*v)[i].allFinite()) {
        return fail(std::string(v == &source_viewpoints ? "source" : "target") +
                        "_viewpoints[" + std::to_string(i) + "] (a coordinate)",
                    (*v)[i].sum(), "finite");
      }
    }
  }
  return true;
}

double CloudRegistrationResult::total_seconds() const {
  double t = 0.0;
  for (const StageTime& s : runtime) t += s.seconds;
  return t;
}

std::string CloudRegistrationResult::BriefReport() const {
  std::ostringstream s;
  s << std::setprecision(4) << "registration " << status;
  if (!reason.empty()) s << " (" << reason << ")";
  s << ": descriptor " << descriptor << ", fitness " << fitness << ", inlier RMSE "
    << inlier_rmse << " m, normal agreement " << normal_agreement << ", confidence "
    << confidence;
  // How sure the pose is, in the result's own words (the JSON has the full covariance).
  if (std::isfinite(resolution_m) && resolution_m > 0.0) {
    s << ", resolved to " << resolution_m << " m";
  }
  if (std::isfinite(sigma_rms_m) && sigma_rms_m > 0.0) s << " (sigma " << sigma_rms_m << " m RMS)";
  s << ", keypoints " << num_keypoints_source << "/" << num_keypoints_target
    << ", correspondences " << num_correspondences << ", " << total_seconds() << " s";
  return s.str();
}

namespace {

// ---------------------------------------------------------------------------------------
// Levels (coarse-to-fine).

struct Level {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;  // empty or one per point
  double spacing = 0.0;
};

struct VoxelKey {
  int64_t x, y, z;
  bool operator==(const VoxelKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct VoxelKeyHash {
  size_t operator()(const VoxelKey& k) const {
    return static_cast<size_t>(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};

// Voxel keys → dense indices in first-seen order: open addressing with linear probing at a
// load of at most 1/2. The voxel grids run over the whole input clouds (tens of millions of
// points for a terrestrial scan pair), where std::unordered_map allocated and freed a node
// per point (its emplace builds the node before it looks the key up).
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

// Number of occupied voxels (what VoxelDownsample would keep), without building the level.
size_t VoxelCount(const std::vector<Eigen::Vector3d>& points, double voxel) {
  if (voxel <= 0) return points.size();
  VoxelTable table;
  bool inserted;
  for (const Eigen::Vector3d& p : points) table.Insert(KeyOf(p, voxel), &inserted);
  return table.size();
}

// Voxel-grid downsampling to the centroid of each occupied voxel (normals averaged).
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

// The `quantiles` (ascending) of the distance to the nearest other point over every
// (size / max_samples)-th point, on `index` (built on `points`); 0.5: the median spacing.
// Points at the same place count once (a tiled LAS or a mesh export repeats its points: the
// nearest other point is then a copy at distance 0, and the median of every point written
// twice would be 0); a sample whose 16 nearest are all copies of it is left out.
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

// Marks the isolated points of `points`: fewer than `min_neighbours` other points in the
// 3 × 3 × 3 cells of size `cell` around the point's own cell (so its min_neighbours-th
// nearest other point lies farther than `cell`). Counted per occupied cell, not per point.
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

// Of the `candidates` (IsolatedPoints), those that do not lie on a surface: the point's
// `neighbours` nearest others either do not form a surface (the smallest singular value of
// their centred coordinates above max_thickness × the largest) or the point lies off their
// plane by more than max_offset × their spread along it (the largest singular value / √k).
// A clean model's sparse far points (a far wall, grazing ground) lie on the surface their
// neighbours form; blunders floating in space do not.
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

// Smallest voxel >= `voxel` that leaves at most `max_points` (0 = keep the cloud as is when
// it is small enough).
// `spacing_5000`: MedianSpacing(cloud.points, 5000) when the caller has it (0: computed here).
double VoxelForBudget(const io::PointCloud& cloud, double voxel, size_t max_points,
                      double spacing_5000 = 0.0) {
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

Eigen::Vector3d Apply(const Eigen::Matrix4d& t, const Eigen::Vector3d& p) {
  return t.topLeftCorner<3, 3>() * p + t.topRightCorner<3, 1>();
}

// Removes points whose normal is not finite.
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

// ---------------------------------------------------------------------------------------
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

// ---------------------------------------------------------------------------------------
// Hypotheses.

struct Hypothesis {
  std::string origin;
  std::string descriptor;
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
  double cost = 0.0;  // SAC-IA cost (lower is better)
  double fitness = 0.0, rmse = 0.0, normal_agreement = 0.0, score = 0.0;
  double conflict = 0.0;  // fine: of the points near a target surface, those not on it
  double violation = 0.0;  // fine: fraction of the source in observed free space
  size_t inliers = 0;
};

// Transforms differ less than `rotation_deg` and `translation_m` (measured at `centre`).
bool SameTransform(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b,
                   const Eigen::Vector3d& centre, double rotation_deg, double translation_m) {
  const Eigen::Matrix3d r = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  return RotationAngleDeg(r) < rotation_deg &&
         (Apply(a, centre) - Apply(b, centre)).norm() < translation_m;
}

struct Matching {
  std::string descriptor;
  std::vector<Eigen::Vector3d> src_kp, tgt_kp;     // valid keypoints
  std::vector<std::vector<int>> src_to_tgt;        // k nearest target keypoints per source
  std::vector<std::pair<int, int>> best_pairs;     // for the clique: nearest (and mutual first)
};

Matching MatchDescriptors(const std::string& name, const Level& src, const Level& tgt,
                          const std::vector<int>& src_kp, const std::vector<int>& tgt_kp,
                          const Descriptors& ds, const Descriptors& dt, int k,
                          size_t max_pairs) {
  Matching m;
  m.descriptor = name;
  std::vector<float> src_data, tgt_data;
  const int dim = ds.dim;
  for (size_t i = 0; i < src_kp.size(); ++i) {
    if (!ds.valid[i]) continue;
    m.src_kp.push_back(src.points[src_kp[i]]);
    src_data.insert(src_data.end(), ds.data.begin() + i * dim, ds.data.begin() + (i + 1) * dim);
  }
  for (size_t i = 0; i < tgt_kp.size(); ++i) {
    if (!dt.valid[i]) continue;
    m.tgt_kp.push_back(tgt.points[tgt_kp[i]]);
    tgt_data.insert(tgt_data.end(), dt.data.begin() + i * dim, dt.data.begin() + (i + 1) * dim);
  }
  if (m.src_kp.size() < 3 || m.tgt_kp.size() < 3) return m;
  FeatureIndex tgt_index(tgt_data, dim), src_index(src_data, dim);
  std::vector<int> idx, back;
  std::vector<float> sq, back_sq;
  std::vector<std::tuple<int, float, int, int>> pairs;  // (not mutual, distance, src, tgt)
  m.src_to_tgt.resize(m.src_kp.size());
  for (size_t i = 0; i < m.src_kp.size(); ++i) {
    tgt_index.KNearest(&src_data[i * dim], k, &idx, &sq);
    m.src_to_tgt[i] = idx;
    if (idx.empty() || idx[0] < 0) continue;
    src_index.KNearest(&tgt_data[idx[0] * dim], 1, &back, &back_sq);
    const bool mutual = !back.empty() && back[0] == static_cast<int>(i);
    pairs.emplace_back(mutual ? 0 : 1, sq[0], static_cast<int>(i), idx[0]);
  }
  // Target-to-source nearest neighbours add the correspondences the other way round.
  for (size_t j = 0; j < m.tgt_kp.size(); ++j) {
    src_index.KNearest(&tgt_data[j * dim], 1, &back, &back_sq);
    if (back.empty() || back[0] < 0) continue;
    if (!m.src_to_tgt[back[0]].empty() && m.src_to_tgt[back[0]][0] == static_cast<int>(j)) {
      continue;  // already in as a mutual pair
    }
    pairs.emplace_back(1, back_sq[0], back[0], static_cast<int>(j));
  }
  std::sort(pairs.begin(), pairs.end());
  for (size_t i = 0; i < pairs.size() && i < max_pairs; ++i) {
    m.best_pairs.emplace_back(std::get<2>(pairs[i]), std::get<3>(pairs[i]));
  }
  return m;
}

// Keeps the `capacity` best distinct hypotheses by cost.
class HypothesisPool {
 public:
  HypothesisPool(size_t capacity, Eigen::Vector3d centre, double translation_m)
      : capacity_(capacity), centre_(std::move(centre)), translation_m_(translation_m) {}
  void Offer(const Hypothesis& h) {
    for (Hypothesis& existing : pool_) {
      if (SameTransform(existing.transform, h.transform, centre_, 5.0, translation_m_)) {
        if (h.cost < existing.cost) existing = h;
        Sort();
        return;
      }
    }
    if (pool_.size() < capacity_) {
      pool_.push_back(h);
    } else if (h.cost < pool_.back().cost) {
      pool_.back() = h;
    } else {
      return;
    }
    Sort();
  }
  const std::vector<Hypothesis>& hypotheses() const { return pool_; }
  /// Cost a new hypothesis must beat to enter (infinite while the pool is not full).
  double worst_cost() const {
    return pool_.size() < capacity_ ? std::numeric_limits<double>::infinity() : pool_.back().cost;
  }

 private:
  void Sort() {
    std::stable_sort(pool_.begin(), pool_.end(),
                     [](const Hypothesis& a, const Hypothesis& b) { return a.cost < b.cost; });
  }
  size_t capacity_;
  Eigen::Vector3d centre_;
  double translation_m_;
  std::vector<Hypothesis> pool_;
};

// Truncated-quadratic alignment cost of `sample` under `t` (mean of min(d², τ²) / τ²).
// Stops early (returns 1) once the cost must exceed `bound` (a hypothesis that cannot enter
// the pool is not worth scoring to the end).
double AlignmentCost(const std::vector<Eigen::Vector3d>& sample, const PointIndex& target,
                     const Eigen::Matrix4d& t, double tau,
                     double bound = std::numeric_limits<double>::infinity()) {
  double cost = 0.0;
  int index;
  double sq;
  const double tau2 = tau * tau;
  const double n = static_cast<double>(std::max<size_t>(1, sample.size()));
  const double limit = bound * tau2 * n;
  // The sample is in random order: after the first kPreview points the mean cost already
  // tells a hopeless hypothesis (preemptive scoring, as Nistér's preemptive RANSAC, 2005).
  constexpr size_t kPreview = 64;
  for (size_t i = 0; i < sample.size(); ++i) {
    if (!target.NearestWithin(Apply(t, sample[i]), tau2, &index, &sq)) sq = tau2;
    cost += std::min(sq, tau2);
    if (cost > limit) return 1.0;
    if (i + 1 == kPreview && sample.size() > 2 * kPreview &&
        cost / (tau2 * kPreview) > std::min(1.0, 1.5 * bound + 0.1)) {
      return 1.0;
    }
  }
  return cost / (tau2 * n);
}

// SAC-IA (Rusu, Blodow & Beetz, "Fast Point Feature Histograms for 3D Registration", ICRA
// 2009, Sec. IV-A): draw samples of source keypoints at least `min_distance` apart, pair each
// with one of its k most similar target keypoints at random, fit a rigid transform and score
// the whole (sampled) source; here with a truncated quadratic score, a cheap edge-length
// pre-check of the sample, and the best distinct hypotheses kept rather than one.
void SacIa(const Matching& m, const std::vector<Eigen::Vector3d>& score_sample,
           const PointIndex& target, const CloudRegistrationOptions& options, double spacing,
           double min_distance, double tau, std::mt19937_64* rng, HypothesisPool* pool) {
  const int n = static_cast<int>(m.src_kp.size());
  if (n < 3 || m.tgt_kp.size() < 3) return;
  const int sample_size = options.gravity_aligned ? 2 : 3;
  const double tolerance = options.consistency_spacing * spacing;
  std::uniform_int_distribution<int> pick(0, n - 1);
  const Eigen::Vector3d* up = options.gravity_aligned ? &options.up : nullptr;
  // `sac_ia_iterations` samples that pass the edge-length pre-check are scored; with many
  // wrong matches (repetitive structure) most draws fail it, so up to
  // sac_ia_draws_per_iteration × as many are drawn.
  int scored = 0;
  const int64_t max_draws =
      static_cast<int64_t>(options.sac_ia_iterations) * options.sac_ia_draws_per_iteration;
  // Adaptive stop (Fischler & Bolles 1981, Eq. for k; Hartley & Zisserman Sec. 4.7.1): with ε
  // the probability that a draw for one source keypoint picks a correct target, a sample is
  // all-correct with probability ε^m, and N = log(1 − p) / log(1 − ε^m) draws find one with
  // probability p. ε is measured under the best pose so far: the fraction of the (keypoint,
  // candidate) pairs it maps within the consistency tolerance; it is scaled by
  // sac_ia_alternative_ratio so that a competing pose with that share of the matches is
  // sampled with probability p as well. Re-estimated whenever the best pose changes.
  int64_t needed_draws = max_draws;
  // The paper's pipeline (paper_only) draws its fixed number of samples.
  const bool adaptive = options.sac_ia_confidence < 1.0 && !options.paper_only;
  Eigen::Matrix4d best_transform = Eigen::Matrix4d::Zero();
  auto update_stop = [&]() {
    if (!adaptive || pool->hypotheses().empty()) return;
    const Hypothesis& best = pool->hypotheses().front();
    if (best.transform == best_transform) return;
    best_transform = best.transform;
    double eps = 0.0;
    for (int i = 0; i < n; ++i) {
      const std::vector<int>& candidates = m.src_to_tgt[i];
      if (candidates.empty()) continue;
      const Eigen::Vector3d q = Apply(best.transform, m.src_kp[i]);
      int right = 0;
      for (int j : candidates) right += j >= 0 && (m.tgt_kp[j] - q).norm() < tolerance;
      eps += static_cast<double>(right) / static_cast<double>(candidates.size());
    }
    eps = options.sac_ia_alternative_ratio * eps / n;
    const double all_right = std::pow(eps, sample_size);
    if (all_right <= 0.0) return;
    if (all_right >= 1.0) {
      needed_draws = 1;
      return;
    }
    const double draws = std::log(1.0 - options.sac_ia_confidence) / std::log1p(-all_right);
    needed_draws = static_cast<int64_t>(std::min(static_cast<double>(max_draws), std::ceil(draws)));
  };
  for (int64_t draw = 0;
       draw < max_draws && scored < options.sac_ia_iterations && draw < needed_draws; ++draw) {
    int sample[3];
    bool ok = true;
    for (int s = 0; s < sample_size && ok; ++s) {
      bool found = false;
      for (int attempt = 0; attempt < 50 && !found; ++attempt) {
        const int c = pick(*rng);
        found = true;
        for (int r = 0; r < s; ++r) {
          if (c == sample[r] || (m.src_kp[c] - m.src_kp[sample[r]]).norm() < min_distance) {
            found = false;
          }
        }
        if (found) sample[s] = c;
      }
      ok = found;
    }
    if (!ok) continue;
    std::vector<Eigen::Vector3d> src, dst;
    for (int s = 0; s < sample_size; ++s) {
      const std::vector<int>& candidates = m.src_to_tgt[sample[s]];
      if (candidates.empty()) {
        ok = false;
        break;
      }
      std::uniform_int_distribution<int> choose(0, static_cast<int>(candidates.size()) - 1);
      const int j = candidates[choose(*rng)];
      if (j < 0) {
        ok = false;
        break;
      }
      src.push_back(m.src_kp[sample[s]]);
      dst.push_back(m.tgt_kp[j]);
    }
    if (!ok) continue;
    for (int a = 0; a < sample_size && ok; ++a) {
      for (int b = a + 1; b < sample_size; ++b) {
        if (std::abs((src[a] - src[b]).norm() - (dst[a] - dst[b]).norm()) > tolerance) ok = false;
      }
    }
    if (!ok) continue;
    Hypothesis h;
    h.transform = EstimateRigid(src, dst, up);
    ++scored;
    h.cost = AlignmentCost(score_sample, target, h.transform, tau, pool->worst_cost());
    h.origin = "sac-ia " + m.descriptor;
    h.descriptor = m.descriptor;
    pool->Offer(h);
    update_stop();
  }
}

// Maximum clique of pairwise-consistent correspondences, then a least-squares fit; then the
// maximum clique of the remaining correspondences, and so on (`count` cliques): a
// pseudo-symmetric object has one consistent set per symmetric pose, and the largest is not
// always the true one.
void CliqueHypotheses(const Matching& m, const CloudRegistrationOptions& options,
                      double spacing, int count, std::vector<Hypothesis>* out,
                      std::vector<std::string>* notes) {
  std::vector<std::pair<int, int>> pairs = m.best_pairs;
  for (int k = 0; k < count && pairs.size() >= 3; ++k) {
    std::vector<Eigen::Vector3d> src, dst;
    for (const auto& [i, j] : pairs) {
      src.push_back(m.src_kp[i]);
      dst.push_back(m.tgt_kp[j]);
    }
    CliqueOptions clique_options;
    clique_options.tolerance_m = options.consistency_spacing * spacing;
    bool exact = true;
    const std::vector<int> clique = MaxConsistentClique(src, dst, clique_options, &exact);
    if (!exact) notes->push_back("max-clique " + m.descriptor + ": search budget reached");
    if (clique.size() < (options.gravity_aligned ? 3u : 4u)) return;
    std::vector<Eigen::Vector3d> cs, cd;
    for (int i : clique) {
      cs.push_back(src[i]);
      cd.push_back(dst[i]);
    }
    Hypothesis h;
    h.transform = EstimateRigid(cs, cd, options.gravity_aligned ? &options.up : nullptr);
    h.origin = "max-clique " + m.descriptor + " #" + std::to_string(k) + " (" +
               std::to_string(clique.size()) + " of " + std::to_string(src.size()) + ")";
    h.descriptor = m.descriptor;
    out->push_back(h);
    std::vector<bool> used(pairs.size(), false);
    for (int i : clique) used[static_cast<size_t>(i)] = true;
    std::vector<std::pair<int, int>> rest;
    for (size_t i = 0; i < pairs.size(); ++i) {
      if (!used[i]) rest.push_back(pairs[i]);
    }
    pairs.swap(rest);
  }
}

// [a]×: [a]× b = a × b.
Eigen::Matrix3d CrossMatrix(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

// ---------------------------------------------------------------------------------------
// Point-to-plane ICP (Chen & Medioni 1991; linearised as Low 2004, Eq. 6–8), coarse to fine
// in the correspondence distance; rotation about `up` only when levelled.

// With `src_normals` the residual is plane-to-plane instead (Segal, Haehnel & Thrun 2009,
// "Generalized-ICP", Eq. 2 with the plane-to-plane covariances of Sec. III-B): each pair's
// 3-D difference d weighed by (R·C_s·Rᵀ + C_t)⁻¹, C = I − (1 − ε)·n·nᵀ (ε = 0.001) from each
// side's normal. Both surfaces' orientations count: a simplified model (a plane proxy)
// against a detailed scan is fitted along the model's planes, not along whatever detail
// the scan's normals describe next to them.
Eigen::Matrix4d PointToPlaneIcp(const std::vector<Eigen::Vector3d>& src,
                                const std::vector<Eigen::Vector3d>& tgt,
                                const std::vector<Eigen::Vector3d>& tgt_normals,
                                const PointIndex& tgt_index, Eigen::Matrix4d transform,
                                double start_distance, double end_distance, int iterations,
                                const Eigen::Vector3d* up,
                                const std::vector<Eigen::Vector3d>* src_normals = nullptr) {
  constexpr double kPlaneEpsilon = 1e-3;
  double distance = std::max(start_distance, end_distance);
  // Each step turns the source about its own centroid c (where it lies under the current
  // transform), not about the origin of the coordinates: a source far from that origin
  // against its size would move by the step's second-order term at that distance (a part
  // registered onto a whole model: the model's centre can be tens of metres away).
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : src) c += p;
  c /= static_cast<double>(std::max<size_t>(1, src.size()));
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> jtj = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> jtr = Eigen::Matrix<double, 6, 1>::Zero();
    int count = 0;
    int index;
    double sq;
    const double d2 = distance * distance;
    const Eigen::Vector3d centre = Apply(transform, c);
    const Eigen::Matrix3d rotation = transform.topLeftCorner<3, 3>();
    for (size_t i = 0; i < src.size(); ++i) {
      const Eigen::Vector3d q = Apply(transform, src[i]);
      if (!tgt_index.NearestWithin(q, d2, &index, &sq)) continue;
      const Eigen::Vector3d& n = tgt_normals[index];
      if (!n.allFinite()) continue;
      if (src_normals != nullptr && (*src_normals)[i].allFinite()) {
        const Eigen::Vector3d ns = rotation * (*src_normals)[i];
        const Eigen::Matrix3d cov = 2.0 * Eigen::Matrix3d::Identity() -
                                    (1.0 - kPlaneEpsilon) * (ns * ns.transpose() + n * n.transpose());
        const Eigen::Matrix3d info = cov.inverse();
        const Eigen::Vector3d e = q - tgt[index];
        // The weight from the residual a point-to-plane fit would see (eᵀ·info·e·2ε is
        // (n·e)² where the normals agree).
        const double r2 = e.dot(info * e) * 2.0 * kPlaneEpsilon;
        const double w = 1.0 / (1.0 + r2 / (0.25 * d2));
        Eigen::Matrix<double, 3, 6> j;
        j.leftCols<3>() = -CrossMatrix(q - centre);
        j.rightCols<3>() = Eigen::Matrix3d::Identity();
        // Scaled by 2ε so that the normal direction weighs as in the point-to-plane sum.
        const Eigen::Matrix3d wi = (w * 2.0 * kPlaneEpsilon) * info;
        jtj += j.transpose() * wi * j;
        jtr += j.transpose() * wi * e;
        ++count;
        continue;
      }
      const double r = (q - tgt[index]).dot(n);
      // Tukey-like down-weighting of the far residuals.
      const double w = 1.0 / (1.0 + (r * r) / (0.25 * d2));
      Eigen::Matrix<double, 6, 1> j;
      j.head<3>() = (q - centre).cross(n);
      j.tail<3>() = n;
      jtj += w * j * j.transpose();
      jtr += w * j * r;
      ++count;
    }
    if (count < 6) break;
    Eigen::Matrix<double, 6, 1> x;
    if (up != nullptr) {
      // Parameters (α about up, t): J_α = (q × n)·up.
      Eigen::Matrix<double, 6, 4> b = Eigen::Matrix<double, 6, 4>::Zero();
      b.block<3, 1>(0, 0) = *up;
      b.block<3, 3>(3, 1) = Eigen::Matrix3d::Identity();
      const Eigen::Matrix4d a = b.transpose() * jtj * b;
      const Eigen::Vector4d y = a.ldlt().solve(-b.transpose() * jtr);
      x = b * y;
    } else {
      x = jtj.ldlt().solve(-jtr);
    }
    if (!x.allFinite()) break;
    Eigen::Matrix4d delta = Eigen::Matrix4d::Identity();
    const Eigen::Vector3d omega = x.head<3>();
    if (omega.norm() > 1e-12) {
      delta.topLeftCorner<3, 3>() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    }
    delta.topRightCorner<3, 1>() = centre + x.tail<3>() - delta.topLeftCorner<3, 3>() * centre;
    transform = delta * transform;
    const bool small = omega.norm() < 1e-6 && x.tail<3>().norm() < 1e-3 * end_distance;
    if (small && distance <= end_distance) break;
    distance = std::max(end_distance, distance * 0.7);
  }
  return transform;
}

// Overlap and normal agreement of `src` (with normals) under `t` (hypothesis verification).
void Verify(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& src_n,
            const std::vector<Eigen::Vector3d>& tgt_n, const PointIndex& tgt_index,
            const Eigen::Matrix4d& t, double tau, Hypothesis* h) {
  size_t inliers = 0, agree = 0;
  double sum_sq = 0.0;
  int index;
  double sq;
  const double cos30 = std::cos(30.0 * M_PI / 180.0);
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  for (size_t i = 0; i < src.size(); ++i) {
    if (!tgt_index.NearestWithin(Apply(t, src[i]), tau * tau, &index, &sq)) continue;
    ++inliers;
    sum_sq += sq;
    if (!src_n.empty() && !tgt_n.empty() && src_n[i].allFinite() && tgt_n[index].allFinite() &&
        std::abs((r * src_n[i]).dot(tgt_n[index])) > cos30) {
      ++agree;
    }
  }
  h->inliers = inliers;
  h->fitness = src.empty() ? 0.0 : static_cast<double>(inliers) / src.size();
  h->rmse = inliers > 0 ? std::sqrt(sum_sq / inliers) : 0.0;
  h->normal_agreement = inliers > 0 ? static_cast<double>(agree) / inliers : 0.0;
  h->score = h->fitness * h->normal_agreement;
}

// The target around one hypothesis: the target points inside the box of the transformed
// source (grown by `margin`), thinned to `budget`, with normals and a kd-tree. A large
// reference (a whole LiDAR model against one object) is verified at its own resolution
// where the source lies rather than thinned as a whole.
struct TargetCrop {
  Level level;
  std::unique_ptr<PointIndex> index;
};

// The target points inside the box of `src` under `t`, grown by `margin`.
std::vector<size_t> CropIndices(const io::PointCloud& target,
                                const std::vector<Eigen::Vector3d>& src, const Eigen::Matrix4d& t,
                                double margin) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : src) {
    const Eigen::Vector3d q = Apply(t, p);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  lo.array() -= margin;
  hi.array() += margin;
  std::vector<size_t> inside;
  for (size_t i = 0; i < target.size(); ++i) {
    const Eigen::Vector3d& p = target.points[i];
    if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
    inside.push_back(i);
  }
  return inside;
}

// FNV-1a over the indices, a word at a time (a crop of a 24 M-point target holds millions):
// with the count, the key of a crop's point set.
uint64_t HashIndices(const std::vector<size_t>& indices) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i : indices) {
    h ^= static_cast<uint64_t>(i);
    h *= 1099511628211ull;
  }
  return h;
}

// The target points `inside` (CropIndices), voxel-thinned to at most `budget` points (grid
// at least `min_voxel`), with their index and spacing; the normals of a target that has them.
TargetCrop CropTarget(const io::PointCloud& target, bool use_normals,
                      const std::vector<size_t>& inside, size_t budget, double min_voxel) {
  io::PointCloud crop;
  crop.points.reserve(inside.size());
  for (size_t i : inside) crop.points.push_back(target.points[i]);
  if (use_normals) {
    crop.normals.reserve(inside.size());
    for (size_t i : inside) crop.normals.push_back(target.normals[i]);
  }
  TargetCrop out;
  const double voxel = crop.size() > budget ? VoxelForBudget(crop, min_voxel, budget) : min_voxel;
  out.level = VoxelDownsample(crop.points, crop.normals, voxel);
  out.index = std::make_unique<PointIndex>(out.level.points);
  out.level.spacing = MedianSpacing(*out.index, out.level.points, 20000);
  return out;
}

// Point-to-plane residuals of `src` under `t` against a target with normals: NaN where the
// nearest target point is farther than `reach` (no overlap there). `agree[i]`: the normals
// agree within 30° (Kim & Hilton's pseudo-symmetric failures, Sec. 5).
void FineResiduals(const std::vector<Eigen::Vector3d>& src,
                   const std::vector<Eigen::Vector3d>& src_n, const TargetCrop& target,
                   const Eigen::Matrix4d& t, double reach, std::vector<double>* residuals,
                   std::vector<bool>* agree) {
  residuals->assign(src.size(), std::nan(""));
  agree->assign(src.size(), false);
  const double cos30 = std::cos(30.0 * M_PI / 180.0);
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  int index;
  double sq;
  for (size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d q = Apply(t, src[i]);
    if (!target.index->NearestWithin(q, reach * reach, &index, &sq)) continue;
    const Eigen::Vector3d& n = target.level.normals[index];
    if (!n.allFinite()) continue;
    (*residuals)[i] = (q - target.level.points[index]).dot(n);
    (*agree)[i] = src_n.empty() || !src_n[i].allFinite() || std::abs((r * src_n[i]).dot(n)) > cos30;
  }
}

// Visibility test of a pose `t` (target_from_source): per source point, true where the pose
// contradicts what a sensor observed as empty space.
//  - Target side: the registered source point has no target point within `near` and lies
//    nearer to a target sensor than the first target surface along that sensor's ray by more
//    than `margin` (the target's sensor saw through it).
//  - Source side: a target point of the crop, taken into the source frame, inside the
//    source's bounding box (the region the source describes; a cropped part says nothing
//    beyond its crop) and with no source point within `near`, lies nearer to a source sensor
//    than the first source surface along its ray; the violation is charged to the source
//    point nearest to where that ray meets the surface (so the count scales with the
//    target's points, as on the target side, not with the z-buffer's cells).
// Points with a surface of the other cloud near them are never flagged (noise within `near`),
// and space no sensor of the other cloud looked through is neutral (occluded or unobserved):
// a partial overlap is not evidence against a pose, a point in observed free space is.
std::vector<bool> FreeSpaceViolations(const std::vector<Eigen::Vector3d>& src,
                                      const PointIndex& src_index,
                                      const internal::FreeSpace* src_free,
                                      const Eigen::AlignedBox3d& src_box,
                                      const TargetCrop& crop,
                                      const internal::FreeSpace* tgt_free,
                                      const Eigen::Matrix4d& t, double near, double margin) {
  std::vector<bool> out(src.size(), false);
  int index;
  double sq;
  if (tgt_free != nullptr && !tgt_free->empty()) {
    for (size_t i = 0; i < src.size(); ++i) {
      const Eigen::Vector3d q = Apply(t, src[i]);
      if (crop.index->NearestWithin(q, near * near, &index, &sq)) continue;
      if (tgt_free->Violates(q, margin)) out[i] = true;
    }
  }
  if (src_free != nullptr && !src_free->empty()) {
    const Eigen::Matrix3d rt = t.topLeftCorner<3, 3>().transpose();
    const Eigen::Vector3d tt = t.topRightCorner<3, 1>();
    for (const Eigen::Vector3d& c : crop.level.points) {
      const Eigen::Vector3d p = rt * (c - tt);
      if (!src_box.contains(p)) continue;
      if (src_index.NearestWithin(p, near * near, &index, &sq)) continue;
      Eigen::Vector3d hit;
      if (src_free->Violates(p, margin, nullptr, &hit) && src_index.Nearest(hit, &index, &sq)) {
        out[static_cast<size_t>(index)] = true;
      }
    }
  }
  return out;
}

// Robust scale of the residuals: 1.4826 × median |r| (MAD about 0), NaN-free; +inf if none.
double RobustScale(const std::vector<double>& residuals) {
  std::vector<double> a;
  a.reserve(residuals.size());
  for (double r : residuals) {
    if (std::isfinite(r)) a.push_back(std::abs(r));
  }
  if (a.size() < 10) return std::numeric_limits<double>::infinity();
  std::nth_element(a.begin(), a.begin() + a.size() / 2, a.end());
  return 1.4826 * a[a.size() / 2];
}

// Fine verification: inliers |r| < τ; score = Σ(1 − r²/τ²) over inliers with agreeing
// normals, divided by all source points (a truncated quadratic, Black & Rangarajan 1996),
// so a hypothesis a few σ off on part of the object loses against the one that fits it.
void ScoreFine(const std::vector<double>& residuals, const std::vector<bool>& agree, double tau,
               const std::vector<bool>& violates, Hypothesis* h) {
  size_t inliers = 0, agreeing = 0, near = 0, violating = 0;
  for (size_t i = 0; i < violates.size(); ++i) violating += violates[i] ? 1 : 0;
  double sum_sq = 0.0, score = 0.0;
  for (size_t i = 0; i < residuals.size(); ++i) {
    const double r = residuals[i];
    if (!std::isfinite(r)) continue;
    ++near;
    if (std::abs(r) >= tau) continue;
    ++inliers;
    sum_sq += r * r;
    if (agree[i]) {
      ++agreeing;
      score += 1.0 - (r * r) / (tau * tau);
    }
  }
  const double n = static_cast<double>(std::max<size_t>(1, residuals.size()));
  h->inliers = inliers;
  h->fitness = static_cast<double>(inliers) / n;
  h->rmse = inliers > 0 ? std::sqrt(sum_sq / inliers) : 0.0;
  h->normal_agreement = inliers > 0 ? static_cast<double>(agreeing) / inliers : 0.0;
  // A point in observed free space is evidence against the pose: −1 (the opposite of a
  // perfect inlier), so a turn that puts asymmetric detail where a sensor saw through loses.
  h->violation = static_cast<double>(violating) / n;
  h->score = (score - static_cast<double>(violating)) / n;
  h->conflict = near > 0 ? 1.0 - static_cast<double>(agreeing) / near : 1.0;
}

}  // namespace

namespace internal {

// pcl_backend.h
double AreaSpacing(const std::vector<Eigen::Vector3d>& points, double voxel) {
  if (points.empty() || !(voxel > 0)) return 0.0;
  const double occupied = static_cast<double>(VoxelCount(points, voxel));
  return voxel * std::sqrt(occupied / (1.5 * static_cast<double>(points.size())));
}

size_t SurfaceNormals(const std::vector<Eigen::Vector3d>& points, const PointIndex& index,
                      double radius, double max_radius, const Eigen::Vector3d& viewpoint,
                      std::vector<Eigen::Vector3d>* normals, double min_ratio) {
  normals->assign(points.size(), Eigen::Vector3d::Constant(std::nan("")));
  // Points [begin, end): each normal depends on its own neighbourhood only, so the two
  // halves run in parallel with the same result as in sequence.
  auto estimate = [&](size_t begin, size_t end, size_t* widened) {
    std::vector<int> idx;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    // Covariance eigen-decomposition of the neighbours of points[i] within r; false with
    // fewer than 3 neighbours.
    auto pca = [&](size_t i, double r) {
      index.Radius(points[i], r, &idx);
      if (idx.size() < 3) return false;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int j : idx) mean += points[static_cast<size_t>(j)] - points[i];
      mean /= static_cast<double>(idx.size());
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (int j : idx) {
        const Eigen::Vector3d d = points[static_cast<size_t>(j)] - points[i] - mean;
        cov += d * d.transpose();
      }
      eig.computeDirect(cov / static_cast<double>(idx.size()));
      return eig.info() == Eigen::Success;
    };
    auto surface = [&] {
      const Eigen::Vector3d& l = eig.eigenvalues();  // ascending
      return l(2) > 0 && l(1) >= min_ratio * l(2);
    };
    // The eigenvector of the smallest eigenvalue, towards the viewpoint.
    auto normal = [&](size_t i) {
      Eigen::Vector3d n = eig.eigenvectors().col(0);
      return n.dot(viewpoint - points[i]) < 0 ? Eigen::Vector3d(-n) : n;
    };
    for (size_t i = begin; i < end; ++i) {
      if (!pca(i, radius)) continue;  // too sparse: NaN
      if (surface()) {
        (*normals)[i] = normal(i);
        continue;
      }
      for (double r = 2.0 * radius; r <= max_radius * 1.0001; r *= 2.0) {
        if (pca(i, r) && surface()) {
          (*normals)[i] = normal(i);
          break;
        }
      }
      ++*widened;
    }
  };
  const size_t half = points.size() / 2;
  size_t first = 0, second = 0;
  std::thread worker(estimate, size_t{0}, half, &first);
  estimate(half, points.size(), &second);
  worker.join();
  return first + second;
}

// The per-point terms of ScoreFine, summed per block; the mean per-point difference over its
// cluster-robust standard error (score_significance.h).
double ScoreSignificance(const std::vector<Eigen::Vector3d>& src, const std::vector<double>& ra,
                         const std::vector<bool>& aa, const std::vector<double>& rb,
                         const std::vector<bool>& ab, double tau, double block) {
  auto term = [tau](double r, bool agree) {
    return std::isfinite(r) && std::abs(r) < tau && agree ? 1.0 - (r * r) / (tau * tau) : 0.0;
  };
  std::unordered_map<VoxelKey, std::pair<double, int>, VoxelKeyHash> blocks;
  for (size_t i = 0; i < src.size(); ++i) {
    const VoxelKey key{static_cast<int64_t>(std::floor(src[i].x() / block)),
                       static_cast<int64_t>(std::floor(src[i].y() / block)),
                       static_cast<int64_t>(std::floor(src[i].z() / block))};
    auto& b = blocks[key];
    b.first += term(ra[i], aa[i]) - term(rb[i], ab[i]);
    ++b.second;
  }
  if (blocks.size() < 3) return 0.0;
  double sum = 0.0, n = 0.0;
  for (const auto& [key, b] : blocks) {
    sum += b.first;
    n += b.second;
  }
  const double mean = sum / n;
  double ss = 0.0;
  for (const auto& [key, b] : blocks) ss += (b.first - b.second * mean) * (b.first - b.second * mean);
  const double k = static_cast<double>(blocks.size());
  const double se = std::sqrt(ss * k / (k - 1.0)) / n;
  return se > 0 ? mean / se : (mean > 0 ? std::numeric_limits<double>::infinity() : 0.0);
}

}  // namespace internal

namespace {

using internal::ScoreSignificance;

// A small motion ξ = (ω, t) of registered points about a centre c: q ↦ c + Exp(ω)(q − c) + t
// (ω a rotation vector, rad; t metres), as a 4×4 transform applied after the pose.
Eigen::Matrix4d MotionAbout(const Vector6d& xi, const Eigen::Vector3d& c) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const Eigen::Vector3d omega = xi.head<3>();
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  if (omega.norm() > 0) r = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = c - r * c + xi.tail<3>();
  return m;
}

// RMS-displacement metric of the motions ξ about c over the registered points q:
// (1/N) Σ ‖ω × (q − c) + t‖² = ξᵀ M ξ.
Matrix6d DisplacementMetric(const std::vector<Eigen::Vector3d>& q, const Eigen::Vector3d& c) {
  Matrix6d m = Matrix6d::Zero();
  for (const Eigen::Vector3d& p : q) {
    Eigen::Matrix<double, 3, 6> a;
    const Eigen::Vector3d d = p - c;
    a.leftCols<3>() << 0, d.z(), -d.y(), -d.z(), 0, d.x(), d.y(), -d.x(), 0;  // −[d]×
    a.rightCols<3>().setIdentity();
    m += a.transpose() * a;
  }
  return m / static_cast<double>(std::max<size_t>(1, q.size()));
}

// How well do the inliers of the fine fit determine the pose? The point-to-plane residual of
// an inlier q with target normal n changes under ξ by Jᵀξ, J = ((q − c) × n, n) (Chen &
// Medioni 1991; linearised as Low 2004, Eq. 6–8), so H = Σ J Jᵀ is the Gauss–Newton matrix of
// the fit. A plane leaves the in-plane shifts and the turn about its normal in H's null space
// (Gelfand et al., "Geometrically stable sampling for the ICP algorithm", 3DIM 2003, Sec. 3:
// the eigenvectors of this matrix with small eigenvalues are the motions the points do not
// constrain). The covariance of ξ is the cluster-robust sandwich H⁻¹ (Σ_b g_b g_bᵀ) H⁻¹
// · B/(B − 1) over B blocks of `block` metres of the source, g_b = Σ_{i∈b} J_i r_i (Liang &
// Zeger 1986; White 1980): a reconstruction's errors are correlated over its smoothing
// window, and a block of such points is one observation, not hundreds. With fewer than 12
// blocks (a 6×6 meat estimated from fewer than 2 blocks per parameter is rank-poor and would
// claim certainty in the motions it does not see) the plain s² H⁻¹ is used, inflated by the
// points per block. Everything is expressed in the RMS metric M of DisplacementMetric
// (M = L Lᵀ, η = Lᵀ ξ: ‖η‖ is the RMS displacement of the source), where the eigenvalues of
// H and of the covariance compare motions of equal size.
struct FitUncertainty {
  Matrix6d covariance = Matrix6d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Matrix6d metric = Matrix6d::Zero();  // M about `centre` (set whenever sigma_rms is finite)
  double sigma_rms = std::numeric_limits<double>::infinity();
  double constraint_ratio = 0.0;
  Vector6d weakest = Vector6d::Zero();  // the least-determined motion, unit RMS
  std::vector<Vector6d> weak_directions;  // H's two weakest motions (unit RMS), for the probes
  int blocks = 0;
};

FitUncertainty EstimateFitUncertainty(const std::vector<Eigen::Vector3d>& src,
                                      const TargetCrop& crop, const Eigen::Matrix4d& t,
                                      const std::vector<double>& residuals,
                                      const std::vector<bool>& agree, double reach, double tau,
                                      double block) {
  FitUncertainty out;
  std::vector<Eigen::Vector3d> q(src.size());
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < src.size(); ++i) {
    q[i] = Apply(t, src[i]);
    c += q[i];
  }
  if (src.empty()) return out;
  c /= static_cast<double>(src.size());
  out.centre = c;
  Matrix6d h = Matrix6d::Zero();
  std::unordered_map<VoxelKey, Vector6d, VoxelKeyHash> gradients;
  double sum_sq = 0.0;
  size_t m = 0;
  int index;
  double sq;
  for (size_t i = 0; i < src.size(); ++i) {
    const double r = residuals[i];
    if (!std::isfinite(r) || !(std::abs(r) < tau) || !agree[i]) continue;
    if (!crop.index->NearestWithin(q[i], reach * reach, &index, &sq)) continue;
    const Eigen::Vector3d& n = crop.level.normals[index];
    if (!n.allFinite()) continue;
    Vector6d j;
    j.head<3>() = (q[i] - c).cross(n);
    j.tail<3>() = n;
    h += j * j.transpose();
    const VoxelKey key{static_cast<int64_t>(std::floor(src[i].x() / block)),
                       static_cast<int64_t>(std::floor(src[i].y() / block)),
                       static_cast<int64_t>(std::floor(src[i].z() / block))};
    auto it = gradients.try_emplace(key, Vector6d::Zero()).first;
    it->second += j * r;
    sum_sq += r * r;
    ++m;
  }
  out.blocks = static_cast<int>(gradients.size());
  if (m < 12) return out;
  out.metric = DisplacementMetric(q, c);
  const Eigen::LLT<Matrix6d> llt(out.metric);
  if (llt.info() != Eigen::Success) return out;  // a degenerate (linear) source
  const Matrix6d l = llt.matrixL();
  const Matrix6d l_inv = l.inverse();
  const Matrix6d h_eta = l_inv * h * l_inv.transpose();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig_h(h_eta);
  const double lambda_max = eig_h.eigenvalues()(5);
  const double lambda_min = eig_h.eigenvalues()(0);
  out.constraint_ratio = lambda_max > 0 ? std::max(0.0, lambda_min) / lambda_max : 0.0;
  for (int k = 0; k < 2; ++k) {
    out.weak_directions.push_back(l_inv.transpose() * eig_h.eigenvectors().col(k));
  }
  out.weakest = out.weak_directions.front();
  if (!(out.constraint_ratio > 1e-9)) return out;  // a motion is free: infinite covariance
  const Matrix6d h_inv = eig_h.eigenvectors() * eig_h.eigenvalues().cwiseInverse().asDiagonal() *
                         eig_h.eigenvectors().transpose();
  Matrix6d cov_eta;
  const double b = static_cast<double>(out.blocks);
  if (out.blocks >= 12) {
    Matrix6d meat = Matrix6d::Zero();
    for (const auto& [key, g] : gradients) {
      const Vector6d g_eta = l_inv * g;
      meat += g_eta * g_eta.transpose();
    }
    cov_eta = h_inv * meat * h_inv * (b / (b - 1.0));
  } else {
    const double s2 = sum_sq / static_cast<double>(m - 6);
    cov_eta = s2 * (static_cast<double>(m) / b) * h_inv;
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig_c(cov_eta);
  out.sigma_rms = std::sqrt(std::max(0.0, eig_c.eigenvalues()(5)));
  out.weakest = l_inv.transpose() * eig_c.eigenvectors().col(5);
  out.covariance = l_inv.transpose() * cov_eta * l_inv;
  return out;
}

// "a turn of 1.9° about (0, 0, 1) and a shift of 0.35 m along (0.7, 0.7, 0)" for scale·ξ (a
// part below 1e-6 of the other is left out).
std::string DescribeMotion(const Vector6d& xi, double scale) {
  std::ostringstream s;
  s << std::setprecision(3) << std::fixed;
  const Eigen::Vector3d omega = scale * xi.head<3>(), shift = scale * xi.tail<3>();
  auto direction = [&s](const Eigen::Vector3d& v) {
    const Eigen::Vector3d u = v.normalized();
    s << "(" << u.x() << ", " << u.y() << ", " << u.z() << ")";
  };
  const bool turn = omega.norm() > 1e-9, move = shift.norm() > 1e-9;
  if (turn) {
    s << "a turn of " << omega.norm() * 180.0 / M_PI << " deg about ";
    direction(omega);
  }
  if (turn && move) s << " and ";
  if (move) {
    s << "a shift of " << shift.norm() << " m along ";
    direction(shift);
  }
  if (!turn && !move) s << "no motion";
  return s.str();
}

// Centroid c and covariance (1/N) Σ (q − c)(q − c)ᵀ of the source points registered by t.
void RegisteredMoments(const std::vector<Eigen::Vector3d>& src, const Eigen::Matrix4d& t,
                       Eigen::Vector3d* c, Eigen::Matrix3d* cov) {
  *c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : src) *c += Apply(t, p);
  *c /= static_cast<double>(std::max<size_t>(1, src.size()));
  *cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : src) {
    const Eigen::Vector3d d = Apply(t, p) - *c;
    *cov += d * d.transpose();
  }
  *cov /= static_cast<double>(std::max<size_t>(1, src.size()));
}

// PoseResolution's test at the resolution bound: the directions it did not tell apart there
// (indices into its list of motions, and the motions themselves, 1 m RMS about the registered
// source's centroid: the caller applies them with MotionAbout(δ·ξ, c)).
struct BoundTest {
  std::vector<size_t> open;
  std::vector<Vector6d> directions;
};

// How precisely do the data fix the pose? The chosen pose is displaced by δ (RMS over the
// source sample) along each of 12 directions — ± a translation along, and ± a rotation about
// (through the centroid), each principal axis of the registered source — and ± along the
// two least-constrained motions of the fit (FitUncertainty::weak_directions: a wall and the
// ground leave the shift along both and the turn about their common line nearly free, a
// motion that need not lie along any principal axis of the source, so that each axis probe
// also moves points across the wall and is told apart). Each displaced pose's fine score is
// compared with the chosen one by the paired block t statistic of ScoreSignificance. The
// pose is resolved at δ when every displacement scores significantly worse (t >= t_min). A
// pose that can slide, tilt or turn by δ without losing score is only known to δ: a thick,
// noisy target (every displaced point still has a noise point near it), a planar or linear
// overlap, or a pose off the score's maximum.
// With `open_at_bound`, only the test at `bound` is made: the directions not told apart there
// are returned in it (bound when none, else +inf). With `known_at_bound`, the test at `bound`
// is not made again: it is that earlier result, for the same pose and arguments (the local
// search's last test of the best it left is the verdict's first step).
// Tested first at `bound` (the verdict); if resolved there, at bound/2, bound/4, bound/8 until
// some direction is not (the reported resolution is the last resolved δ); if not, at 2·bound,
// 4·bound, … and at `max_delta` for the unresolved directions only (a direction resolved at δ
// stays resolved at larger δ: the score falls off around its maximum); +inf beyond.
double PoseResolution(const std::vector<Eigen::Vector3d>& src,
                      const std::vector<Eigen::Vector3d>& src_n, const TargetCrop& crop,
                      const Eigen::Matrix4d& t, const std::vector<double>& base_residuals,
                      const std::vector<bool>& base_agree, double reach, double tau, double block,
                      double bound, double max_delta, double t_min, bool principal_axes,
                      const std::vector<Vector6d>& extra_directions,
                      BoundTest* open_at_bound = nullptr,
                      const BoundTest* known_at_bound = nullptr) {
  if (src.size() < 10) return std::numeric_limits<double>::infinity();
  Eigen::Vector3d c;
  Eigen::Matrix3d cov;
  RegisteredMoments(src, t, &c, &cov);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  // Motions ξ = (ω, t) about c with an RMS displacement of 1 m over the source.
  std::vector<Vector6d> dirs;
  for (int k = 0; k < 3 && principal_axes; ++k) {
    const Eigen::Vector3d a = eig.eigenvectors().col(k);
    // RMS distance of the source from the axis a through c: sqrt(trace(cov) − aᵀ·cov·a).
    const double radius = std::sqrt(std::max(0.0, cov.trace() - a.dot(cov * a)));
    for (double sign : {1.0, -1.0}) {
      Vector6d shift = Vector6d::Zero();
      shift.tail<3>() = sign * a;
      dirs.push_back(shift);
      if (radius > 0) {
        Vector6d turn = Vector6d::Zero();
        turn.head<3>() = sign * a / radius;
        dirs.push_back(turn);
      }
    }
  }
  for (const Vector6d& xi : extra_directions) {
    if (!xi.allFinite() || xi.isZero()) continue;
    dirs.push_back(xi);
    dirs.push_back(-xi);
  }
  if (dirs.empty()) return 0.0;
  auto resolved = [&](const Vector6d& xi, double delta) {
    std::vector<double> residuals;
    std::vector<bool> agree;
    FineResiduals(src, src_n, crop, MotionAbout(delta * xi, c) * t, reach, &residuals, &agree);
    return ScoreSignificance(src, base_residuals, base_agree, residuals, agree, tau, block) >=
           t_min;
  };
  // The directions in `which` tested at delta on two threads (each verdict is independent, so
  // the result is the same as one by one); returns those not resolved, in order.
  auto unresolved = [&](const std::vector<size_t>& which, double delta) {
    std::vector<char> ok(which.size(), 0);
    const long n = static_cast<long>(which.size());
#pragma omp parallel for num_threads(2) schedule(dynamic, 1)
    for (long k = 0; k < n; ++k) ok[k] = resolved(dirs[which[k]], delta) ? 1 : 0;
    std::vector<size_t> still;
    for (size_t k = 0; k < which.size(); ++k) {
      if (!ok[k]) still.push_back(which[k]);
    }
    return still;
  };
  std::vector<size_t> all(dirs.size());
  for (size_t d = 0; d < dirs.size(); ++d) all[d] = d;
  std::vector<size_t> open =
      known_at_bound != nullptr ? known_at_bound->open : unresolved(all, bound);
  if (open_at_bound != nullptr) {
    open_at_bound->open = open;
    open_at_bound->directions.clear();
    for (size_t d : open) open_at_bound->directions.push_back(dirs[d]);
    return open.empty() ? bound : std::numeric_limits<double>::infinity();
  }
  if (open.empty()) {
    double delta = bound;
    for (int k = 0; k < 3; ++k) {
      if (!unresolved(all, delta / 2.0).empty()) break;
      delta /= 2.0;
    }
    return delta;
  }
  // 2·bound, 4·bound, … and max_delta itself last (the doubling need not land on it).
  for (double delta = bound; delta < max_delta * 0.9999;) {
    delta = std::min(2.0 * delta, max_delta);
    open = unresolved(open, delta);
    if (open.empty()) return delta;
  }
  return std::numeric_limits<double>::infinity();
}

using internal::StrideSample;

// Rounds of the pseudo-symmetric turns of the best pose: each turns the best of the round
// before when a turn became the best.
constexpr int kSymmetryTurnRounds = 4;
// Below this many points in a cloud, a failure's reason says the cloud has too few points
// (PCL's bunny thinned to 10-20 points fails, to 30 registers: bench/RESULTS.md, session 41).
constexpr size_t kFewPointsForDescriptors = 30;
// Rounds of the local search (CloudRegistrationOptions::local_search): each starts from the
// move of the round before that scored above the best.
constexpr int kLocalSearchRounds = 4;
// ICP iterations and source points of each move's screening in the local search.
constexpr int kLocalSearchIterations = 10;
constexpr size_t kLocalSearchScreenPoints = 2000;

template <typename T>
std::vector<T> Pick(const std::vector<T>& v, const std::vector<size_t>& idx) {
  std::vector<T> out;
  if (v.empty()) return out;
  out.reserve(idx.size());
  for (size_t i : idx) out.push_back(v[i]);
  return out;
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

}  // namespace

double EstimatePointSpacing(const io::PointCloud& cloud, size_t max_samples) {
  return MedianSpacing(cloud.points, max_samples);
}

namespace {

// RegisterClouds on clouds whose coordinates are small (see RegisterClouds below):
// `source_viewpoint` / `target_viewpoint` = each cloud's own origin in these coordinates,
// towards which its normals are oriented (the scanner of a scan in its own frame).
// `past_normals` (optional): set when the normals were estimated (the input passed its checks).
CloudRegistrationResult RegisterCloudsNearOrigin(const io::PointCloud& source_in,
                                                 const io::PointCloud& target_in,
                                                 const CloudRegistrationOptions& options,
                                                 const Eigen::Vector3d& source_viewpoint,
                                                 const Eigen::Vector3d& target_viewpoint,
                                                 bool* past_normals = nullptr) {
  std::string option_error;
  if (!options.Check(&option_error)) throw InputError::Message("registration options", option_error);
  CloudRegistrationResult result;
  Timer stage_timer;
  std::clock_t stage_cpu = std::clock();
  // Long work shows progress: once a registration has run 10 s (large clouds), each stage
  // is logged as it ends; a quick one stays silent.
  const Timer total_timer;
  if (source_in.size() + target_in.size() > 4000000) {
    spdlog::info("registration: {} source and {} target points; thinning them to the coarse "
                 "and fine levels first", source_in.size(), target_in.size());
  }
  auto end_stage = [&](const std::string& name) {
    const std::clock_t now = std::clock();
    result.runtime.push_back({name, stage_timer.ElapsedSeconds(),
                              static_cast<double>(now - stage_cpu) / CLOCKS_PER_SEC});
    if (total_timer.ElapsedSeconds() > 10.0) {
      spdlog::info("registration: {} done ({:.1f} s, {:.1f} s in all)", name,
                   stage_timer.ElapsedSeconds(), total_timer.ElapsedSeconds());
    }
    stage_timer.Restart();
    stage_cpu = now;
  };
  auto fail = [&](const std::string& reason) {
    result.status = "failed";
    result.reason = reason;
    return result;
  };
  for (const auto& [cloud, which] : {std::pair{&source_in, "source"}, std::pair{&target_in, "target"}}) {
    const std::string problem = CheckCloud(*cloud, which);
    if (!problem.empty()) return fail(problem);
  }

  // --- Each cloud's spacing (median nearest-neighbour distance) and (options.remove_blunders)
  // its scattered blunders, from one kd-tree per cloud: on tens of millions of points each
  // tree takes seconds. The source's spacing on 20,000 and (for the fine level's budget
  // search below) on 5,000 samples.
  double s_src = 0.0, s_src_5000 = 0.0, s_tgt = 0.0;
  io::PointCloud kept_source, kept_target;
  const io::PointCloud* source_ptr = &source_in;
  const io::PointCloud* target_ptr = &target_in;
  for (const bool is_source : {true, false}) {
    const io::PointCloud& cloud = is_source ? source_in : target_in;
    if (cloud.size() < 2) continue;
    const PointIndex index(cloud.points);
    const std::vector<double> spacing = SpacingQuantiles(index, cloud.points, 20000, {0.5, 0.9});
    (is_source ? s_src : s_tgt) = spacing[0];
    if (is_source) s_src_5000 = MedianSpacing(index, cloud.points, 5000);
    if (options.paper_only || !options.remove_blunders) continue;
    const double cell = options.isolated_cell_spacing * spacing[1];
    if (!(cell > 0)) continue;
    // The surface test's constants (CloudRegistrationOptions::remove_blunders): 8 neighbours,
    // thickness 0.25, offset 0.3.
    const std::vector<char> isolated = OffTheSurface(
        index, cloud.points, IsolatedPoints(cloud.points, cell, options.isolated_min_neighbours),
        /*neighbours=*/8, /*max_thickness=*/0.25, /*max_offset=*/0.3);
    const size_t removed = static_cast<size_t>(std::count(isolated.begin(), isolated.end(), 1));
    if (removed == 0 || removed == cloud.size() ||
        static_cast<double>(removed) < options.isolated_min_fraction * static_cast<double>(cloud.size())) {
      continue;
    }
    (is_source ? kept_source : kept_target) = io::WithoutMarked(cloud, isolated);
    (is_source ? source_ptr : target_ptr) = is_source ? &kept_source : &kept_target;
    (is_source ? result.blunders_removed_source : result.blunders_removed_target) = removed;
    std::ostringstream note;
    note << "removed " << removed << " scattered point" << (removed == 1 ? "" : "s") << " of "
         << cloud.size() << " from the " << (is_source ? "source" : "target") << " (fewer than "
         << options.isolated_min_neighbours << " others in the 3 x 3 x 3 cells of " << cell
         << " m around, and off the surface of their 8 nearest)";
    result.notes.push_back(note.str());
  }
  const io::PointCloud& source = *source_ptr;
  const io::PointCloud& target = *target_ptr;

  // --- Levels: a common coarse voxel for the features (clouds of different density are
  // matched at the density of the sparser one; the larger cloud may keep
  // larger_cloud_factor × as many points), a finer one for ICP (the target is cropped to each
  // hypothesis there).
  if (s_src <= 0 || s_tgt <= 0) return fail("all points of a cloud coincide (spacing 0)");
  const bool source_larger = source.size() > target.size();
  const size_t small_budget = static_cast<size_t>(options.max_points_features);
  const size_t large_budget =
      static_cast<size_t>(options.larger_cloud_factor * options.max_points_features);
  double coarse_voxel = std::max(s_src, s_tgt);
  {
    // Coarser by coarse_voxel_spacing while the smaller cloud keeps enough points to describe.
    const io::PointCloud& smaller = source_larger ? target : source;
    const double candidate = options.coarse_voxel_spacing * coarse_voxel;
    if (VoxelCount(smaller.points, candidate) >=
        static_cast<size_t>(options.min_points_coarse)) {
      coarse_voxel = candidate;
    }
  }
  coarse_voxel = std::max(coarse_voxel, VoxelForBudget(source, coarse_voxel,
                                                       source_larger ? large_budget : small_budget));
  coarse_voxel = std::max(coarse_voxel, VoxelForBudget(target, coarse_voxel,
                                                       source_larger ? small_budget : large_budget));
  const bool src_normals = options.use_existing_normals && source.has_normals();
  const bool tgt_normals = options.use_existing_normals && target.has_normals();
  Level src_coarse = VoxelDownsample(source.points, src_normals ? source.normals : std::vector<Eigen::Vector3d>{}, coarse_voxel);
  Level tgt_coarse = VoxelDownsample(target.points, tgt_normals ? target.normals : std::vector<Eigen::Vector3d>{}, coarse_voxel);
  const double fine_voxel_src = VoxelForBudget(source, 0.0, options.max_points_icp, s_src_5000);
  Level src_fine = VoxelDownsample(source.points, src_normals ? source.normals : std::vector<Eigen::Vector3d>{}, fine_voxel_src);
  const double src_fine_spacing = MedianSpacing(src_fine.points, 20000);
  const double spacing = std::max(MedianSpacing(src_coarse.points, 20000),
                                  MedianSpacing(tgt_coarse.points, 20000));
  result.point_spacing_m = spacing;
  const double normal_radius = options.normal_radius_m > 0 ? options.normal_radius_m
                                                           : options.normal_radius_spacing * spacing;
  const double support_radius = options.support_radius_m > 0
                                    ? options.support_radius_m
                                    : options.support_radius_spacing * spacing;
  result.normal_radius_m = normal_radius;
  result.support_radius_m = support_radius;
  spdlog::debug("registration: spacing {:.4g} m (fine source {:.4g}), R_n {:.4g} m, R_s {:.4g} m, "
                "coarse {} / {} points, fine source {}",
                spacing, src_fine_spacing, normal_radius, support_radius, src_coarse.points.size(),
                tgt_coarse.points.size(), src_fine.points.size());
  end_stage("downsample");

  // --- Normals within R_n, oriented towards each cloud's sensors when they are given
  // (internal::OrientTowardsNearest), else towards its origin (the scanner of a scan) and,
  // with NormalOrientation::kConsistent(Turned), then made consistent over the neighbour
  // graph (and the source's turned). Only the coarse level's signs matter: the fine
  // verification and ICP use |n_s·n_t| and squared point-to-plane residuals.
  for (Level* level : {&src_coarse, &tgt_coarse}) {
    if (level->normals.empty()) {
      const bool is_source = level == &src_coarse;
      const std::vector<Eigen::Vector3d>& sensors =
          is_source ? options.source_viewpoints : options.target_viewpoints;
      level->normals = internal::EstimateNormals(level->points, normal_radius,
                                                 is_source ? source_viewpoint : target_viewpoint);
      internal::OrientTowardsNearest(level->points, sensors, &level->normals);
      if (sensors.empty() && (options.normal_orientation == NormalOrientation::kConsistent ||
                              options.normal_orientation == NormalOrientation::kConsistentTurned)) {
        const size_t turned = internal::OrientConsistently(level->points, 10, &level->normals);
        std::ostringstream note;
        note << (is_source ? "source" : "target") << " normals oriented consistently over the "
             << "neighbour graph: " << turned << " of " << level->points.size() << " turned";
        result.notes.push_back(note.str());
      }
    }
    if (options.normal_orientation == NormalOrientation::kConsistentTurned &&
        level == &src_coarse) {
      for (Eigen::Vector3d& n : level->normals) n = -n;
    }
    const size_t before = level->points.size();
    if (before < 10) {
      // Both clouds are thinned to the sparser one's spacing: a cloud that collapses to a few
      // points there is much smaller than the other, as a cloud in millimetres against one in
      // metres is (the normal radius is not the cause, and a larger one would not help).
      auto extent = [](const std::vector<Eigen::Vector3d>& points) {
        Eigen::AlignedBox3d box;
        for (const Eigen::Vector3d& p : points) box.extend(p);
        return points.empty() ? 0.0 : box.diagonal().norm();
      };
      const bool is_source = level == &src_coarse;
      const double own = extent(level->points), other = extent((is_source ? tgt_coarse : src_coarse).points);
      std::ostringstream s;
      s << (is_source ? "source" : "target") << " cloud thins to only " << before
        << " points at the common point spacing " << spacing << " m (the sparser cloud's)";
      if (other > 10 * own) {
        s << ": its extent is " << other / std::max(own, 1e-300) << "x smaller than the "
          << (is_source ? "target" : "source") << "'s (" << own << " against " << other
          << "): are they in different units (millimetres against metres)? Convert one, or give "
             "--scale-range";
      } else {
        s << ": too few points to register";
      }
      return fail(s.str());
    }
    DropInvalidNormals(level);
    if (level->points.size() < before / 2 || level->points.size() < 10) {
      std::ostringstream s;
      s << "cloud too sparse for the normal radius " << normal_radius << " m: "
        << before - level->points.size() << " of " << before
        << " points have too few neighbours (give a larger --normal-radius)";
      return fail(s.str());
    }
  }
  // The fine level's normals are needed only at its sample for the fine verification (up to
  // 8000 points); their neighbourhoods are taken from the whole fine level.
  const std::vector<size_t> fine_idx = StrideSample(src_fine.points.size(), 8000);
  const std::vector<Eigen::Vector3d> fine_src = Pick(src_fine.points, fine_idx);
  std::vector<Eigen::Vector3d> fine_src_n =
      src_fine.normals.empty()
          ? internal::EstimateNormals(
                src_fine.points,
                std::min(normal_radius, options.normal_radius_spacing * src_fine_spacing),
                source_viewpoint, &fine_idx)
          : Pick(src_fine.normals, fine_idx);
  if (src_fine.normals.empty()) {
    internal::OrientTowardsNearest(fine_src, options.source_viewpoints, &fine_src_n);
  }
  end_stage("normals");
  if (past_normals != nullptr) *past_normals = true;

  // --- Keypoints.
  // The larger cloud gets keypoints in proportion to its coarse size (at most
  // min(4, larger_cloud_factor) × max_keypoints), so the part the smaller one overlaps is not
  // starved.
  const double size_ratio = static_cast<double>(std::max(src_coarse.points.size(), tgt_coarse.points.size())) /
                            static_cast<double>(std::max<size_t>(1, std::min(src_coarse.points.size(), tgt_coarse.points.size())));
  const int max_kp_large = static_cast<int>(options.max_keypoints *
                                            std::clamp(size_ratio, 1.0, std::min(4.0, options.larger_cloud_factor)));
  const bool src_is_large = src_coarse.points.size() > tgt_coarse.points.size();
  const std::vector<int> src_kp =
      SelectKeypoints(src_coarse, normal_radius, options,
                      src_is_large ? max_kp_large : options.max_keypoints, "source", &result.notes);
  const std::vector<int> tgt_kp =
      SelectKeypoints(tgt_coarse, normal_radius, options,
                      src_is_large ? options.max_keypoints : max_kp_large, "target", &result.notes);
  result.num_keypoints_source = src_kp.size();
  result.num_keypoints_target = tgt_kp.size();
  end_stage("keypoints");
  if (src_kp.size() < 3 || tgt_kp.size() < 3) {
    return fail("too few keypoints (" + std::to_string(src_kp.size()) + " source, " +
                std::to_string(tgt_kp.size()) + " target; need 3)");
  }
  // Sparse for the support radius?
  {
    PointIndex tgt_coarse_index(tgt_coarse.points);
    std::vector<int> neighbours;
    std::vector<size_t> counts;
    for (size_t i = 0; i < tgt_kp.size(); i += std::max<size_t>(1, tgt_kp.size() / 50)) {
      tgt_coarse_index.Radius(tgt_coarse.points[tgt_kp[i]], support_radius, &neighbours);
      counts.push_back(neighbours.size());
    }
    std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
    if (counts[counts.size() / 2] < 16) {
      return fail("cloud too sparse for the support radius " + std::to_string(support_radius) +
                  " m: median " + std::to_string(counts[counts.size() / 2]) +
                  " neighbours at the keypoints (need 16; give a larger --support-radius)");
    }
  }

  // --- Descriptors and matching.
  std::vector<Descriptor> descriptors;
  if (options.descriptor == Descriptor::kAuto) {
    descriptors = {Descriptor::kFpfh, Descriptor::kShot};
  } else {
    descriptors = {options.descriptor};
  }
  const Eigen::Vector3d* up = options.gravity_aligned ? &options.up : nullptr;
  std::vector<Matching> matchings;
  for (Descriptor d : descriptors) {
    Descriptors ds, dt;
    try {
      ds = internal::ComputeDescriptors(d, src_coarse.points, src_coarse.normals, src_kp,
                                        support_radius, up);
      dt = internal::ComputeDescriptors(d, tgt_coarse.points, tgt_coarse.normals, tgt_kp,
                                        support_radius, up);
    } catch (const std::exception& e) {  // PCL reports degenerate input by exceptions
      return fail("descriptor " + DescriptorName(d) + " could not be computed: " + e.what());
    }
    end_stage("descriptors " + DescriptorName(d));
    matchings.push_back(MatchDescriptors(DescriptorName(d), src_coarse, tgt_coarse, src_kp,
                                         tgt_kp, ds, dt, options.sac_ia_randomness,
                                         options.max_correspondences));
    result.num_correspondences += matchings.back().best_pairs.size();
    end_stage("matching " + DescriptorName(d));
  }

  // --- Hypotheses: SAC-IA and the maximum consistent clique.
  PointIndex tgt_coarse_index(tgt_coarse.points);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : src_coarse.points) centre += p;
  centre /= static_cast<double>(src_coarse.points.size());
  const std::vector<size_t> score_idx = StrideSample(src_coarse.points.size(), 300);
  std::vector<Eigen::Vector3d> score_sample = Pick(src_coarse.points, score_idx);
  std::shuffle(score_sample.begin(), score_sample.end(), std::mt19937_64(options.seed + 1));
  std::mt19937_64 rng(options.seed);
  const double tau_coarse = normal_radius;
  HypothesisPool pool(static_cast<size_t>(options.num_hypotheses), centre, normal_radius);
  for (const Matching& m : matchings) {
    SacIa(m, score_sample, tgt_coarse_index, options, spacing, support_radius / 2.0, tau_coarse,
          &rng, &pool);
  }
  end_stage("sac-ia");
  std::vector<Hypothesis> hypotheses = pool.hypotheses();
  if (options.paper_only && hypotheses.size() > 1) hypotheses.resize(1);
  if (!options.paper_only && options.use_max_clique) {
    for (const Matching& m : matchings) {
      std::vector<Hypothesis> cliques;
      CliqueHypotheses(m, options, spacing, options.num_cliques, &cliques, &result.notes);
      for (Hypothesis& h : cliques) {
        h.cost = AlignmentCost(score_sample, tgt_coarse_index, h.transform, tau_coarse);
        hypotheses.push_back(h);
      }
    }
    end_stage("max-clique");
  }
  // A known approximate pose (search window): it is a hypothesis itself — descriptors may
  // find nothing on a poor overlap — and every hypothesis outside the window is dropped.
  const bool windowed = options.search_window_m > 0.0;
  const auto inside = [&](const Eigen::Matrix4d& t) {
    if (!windowed) return true;
    const Eigen::Vector3d moved = t.topLeftCorner<3, 3>() * centre + t.topRightCorner<3, 1>() - centre;
    const double angle = Eigen::AngleAxisd(Eigen::Matrix3d(t.topLeftCorner<3, 3>())).angle() * 180.0 / M_PI;
    return moved.norm() <= options.search_window_m && angle <= options.search_window_deg;
  };
  if (windowed && !options.paper_only) {
    Hypothesis h;
    h.origin = "approximate pose";
    h.descriptor = matchings.empty() ? "" : matchings.front().descriptor;
    h.cost = AlignmentCost(score_sample, tgt_coarse_index, h.transform, tau_coarse);
    hypotheses.push_back(h);
  }
  if (hypotheses.empty()) {
    return fail("no hypothesis: no consistent descriptor matches (" +
                std::to_string(result.num_correspondences) + " correspondences)");
  }

  // --- Refine each hypothesis with ICP on the coarse level, then verify.
  const std::vector<size_t> icp_idx = StrideSample(src_coarse.points.size(), 1500);
  const std::vector<Eigen::Vector3d> icp_src = Pick(src_coarse.points, icp_idx);
  const std::vector<Eigen::Vector3d> icp_src_n = Pick(src_coarse.normals, icp_idx);
  const double tau = options.inlier_distance_spacing * spacing;
  for (Hypothesis& h : hypotheses) {
    if (options.icp) {
      h.transform = PointToPlaneIcp(icp_src, tgt_coarse.points, tgt_coarse.normals,
                                    tgt_coarse_index, h.transform, support_radius / 2.0,
                                    options.icp_distance_spacing * spacing,
                                    std::min(options.icp_iterations, 20), up);  // ranking only
    }
    Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, h.transform, tau, &h);
  }
  hypotheses.erase(std::remove_if(hypotheses.begin(), hypotheses.end(),
                                  [&](const Hypothesis& h) { return !inside(h.transform); }),
                   hypotheses.end());
  if (hypotheses.empty()) return fail("no hypothesis within the search window");
  std::stable_sort(hypotheses.begin(), hypotheses.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.score > b.score; });
  end_stage("icp+verify coarse");

  // --- Fine ICP and verification of the best distinct coarse hypotheses (coarse-to-fine:
  // a loose coarse inlier distance cannot tell a shifted repetitive structure or a
  // pseudo-symmetric turn from the truth; the fine level can). The target is cropped to
  // each hypothesis' footprint and kept at up to max_points_icp points there.
  struct Finalist {
    Hypothesis h;
    std::vector<double> residuals;
    std::vector<bool> agree;
    double sigma = 0.0, spacing = 0.0;
    double icp_end = 0.0;  // the last correspondence distance of its fine ICP (0: no ICP)
    std::shared_ptr<TargetCrop> crop;
    std::vector<bool> violates;  // FreeSpaceViolations (empty: no sensor positions known)
    // Coarse score of the hypothesis it was refined from (the best of those merged into it);
    // NaN for finalists made at the fine level (symmetric turns, period shifts).
    double coarse_score = std::numeric_limits<double>::quiet_NaN();
  };
  // Visibility: z-buffers of each cloud from its own sensors (given in its own frame), the
  // whole target's (an occluder outside a hypothesis' crop still hides what lies behind it)
  // and the fine source sample's.
  const bool visibility = !options.paper_only &&
                          (!options.source_viewpoints.empty() || !options.target_viewpoints.empty());
  std::unique_ptr<internal::FreeSpace> src_free, tgt_free;
  std::unique_ptr<PointIndex> fine_src_index;
  Eigen::AlignedBox3d src_box;
  if (visibility) {
    fine_src_index = std::make_unique<PointIndex>(fine_src);
    for (const Eigen::Vector3d& p : fine_src) src_box.extend(p);
    if (!options.source_viewpoints.empty()) {
      src_free = std::make_unique<internal::FreeSpace>(fine_src, options.source_viewpoints,
                                                       MedianSpacing(fine_src, 20000));
    }
    if (!options.target_viewpoints.empty()) {
      tgt_free = std::make_unique<internal::FreeSpace>(target.points, options.target_viewpoints,
                                                       s_tgt);
    }
  }
  // The target around a hypothesis; a target within the budget is prepared once, whole.
  std::shared_ptr<TargetCrop> whole_target;
  struct CachedCrop {
    size_t count;
    uint64_t hash;
    std::shared_ptr<TargetCrop> crop;
  };
  std::vector<CachedCrop> crop_cache;
  auto crop_for = [&](const Eigen::Matrix4d& t) {
    if (whole_target) return whole_target;
    const bool whole = target.size() <= static_cast<size_t>(options.max_points_icp);
    const std::vector<size_t> inside = CropIndices(
        target, fine_src, t, whole ? std::numeric_limits<double>::infinity() : support_radius);
    // Finalists near one pose often crop the same target points (a room the source spans:
    // eight finalists, five of them the same 98 k points). A crop depends on its points
    // alone, so those share one, normals included (0.2–0.3 s each there).
    const uint64_t key = HashIndices(inside);
    for (const CachedCrop& cached : crop_cache) {
      if (cached.count == inside.size() && cached.hash == key) return cached.crop;
    }
    auto c = std::make_shared<TargetCrop>(CropTarget(
        target, tgt_normals, inside, static_cast<size_t>(options.max_points_icp),
        0.5 * src_fine_spacing));
    // The crop's normals within a few of its spacings, and wider where that is a line, not a
    // surface. Near a scanner the nearest-neighbour spacing is the spacing along a scan line,
    // and a radius of a few of those spans one line or two (normals that disagreed with the
    // source's at the truth, and a fine ICP that slid along them: the full-preset gate's
    // stereo cloud onto its LiDAR model went to its 180° twin). So the spacing is at least
    // the area spacing over 2.2, its ratio to the nearest-neighbour spacing on a uniformly
    // random sample (1.5–1.7 on an even voxel-centroid sample: neither is changed; 3.3 next
    // to the simulated gate's scanner), and a normal whose neighbourhood is still a line is
    // estimated wider.
    if (c->level.normals.empty() && c->level.points.size() >= 10) {
      const double area_spacing = internal::AreaSpacing(c->level.points, normal_radius);
      const double radius =
          std::min(normal_radius,
                   options.normal_radius_spacing * std::max(c->level.spacing, area_spacing / 2.2));
      const size_t repaired = internal::SurfaceNormals(c->level.points, *c->index, radius,
                                                       normal_radius, target_viewpoint,
                                                       &c->level.normals);
      spdlog::debug("registration: target crop of {} points, spacing {:.4g} m, normals within "
                    "{:.4g} m, {} of them wider (a line at that radius)",
                    c->level.points.size(), c->level.spacing, radius, repaired);
    }
    if (whole) whole_target = c;
    crop_cache.push_back({inside.size(), key, c});
    return c;
  };
  // The clouds' noise, once known: the smallest robust residual scale of the finalists
  // refined from the coarse hypotheses (set below; see fine_tau).
  double noise_sigma = std::numeric_limits<double>::infinity();
  // The fine ICP: plane-to-plane from both clouds' normals, ending at its own distance, or
  // point-to-plane ending at the coarse levels' distance.
  const std::vector<Eigen::Vector3d>* plane_to_plane_normals =
      options.icp_plane_to_plane ? &fine_src_n : nullptr;
  const double fine_end_spacing = options.icp_plane_to_plane ? options.icp_plane_distance_spacing
                                                             : options.icp_distance_spacing;
  // A finalist refined on its own crop of the target: fine ICP from `icp_start`, then its fine
  // residuals and their robust scale. False when the pose puts the source off the target.
  auto refine = [&](Finalist* f, double icp_start) {
    const std::shared_ptr<TargetCrop> crop = crop_for(f->h.transform);
    const TargetCrop& c = *crop;
    if (c.level.points.size() < 10) return false;
    f->spacing = std::max(src_fine_spacing, c.level.spacing);
    if (options.icp) {
      f->h.transform = PointToPlaneIcp(fine_src, c.level.points, c.level.normals, *c.index,
                                       f->h.transform, icp_start,
                                       fine_end_spacing * f->spacing,
                                       options.icp_iterations, nullptr,  // free: levelled ≠ exact
                                       plane_to_plane_normals);
      f->icp_end = fine_end_spacing * f->spacing;
    }
    const double reach = std::min(normal_radius, options.normal_radius_spacing * f->spacing);
    FineResiduals(fine_src, fine_src_n, c, f->h.transform, reach, &f->residuals, &f->agree);
    f->sigma = RobustScale(f->residuals);
    // A noisy cloud (a stereo reconstruction's range noise can be several spacings): a final
    // correspondence distance below its noise keeps only the residuals that happen to be
    // small, and the pose drifts to wherever those are. Again with the distance at
    // icp_noise_sigmas × the robust residual scale (at most the reach). Once the noise is
    // known (a period shift or turn of the best pose), a larger scale is the pose's misfit,
    // not noise: the second pass then runs within the noise alone.
    const double noise_distance =
        std::min(reach, options.icp_noise_sigmas * std::min(f->sigma, noise_sigma));
    if (options.icp && !options.paper_only &&
        noise_distance > fine_end_spacing * f->spacing) {
      f->h.transform = PointToPlaneIcp(fine_src, c.level.points, c.level.normals, *c.index,
                                       f->h.transform, noise_distance, noise_distance,
                                       options.icp_iterations, nullptr, plane_to_plane_normals);
      f->icp_end = noise_distance;
      FineResiduals(fine_src, fine_src_n, c, f->h.transform, reach, &f->residuals, &f->agree);
      f->sigma = RobustScale(f->residuals);
    }
    f->crop = crop;
    return true;
  };
  std::vector<Finalist> finalists;
  const size_t max_finalists = options.paper_only ? 1 : 4;
  for (const Hypothesis& h : hypotheses) {
    if (finalists.size() >= max_finalists) break;
    bool duplicate = false;
    for (const Finalist& f : finalists) {
      duplicate = duplicate || SameTransform(f.h.transform, h.transform, centre, 2.0, 2.0 * tau);
    }
    if (duplicate) continue;
    Finalist f;
    f.h = h;
    f.coarse_score = h.score;
    // Levelled hypotheses were turned about `up` only: the tilt left to the free fine ICP
    // needs a wider start.
    const double start = options.gravity_aligned ? support_radius / 2.0
                                                 : options.icp_distance_spacing * spacing;
    if (!refine(&f, start) || !inside(f.h.transform)) continue;
    finalists.push_back(std::move(f));
  }
  if (finalists.empty()) return fail("no hypothesis puts the source onto the target");
  for (const Finalist& f : finalists) noise_sigma = std::min(noise_sigma, f.sigma);
  // One inlier threshold for all finalists: inlier_sigma × the smallest robust residual scale
  // (the best-fitting hypothesis sees the clouds' noise; a wrong one sees its misfit too),
  // at least a quarter of the fine spacing.
  double fine_tau = std::numeric_limits<double>::infinity();
  for (const Finalist& f : finalists) {
    fine_tau = std::min(fine_tau, std::max(options.inlier_sigma * f.sigma, 0.25 * f.spacing));
  }
  if (!std::isfinite(fine_tau)) fine_tau = tau;
  auto violations_of = [&](const Finalist& f) -> std::vector<bool> {
    if (!visibility) return {};
    // A point counts as in free space only beyond the noise: two inlier distances (6 robust
    // σ of the best fit) in front of the first surface, and no point of the other cloud
    // within that distance.
    const double margin = 2.0 * fine_tau;
    return FreeSpaceViolations(fine_src, *fine_src_index, src_free.get(), src_box, *f.crop,
                               tgt_free.get(), f.h.transform, margin, margin);
  };
  double fine_spacing = 0.0;
  for (Finalist& f : finalists) {
    f.violates = violations_of(f);
    ScoreFine(f.residuals, f.agree, fine_tau, f.violates, &f.h);
    fine_spacing = std::max(fine_spacing, f.spacing);
  }
  // Best score first (stable: ties keep their order).
  auto sort_finalists = [&] {
    std::stable_sort(finalists.begin(), finalists.end(),
                     [](const Finalist& a, const Finalist& b) { return a.h.score > b.h.score; });
  };
  sort_finalists();
  // Finalists that converged to the same transform are one hypothesis.
  // The one kept takes the better coarse score of the two (the scale-agreement test below).
  for (size_t i = 1; i < finalists.size();) {
    size_t same = i;
    for (size_t j = 0; j < i && same == i; ++j) {
      // Noisy clouds leave ICP in slightly different spots of one basin.
      if (SameTransform(finalists[i].h.transform, finalists[j].h.transform, centre, 10.0,
                        std::max(10.0 * fine_tau, 2.0 * fine_spacing))) {
        same = j;
      }
    }
    if (same < i) {
      finalists[same].coarse_score = std::fmax(finalists[same].coarse_score, finalists[i].coarse_score);
      finalists.erase(finalists.begin() + static_cast<long>(i));
    } else {
      ++i;
    }
  }
  // The displacement modes of the descriptor matches under a pose T, strongest first: at most
  // `max_modes`, each with at least 3 votes and longer than `min_norm`.
  auto displacement_modes = [&](const Eigen::Matrix4d& t, double min_norm, size_t max_modes) {
    const double cell = 2.0 * normal_radius;
    std::unordered_map<VoxelKey, std::pair<Eigen::Vector3d, int>, VoxelKeyHash> votes;
    for (const Matching& m : matchings) {
      for (size_t i = 0; i < m.src_to_tgt.size(); ++i) {
        const Eigen::Vector3d q = Apply(t, m.src_kp[i]);
        for (int j : m.src_to_tgt[i]) {
          if (j < 0) continue;
          const Eigen::Vector3d d = m.tgt_kp[j] - q;
          const VoxelKey key{static_cast<int64_t>(std::floor(d.x() / cell)),
                             static_cast<int64_t>(std::floor(d.y() / cell)),
                             static_cast<int64_t>(std::floor(d.z() / cell))};
          auto it = votes.try_emplace(key, Eigen::Vector3d::Zero(), 0).first;
          it->second.first += d;
          ++it->second.second;
        }
      }
    }
    // A displacement near a cell boundary splits its votes: each cell is scored with its 26
    // neighbours (sum and mean over the 3×3×3 block), and only blocks whose centre cell has
    // the most votes of its neighbourhood are kept (non-maximum suppression).
    std::vector<std::pair<int, Eigen::Vector3d>> modes;  // (votes, mean displacement)
    for (const auto& [key, v] : votes) {
      int total = 0;
      bool peak = true;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = votes.find(VoxelKey{key.x + dx, key.y + dy, key.z + dz});
            if (it == votes.end()) continue;
            total += it->second.second;
            sum += it->second.first;
            const bool other = dx != 0 || dy != 0 || dz != 0;
            if (other && (it->second.second > v.second ||
                          (it->second.second == v.second &&
                           std::make_tuple(it->first.x, it->first.y, it->first.z) <
                               std::make_tuple(key.x, key.y, key.z)))) {
              peak = false;
            }
          }
        }
      }
      const Eigen::Vector3d mean = sum / total;
      if (peak && total >= 3 && mean.norm() > min_norm) modes.emplace_back(total, mean);
    }
    std::sort(modes.begin(), modes.end(), [](const auto& a, const auto& b) {
      return a.first > b.first ||
             (a.first == b.first && std::make_tuple(a.second.x(), a.second.y(), a.second.z()) <
                                        std::make_tuple(b.second.x(), b.second.y(), b.second.z()));
    });
    if (modes.size() > max_modes) modes.resize(max_modes);
    return modes;
  };
  // A candidate finalist refined from `start`, scored, and kept when it is inside the search
  // window and distinct from every finalist so far.
  // Adds a refined, scored finalist unless it is the same pose as one already there (within
  // 10° and 10 τ). With `replace_worse`, a same pose that scores higher takes the other's
  // place: 10 τ can span a pose and one part of a metre off it (the symmetric gate's part:
  // τ 0.19 m, a turn's pose 0.6 m off the truth kept and the truth, scoring 0.84 against
  // 0.49, dropped). Returns true when the finalists changed.
  auto add_finalist = [&](Finalist f, double start, bool replace_worse = false) {
    if (!refine(&f, start) || !inside(f.h.transform)) return false;
    f.violates = violations_of(f);
    ScoreFine(f.residuals, f.agree, fine_tau, f.violates, &f.h);
    for (Finalist& g : finalists) {
      if (SameTransform(f.h.transform, g.h.transform, centre, 10.0,
                        std::max(10.0 * fine_tau, 2.0 * fine_spacing))) {
        if (!replace_worse || !(f.h.score > g.h.score)) return false;
        g = std::move(f);
        return true;
      }
    }
    finalists.push_back(std::move(f));
    return true;
  };
  // Shifted copies of the best pose (a repeated structure: bays, windows, columns). The
  // hypotheses need not contain the pose one period away, and then the ambiguity test has
  // nothing to compare with. Under the best pose T every descriptor match (source keypoint
  // s, candidate target keypoint t) votes for the displacement t − T·s (a Hough vote over
  // translations, Ballard 1981): the right matches vote near 0, the matches to the same
  // feature in a repeated unit vote for the period. The up-to-`num_period_shifts` strongest
  // displacement cells beyond R_s (smaller shifts are the resolution test's) with at least 3
  // votes give T moved by their mean displacement, refined by the fine ICP and scored like
  // the other finalists; a distinct one then enters the ambiguity test.
  if (!options.paper_only && options.num_period_shifts > 0 && !finalists.empty()) {
    const std::vector<std::pair<int, Eigen::Vector3d>> modes =
        displacement_modes(finalists.front().h.transform, support_radius,
                           static_cast<size_t>(options.num_period_shifts));
    const size_t before_shifts = finalists.size();
    for (const auto& [count, shift] : modes) {
      Finalist f;
      f.h = finalists.front().h;
      f.h.transform.topRightCorner<3, 1>() += shift;
      std::ostringstream origin;
      origin << std::setprecision(3) << "period shift (" << shift.x() << ", " << shift.y() << ", "
             << shift.z() << ") m, " << count << " votes";
      f.h.origin = origin.str();
      add_finalist(std::move(f), options.icp_distance_spacing * spacing);
    }
    if (finalists.size() > before_shifts) {
      sort_finalists();
    }
  }
  // Pseudo-symmetric turns of the best pose (Kim & Hilton, Sec. 5: pseudo-symmetric parts
  // registered upside down or turned 180°). As with the period shifts, the hypotheses need
  // not contain the turned pose, and then the ambiguity test has nothing to compare with: a
  // plane proxy's gate part turned 180° about up fits the stereo cloud at fitness 0.79 (gate,
  // seed 2) with no finalist near the truth. Under the best pose T the source is turned about
  // its registered centroid c — levelled: by 90°, 180°, 270° about up; else by 180° about each
  // principal axis of the registered source and the axes in a cone around it — and placed
  // there or by the descriptor matches' displacement vote under it (the object's symmetry axis
  // need not pass through c): of the placements and cone axes, the one scoring best on the
  // coarse level is refined by the fine ICP from R_s/2 (the vote's cells are 2 R_n wide) and
  // scored like the other finalists, unless it scores below half the best's coarse score; a
  // distinct one enters the ambiguity test, and one that scores better becomes the best.
  // A turn that becomes the best is turned in its turn, up to kSymmetryTurnRounds times in
  // all: the first best may be neither pose (a wrong hypothesis whose turn lands on the twin;
  // the symmetric gate's part with three keypoints, test PartTurnedAboutTheTargetsCentroid),
  // and the twin's own turn is then the rival that makes the result ambiguous. The turn of a
  // pose that is neither may itself be neither (the gate's part turned +1 rad: sac-ia's pose
  // 1.6 m off, its turn about the centroid 0.6 m off the truth, that one's turn the twin,
  // reported "ok" when the turns stopped after two rounds; test
  // EverySymmetricTurnOfTheGatesPartIsRefused).
  Eigen::Vector3d target_centroid = Eigen::Vector3d::Zero();  // for the turns about it
  for (const Eigen::Vector3d& p : tgt_coarse.points) target_centroid += p;
  target_centroid /= static_cast<double>(std::max<size_t>(1, tgt_coarse.points.size()));
  auto symmetric_turns = [&]() {
    for (int round = 0;
         round < kSymmetryTurnRounds && !options.paper_only && options.symmetry_turns && !finalists.empty();
         ++round) {
      const Eigen::Matrix4d best_t = finalists.front().h.transform;
      Eigen::Vector3d c;
      Eigen::Matrix3d cov;
      RegisteredMoments(fine_src, best_t, &c, &cov);
      // Groups of turns; each group gives at most one finalist (its best on the coarse level).
      std::vector<std::vector<Vector6d>> turns;
      if (options.gravity_aligned) {
        for (double angle : {0.5 * M_PI, M_PI, 1.5 * M_PI}) {
          Vector6d xi = Vector6d::Zero();
          xi.head<3>() = angle * options.up;
          turns.push_back({xi});
        }
      } else {
        // The 180° twin's axis is the object's symmetry axis, which a principal axis of the
        // source only approximates: a gate's multi-view cloud (full gate, seed 1) has its up
        // axis 5° from the twin's, and a turn about an axis θ off is 2θ off, beyond the coarse
        // ICP's reach. So each principal axis a is tried with the axes around it, in rings
        // every symmetry_cone_step_deg up to symmetry_cone_deg (6 axes on the first ring, 12 on
        // the second, …).
        std::vector<Eigen::Vector3d> axes;
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
        for (int k = 0; k < 3; ++k) axes.push_back(eig.eigenvectors().col(k));
        const double step = options.symmetry_cone_step_deg * M_PI / 180.0;
        const int rings = static_cast<int>(
            std::floor(options.symmetry_cone_deg / options.symmetry_cone_step_deg + 1e-9));
        for (const Eigen::Vector3d& a : axes) {
          const Eigen::Vector3d u = a.unitOrthogonal(), v = a.cross(u);
          std::vector<Vector6d> group;
          for (int ring = 0; ring <= rings; ++ring) {
            const int around = ring == 0 ? 1 : 6 * ring;
            for (int j = 0; j < around; ++j) {
              const double phi = 2.0 * M_PI * j / around, theta = ring * step;
              Vector6d xi = Vector6d::Zero();
              xi.head<3>() = M_PI * (std::cos(theta) * a + std::sin(theta) * (std::cos(phi) * u +
                                                                               std::sin(phi) * v));
              group.push_back(xi);
            }
          }
          turns.push_back(std::move(group));
        }
      }
      bool turns_changed = false;
      // The best pose's coarse score: a turn that fits the coarse level less than half as well
      // is no rival (the fine refinement, a crop of the target with its normals, is the dear
      // part).
      Hypothesis best_coarse = finalists.front().h;
      Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, best_t, tau, &best_coarse);
      auto coarse_fit = [&](Hypothesis* h) {
        if (options.icp) {
          h->transform = PointToPlaneIcp(icp_src, tgt_coarse.points, tgt_coarse.normals,
                                         tgt_coarse_index, h->transform, support_radius / 2.0,
                                         options.icp_distance_spacing * spacing,
                                         std::min(options.icp_iterations, 20), up);
        }
        Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, h->transform, tau, h);
      };
      for (const std::vector<Vector6d>& group : turns) {
        // Each turn's placements (below) are compared on the coarse level (ICP and score as for
        // the hypotheses); only the group's best is refined at the fine level.
        Hypothesis pick;
        bool picked = false;
        std::string pick_how;  // how the pick was placed, for its origin text
        Vector6d pick_xi = Vector6d::Zero();
        for (size_t g = 0; g < group.size(); ++g) {
          // The cone refines an axis whose turn nearly fits; a central turn that fits the
          // coarse level less than a quarter as well as the best is not tried around (the
          // coarse ICPs of the cone were 0.75 s of a Stanford pair's 2.2 s).
          if (g == 1 && pick.score < 0.25 * best_coarse.score) break;
          const Vector6d& xi = group[g];
          const Eigen::Matrix4d turned = MotionAbout(xi, c) * best_t;
          // Placed as turned about c (an object symmetric about an axis through its centroid
          // maps onto itself), and by the two strongest modes of the descriptor matches'
          // displacement vote (for a part whose object's axis does not pass through c). The
          // vote alone is not enough: where the twin's matches outnumber the right ones they
          // vote along a line (full gate, multi-view → LiDAR: every mode 1.7 m off, the gate's
          // thickness, while the turn about c was within the coarse ICP's reach). The cone's
          // other axes are placed about c only (the coarse ICP is the dear part here).
          std::vector<std::pair<Eigen::Vector3d, std::string>> placements = {
              {Eigen::Vector3d::Zero(), "about the centroid"}};
          if (g == 0) {
            for (const auto& [count, shift] : displacement_modes(turned, -1.0, 2)) {
              std::ostringstream how;
              how << std::setprecision(3) << "shift of " << shift.norm() << " m, " << count
                  << " votes";
              placements.emplace_back(shift, how.str());
            }
            // And turned about the target's centroid: a part registered onto its whole
            // symmetric object, whose axis passes through the object's centroid, not the
            // part's (full gate, plane-proxy part → stereo cloud, levelled: the turn about the
            // part's centroid was 4.5 m off, no vote mode, and the twin was reported ok).
            // MotionAbout(ξ, c_t) = MotionAbout(ξ, c) shifted by (I − R)(c_t − c).
            const Eigen::Matrix3d r = MotionAbout(xi, c).topLeftCorner<3, 3>();
            placements.emplace_back((Eigen::Matrix3d::Identity() - r) * (target_centroid - c),
                                    "about the target's centroid");
          }
          for (const auto& [shift, how] : placements) {
            Hypothesis h = finalists.front().h;
            h.transform = turned;
            h.transform.topRightCorner<3, 1>() += shift;
            coarse_fit(&h);
            if (!picked || h.score > pick.score) {
              picked = true;
              pick = h;
              pick_how = how;
              pick_xi = xi;
            }
          }
        }
        const Vector6d& xi = pick_xi;
        spdlog::debug("registration: symmetric turn {:.3g} deg about ({:.3f}, {:.3f}, {:.3f}): "
                      "{}, coarse score {:.3g} (best {:.3g})",
                      xi.head<3>().norm() * 180.0 / M_PI, xi(0) / xi.head<3>().norm(),
                      xi(1) / xi.head<3>().norm(), xi(2) / xi.head<3>().norm(), pick_how,
                      pick.score, best_coarse.score);
        if (!picked || pick.score < 0.5 * best_coarse.score) continue;
        Finalist f;
        f.h = pick;
        std::ostringstream origin;
        const Eigen::Vector3d axis = xi.head<3>().normalized();
        origin << std::setprecision(3) << "symmetric turn of " << xi.head<3>().norm() * 180.0 / M_PI
               << " deg about (" << axis.x() << ", " << axis.y() << ", " << axis.z()
               << "), " << pick_how;
        f.h.origin = origin.str();
        turns_changed = add_finalist(std::move(f), support_radius / 2.0, /*replace_worse=*/true) || turns_changed;
      }
      if (turns_changed) {
        sort_finalists();
      }
      if (finalists.front().h.transform == best_t) break;
    }
  };
  symmetric_turns();
  const Eigen::Matrix4d best_before_local_search =
      finalists.empty() ? Eigen::Matrix4d::Zero() : Eigen::Matrix4d(finalists.front().h.transform);
  // Local search (options.local_search): a best pose that slides along or about a principal
  // axis of the source at the resolution bound may sit off the score's maximum — the
  // hypotheses' ICP stopped short on a noisy or planar overlap (the gate's multi-view part on
  // the stereo cloud, seed 8: every hypothesis 0.7–1.4 m along the gate, the truth scoring
  // 0.66 against 0.47). The pose is moved along each open direction by δ = bound, 2·bound, …
  // up to R_s, each move screened by a short ICP from δ, and the best move, refined in full,
  // joins the finalists (or replaces the one it converged to) when it scores above the best.
  // A resolved best has no open direction: nothing changes. Repeated from the new best, up
  // to kLocalSearchRounds times.
  // The local search's last test at the bound, of the pose and crop it was made for.
  struct {
    Eigen::Matrix4d transform = Eigen::Matrix4d::Zero();
    const TargetCrop* crop = nullptr;
    double spacing = 0.0;
    BoundTest test;
  } best_tested;
  for (int round = 0; !options.paper_only && options.local_search && !finalists.empty() &&
                      round < kLocalSearchRounds;
       ++round) {
    const Finalist& f0 = finalists.front();
    const double bound = options.max_resolution_spacing * f0.spacing;
    const double reach = std::min(normal_radius, options.normal_radius_spacing * f0.spacing);
    BoundTest test;
    PoseResolution(fine_src, fine_src_n, *f0.crop, f0.h.transform, f0.residuals, f0.agree, reach,
                   fine_tau, support_radius, bound, support_radius, options.resolution_t, true, {},
                   &test);
    best_tested = {f0.h.transform, f0.crop.get(), f0.spacing, std::move(test)};
    const std::vector<Vector6d>& open = best_tested.test.directions;
    Eigen::Vector3d c;
    Eigen::Matrix3d cov;
    RegisteredMoments(fine_src, f0.h.transform, &c, &cov);
    // The moves are screened on the best's crop (no new crops) with a sample of the fine
    // source (kLocalSearchScreenPoints): a short ICP from δ (kLocalSearchIterations), scored
    // against the best's score on the same sample (free space left out). The move screening
    // best is then refined in full on its own crop and scored like every finalist.
    std::optional<Finalist> top;
    const TargetCrop& crop0 = *f0.crop;
    const std::vector<size_t> screen_idx =
        StrideSample(fine_src.size(), kLocalSearchScreenPoints);
    const std::vector<Eigen::Vector3d> screen_src = Pick(fine_src, screen_idx);
    const std::vector<Eigen::Vector3d> screen_n = Pick(fine_src_n, screen_idx);
    auto screen_score = [&](const Eigen::Matrix4d& t) {
      std::vector<double> residuals;
      std::vector<bool> agree;
      FineResiduals(screen_src, screen_n, crop0, t, reach, &residuals, &agree);
      Hypothesis h;
      ScoreFine(residuals, agree, fine_tau, {}, &h);
      return h.score;
    };
    double top_screen = open.empty() ? 0.0 : screen_score(f0.h.transform);
    for (double delta = bound; delta <= support_radius * 1.0001 && !open.empty(); delta *= 2.0) {
      for (const Vector6d& xi : open) {
        const Eigen::Matrix4d moved = PointToPlaneIcp(
            screen_src, crop0.level.points, crop0.level.normals, *crop0.index,
            MotionAbout(delta * xi, c) * f0.h.transform, delta,
            options.icp_distance_spacing * f0.spacing,
            std::min(options.icp_iterations, kLocalSearchIterations), nullptr);
        if (!inside(moved)) continue;
        const double score = screen_score(moved);
        if (score <= top_screen) continue;
        top_screen = score;
        top.emplace();
        top->h = f0.h;
        top->h.transform = moved;
      }
    }
    if (top) {
      if (refine(&*top, bound) && inside(top->h.transform)) {
        top->violates = violations_of(*top);
        ScoreFine(top->residuals, top->agree, fine_tau, top->violates, &top->h);
      } else {
        top.reset();
      }
    }
    spdlog::debug("registration: local search round {}: {} open directions, best move scores "
                  "{:.4g} (best {:.4g})",
                  round + 1, open.size(), top ? top->h.score : 0.0, f0.h.score);
    if (top && top->h.score > f0.h.score) {
      if (round == 0) top->h.origin = f0.h.origin + ", local search";
      top->coarse_score = f0.coarse_score;  // a refinement of the best
      // It replaces a finalist it converged to (scoring below it), else joins them.
      auto same = std::find_if(finalists.begin(), finalists.end(), [&](const Finalist& g) {
        return SameTransform(top->h.transform, g.h.transform, centre, 10.0,
                             std::max(10.0 * fine_tau, 2.0 * fine_spacing));
      });
      if (same == finalists.end()) {
        finalists.push_back(std::move(*top));
      } else if (top->h.score > same->h.score) {
        *same = std::move(*top);
      }
      sort_finalists();
    } else {
      break;
    }
  }
  // A best pose the local search moved is turned again: the turns above turned the pose it
  // started from, and a turn of a pose some decimetres off lands as far off the twin, beyond
  // the fine ICP's reach (the symmetric gate's part at −0.6 rad: the truth found by the local
  // search, the twin never, "ok"; test EverySymmetricTurnOfTheGatesPartIsRefused).
  if (!finalists.empty() && finalists.front().h.transform != best_before_local_search) {
    symmetric_turns();
  }
  // A finalist that the visibility test contradicts (the verdict below would fail it as the
  // best) is no alternative in the ambiguity test.
  auto contradicted = [&](const Hypothesis& h) {
    return visibility && h.violation > options.max_violation_ratio * h.fitness;
  };
  // The ambiguity test's rivals: every distinct finalist scoring above max_ambiguity × the
  // best that the visibility test does not contradict, with the paired block t of the best
  // over it. The t statistic itself is geometric (without the −1 terms of the free-space
  // violations): one region where a sensor sees through a real surface — glass for a LiDAR,
  // which a camera reconstructs — would otherwise dominate the block variance.
  std::vector<std::pair<size_t, double>> rivals;  // (finalist, geometric t)
  for (size_t k = 1; k < finalists.size(); ++k) {
    if (!(finalists[k].h.score > options.max_ambiguity * finalists[0].h.score)) continue;
    if (contradicted(finalists[k].h)) continue;
    rivals.emplace_back(k, ScoreSignificance(fine_src, finalists[0].residuals, finalists[0].agree,
                                             finalists[k].residuals, finalists[k].agree, fine_tau,
                                             support_radius));
  }
  // Intensity test (intensity_test.h). Only where the geometry leaves a tie (some rival within
  // min_significance of the best) and both clouds carry a brightness: the intensity t of the
  // best over each rival (jackknifed over the same blocks) joins the geometric one
  // (internal::CombinedSignificance). It only ever adds evidence for the geometric best:
  // letting it pick a geometric runner-up instead was tried, and on a fresh cathedral (seed 4)
  // it picked a plane-proxy part's pose 23.6 m off over one 0.68 m off (a proxy's per-face
  // brightness can fit a wrong placement best).
  std::vector<internal::IntensityBlocks> photo;  // per finalist; empty: not tested
  const bool tie = std::any_of(rivals.begin(), rivals.end(), [&](const auto& r) {
    return r.second < options.min_significance;
  });
  if (!options.paper_only && options.intensity_test && tie) {
    const internal::IntensityAgreement brightness(source, target, fine_src, support_radius);
    if (brightness.available()) {
      for (const Finalist& f : finalists) {
        std::vector<bool> inlier(f.residuals.size());
        for (size_t i = 0; i < inlier.size(); ++i) {
          inlier[i] =
              std::isfinite(f.residuals[i]) && std::abs(f.residuals[i]) < fine_tau && f.agree[i];
        }
        photo.push_back(brightness.Measure(f.h.transform, inlier));
      }
      result.intensity_tested = true;
      result.intensity_correlation = photo[0].AbsCorrelation();
    }
  }
  spdlog::debug("registration: fine τ {:.4g} m, {} distinct finalists", fine_tau, finalists.size());
  Hypothesis best = finalists.front().h;
  const Hypothesis fine_check = best;
  end_stage("icp+verify fine");
  double axis_resolution = std::numeric_limits<double>::infinity();
  std::string weak_motion;
  if (!options.paper_only) {
    const Finalist& f = finalists.front();
    result.fine_spacing_m = f.spacing;
    const double reach = std::min(normal_radius, options.normal_radius_spacing * f.spacing);
    const FitUncertainty u = EstimateFitUncertainty(fine_src, *f.crop, f.h.transform, f.residuals,
                                                    f.agree, reach, fine_tau, support_radius);
    result.covariance = u.covariance;
    result.covariance_centre = u.centre;
    result.sigma_rms_m = u.sigma_rms;
    result.constraint_ratio = u.constraint_ratio;
    Vector6d weakest = u.weakest;
    // The fit's dependence on its last correspondence distance and on its objective, a
    // systematic error the residuals' covariance does not contain: point-to-plane ICP ended
    // at half and at twice that distance (at most the reach); after a plane-to-plane fit
    // (`icp_plane_to_plane`) also point-to-plane's own answer, which differs where the two
    // clouds' surfaces differ in detail (a plane proxy against a scan). On the simulated
    // cathedral's plane proxy → LiDAR the point-to-plane pose moved 3.1 cm (twice) and
    // 18.6 cm (half) from one 8 cm off the truth whose covariance said 0.7 cm.
    // Without ICP (--no-icp) the pose is a sample consensus's, not the fit's optimum: its
    // distance to that optimum (the same ICP it skipped) enters whole, so that the stated σ
    // covers the error it left (Stanford bun000 → bun045: 0.66 mm RMS off, σ 0.09 mm without
    // this term).
    std::vector<std::pair<double, double>> moves =  // (ICP end distance, weight)
        options.icp ? std::vector<std::pair<double, double>>{{0.5 * f.icp_end, 0.5},
                                                             {2.0 * f.icp_end, 0.5}}
                    : std::vector<std::pair<double, double>>{
                          {options.icp_distance_spacing * f.spacing, 1.0}};
    // After a plane-to-plane fit, also point-to-plane's own answer, whole.
    if (options.icp && options.icp_plane_to_plane) {
      moves.push_back({options.icp_distance_spacing * f.spacing, 1.0});
    }
    if ((!options.icp || f.icp_end > 0) && std::isfinite(u.sigma_rms)) {
      const Eigen::Matrix4d inv = f.h.transform.inverse();
      const Matrix6d& metric = u.metric;
      Matrix6d systematic = Matrix6d::Zero();
      double sum_sq = 0.0;
      for (const auto& [distance, weight] : moves) {
        const double end = std::min(reach, distance);
        const Eigen::Matrix4d moved = PointToPlaneIcp(
            fine_src, f.crop->level.points, f.crop->level.normals, *f.crop->index, f.h.transform,
            options.icp ? end : std::max(end, reach), end,
            options.icp_iterations, nullptr);
        const Eigen::Matrix4d delta = moved * inv;  // as MotionAbout(ξ, centre)
        const Eigen::Matrix3d r = delta.topLeftCorner<3, 3>();
        const Eigen::AngleAxisd aa(r);
        Vector6d xi;
        xi.head<3>() = aa.angle() * aa.axis();
        xi.tail<3>() = delta.topRightCorner<3, 1>() - u.centre + r * u.centre;
        systematic += weight * xi * xi.transpose();
        sum_sq += weight * xi.dot(metric * xi);
      }
      result.gate_sensitivity_m = std::sqrt(sum_sq);
      result.covariance += systematic;
      if (!options.icp) {
        std::ostringstream note;
        note << std::setprecision(3) << "not refined by ICP (--no-icp): the pose is "
             << result.gate_sensitivity_m
             << " m RMS over the source from the fit's optimum; its covariance includes that";
        result.notes.push_back(note.str());
      }
      const Eigen::LLT<Matrix6d> llt(metric);
      if (llt.info() == Eigen::Success) {
        const Matrix6d l = llt.matrixL();
        const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(l.transpose() * result.covariance * l);
        result.sigma_rms_m = std::sqrt(std::max(0.0, eig.eigenvalues()(5)));
        weakest = l.transpose().triangularView<Eigen::Upper>().solve(eig.eigenvectors().col(5));
      } else {
        result.sigma_rms_m = std::hypot(u.sigma_rms, result.gate_sensitivity_m);
      }
    }
    for (int k = 0; k < 3; ++k) {
      result.sigma_rotation_deg(k) = std::sqrt(result.covariance(k, k)) * 180.0 / M_PI;
      result.sigma_translation_m(k) = std::sqrt(result.covariance(3 + k, 3 + k));
    }
    const double bound = options.max_resolution_spacing * f.spacing;
    std::ostringstream at_bound;
    at_bound << std::setprecision(3) << " (unconstrained; shown for " << bound
             << " m RMS, the resolution bound)";
    if (!weakest.isZero()) {
      result.weakest_motion =
          std::isfinite(u.sigma_rms) ? DescribeMotion(weakest, result.sigma_rms_m) + " (1 sigma)"
                                     : DescribeMotion(weakest, bound) + at_bound.str();
    }
    // The local search tested this pose at the bound already when it left it as the best.
    const bool tested = best_tested.crop == f.crop.get() && best_tested.spacing == f.spacing &&
                        best_tested.transform == f.h.transform;
    axis_resolution = PoseResolution(fine_src, fine_src_n, *f.crop, f.h.transform, f.residuals,
                                     f.agree, reach, fine_tau, support_radius, bound,
                                     support_radius, options.resolution_t, true, {}, nullptr,
                                     tested ? &best_tested.test : nullptr);
    if (options.probe_weak_motions && !u.weak_directions.empty()) {
      // Probed first at its own bound (the δ grid ·2 / ÷2 from there).
      const double weak_bound = options.max_weak_motion_resolution_spacing * f.spacing;
      result.weak_motion_resolution_m = PoseResolution(
          fine_src, fine_src_n, *f.crop, f.h.transform, f.residuals, f.agree, reach, fine_tau,
          support_radius, weak_bound, support_radius, options.resolution_t, false,
          u.weak_directions);
      weak_motion = DescribeMotion(u.weak_directions.front(), bound);
    }
    result.resolution_m = std::max(axis_resolution, result.weak_motion_resolution_m);
    spdlog::debug("registration: pose resolution {:.4g} m (axes {:.4g} m, weak motions {:.4g} m; "
                  "fine spacing {:.4g} m), sigma {:.4g} m RMS over {} blocks, {:.4g} m with the "
                  "ICP distance's {:.4g} m, constraint ratio {:.3g}, weakest motion {}",
                  result.resolution_m, axis_resolution, result.weak_motion_resolution_m, f.spacing,
                  u.sigma_rms, u.blocks, result.sigma_rms_m, result.gate_sensitivity_m,
                  u.constraint_ratio, result.weakest_motion);
    end_stage("resolution");
  }

  // --- Verdict.
  result.descriptor = best.descriptor;
  result.target_from_source = best.transform;
  result.fitness = fine_check.fitness;
  result.inlier_rmse = fine_check.rmse;
  result.normal_agreement = fine_check.normal_agreement;
  result.num_inliers = static_cast<size_t>(
      std::llround(fine_check.fitness * static_cast<double>(src_fine.points.size())));
  result.fine_inlier_distance_m = fine_tau;
  result.conflict = fine_check.conflict;
  result.visibility_tested = visibility;
  result.violation = fine_check.violation;
  double runner_up = 0.0;
  const RegistrationHypothesis* runner = nullptr;
  for (size_t k = 0; k < finalists.size(); ++k) {
    const Hypothesis& h = finalists[k].h;
    RegistrationHypothesis r;
    r.origin = h.origin + " (fine)";
    if (!photo.empty()) r.intensity_correlation = photo[k].AbsCorrelation();
    r.target_from_source = h.transform;
    r.fitness = h.fitness;
    r.inlier_rmse = h.rmse;
    r.normal_agreement = h.normal_agreement;
    r.score = h.score;
    r.conflict = h.conflict;
    r.violation = h.violation;
    result.hypotheses.push_back(r);
    spdlog::debug("registration: finalist {}: score {:.4g}, fitness {:.3g}, normals {:.3g}, "
                  "free-space violations {:.3g}",
                  h.origin, h.score, h.fitness, h.normal_agreement, h.violation);
  }
  for (const Hypothesis& h : hypotheses) {
    RegistrationHypothesis r;
    r.origin = h.origin + " (coarse)";
    r.target_from_source = h.transform;
    r.fitness = h.fitness;
    r.inlier_rmse = h.rmse;
    r.normal_agreement = h.normal_agreement;
    r.score = h.score;
    result.hypotheses.push_back(r);
  }
  // Ambiguity: the best pose must beat every distinct finalist that scores above
  // max_ambiguity × its score by at least min_significance standard errors of the paired block
  // score difference — the test PoseResolution applies to small displacements, applied here to
  // the distinct poses found: a pseudo-symmetric turn, or a shift by one period of a repeated
  // structure (the runner-up need not score close to the best: a noisy source shifted by one
  // bay may score 70 % of the truth and still not be told from it). `significance` is the
  // smallest of these t statistics (+inf when no distinct finalist is left).
  result.significance = std::numeric_limits<double>::infinity();
  if (finalists.size() > 1) runner_up = finalists[1].h.score;
  double runner_geometric_t = 0.0, runner_intensity_t = 0.0;
  for (const auto& [k, tg] : rivals) {
    const double ti =
        photo.empty() ? 0.0 : internal::IntensityAgreement::Significance(photo[0], photo[k]);
    const double t = photo.empty() ? tg : internal::CombinedSignificance(tg, ti);
    if (t < result.significance) {
      result.significance = t;
      runner = &result.hypotheses[k];
      runner_geometric_t = tg;
      runner_intensity_t = ti;
    }
  }
  if (!photo.empty() && runner != nullptr) result.intensity_significance = runner_intensity_t;
  const double best_score = best.score;
  result.confidence = best_score > 0 ? std::clamp(1.0 - runner_up / best_score, 0.0, 1.0) : 0.0;
  std::ostringstream why;
  why << std::setprecision(3);
  // With the target's sensors known, a small overlap is not by itself evidence against the
  // pose: the source points off the target are checked against the target's free space
  // (they must lie where its sensors did not look). The pose is contradicted when the points
  // in observed free space exceed max_violation_ratio × the inliers, and then only a floor of
  // min_fitness_visible remains for the statistics. Without the target's sensors (a plane
  // proxy has none) the source's sensors test only the other direction — target points off
  // the source — and the overlap floor min_fitness stays: a stereo part moved 30 m along the
  // cathedral's bays onto the proxy (fitness 0.26) contradicts none of its stations' rays.
  const double fitness_floor = visibility && !options.target_viewpoints.empty()
                                   ? options.min_fitness_visible
                                   : options.min_fitness;
  if (fine_check.fitness < fitness_floor) {
    why << "best hypothesis (" << best.origin << ") makes only " << 100 * fine_check.fitness
        << "% of the source lie within " << fine_tau << " m of the target (need "
        << 100 * fitness_floor << "%): the clouds do not overlap, no hypothesis is right, or they overlap "
        << "less than that (--min-fitness lowers the bar, at the risk of a wrong pose on a partial fit)";
    return fail(why.str());
  }
  if (contradicted(fine_check)) {
    why << "visibility: " << 100 * fine_check.violation
        << "% of the source lies in space a sensor observed as empty (allowed: "
        << options.max_violation_ratio << " x the " << 100 * fine_check.fitness
        << "% inliers): the pose contradicts the data";
    return fail(why.str());
  }
  if (!options.paper_only && fine_check.normal_agreement < options.min_normal_agreement) {
    why << "normals disagree: only " << 100 * fine_check.normal_agreement
        << "% of the inliers have matching normals (need "
        << 100 * options.min_normal_agreement << "%)";
    return fail(why.str());
  }
  // The best pose fits; what follows asks whether it is the only one and whether it is fixed.
  result.best_pose_fits = true;
  if (!options.paper_only && runner != nullptr && result.significance < options.min_significance) {
    const Eigen::Matrix3d r = runner->target_from_source.topLeftCorner<3, 3>().transpose() *
                              best.transform.topLeftCorner<3, 3>();
    const double shift =
        (Apply(runner->target_from_source, centre) - Apply(best.transform, centre)).norm();
    why << "ambiguous: a different pose fits almost as well (scores " << best_score << " and "
        << runner->score << "; " << RotationAngleDeg(r) << "° and " << shift
        << " m apart at the source centre); the best is better by only " << result.significance
        << " standard errors (need " << options.min_significance << ")";
    if (!photo.empty()) {
      why << " with the intensity test (geometry " << runner_geometric_t << ", intensity "
          << runner_intensity_t << ")";
    }
    why << ": a (pseudo-)symmetric or repeated structure — give "
        << (options.gravity_aligned ? "" : "--gravity-aligned, ")
        << "more overlap or an approximate pose (--search-window)";
    return fail(why.str());
  }
  // Scale agreement: a chosen pose that the coarse level ranked well below another distinct
  // finalist is contradicted by the coarse evidence (fine ICP can leave a good coarse start on
  // a dense, noisy cloud; the fine score then sees a symmetric twin fit better).
  if (!options.paper_only && options.min_coarse_agreement > 0 &&
      std::isfinite(finalists[0].coarse_score)) {
    size_t leader = 0;
    for (size_t k = 1; k < finalists.size(); ++k) {
      // A pose the visibility test contradicts is no evidence against the chosen one (as in
      // the ambiguity test).
      if (std::isfinite(finalists[k].coarse_score) && !contradicted(finalists[k].h) &&
          !(finalists[k].coarse_score <= finalists[leader].coarse_score)) {
        leader = k;
      }
    }
    if (leader != 0 &&
        finalists[0].coarse_score < options.min_coarse_agreement * finalists[leader].coarse_score) {
      const Finalist& l = finalists[leader];
      const Eigen::Matrix3d r =
          l.h.transform.topLeftCorner<3, 3>().transpose() * best.transform.topLeftCorner<3, 3>();
      const double shift = (Apply(l.h.transform, centre) - Apply(best.transform, centre)).norm();
      why << "scales disagree: the coarse level prefers a pose " << RotationAngleDeg(r) << "° and "
          << shift << " m away (coarse scores " << l.coarse_score << " against "
          << finalists[0].coarse_score << " for this one), the fine level this one (fine scores "
          << best_score << " against " << l.h.score
          << "): a dense noisy cloud or a (pseudo-)symmetric structure — give an approximate "
             "pose (--search-window)";
      return fail(why.str());
    }
  }
  if (!options.paper_only &&
      !(axis_resolution <= options.max_resolution_spacing * result.fine_spacing_m)) {
    why << "pose not resolved: the fine verification cannot tell it from displacements of "
        << axis_resolution << " m RMS (need <= " << options.max_resolution_spacing
        << " x the fine spacing " << result.fine_spacing_m
        << " m); a noisy, planar or featureless overlap";
    return fail(why.str());
  }
  // The fit's least-constrained motion must be told apart within its bound. Not at all up to
  // R_s: the data leave it free (or the pose is off the score's maximum along it). Only
  // beyond the bound: it is fixed by too little (a few edges or steps) to call the pose
  // known — on the simulated cathedral a proxy part slid along the facade was "ok"
  // 0.46–0.58 m off, resolved to 1.28–2.56 m (bench/RESULTS.md, session 17).
  const double weak_bound = options.max_weak_motion_resolution_spacing * result.fine_spacing_m;
  if (!options.paper_only && !(result.weak_motion_resolution_m <= weak_bound)) {
    why << "pose not determined: the fit's least-constrained motion (" << weak_motion
        << ", " << options.max_resolution_spacing * result.fine_spacing_m
        << " m RMS over the source) is ";
    if (std::isfinite(result.weak_motion_resolution_m)) {
      why << "told apart by the fine verification only at " << result.weak_motion_resolution_m
          << " m RMS (need <= " << options.max_weak_motion_resolution_spacing
          << " x the fine spacing " << result.fine_spacing_m << " m = " << weak_bound
          << " m); the overlap fixes it by a few edges or steps only";
    } else {
      why << "not told apart by the fine verification at any displacement up to R_s = "
          << support_radius << " m; a planar or featureless overlap";
    }
    return fail(why.str());
  }
  if (!options.paper_only && options.check_fit_uncertainty &&
      !(options.resolution_t * result.sigma_rms_m <=
                               options.max_resolution_spacing * result.fine_spacing_m)) {
    why << "pose not determined: the inliers of the fit leave " << result.weakest_motion
        << " (" << result.sigma_rms_m << " m RMS over the source; need " << options.resolution_t
        << " sigma <= " << options.max_resolution_spacing << " x the fine spacing "
        << result.fine_spacing_m << " m): a planar or featureless overlap";
    return fail(why.str());
  }
  if (options.paper_only) {
    // The paper's pipeline has no verification: its result is not claimed as "ok".
    result.status = "unverified";
    result.reason = "paper pipeline (best SAC-IA + ICP) without hypothesis verification";
    return result;
  }
  result.status = "ok";
  result.reason.clear();
  return result;
}

io::PointCloud Shifted(const io::PointCloud& cloud, const Eigen::Vector3d& offset) {
  io::PointCloud out = cloud;
  for (Eigen::Vector3d& p : out.points) p += offset;
  return out;
}

}  // namespace

// Each cloud is registered about its own centre c (io::MedianCentre: a blunder far away does
// not move it), and the result is mapped back: T = [I | c_t] · T_local · [I | −c_s]. The
// floats of the kd-trees and PCL then resolve a cloud at its own size (map-grid coordinates,
// 10^5–10^7 m, left them 0.01–0.5 m), and no step but the normals' orientation (below)
// depends on where the frame's origin lies.
// Before session 40 a cloud within 500 m of its origin was registered as given, and an object
// far from that origin against its size (the bunny 30 m above it) failed: the ICP turned it
// about the origin, so each step moved it by the turn's second-order term at that distance
// (10° at 30 m: 0.46 m). The ICP now also turns the source about its own centroid.
// With a search window both clouds share the target's c, so that the given (identity) pose
// stays the identity.
// The normals of a cloud within 500 m of its origin (io::LocalOrigin is zero) are oriented
// towards that origin, its scanner when it is a scan in its own frame. Those of a cloud in a
// grid cannot be (its origin is thousands of km away, nearly level: ground normals would flip
// at random); they are oriented towards a point high above its centroid along `up` instead —
// ground up, walls towards the middle of the cloud, as a levelled scanner standing inside it
// sees them.
namespace {
// A levelled pair whose registered pose tilts the source by more than this gets a note.
constexpr double kLevelledTiltNote = 2.0 * M_PI / 180.0;

// In the cloud's coordinates about its centre (io::MedianCentre): high above it, ten times the
// cloud's robust extent (a blunder far away does not send the viewpoint there), measured on
// at most 100,000 evenly strided points (it runs once per cloud and per trial scale).
Eigen::Vector3d GridViewpoint(const io::PointCloud& cloud, const Eigen::Vector3d& up) {
  const double extent = RobustExtent(Pick(cloud.points, StrideSample(cloud.size(), 100000)));
  return std::max(100.0, 10.0 * extent) * up.normalized();
}

// NormalOrientation::kAuto: RegisterCloudsNearOrigin with the normals towards each cloud's
// origin (or sensors). When that fails after the normals stage with no pose that fits, and
// the two clouds do not both have sensor positions, it is tried again with kConsistentTurned
// (a scan moved into another frame, its origin behind its surfaces: bench/RESULTS.md, issue 5,
// "Normals retried") and, when a cloud's normals are estimated without sensors, with
// kConsistent (part of a cloud turned against the rest). A retry's result is taken only when
// it is "ok"; the runtime counts every try.
CloudRegistrationResult RegisterCloudsNearOriginRetrying(const io::PointCloud& source,
                                                         const io::PointCloud& target,
                                                         const CloudRegistrationOptions& options,
                                                         const Eigen::Vector3d& source_viewpoint,
                                                         const Eigen::Vector3d& target_viewpoint) {
  if (options.normal_orientation != NormalOrientation::kAuto) {
    return RegisterCloudsNearOrigin(source, target, options, source_viewpoint, target_viewpoint);
  }
  CloudRegistrationOptions first_options = options;
  first_options.normal_orientation = NormalOrientation::kViewpoint;
  bool past_normals = false;
  CloudRegistrationResult first = RegisterCloudsNearOrigin(
      source, target, first_options, source_viewpoint, target_viewpoint, &past_normals);
  // A first try whose best pose fits (overlap, normals, visibility) and was refused as
  // ambiguous or not fixed found its poses: a retry would only draw other hypotheses, and an
  // "ok" among them would lack the competitor the first try saw (on the simulated gate, seed 2,
  // the multi-view part onto the proxy: its 180° twin, refused at t 2.5 against the right
  // pose, became a wrong "ok" 5.9 m off on the retry, where the right pose came out worse).
  if (first.status != "failed" || !past_normals || first.best_pose_fits ||
      (!options.source_viewpoints.empty() && !options.target_viewpoints.empty())) {
    return first;
  }
  const auto estimated = [&](const io::PointCloud& cloud, const std::vector<Eigen::Vector3d>& sensors) {
    return sensors.empty() && !(options.use_existing_normals && cloud.has_normals());
  };
  const bool any_estimated =
      estimated(source, options.source_viewpoints) || estimated(target, options.target_viewpoints);
  // One stage per try that did not give the result, so runtime_seconds counts every try.
  const auto as_stage = [](const std::string& name, const CloudRegistrationResult& r) {
    StageTime t{name, 0.0, 0.0};
    for (const StageTime& s : r.runtime) {
      t.seconds += s.seconds;
      t.cpu_seconds += s.cpu_seconds;
    }
    return t;
  };
  CloudRegistrationOptions retry_options = options;
  std::vector<StageTime> tries = {as_stage("first try (normals towards the origin)", first)};
  for (const bool turn : {true, false}) {
    if (!turn && !any_estimated) break;
    const std::string what = any_estimated
                                 ? (turn ? "consistent normals (Hoppe et al. 1992), the source's turned"
                                         : "consistent normals (Hoppe et al. 1992)")
                                 : "the source's normals turned";
    retry_options.normal_orientation =
        turn ? NormalOrientation::kConsistentTurned : NormalOrientation::kConsistent;
    CloudRegistrationResult retry = RegisterCloudsNearOrigin(
        source, target, retry_options, source_viewpoint, target_viewpoint);
    if (retry.ok()) {
      retry.notes.insert(retry.notes.begin(),
                         "registered with " + what + "; with the normals towards each "
                         "cloud's origin it failed: " + first.reason);
      retry.runtime.insert(retry.runtime.begin(), tries.begin(), tries.end());
      return retry;
    }
    first.notes.push_back("retried with " + what + ": failed too (" + retry.reason + ")");
    tries.push_back(as_stage("retry (" + what + ")", retry));
  }
  first.runtime.insert(first.runtime.end(), tries.begin() + 1, tries.end());
  return first;
}
}  // namespace

CloudRegistrationResult RegisterClouds(const io::PointCloud& source,
                                       const io::PointCloud& target,
                                       const CloudRegistrationOptions& options) {
  Eigen::Vector3d o_t = io::MedianCentre(target.points);
  Eigen::Vector3d o_s = options.search_window_m > 0.0 ? o_t : io::MedianCentre(source.points);
  if (!o_t.allFinite() || !o_s.allFinite()) o_t = o_s = Eigen::Vector3d::Zero();  // NaN: fails
  CloudRegistrationOptions local = options;
  for (Eigen::Vector3d& v : local.source_viewpoints) v -= o_s;
  for (Eigen::Vector3d& v : local.target_viewpoints) v -= o_t;
  const auto viewpoint = [&](const io::PointCloud& cloud, const Eigen::Vector3d& o) {
    return io::LocalOrigin(cloud.points).isZero() ? Eigen::Vector3d(-o)
                                                  : GridViewpoint(cloud, options.up);
  };
  const Eigen::Vector3d v_s = viewpoint(source, o_s);
  const Eigen::Vector3d v_t = viewpoint(target, o_t);
  CloudRegistrationResult result = RegisterCloudsNearOriginRetrying(
      Shifted(source, -o_s), Shifted(target, -o_t), local, v_s, v_t);
  const auto back = [&](const Eigen::Matrix4d& t) {
    Eigen::Matrix4d out = t;
    out.topRightCorner<3, 1>() = t.topRightCorner<3, 1>() + o_t - t.topLeftCorner<3, 3>() * o_s;
    return out;
  };
  result.target_from_source = back(result.target_from_source);
  for (RegistrationHypothesis& h : result.hypotheses) {
    h.target_from_source = back(h.target_from_source);
  }
  result.covariance_centre += o_t;
  // A failure with a cloud of a few points (above the hard minimum of 10) is most likely that:
  // say so, rather than leave only the symptom ("do not overlap", "not resolved").
  const size_t fewest = std::min(source.size(), target.size());
  if (!result.ok() && fewest >= 10 && fewest < kFewPointsForDescriptors) {
    std::ostringstream hint;
    hint << "; the " << (source.size() <= target.size() ? "source" : "target") << " has only " << fewest
         << " points: too few for local descriptors (a few dozen at least in each cloud)";
    result.reason += hint.str();
  }
  // Levelled clouds were assumed (--gravity-aligned): the hypotheses turn about `up` only, but
  // the fine ICP is free, so a pose that tilts the source says the assumption did not hold.
  if (options.gravity_aligned && result.ok()) {
    const Eigen::Vector3d up = options.up.normalized();
    const double tilt = std::acos(std::clamp(
        (result.target_from_source.topLeftCorner<3, 3>() * up).normalized().dot(up), -1.0, 1.0));
    if (tilt > kLevelledTiltNote) {
      std::ostringstream note;
      note << std::setprecision(3) << "--gravity-aligned: the pose tilts the source by "
           << tilt * 180.0 / M_PI << " deg against --up; the clouds were not both levelled "
           << "about that axis (the result was found all the same)";
      result.notes.push_back(note.str());
    }
  }
  return result;
}

double FreeSpaceViolation(const io::PointCloud& source, const io::PointCloud& target,
                          const std::vector<Eigen::Vector3d>& source_viewpoints,
                          const std::vector<Eigen::Vector3d>& target_viewpoints,
                          const Eigen::Matrix4d& target_from_source, double margin) {
  if (source.empty() || target.empty()) return 0.0;
  TargetCrop crop;
  crop.level.points = target.points;
  crop.index = std::make_unique<PointIndex>(crop.level.points);
  const PointIndex src_index(source.points);
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : source.points) box.extend(p);
  const internal::FreeSpace src_free(source.points, source_viewpoints,
                                     EstimatePointSpacing(source));
  const internal::FreeSpace tgt_free(target.points, target_viewpoints,
                                     EstimatePointSpacing(target));
  const std::vector<bool> v = FreeSpaceViolations(source.points, src_index, &src_free, box, crop,
                                                  &tgt_free, target_from_source, margin, margin);
  return static_cast<double>(std::count(v.begin(), v.end(), true)) / source.size();
}

std::vector<double> DistancesToTarget(const io::PointCloud& source, const io::PointCloud& target,
                                      const Eigen::Matrix4d& target_from_source) {
  PointIndex index(target.points);
  std::vector<double> out(source.size(), std::numeric_limits<double>::infinity());
  int i_near;
  double sq;
  for (size_t i = 0; i < source.size(); ++i) {
    if (index.Nearest(Apply(target_from_source, source.points[i]), &i_near, &sq)) {
      out[i] = std::sqrt(sq);
    }
  }
  return out;
}

io::PointCloud MakeErrorMap(const io::PointCloud& source, const io::PointCloud& target,
                            const Eigen::Matrix4d& target_from_source, double max_m) {
  const std::vector<double> d = DistancesToTarget(source, target, target_from_source);
  io::PointCloud out;
  out.points.reserve(source.size());
  out.colors.reserve(source.size());
  out.intensity.reserve(source.size());
  for (size_t i = 0; i < source.size(); ++i) {
    out.points.push_back(Apply(target_from_source, source.points[i]));
    // Blue → cyan → green → yellow → red ("jet"), as the error maps of Kim & Hilton Fig. 6.
    const double t = max_m > 0 ? std::clamp(d[i] / max_m, 0.0, 1.0) : 0.0;
    auto channel = [t](double centre) {
      return static_cast<uint8_t>(255.0 * std::clamp(1.5 - std::abs(4.0 * t - centre), 0.0, 1.0));
    };
    out.colors.push_back({channel(3.0), channel(2.0), channel(1.0)});
    out.intensity.push_back(static_cast<float>(d[i]));
  }
  return out;
}

SimilarityFit RefineSimilarity(const io::PointCloud& source, const io::PointCloud& target,
                               const Eigen::Matrix4d& start, double start_distance,
                               double end_distance, int iterations, size_t max_target_points) {
  SimilarityFit fit;
  fit.target_from_source = start;
  fit.scale = start.topLeftCorner<3, 3>().col(0).norm();
  if (source.empty() || target.empty() || !(end_distance > 0)) return fit;
  // The target near the moved source, thinned, with normals within 4 of its spacings.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Eigen::Vector3d& p : source.points) {
    const Eigen::Vector3d q = Apply(start, p);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const double margin = std::max(start_distance, end_distance);
  lo.array() -= margin;
  hi.array() += margin;
  io::PointCloud crop;
  for (const Eigen::Vector3d& x : target.points) {
    if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) crop.points.push_back(x);
  }
  if (crop.size() < 10) return fit;
  Level tgt = VoxelDownsample(crop.points, {}, VoxelForBudget(crop, 0.0, max_target_points));
  const double spacing = MedianSpacing(tgt.points, 20000);
  tgt.normals = internal::EstimateNormals(tgt.points, 4.0 * spacing, Eigen::Vector3d::Zero());
  DropInvalidNormals(&tgt);
  if (tgt.points.size() < 10) return fit;
  const internal::PointIndex index(tgt.points);
  Eigen::Matrix4d transform = start;
  double distance = margin;
  int idx;
  double sq;
  for (int it = 0; it < iterations; ++it) {
    fit.iterations = it + 1;
    std::vector<Eigen::Vector3d> moved;
    moved.reserve(source.size());
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : source.points) {
      moved.push_back(Apply(transform, p));
      centre += moved.back();
    }
    centre /= static_cast<double>(moved.size());
    // Parameters (ω, t, σ): q' = c + e^σ Exp(ω)(q − c) + t; at zero the residual
    // n·(q' − x) changes by ω·((q − c) × n) + n·t + σ n·(q − c).
    Eigen::Matrix<double, 7, 7> jtj = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> jtr = Eigen::Matrix<double, 7, 1>::Zero();
    const double d2 = distance * distance;
    int count = 0;
    for (const Eigen::Vector3d& q : moved) {
      if (!index.NearestWithin(q, d2, &idx, &sq)) continue;
      const Eigen::Vector3d& n = tgt.normals[static_cast<size_t>(idx)];
      const Eigen::Vector3d a = q - centre;
      const double r = (q - tgt.points[static_cast<size_t>(idx)]).dot(n);
      const double w = 1.0 / (1.0 + (r * r) / (0.25 * d2));
      Eigen::Matrix<double, 7, 1> j;
      j << a.cross(n), n, n.dot(a);
      jtj += w * j * j.transpose();
      jtr += w * j * r;
      ++count;
    }
    if (count < 7) break;
    const Eigen::Matrix<double, 7, 1> x = jtj.ldlt().solve(-jtr);
    if (!x.allFinite()) break;
    const Eigen::Vector3d omega = x.head<3>();
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    if (omega.norm() > 1e-12) rotation = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    Eigen::Matrix4d delta = Eigen::Matrix4d::Identity();
    delta.topLeftCorner<3, 3>() = std::exp(x(6)) * rotation;
    delta.topRightCorner<3, 1>() = centre + x.segment<3>(3) - delta.topLeftCorner<3, 3>() * centre;
    transform = delta * transform;
    const bool small = omega.norm() < 1e-6 && std::abs(x(6)) < 1e-6 && x.segment<3>(3).norm() < 1e-3 * end_distance;
    if (small && distance <= end_distance) break;
    distance = std::max(end_distance, distance * 0.8);
  }
  fit.target_from_source = transform;
  fit.scale = transform.topLeftCorner<3, 3>().col(0).norm();
  size_t inliers = 0;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : source.points) {
    if (!index.NearestWithin(Apply(transform, p), end_distance * end_distance, &idx, &sq)) continue;
    ++inliers;
    sum += sq;
  }
  fit.fitness = static_cast<double>(inliers) / static_cast<double>(source.size());
  fit.inlier_rmse = inliers > 0 ? std::sqrt(sum / static_cast<double>(inliers)) : 0.0;
  return fit;
}

double RobustExtent(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d span;
  std::vector<double> v(points.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (size_t i = 0; i < points.size(); ++i) v[i] = points[i](axis);
    const size_t lo = v.size() / 20, hi = v.size() - 1 - v.size() / 20;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(lo), v.end());
    const double a = v[lo];
    std::nth_element(v.begin(), v.begin() + static_cast<long>(hi), v.end());
    span(axis) = v[hi] - a;
  }
  return span.norm();
}

namespace {
// Runs job(0) … job(n − 1), two at a time on a machine with two cores or more (each is mostly
// single-threaded); the first exception is rethrown once both workers have stopped.
void RunTwoAtATime(size_t n, const std::function<void(size_t)>& job) {
  std::atomic<size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  const auto work = [&]() {
    try {
      for (size_t k = next++; k < n; k = next++) job(k);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      next = n;
    }
  };
  const size_t workers = std::min<size_t>({2, std::max(1u, std::thread::hardware_concurrency()), n});
  std::vector<std::thread> pool;
  for (size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}
}  // namespace

double ScaleSearchTolerance(const io::PointCloud& target) {
  return std::max(3.0 * EstimatePointSpacing(target), 0.005 * RobustExtent(target.points));
}

ScaleSearchResult RegisterCloudsOverScales(
    const io::PointCloud& source, const io::PointCloud& target,
    const CloudRegistrationOptions& options, double min_scale, double max_scale, double step,
    double tolerance_m, const std::function<void(size_t, size_t, const ScaleTrial&)>& progress) {
  ScaleSearchResult result;
  Timer timer;
  if (!(min_scale > 0) || !(max_scale >= min_scale) || !(step > 1.0) || !std::isfinite(max_scale)) {
    throw InputError::Message("scale search", "expected 0 < min scale <= max scale and a step > 1");
  }
  const double tau = tolerance_m > 0 ? tolerance_m : ScaleSearchTolerance(target);
  result.tolerance_m = tau;
  auto fail = [&](const std::string& reason) {
    result.status = "failed";
    result.reason = reason;
    result.seconds = timer.ElapsedSeconds();
    return result;
  };
  for (const auto& [cloud, which] : {std::pair{&source, "source"}, std::pair{&target, "target"}}) {
    const std::string problem = CheckCloud(*cloud, which);
    if (!problem.empty()) return fail(problem);
  }
  std::vector<double> scales;
  for (double x = min_scale; x <= max_scale * (1 + 1e-9); x *= step) scales.push_back(x);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& x : source.points) centroid += x;
  centroid /= static_cast<double>(source.size());
  const double extent = RobustExtent(source.points);
  struct Candidate {
    double trial_scale;
    SimilarityFit fit;
  };
  struct Outcome {
    CloudRegistrationResult rigid;
    std::optional<SimilarityFit> fit;
  };
  // One trial: the source at `scale` (about its centroid) registered rigidly; an "ok" one is
  // refined as a similarity (a rigid pose at a scale 5 % off leaves the source's ends 5 % of
  // its half extent off).
  const auto run_trial = [&](double scale, Outcome* o, ScaleTrial* trial) {
    io::PointCloud scaled;
    scaled.points.reserve(source.size());
    for (const Eigen::Vector3d& x : source.points) scaled.points.push_back(scale * (x - centroid));
    CloudRegistrationOptions trial_options = options;
    for (Eigen::Vector3d& c : trial_options.source_viewpoints) c = scale * (c - centroid);
    if (trial_options.normal_orientation == NormalOrientation::kAuto) {
      trial_options.normal_orientation = NormalOrientation::kViewpoint;  // no retries
    }
    o->rigid = RegisterClouds(scaled, target, trial_options);
    trial->scale = scale;
    trial->status = o->rigid.ok() ? "ok" : "failed: " + o->rigid.reason;
    trial->fitness = o->rigid.fitness;
  };
  // The similarity target ← source of a trial's rigid pose, refined with the scale free.
  const auto refine = [&](double scale, const CloudRegistrationResult& rigid) {
    Eigen::Matrix4d start = Eigen::Matrix4d::Identity();
    start.topLeftCorner<3, 3>() = scale * rigid.target_from_source.topLeftCorner<3, 3>();
    start.topRightCorner<3, 1>() =
        rigid.target_from_source.topRightCorner<3, 1>() - start.topLeftCorner<3, 3>() * centroid;
    const double reach = std::max(10.0 * tau, 0.05 * scale * extent);
    return RefineSimilarity(source, target, start, reach, tau);
  };
  std::vector<Outcome> outcomes(scales.size());
  std::vector<ScaleTrial> trials(scales.size());
  std::mutex progress_mutex;
  size_t finished = 0;
  // The trials are independent: two at a time, then taken in the order of their scales, so the
  // result does not depend on which finished first.
  const auto trial_job = [&](size_t k) {
    Outcome& o = outcomes[k];
    ScaleTrial& trial = trials[k];
    run_trial(scales[k], &o, &trial);
    if (o.rigid.ok()) {
      o.fit = refine(scales[k], o.rigid);
      trial.refined = true;
      trial.refined_scale = o.fit->scale;
      trial.refined_fitness = o.fit->fitness;
    }
    const std::lock_guard<std::mutex> lock(progress_mutex);
    ++finished;
    if (progress) progress(finished, trials.size(), trial);
  };
  RunTwoAtATime(scales.size(), trial_job);
  // Second pass, when no trial scale registered: the checks of a rigid registration refuse a
  // pose whose scale is a few per cent off (its ends lie beyond the fine tolerance, so it is
  // "not resolved" or "not determined" though it fits). Every failed trial whose pose fits is
  // refined as a similarity; the two refined scales that fit best (distinct, within the range
  // widened by a step) are each registered again from scratch, with every check. An "ok" there
  // is a trial like the others.
  if (std::none_of(outcomes.begin(), outcomes.end(), [](const Outcome& o) { return o.rigid.ok(); })) {
    std::vector<std::optional<SimilarityFit>> fits(scales.size());
    RunTwoAtATime(scales.size(), [&](size_t k) {
      if (outcomes[k].rigid.best_pose_fits) fits[k] = refine(scales[k], outcomes[k].rigid);
    });
    std::vector<SimilarityFit> refined;
    for (const std::optional<SimilarityFit>& fit : fits) {
      if (fit && fit->scale >= min_scale / step && fit->scale <= max_scale * step) refined.push_back(*fit);
    }
    std::stable_sort(refined.begin(), refined.end(),
                     [](const SimilarityFit& a, const SimilarityFit& b) { return a.fitness > b.fitness; });
    std::vector<double> tried = scales;
    for (const SimilarityFit& fit : refined) {
      if (tried.size() == scales.size() + 2) break;
      if (std::none_of(tried.begin(), tried.end(), [&](double t) { return std::abs(fit.scale / t - 1.0) < 1e-3; })) {
        tried.push_back(fit.scale);
      }
    }
    const size_t first_new = scales.size();
    scales.assign(tried.begin(), tried.end());
    outcomes.resize(scales.size());
    trials.resize(scales.size());
    for (size_t k = first_new; k < scales.size(); ++k) trials[k].from_refinement = true;
    RunTwoAtATime(scales.size() - first_new, [&](size_t i) { trial_job(first_new + i); });
  }
  std::vector<Candidate> candidates;
  std::string closest;  // the reason of the failed trial that fitted best
  double closest_fitness = -1.0;
  for (size_t k = 0; k < scales.size(); ++k) {
    const Outcome& o = outcomes[k];
    if (o.fit) {
      candidates.push_back({scales[k], *o.fit});
    } else if (o.rigid.fitness > closest_fitness) {
      closest_fitness = o.rigid.fitness;
      std::ostringstream m;
      m << "; the best-fitting trial, scale " << scales[k] << ", " << o.rigid.reason;
      closest = m.str();
    }
  }
  result.trials = trials;
  if (candidates.empty()) {
    std::ostringstream m;
    m << "registered at none of " << scales.size() << " trial scales " << min_scale << " … " << max_scale << closest;
    return fail(m.str());
  }
  std::stable_sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.fit.fitness > b.fit.fitness; });
  const Candidate& best = candidates.front();
  // Another trial that ends elsewhere (a pseudo-symmetric site, a repeated bay) and fits almost
  // as well: ambiguous.
  for (size_t k = 1; k < candidates.size(); ++k) {
    const double apart = TransformRmsOnCloud(source, best.fit.target_from_source, candidates[k].fit.target_from_source);
    if (apart > 5.0 * tau && candidates[k].fit.fitness > 0.9 * best.fit.fitness) {
      std::ostringstream m;
      m << "ambiguous: the trial scales " << best.trial_scale << " and " << candidates[k].trial_scale
        << " place the source " << apart << " m RMS apart with fitness " << best.fit.fitness << " and "
        << candidates[k].fit.fitness;
      return fail(m.str());
    }
  }
  result.target_from_source = best.fit.target_from_source;
  result.scale = best.fit.scale;
  result.fitness = best.fit.fitness;
  result.inlier_rmse = best.fit.inlier_rmse;
  if (best.fit.fitness < 0.3) {
    std::ostringstream m;
    m << "the best placement puts only " << 100 * best.fit.fitness << " % of the source within " << tau
      << " m of the target (30 % needed)";
    return fail(m.str());
  }
  result.status = "ok";
  result.seconds = timer.ElapsedSeconds();
  return result;
}

double TransformRmsOnCloud(const io::PointCloud& cloud, const Eigen::Matrix4d& a,
                           const Eigen::Matrix4d& b) {
  if (cloud.empty()) return 0.0;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : cloud.points) sum += (Apply(a, p) - Apply(b, p)).squaredNorm();
  return std::sqrt(sum / static_cast<double>(cloud.size()));
}

}  // namespace mmba::registration
