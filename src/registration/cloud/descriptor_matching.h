#pragma once

// Correspondences between the keypoints of two clouds by their descriptors.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

/// The descriptor matches of one descriptor between the keypoints of two clouds.
struct Matching {
  std::string descriptor;
  std::vector<Eigen::Vector3d> src_kp, tgt_kp;     // valid keypoints
  std::vector<std::vector<int>> src_to_tgt;        // k nearest target keypoints per source
  std::vector<std::pair<int, int>> best_pairs;     // for the clique: nearest (and mutual first)
};

/// Matches the valid descriptors `ds` of the source keypoints `src_kp` (indices into
/// `src.points`) with `dt` of the target's: each source keypoint's `k` nearest target
/// descriptors (for SAC-IA), and up to `max_pairs` best pairs for the clique search — mutual
/// nearest neighbours first, then the one-way ones of either direction, by descriptor distance.
Matching MatchDescriptors(const std::string& name, const Level& src, const Level& tgt,
                          const std::vector<int>& src_kp, const std::vector<int>& tgt_kp,
                          const Descriptors& ds, const Descriptors& dt, int k,
                          size_t max_pairs);

}  // namespace mmba::registration::internal
