// Stages of the cloud registration: the clouds' spacing and blunders, the levels.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <sstream>

#include "mmba/core/logging.h"

namespace mmba::registration::internal {

bool PrepareClouds(RegistrationContext& ctx) {
  io::PointCloud& kept_source = ctx.kept_source;
  io::PointCloud& kept_target = ctx.kept_target;
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  double& s_src = ctx.s_src;
  double& s_src_5000 = ctx.s_src_5000;
  double& s_tgt = ctx.s_tgt;
  const io::PointCloud& source_in = ctx.source_in;
  const io::PointCloud*& source_ptr = ctx.source;
  const io::PointCloud& target_in = ctx.target_in;
  const io::PointCloud*& target_ptr = ctx.target;
  for (const auto& [cloud, which] : {std::pair{&source_in, "source"}, std::pair{&target_in, "target"}}) {
    const std::string problem = CheckCloud(*cloud, which);
    if (!problem.empty()) return ctx.Fail(problem);
  }

  // Each cloud's spacing (median nearest-neighbour distance) and (options.remove_blunders)
  // its scattered blunders, from one kd-tree per cloud: on tens of millions of points each
  // tree takes seconds. The source's spacing on 20,000 and (for the fine level's budget
  // search below) on 5,000 samples.
  s_src = 0.0, s_src_5000 = 0.0, s_tgt = 0.0;
  source_ptr = &source_in;
  target_ptr = &target_in;
  for (const bool is_source : {true, false}) {
    const io::PointCloud& cloud = is_source ? source_in : target_in;
    if (cloud.size() < 2) continue;
    const PointIndex index(cloud.points);
    const std::vector<double> spacing = SpacingQuantiles(index, cloud.points, 20000, {0.5, 0.9});
    (is_source ? s_src : s_tgt) = spacing[0];
    if (is_source) s_src_5000 = MedianSpacing(index, cloud.points, 5000);
    if (options.paper_only || !options.remove_blunders) continue;
    const double cell = options.isolated_cell_spacing * spacing[1];
    if (!(cell > 0)) continue;
    // The surface test's constants (CloudRegistrationOptions::remove_blunders): 8 neighbours,
    // thickness 0.25, offset 0.3.
    const std::vector<char> isolated = OffTheSurface(
        index, cloud.points, IsolatedPoints(cloud.points, cell, options.isolated_min_neighbours),
        /*neighbours=*/8, /*max_thickness=*/0.25, /*max_offset=*/0.3);
    const size_t removed = static_cast<size_t>(std::count(isolated.begin(), isolated.end(), 1));
    if (removed == 0 || removed == cloud.size() ||
        static_cast<double>(removed) < options.isolated_min_fraction * static_cast<double>(cloud.size())) {
      continue;
    }
    (is_source ? kept_source : kept_target) = io::WithoutMarked(cloud, isolated);
    (is_source ? source_ptr : target_ptr) = is_source ? &kept_source : &kept_target;
    (is_source ? result.blunders_removed_source : result.blunders_removed_target) = removed;
    std::ostringstream note;
    note << "removed " << removed << " scattered point" << (removed == 1 ? "" : "s") << " of "
         << cloud.size() << " from the " << (is_source ? "source" : "target") << " (fewer than "
         << options.isolated_min_neighbours << " others in the 3 x 3 x 3 cells of " << cell
         << " m around, and off the surface of their 8 nearest)";
    result.notes.push_back(note.str());
  }
  return true;
}

bool BuildLevels(RegistrationContext& ctx) {
  double& normal_radius = ctx.normal_radius;
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  double& s_src = ctx.s_src;
  double& s_src_5000 = ctx.s_src_5000;
  double& s_tgt = ctx.s_tgt;
  const io::PointCloud& source = *ctx.source;
  double& spacing = ctx.spacing;
  Level& src_coarse = ctx.src_coarse;
  Level& src_fine = ctx.src_fine;
  double& src_fine_spacing = ctx.src_fine_spacing;
  double& support_radius = ctx.support_radius;
  const io::PointCloud& target = *ctx.target;
  Level& tgt_coarse = ctx.tgt_coarse;
  bool& tgt_normals = ctx.tgt_normals;
  // Levels: a common coarse voxel for the features (clouds of different density are
  // matched at the density of the sparser one; the larger cloud may keep
  // larger_cloud_factor × as many points), a finer one for ICP (the target is cropped to each
  // hypothesis there).
  if (s_src <= 0 || s_tgt <= 0) return ctx.Fail("all points of a cloud coincide (spacing 0)");
  const bool source_larger = source.size() > target.size();
  const size_t small_budget = static_cast<size_t>(options.max_points_features);
  const size_t large_budget =
      static_cast<size_t>(options.larger_cloud_factor * options.max_points_features);
  double coarse_voxel = std::max(s_src, s_tgt);
  {
    // Coarser by coarse_voxel_spacing while the smaller cloud keeps enough points to describe.
    const io::PointCloud& smaller = source_larger ? target : source;
    const double candidate = options.coarse_voxel_spacing * coarse_voxel;
    if (VoxelCount(smaller.points, candidate) >=
        static_cast<size_t>(options.min_points_coarse)) {
      coarse_voxel = candidate;
    }
  }
  coarse_voxel = std::max(coarse_voxel, VoxelForBudget(source, coarse_voxel,
                                                       source_larger ? large_budget : small_budget));
  coarse_voxel = std::max(coarse_voxel, VoxelForBudget(target, coarse_voxel,
                                                       source_larger ? small_budget : large_budget));
  const bool src_normals = options.use_existing_normals && source.has_normals();
  tgt_normals = options.use_existing_normals && target.has_normals();
  src_coarse = VoxelDownsample(source.points, src_normals ? source.normals : std::vector<Eigen::Vector3d>{}, coarse_voxel);
  tgt_coarse = VoxelDownsample(target.points, tgt_normals ? target.normals : std::vector<Eigen::Vector3d>{}, coarse_voxel);
  const double fine_voxel_src = VoxelForBudget(source, 0.0, options.max_points_icp, s_src_5000);
  src_fine = VoxelDownsample(source.points, src_normals ? source.normals : std::vector<Eigen::Vector3d>{}, fine_voxel_src);
  src_fine_spacing = MedianSpacing(src_fine.points, 20000);
  spacing = std::max(MedianSpacing(src_coarse.points, 20000),
                                  MedianSpacing(tgt_coarse.points, 20000));
  result.point_spacing_m = spacing;
  normal_radius = options.normal_radius_m > 0 ? options.normal_radius_m
                                                           : options.normal_radius_spacing * spacing;
  support_radius = options.support_radius_m > 0
                                    ? options.support_radius_m
                                    : options.support_radius_spacing * spacing;
  result.normal_radius_m = normal_radius;
  result.support_radius_m = support_radius;
  spdlog::debug("registration: spacing {:.4g} m (fine source {:.4g}), R_n {:.4g} m, R_s {:.4g} m, "
                "coarse {} / {} points, fine source {}",
                spacing, src_fine_spacing, normal_radius, support_radius, src_coarse.points.size(),
                tgt_coarse.points.size(), src_fine.points.size());
  ctx.EndStage("downsample");
  return true;
}

}  // namespace mmba::registration::internal
