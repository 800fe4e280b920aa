#pragma once

// Verification of a pose hypothesis: overlap and normal agreement on the coarse level; on the
// fine level point-to-plane residuals against a crop of the target, free-space violations
// and the truncated-quadratic score.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mmba/geometry/point_index.h"
#include "mmba/io_cloud/point_cloud.h"
#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/free_space.h"
#include "registration/cloud/hypotheses.h"

namespace mmba::registration::internal {

/// Overlap and normal agreement of `src` (with normals) under `t` (hypothesis verification).
void Verify(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& src_n,
            const std::vector<Eigen::Vector3d>& tgt_n, const PointIndex& tgt_index,
            const Eigen::Matrix4d& t, double tau, Hypothesis* h);

/// The target around one hypothesis: the target points inside the box of the transformed
/// source (grown by `margin`), thinned to `budget`, with normals and a kd-tree. A large
/// reference (a whole LiDAR model against one object) is verified at its own resolution
/// where the source lies rather than thinned as a whole.
struct TargetCrop {
  Level level;
  std::unique_ptr<PointIndex> index;
};

/// The target points inside the box of `src` under `t`, grown by `margin`.
std::vector<size_t> CropIndices(const io::PointCloud& target,
                                const std::vector<Eigen::Vector3d>& src, const Eigen::Matrix4d& t,
                                double margin);

/// FNV-1a over the indices, a word at a time (a crop of a 24 M-point target holds millions):
/// with the count, the key of a crop's point set.
uint64_t HashIndices(const std::vector<size_t>& indices);

/// The target points `inside` (CropIndices), voxel-thinned to at most `budget` points (grid
/// at least `min_voxel`), with their index and spacing; the normals of a target that has them.
TargetCrop CropTarget(const io::PointCloud& target, bool use_normals,
                      const std::vector<size_t>& inside, size_t budget, double min_voxel);

/// Point-to-plane residuals of `src` under `t` against a target with normals: NaN where the
/// nearest target point is farther than `reach` (no overlap there). `agree[i]`: the normals
/// agree within 30° (Kim & Hilton's pseudo-symmetric failures, Sec. 5).
void FineResiduals(const std::vector<Eigen::Vector3d>& src,
                   const std::vector<Eigen::Vector3d>& src_n, const TargetCrop& target,
                   const Eigen::Matrix4d& t, double reach, std::vector<double>* residuals,
                   std::vector<bool>* agree);

/// Visibility test of a pose `t` (target_from_source): per source point, true where the pose
/// contradicts what a sensor observed as empty space.
///  - Target side: the registered source point has no target point within `near` and lies
///    nearer to a target sensor than the first target surface along that sensor's ray by more
///    than `margin` (the target's sensor saw through it).
///  - Source side: a target point of the crop, taken into the source frame, inside the
///    source's bounding box (the region the source describes; a cropped part says nothing
///    beyond its crop) and with no source point within `near`, lies nearer to a source sensor
///    than the first source surface along its ray; the violation is charged to the source
///    point nearest to where that ray meets the surface (so the count scales with the
///    target's points, as on the target side, not with the z-buffer's cells).
/// Points with a surface of the other cloud near them are never flagged (noise within `near`),
/// and space no sensor of the other cloud looked through is neutral (occluded or unobserved):
/// a partial overlap is not evidence against a pose, a point in observed free space is.
std::vector<bool> FreeSpaceViolations(const std::vector<Eigen::Vector3d>& src,
                                      const PointIndex& src_index,
                                      const internal::FreeSpace* src_free,
                                      const Eigen::AlignedBox3d& src_box,
                                      const TargetCrop& crop,
                                      const internal::FreeSpace* tgt_free,
                                      const Eigen::Matrix4d& t, double near, double margin);

/// Robust scale of the residuals: 1.4826 × median |r| (MAD about 0), NaN-free; +inf if none.
double RobustScale(const std::vector<double>& residuals);

/// Fine verification: inliers |r| < τ; score = Σ(1 − r²/τ²) over inliers with agreeing
/// normals, divided by all source points (a truncated quadratic, Black & Rangarajan 1996),
/// so a hypothesis a few σ off on part of the object loses against the one that fits it.
void ScoreFine(const std::vector<double>& residuals, const std::vector<bool>& agree, double tau,
               const std::vector<bool>& violates, Hypothesis* h);

}  // namespace mmba::registration::internal
