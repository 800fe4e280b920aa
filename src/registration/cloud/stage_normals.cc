// Stage of the cloud registration: the normals of the levels.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <sstream>

#include "registration/cloud/normal_orientation.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

namespace {

// Normals within R_n of a coarse level, oriented towards its cloud's sensors when they are
// given (internal::OrientTowardsNearest), else towards its origin (the scanner of a scan)
// and, with NormalOrientation::kConsistent(Turned), then made consistent over the neighbour
// graph (and the source's turned). Only the coarse level's signs matter: the fine
// verification and ICP use |n_s·n_t| and squared point-to-plane residuals.
void OrientLevelNormals(RegistrationContext& ctx, Level* level, bool is_source) {
  const CloudRegistrationOptions& options = ctx.options;
  if (level->normals.empty()) {
    const std::vector<Eigen::Vector3d>& sensors =
        is_source ? options.source_viewpoints : options.target_viewpoints;
    level->normals = internal::EstimateNormals(
        level->points, ctx.normal_radius, is_source ? ctx.source_viewpoint : ctx.target_viewpoint);
    internal::OrientTowardsNearest(level->points, sensors, &level->normals);
    if (sensors.empty() && (options.normal_orientation == NormalOrientation::kConsistent ||
                            options.normal_orientation == NormalOrientation::kConsistentTurned)) {
      const size_t turned = internal::OrientConsistently(level->points, 10, &level->normals);
      std::ostringstream note;
      note << (is_source ? "source" : "target") << " normals oriented consistently over the "
           << "neighbour graph: " << turned << " of " << level->points.size() << " turned";
      ctx.result.notes.push_back(note.str());
    }
  }
  if (options.normal_orientation == NormalOrientation::kConsistentTurned && is_source) {
    for (Eigen::Vector3d& n : level->normals) n = -n;
  }
}

// Why a coarse level of `before` < 10 points cannot be registered. Both clouds are thinned
// to the sparser one's spacing: a cloud that collapses to a few points there is much smaller
// than the other, as a cloud in millimetres against one in metres is (the normal radius is
// not the cause, and a larger one would not help).
std::string TooFewPointsReason(const RegistrationContext& ctx, bool is_source, size_t before) {
  auto extent = [](const std::vector<Eigen::Vector3d>& points) {
    Eigen::AlignedBox3d box;
    for (const Eigen::Vector3d& p : points) box.extend(p);
    return points.empty() ? 0.0 : box.diagonal().norm();
  };
  const Level& level = is_source ? ctx.src_coarse : ctx.tgt_coarse;
  const Level& other_level = is_source ? ctx.tgt_coarse : ctx.src_coarse;
  const double own = extent(level.points), other = extent(other_level.points);
  std::ostringstream s;
  s << (is_source ? "source" : "target") << " cloud thins to only " << before
    << " points at the common point spacing " << ctx.spacing << " m (the sparser cloud's)";
  if (other > 10 * own) {
    s << ": its extent is " << other / std::max(own, 1e-300) << "x smaller than the "
      << (is_source ? "target" : "source") << "'s (" << own << " against " << other
      << "): are they in different units (millimetres against metres)? Convert one, or give "
         "--scale-range";
  } else {
    s << ": too few points to register";
  }
  return s.str();
}

// The fine level's normals are needed only at its sample for the fine verification (up to
// 8000 points); their neighbourhoods are taken from the whole fine level.
void SampleFineSource(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  const Level& src_fine = ctx.src_fine;
  const std::vector<size_t> fine_idx = StrideSample(src_fine.points.size(), 8000);
  ctx.fine_src = Pick(src_fine.points, fine_idx);
  ctx.fine_src_n =
      src_fine.normals.empty()
          ? internal::EstimateNormals(
                src_fine.points,
                std::min(ctx.normal_radius, options.normal_radius_spacing * ctx.src_fine_spacing),
                ctx.source_viewpoint, &fine_idx)
          : Pick(src_fine.normals, fine_idx);
  if (src_fine.normals.empty()) {
    internal::OrientTowardsNearest(ctx.fine_src, options.source_viewpoints, &ctx.fine_src_n);
  }
}

}  // namespace

bool EstimateLevelNormals(RegistrationContext& ctx) {
  for (Level* level : {&ctx.src_coarse, &ctx.tgt_coarse}) {
    const bool is_source = level == &ctx.src_coarse;
    OrientLevelNormals(ctx, level, is_source);
    const size_t before = level->points.size();
    if (before < 10) return ctx.Fail(TooFewPointsReason(ctx, is_source, before));
    DropInvalidNormals(level);
    if (level->points.size() < before / 2 || level->points.size() < 10) {
      std::ostringstream s;
      s << "cloud too sparse for the normal radius " << ctx.normal_radius << " m: "
        << before - level->points.size() << " of " << before
        << " points have too few neighbours (give a larger --normal-radius)";
      return ctx.Fail(s.str());
    }
  }
  SampleFineSource(ctx);
  ctx.EndStage("normals");
  return true;
}

}  // namespace mmba::registration::internal
