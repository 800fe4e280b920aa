#pragma once

// How precisely the data fix the pose: the smallest displacement the fine verification
// tells from the chosen pose.

#include <vector>

#include <Eigen/Core>

#include "registration/cloud/fit_uncertainty.h"
#include "registration/cloud/verification.h"

namespace mmba::registration::internal {

/// PoseResolution's test at the resolution bound: the directions it did not tell apart there
/// (indices into its list of motions, and the motions themselves, 1 m RMS about the registered
/// source's centroid: the caller applies them with MotionAbout(δ·ξ, c)).
struct BoundTest {
  std::vector<size_t> open;
  std::vector<Vector6d> directions;
};

/// How precisely do the data fix the pose? The chosen pose is displaced by δ (RMS over the
/// source sample) along each of 12 directions — ± a translation along, and ± a rotation about
/// (through the centroid), each principal axis of the registered source — and ± along the
/// two least-constrained motions of the fit (FitUncertainty::weak_directions: a wall and the
/// ground leave the shift along both and the turn about their common line nearly free, a
/// motion that need not lie along any principal axis of the source, so that each axis probe
/// also moves points across the wall and is told apart). Each displaced pose's fine score is
/// compared with the chosen one by the paired block t statistic of ScoreSignificance. The
/// pose is resolved at δ when every displacement scores significantly worse (t >= t_min). A
/// pose that can slide, tilt or turn by δ without losing score is only known to δ: a thick,
/// noisy target (every displaced point still has a noise point near it), a planar or linear
/// overlap, or a pose off the score's maximum.
/// With `open_at_bound`, only the test at `bound` is made: the directions not told apart there
/// are returned in it (bound when none, else +inf). With `known_at_bound`, the test at `bound`
/// is not made again: it is that earlier result, for the same pose and arguments (the local
/// search's last test of the best it left is the verdict's first step).
/// Tested first at `bound` (the verdict); if resolved there, at bound/2, bound/4, bound/8 until
/// some direction is not (the reported resolution is the last resolved δ); if not, at 2·bound,
/// 4·bound, … and at `max_delta` for the unresolved directions only (a direction resolved at δ
/// stays resolved at larger δ: the score falls off around its maximum); +inf beyond.
double PoseResolution(const std::vector<Eigen::Vector3d>& src,
                      const std::vector<Eigen::Vector3d>& src_n, const TargetCrop& crop,
                      const Eigen::Matrix4d& t, const std::vector<double>& base_residuals,
                      const std::vector<bool>& base_agree, double reach, double tau, double block,
                      double bound, double max_delta, double t_min, bool principal_axes,
                      const std::vector<Vector6d>& extra_directions,
                      BoundTest* open_at_bound = nullptr,
                      const BoundTest* known_at_bound = nullptr);

}  // namespace mmba::registration::internal
