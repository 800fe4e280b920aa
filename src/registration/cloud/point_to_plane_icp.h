#pragma once

// Point-to-plane ICP (Chen & Medioni 1991; linearised as Low 2004, Eq. 6–8) and its
// plane-to-plane variant (Segal, Haehnel & Thrun 2009).

#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/point_index.h"

namespace mmba::registration::internal {

/// Point-to-plane ICP (Chen & Medioni 1991; linearised as Low 2004, Eq. 6–8), coarse to fine
/// in the correspondence distance (from `start_distance` shrinking by 0.7 per iteration to
/// `end_distance`, metres); rotation about `up` only when levelled (`up` non-null). Each step
/// turns the source about its own centroid. Returns the refined `transform`
/// (target_from_source).
///
/// With `src_normals` the residual is plane-to-plane instead (Segal, Haehnel & Thrun 2009,
/// "Generalized-ICP", Eq. 2 with the plane-to-plane covariances of Sec. III-B): each pair's
/// 3-D difference d weighed by (R·C_s·Rᵀ + C_t)⁻¹, C = I − (1 − ε)·n·nᵀ (ε = 0.001) from each
/// side's normal. Both surfaces' orientations count: a simplified model (a plane proxy)
/// against a detailed scan is fitted along the model's planes, not along whatever detail
/// the scan's normals describe next to them.
Eigen::Matrix4d PointToPlaneIcp(const std::vector<Eigen::Vector3d>& src,
                                const std::vector<Eigen::Vector3d>& tgt,
                                const std::vector<Eigen::Vector3d>& tgt_normals,
                                const PointIndex& tgt_index, Eigen::Matrix4d transform,
                                double start_distance, double end_distance, int iterations,
                                const Eigen::Vector3d* up,
                                const std::vector<Eigen::Vector3d>* src_normals = nullptr);

}  // namespace mmba::registration::internal
