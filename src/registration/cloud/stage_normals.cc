// Stage of the cloud registration: the normals of the levels.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <sstream>

#include "registration/cloud/normal_orientation.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

bool EstimateLevelNormals(RegistrationContext& ctx) {
  std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  std::vector<Eigen::Vector3d>& fine_src_n = ctx.fine_src_n;
  double& normal_radius = ctx.normal_radius;
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  const Eigen::Vector3d& source_viewpoint = ctx.source_viewpoint;
  double& spacing = ctx.spacing;
  Level& src_coarse = ctx.src_coarse;
  Level& src_fine = ctx.src_fine;
  double& src_fine_spacing = ctx.src_fine_spacing;
  const Eigen::Vector3d& target_viewpoint = ctx.target_viewpoint;
  Level& tgt_coarse = ctx.tgt_coarse;
  // Normals within R_n, oriented towards each cloud's sensors when they are given
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
      return ctx.Fail(s.str());
    }
    DropInvalidNormals(level);
    if (level->points.size() < before / 2 || level->points.size() < 10) {
      std::ostringstream s;
      s << "cloud too sparse for the normal radius " << normal_radius << " m: "
        << before - level->points.size() << " of " << before
        << " points have too few neighbours (give a larger --normal-radius)";
      return ctx.Fail(s.str());
    }
  }
  // The fine level's normals are needed only at its sample for the fine verification (up to
  // 8000 points); their neighbourhoods are taken from the whole fine level.
  const std::vector<size_t> fine_idx = StrideSample(src_fine.points.size(), 8000);
  fine_src = Pick(src_fine.points, fine_idx);
  fine_src_n =
      src_fine.normals.empty()
          ? internal::EstimateNormals(
                src_fine.points,
                std::min(normal_radius, options.normal_radius_spacing * src_fine_spacing),
                source_viewpoint, &fine_idx)
          : Pick(src_fine.normals, fine_idx);
  if (src_fine.normals.empty()) {
    internal::OrientTowardsNearest(fine_src, options.source_viewpoints, &fine_src_n);
  }
  ctx.EndStage("normals");
  return true;
}

}  // namespace mmba::registration::internal
