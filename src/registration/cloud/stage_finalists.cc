// Stages of the cloud registration: the fine level — target crops, the finalists' fine ICP,
// their free-space test and scores.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "mmba/core/logging.h"
#include "registration/cloud/pcl_backend.h"
#include "registration/cloud/point_to_plane_icp.h"

namespace mmba::registration::internal {

bool PrepareFineLevel(RegistrationContext& ctx) {
  double& fine_end_spacing = ctx.fine_end_spacing;
  std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  std::unique_ptr<PointIndex>& fine_src_index = ctx.fine_src_index;
  std::vector<Eigen::Vector3d>& fine_src_n = ctx.fine_src_n;
  double& noise_sigma = ctx.noise_sigma;
  const CloudRegistrationOptions& options = ctx.options;
  const std::vector<Eigen::Vector3d>*& plane_to_plane_normals = ctx.plane_to_plane_normals;
  double& s_tgt = ctx.s_tgt;
  Eigen::AlignedBox3d& src_box = ctx.src_box;
  std::unique_ptr<FreeSpace>& src_free = ctx.src_free;
  const io::PointCloud& target = *ctx.target;
  std::unique_ptr<FreeSpace>& tgt_free = ctx.tgt_free;
  bool& visibility = ctx.visibility;
  // Fine ICP and verification of the best distinct coarse hypotheses (coarse-to-fine:
  // a loose coarse inlier distance cannot tell a shifted repetitive structure or a
  // pseudo-symmetric turn from the truth; the fine level can). The target is cropped to
  // each hypothesis' footprint and kept at up to max_points_icp points there.
  // Visibility: z-buffers of each cloud from its own sensors (given in its own frame), the
  // whole target's (an occluder outside a hypothesis' crop still hides what lies behind it)
  // and the fine source sample's.
  visibility = !options.paper_only &&
                          (!options.source_viewpoints.empty() || !options.target_viewpoints.empty());
  if (visibility) {
    fine_src_index = std::make_unique<PointIndex>(fine_src);
    for (const Eigen::Vector3d& p : fine_src) src_box.extend(p);
    if (!options.source_viewpoints.empty()) {
      src_free = std::make_unique<internal::FreeSpace>(fine_src, options.source_viewpoints,
                                                       MedianSpacing(fine_src, 20000));
    }
    if (!options.target_viewpoints.empty()) {
      tgt_free = std::make_unique<internal::FreeSpace>(target.points, options.target_viewpoints,
                                                       s_tgt);
    }
  }
  // The clouds' noise, once known: the smallest robust residual scale of the finalists
  // refined from the coarse hypotheses (set below; see fine_tau).
  noise_sigma = std::numeric_limits<double>::infinity();
  // The fine ICP: plane-to-plane from both clouds' normals, ending at its own distance, or
  // point-to-plane ending at the coarse levels' distance.
  plane_to_plane_normals =
      options.icp_plane_to_plane ? &fine_src_n : nullptr;
  fine_end_spacing = options.icp_plane_to_plane ? options.icp_plane_distance_spacing
                                                             : options.icp_distance_spacing;
  return true;
}

std::shared_ptr<TargetCrop> CropFor(RegistrationContext& ctx, const Eigen::Matrix4d& t) {
  std::vector<CachedCrop>& crop_cache = ctx.crop_cache;
  std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  double& normal_radius = ctx.normal_radius;
  const CloudRegistrationOptions& options = ctx.options;
  double& src_fine_spacing = ctx.src_fine_spacing;
  double& support_radius = ctx.support_radius;
  const io::PointCloud& target = *ctx.target;
  const Eigen::Vector3d& target_viewpoint = ctx.target_viewpoint;
  bool& tgt_normals = ctx.tgt_normals;
  std::shared_ptr<TargetCrop>& whole_target = ctx.whole_target;
  if (whole_target) return whole_target;
  const bool whole = target.size() <= static_cast<size_t>(options.max_points_icp);
  const std::vector<size_t> inside = CropIndices(
      target, fine_src, t, whole ? std::numeric_limits<double>::infinity() : support_radius);
  // Finalists near one pose often crop the same target points (a room the source spans:
  // eight finalists, five of them the same 98 k points). A crop depends on its points
  // alone, so those share one, normals included (0.2–0.3 s each there).
  const uint64_t key = HashIndices(inside);
  for (const CachedCrop& cached : crop_cache) {
    if (cached.count == inside.size() && cached.hash == key) return cached.crop;
  }
  auto c = std::make_shared<TargetCrop>(CropTarget(
      target, tgt_normals, inside, static_cast<size_t>(options.max_points_icp),
      0.5 * src_fine_spacing));
  // The crop's normals within a few of its spacings, and wider where that is a line, not a
  // surface. Near a scanner the nearest-neighbour spacing is the spacing along a scan line,
  // and a radius of a few of those spans one line or two (normals that disagreed with the
  // source's at the truth, and a fine ICP that slid along them: the full-preset gate's
  // stereo cloud onto its LiDAR model went to its 180° twin). So the spacing is at least
  // the area spacing over 2.2, its ratio to the nearest-neighbour spacing on a uniformly
  // random sample (1.5–1.7 on an even voxel-centroid sample: neither is changed; 3.3 next
  // to the simulated gate's scanner), and a normal whose neighbourhood is still a line is
  // estimated wider.
  if (c->level.normals.empty() && c->level.points.size() >= 10) {
    const double area_spacing = internal::AreaSpacing(c->level.points, normal_radius);
    const double radius =
        std::min(normal_radius,
                 options.normal_radius_spacing * std::max(c->level.spacing, area_spacing / 2.2));
    const size_t repaired = internal::SurfaceNormals(c->level.points, *c->index, radius,
                                                     normal_radius, target_viewpoint,
                                                     &c->level.normals);
    spdlog::debug("registration: target crop of {} points, spacing {:.4g} m, normals within "
                  "{:.4g} m, {} of them wider (a line at that radius)",
                  c->level.points.size(), c->level.spacing, radius, repaired);
  }
  if (whole) whole_target = c;
  crop_cache.push_back({inside.size(), key, c});
  return c;
}

bool RefineFinalist(RegistrationContext& ctx, Finalist* f, double icp_start) {
  double& fine_end_spacing = ctx.fine_end_spacing;
  std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  std::vector<Eigen::Vector3d>& fine_src_n = ctx.fine_src_n;
  double& noise_sigma = ctx.noise_sigma;
  double& normal_radius = ctx.normal_radius;
  const CloudRegistrationOptions& options = ctx.options;
  const std::vector<Eigen::Vector3d>*& plane_to_plane_normals = ctx.plane_to_plane_normals;
  double& src_fine_spacing = ctx.src_fine_spacing;
  const std::shared_ptr<TargetCrop> crop = CropFor(ctx, f->h.transform);
  const TargetCrop& c = *crop;
  if (c.level.points.size() < 10) return false;
  f->spacing = std::max(src_fine_spacing, c.level.spacing);
  if (options.icp) {
    f->h.transform = PointToPlaneIcp(fine_src, c.level.points, c.level.normals, *c.index,
                                     f->h.transform, icp_start,
                                     fine_end_spacing * f->spacing,
                                     options.icp_iterations, nullptr,  // free: levelled ≠ exact
                                     plane_to_plane_normals);
    f->icp_end = fine_end_spacing * f->spacing;
  }
  const double reach = std::min(normal_radius, options.normal_radius_spacing * f->spacing);
  FineResiduals(fine_src, fine_src_n, c, f->h.transform, reach, &f->residuals, &f->agree);
  f->sigma = RobustScale(f->residuals);
  // A noisy cloud (a stereo reconstruction's range noise can be several spacings): a final
  // correspondence distance below its noise keeps only the residuals that happen to be
  // small, and the pose drifts to wherever those are. Again with the distance at
  // icp_noise_sigmas × the robust residual scale (at most the reach). Once the noise is
  // known (a period shift or turn of the best pose), a larger scale is the pose's misfit,
  // not noise: the second pass then runs within the noise alone.
  const double noise_distance =
      std::min(reach, options.icp_noise_sigmas * std::min(f->sigma, noise_sigma));
  if (options.icp && !options.paper_only &&
      noise_distance > fine_end_spacing * f->spacing) {
    f->h.transform = PointToPlaneIcp(fine_src, c.level.points, c.level.normals, *c.index,
                                     f->h.transform, noise_distance, noise_distance,
                                     options.icp_iterations, nullptr, plane_to_plane_normals);
    f->icp_end = noise_distance;
    FineResiduals(fine_src, fine_src_n, c, f->h.transform, reach, &f->residuals, &f->agree);
    f->sigma = RobustScale(f->residuals);
  }
  f->crop = crop;
  return true;
}

std::vector<bool> Violations(RegistrationContext& ctx, const Finalist& f) {
  std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  std::unique_ptr<PointIndex>& fine_src_index = ctx.fine_src_index;
  double& fine_tau = ctx.fine_tau;
  Eigen::AlignedBox3d& src_box = ctx.src_box;
  std::unique_ptr<FreeSpace>& src_free = ctx.src_free;
  std::unique_ptr<FreeSpace>& tgt_free = ctx.tgt_free;
  bool& visibility = ctx.visibility;
  if (!visibility) return {};
  // A point counts as in free space only beyond the noise: two inlier distances (6 robust
  // σ of the best fit) in front of the first surface, and no point of the other cloud
  // within that distance.
  const double margin = 2.0 * fine_tau;
  return FreeSpaceViolations(fine_src, *fine_src_index, src_free.get(), src_box, *f.crop,
                             tgt_free.get(), f.h.transform, margin, margin);
}

void SortFinalists(RegistrationContext& ctx) {
  std::vector<Finalist>& finalists = ctx.finalists;
  std::stable_sort(finalists.begin(), finalists.end(),
                   [](const Finalist& a, const Finalist& b) { return a.h.score > b.h.score; });
}

bool SelectFinalists(RegistrationContext& ctx) {
  Eigen::Vector3d& centre = ctx.centre;
  std::vector<Finalist>& finalists = ctx.finalists;
  double& fine_spacing = ctx.fine_spacing;
  double& fine_tau = ctx.fine_tau;
  std::vector<Hypothesis>& hypotheses = ctx.hypotheses;
  double& noise_sigma = ctx.noise_sigma;
  const CloudRegistrationOptions& options = ctx.options;
  double& spacing = ctx.spacing;
  double& support_radius = ctx.support_radius;
  double& tau = ctx.tau;
  const size_t max_finalists = options.paper_only ? 1 : 4;
  for (const Hypothesis& h : hypotheses) {
    if (finalists.size() >= max_finalists) break;
    bool duplicate = false;
    for (const Finalist& f : finalists) {
      duplicate = duplicate || SameTransform(f.h.transform, h.transform, centre, 2.0, 2.0 * tau);
    }
    if (duplicate) continue;
    Finalist f;
    f.h = h;
    f.coarse_score = h.score;
    // Levelled hypotheses were turned about `up` only: the tilt left to the free fine ICP
    // needs a wider start.
    const double start = options.gravity_aligned ? support_radius / 2.0
                                                 : options.icp_distance_spacing * spacing;
    if (!RefineFinalist(ctx, &f, start) || !ctx.Inside(f.h.transform)) continue;
    finalists.push_back(std::move(f));
  }
  if (finalists.empty()) return ctx.Fail("no hypothesis puts the source onto the target");
  for (const Finalist& f : finalists) noise_sigma = std::min(noise_sigma, f.sigma);
  // One inlier threshold for all finalists: inlier_sigma × the smallest robust residual scale
  // (the best-fitting hypothesis sees the clouds' noise; a wrong one sees its misfit too),
  // at least a quarter of the fine spacing.
  fine_tau = std::numeric_limits<double>::infinity();
  for (const Finalist& f : finalists) {
    fine_tau = std::min(fine_tau, std::max(options.inlier_sigma * f.sigma, 0.25 * f.spacing));
  }
  if (!std::isfinite(fine_tau)) fine_tau = tau;
  fine_spacing = 0.0;
  for (Finalist& f : finalists) {
    f.violates = Violations(ctx, f);
    ScoreFine(f.residuals, f.agree, fine_tau, f.violates, &f.h);
    fine_spacing = std::max(fine_spacing, f.spacing);
  }
  SortFinalists(ctx);
  // Finalists that converged to the same transform are one hypothesis.
  // The one kept takes the better coarse score of the two (the scale-agreement test below).
  for (size_t i = 1; i < finalists.size();) {
    size_t same = i;
    for (size_t j = 0; j < i && same == i; ++j) {
      // Noisy clouds leave ICP in slightly different spots of one basin.
      if (SameTransform(finalists[i].h.transform, finalists[j].h.transform, centre, 10.0,
                        std::max(10.0 * fine_tau, 2.0 * fine_spacing))) {
        same = j;
      }
    }
    if (same < i) {
      finalists[same].coarse_score = std::fmax(finalists[same].coarse_score, finalists[i].coarse_score);
      finalists.erase(finalists.begin() + static_cast<long>(i));
    } else {
      ++i;
    }
  }
  return true;
}

}  // namespace mmba::registration::internal
