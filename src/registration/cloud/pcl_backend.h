#pragma once

// The PCL part of the cloud registration behind a PCL-free interface: the descriptor index,
// normals, the Kanade–Tomasi response and the four descriptors. Only pcl_backend.cc includes
// PCL.

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/point_index.h"
#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::registration::internal {

/// Indices of at most `max_count` of `n` items at an even stride (a deterministic subsample,
/// e.g. of the points an index is built over).
std::vector<size_t> StrideSample(size_t n, size_t max_count);

/// The kd-tree over 3-D points (include/mmba/geometry/point_index.h).
using mmba::PointIndex;

/// Exact nearest neighbours in descriptor space (brute force; deterministic).
class FeatureIndex {
 public:
  /// `rows` descriptors of `dim` floats each, row-major.
  FeatureIndex(const std::vector<float>& data, int dim);
  ~FeatureIndex();
  FeatureIndex(const FeatureIndex&) = delete;
  FeatureIndex& operator=(const FeatureIndex&) = delete;
  void KNearest(const float* query, int k, std::vector<int>* indices,
                std::vector<float>* squared_distances) const;
  size_t rows() const { return rows_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  size_t rows_ = 0;
};

/// Point spacing of a surface sample from the area it covers: `points` occupy K voxels of
/// side V; a plane with unit normal n crosses ‖n‖₁·A/V² voxels per area A, 1.5·A/V² on
/// average over orientations (‖n‖₁ ∈ [1, √3]), so the area per point is V² K / (1.5 N) and
/// the spacing V·√(K / 1.5 N), within −18 % / +8 % by orientation. V must be well above the
/// spacing (a few points per voxel) and below the surface's curvature. On an even sampling
/// it is about the nearest-neighbour spacing (1.5–1.7 × it on voxel centroids, about 2.2 × on
/// a uniformly random sample); on a scan's lines √(along-line × between-line spacing), where
/// the nearest neighbour sees only the along-line spacing. 0 for an empty cloud.
double AreaSpacing(const std::vector<Eigen::Vector3d>& points, double voxel);

/// Normals of `points` (`index` built on them) by PCA within `radius`, and where that
/// neighbourhood is a line, not a surface, within 2, 4, … × `radius` (at most `max_radius`)
/// until it is a surface: the middle eigenvalue of the neighbours' covariance at least
/// `min_ratio` × the largest (a disc gives 1, a single noisy line about 0). A scan's points
/// lie on lines whose spacing along the line is far below the spacing between lines, and a
/// radius of a few along-line spacings (the nearest-neighbour spacing) spans one line: its
/// normal is any direction across the line. Oriented towards `viewpoint`; NaN with fewer than
/// 3 neighbours within `radius` or no radius up to `max_radius` giving a surface. One PCA per
/// point where EstimateNormals and a second test would take two. Returns the number of
/// normals estimated wider.
size_t SurfaceNormals(const std::vector<Eigen::Vector3d>& points, const PointIndex& index,
                      double radius, double max_radius, const Eigen::Vector3d& viewpoint,
                      std::vector<Eigen::Vector3d>* normals, double min_ratio = 0.1);

/// Normals by PCA within `radius` (PCL NormalEstimationOMP), oriented towards `viewpoint`.
/// Points with too few neighbours get a NaN normal. With `only`, the normals of those points
/// alone (in that order), their neighbours still taken from all `points`: the same normals
/// as the whole set's at those indices.
std::vector<Eigen::Vector3d> EstimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             double radius, const Eigen::Vector3d& viewpoint,
                                             const std::vector<size_t>* only = nullptr);

/// Turns each normal towards the nearest of the cloud's sensor positions `viewpoints` (PCL's
/// viewpoint convention with one sensor per point; nothing when there are none; NaN normals
/// left). Normals estimated towards the cloud's frame origin are right for a scan in its own
/// frame; for a cloud whose origin is no sensor — a reconstruction in a frame of its own, a
/// merged model whose origin lies on the ground — they turn at random where the origin is
/// nearly in their plane, and the descriptors (FPFH, SHOT, spin images, 3DSC) depend on the
/// normals' sign.
void OrientTowardsNearest(const std::vector<Eigen::Vector3d>& points,
                          const std::vector<Eigen::Vector3d>& viewpoints,
                          std::vector<Eigen::Vector3d>* normals);

/// Kanade–Tomasi response per point: smallest eigenvalue of the mean of n·nᵀ over the
/// neighbours within `radius` (PCL HarrisKeypoint3D, method TOMASI, no suppression).
std::vector<float> TomasiResponse(const std::vector<Eigen::Vector3d>& points,
                                  const std::vector<Eigen::Vector3d>& normals, double radius);

/// Descriptors of the keypoints `keypoints` (indices into `points`) within `radius`, on the
/// surface `points`/`normals`. `valid[i]` is false where the descriptor is undefined (too few
/// neighbours, NaN). `up` (optional) is the spin-image axis for levelled clouds.
struct Descriptors {
  int dim = 0;
  std::vector<float> data;  // keypoints × dim
  std::vector<bool> valid;
};
Descriptors ComputeDescriptors(Descriptor descriptor, const std::vector<Eigen::Vector3d>& points,
                               const std::vector<Eigen::Vector3d>& normals,
                               const std::vector<int>& keypoints, double radius,
                               const Eigen::Vector3d* up);

/// FPFH of the keypoints (fpfh.cc): the descriptor of pcl::FPFHEstimation (33 bins; the
/// same pair features, weights and normalisation), computed on the nanoflann index with
/// 2 OpenMP threads. ComputeDescriptors(kFpfh, …) uses it.
Descriptors ComputeFpfh(const std::vector<Eigen::Vector3d>& points,
                        const std::vector<Eigen::Vector3d>& normals,
                        const std::vector<int>& keypoints, double radius);

/// PCL's FPFHEstimationOMP on the same input: the reference ComputeFpfh is tested against.
Descriptors ComputeFpfhPcl(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector3d>& normals,
                           const std::vector<int>& keypoints, double radius);

}  // namespace mmba::registration::internal
