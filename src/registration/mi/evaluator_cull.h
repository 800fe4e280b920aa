#pragma once

// FrameSetEvaluator's preparation of the points (private): the cull of the cloud to what can
// reach a view from inside the search bounds, and the render order of the kept points.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "mmba/registration/mi/lidar_image.h"

namespace mmba::registration::mi::internal {

/// The positions 0 .. points.size() − 1 in the order of the pixel each point falls on at
/// `cam_from_lidar` (the first view it projects into; view, row, column), the points that
/// fall on no view last; ties in the points' order (stable, deterministic).
std::vector<uint32_t> RenderOrder(const std::vector<Eigen::Vector3f>& points,
                                  const std::vector<View>& views, const Rigid3d& cam_from_lidar,
                                  const RenderOptions& render);

/// One pinhole view's cull test (FrameSetEvaluator's constructor): its transform of the
/// LiDAR frame in float, its intrinsics, the margins (rot_margin: tan of the rotation bound;
/// bound_translation_m) and the ranges (m).
struct PinholeCull {
  Eigen::Matrix3f rotation;
  Eigen::Vector3f translation;
  const sensors::Camera& camera;
  double focal, rot_margin, bound_translation_m, max_range, near_range;
};

/// The cull of candidates [begin, end) (indices into `all`, or the points themselves when
/// `candidates` is null) against one pinhole view: keep[k] |= the test of candidate k, with
/// the roundings of the general path (test StreetTest.PinholeCullEqualsTheGenericModel).
void CullPinholeBlocks(const PinholeCull& cull, const LidarPoints& all,
                       const std::vector<uint32_t>* candidates, size_t begin, size_t end,
                       char* keep);

}  // namespace mmba::registration::mi::internal
