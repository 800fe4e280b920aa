#pragma once

// Closed-form and robust estimators on 3D correspondences, free of PCL.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace mmba::registration {

/// Least-squares rigid transform (no scale) mapping src[i] to dst[i]: Umeyama 1991, Eq. (39)–
/// (42) with c = 1. With `up` non-null the rotation is restricted to a rotation about *up
/// (levelled instruments): the yaw is the 2-D Procrustes angle of the horizontal components.
/// Needs >= 3 pairs (>= 2 with up). Returns target_from_source (4×4).
Eigen::Matrix4d EstimateRigid(const std::vector<Eigen::Vector3d>& src,
                              const std::vector<Eigen::Vector3d>& dst,
                              const Eigen::Vector3d* up = nullptr);

/// Options of MaxConsistentClique.
struct CliqueOptions {
  double tolerance_m = 0.01;      ///< | ‖s_i − s_j‖ − ‖d_i − d_j‖ | below this = consistent
  double min_length_m = 0.0;      ///< pairs closer than this in the source are not edges
  int64_t max_nodes_expanded = 20000;  ///< branch-and-bound budget; best found so far after
};

/// Largest set of correspondences whose pairwise source and target distances agree (rigid
/// motion preserves lengths): a maximum clique of the consistency graph, found by branch and
/// bound with greedy-colouring bounds (Tomita & Seki 2003) over a degeneracy order, stopping
/// after `max_nodes_expanded` (then the best clique found). Returns indices into src/dst.
std::vector<int> MaxConsistentClique(const std::vector<Eigen::Vector3d>& src,
                                     const std::vector<Eigen::Vector3d>& dst,
                                     const CliqueOptions& options, bool* exact = nullptr);

/// Angle of a rotation matrix in degrees.
double RotationAngleDeg(const Eigen::Matrix3d& rotation);

}  // namespace mmba::registration
