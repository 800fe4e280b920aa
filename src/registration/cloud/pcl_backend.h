#pragma once

// The PCL part of the cloud registration behind a PCL-free interface: kd-trees, normals,
// the Kanade–Tomasi response and the four descriptors. Only pcl_backend.cc includes PCL.

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::registration::internal {

/// Indices of at most `max_count` of `n` items at an even stride (a deterministic subsample,
/// e.g. of the points an index is built over).
std::vector<size_t> StrideSample(size_t n, size_t max_count);

/// Exact kd-tree over 3-D points (nanoflann; float coordinates relative to io::LocalOrigin,
/// so that clouds in map-grid coordinates keep ~0.1 mm).
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
  /// bound: far queries (a wrong hypothesis puts the source off the target) cost little.
  bool NearestWithin(const Eigen::Vector3d& query, double max_squared_distance, int* index,
                     double* squared_distance) const;
  void KNearest(const Eigen::Vector3d& query, int k, std::vector<int>* indices,
                std::vector<float>* squared_distances) const;
  void Radius(const Eigen::Vector3d& query, double radius, std::vector<int>* indices) const;
  /// Points within `radius` (strictly) with their squared distances; nearest first when
  /// `sorted`, else in the tree's order.
  void RadiusWithDistances(const Eigen::Vector3d& query, double radius, std::vector<int>* indices,
                           std::vector<float>* squared_distances, bool sorted = true) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

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

/// Normals by PCA within `radius` (PCL NormalEstimationOMP), oriented towards `viewpoint`.
/// Points with too few neighbours get a NaN normal.
std::vector<Eigen::Vector3d> EstimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             double radius, const Eigen::Vector3d& viewpoint);

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
