// Stages of the cloud registration: keypoints, descriptors and their matches.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <exception>
#include <string>

#include "registration/cloud/keypoints.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

bool DetectKeypoints(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  // Keypoints.
  // The larger cloud gets keypoints in proportion to its coarse size (at most
  // min(4, larger_cloud_factor) × max_keypoints), so the part the smaller one overlaps is not
  // starved.
  const size_t src_size = ctx.src_coarse.points.size(), tgt_size = ctx.tgt_coarse.points.size();
  const double size_ratio = static_cast<double>(std::max(src_size, tgt_size)) /
                            static_cast<double>(std::max<size_t>(1, std::min(src_size, tgt_size)));
  const int max_kp_large = static_cast<int>(options.max_keypoints *
                                            std::clamp(size_ratio, 1.0, std::min(4.0, options.larger_cloud_factor)));
  const bool src_is_large = src_size > tgt_size;
  ctx.src_kp = SelectKeypoints(ctx.src_coarse, ctx.normal_radius, options,
                               src_is_large ? max_kp_large : options.max_keypoints, "source",
                               &ctx.result.notes);
  ctx.tgt_kp = SelectKeypoints(ctx.tgt_coarse, ctx.normal_radius, options,
                               src_is_large ? options.max_keypoints : max_kp_large, "target",
                               &ctx.result.notes);
  ctx.result.num_keypoints_source = ctx.src_kp.size();
  ctx.result.num_keypoints_target = ctx.tgt_kp.size();
  ctx.EndStage("keypoints");
  if (ctx.src_kp.size() < 3 || ctx.tgt_kp.size() < 3) {
    return ctx.Fail("too few keypoints (" + std::to_string(ctx.src_kp.size()) + " source, " +
                std::to_string(ctx.tgt_kp.size()) + " target; need 3)");
  }
  // Sparse for the support radius?
  {
    PointIndex tgt_coarse_index(ctx.tgt_coarse.points);
    std::vector<int> neighbours;
    std::vector<size_t> counts;
    for (size_t i = 0; i < ctx.tgt_kp.size(); i += std::max<size_t>(1, ctx.tgt_kp.size() / 50)) {
      tgt_coarse_index.Radius(ctx.tgt_coarse.points[ctx.tgt_kp[i]], ctx.support_radius,
                              &neighbours);
      counts.push_back(neighbours.size());
    }
    std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
    if (counts[counts.size() / 2] < 16) {
      return ctx.Fail("cloud too sparse for the support radius " +
                      std::to_string(ctx.support_radius) + " m: median " +
                      std::to_string(counts[counts.size() / 2]) +
                      " neighbours at the keypoints (need 16; give a larger --support-radius)");
    }
  }
  return true;
}

bool DescribeAndMatch(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  // Descriptors and matching.
  std::vector<Descriptor> descriptors;
  if (options.descriptor == Descriptor::kAuto) {
    descriptors = {Descriptor::kFpfh, Descriptor::kShot};
  } else {
    descriptors = {options.descriptor};
  }
  ctx.up = options.gravity_aligned ? &options.up : nullptr;
  for (Descriptor d : descriptors) {
    Descriptors ds, dt;
    try {
      ds = internal::ComputeDescriptors(d, ctx.src_coarse.points, ctx.src_coarse.normals,
                                        ctx.src_kp, ctx.support_radius, ctx.up);
      dt = internal::ComputeDescriptors(d, ctx.tgt_coarse.points, ctx.tgt_coarse.normals,
                                        ctx.tgt_kp, ctx.support_radius, ctx.up);
    } catch (const std::exception& e) {  // PCL reports degenerate input by exceptions
      return ctx.Fail("descriptor " + DescriptorName(d) + " could not be computed: " + e.what());
    }
    ctx.EndStage("descriptors " + DescriptorName(d));
    ctx.matchings.push_back(MatchDescriptors(DescriptorName(d), ctx.src_coarse, ctx.tgt_coarse,
                                             ctx.src_kp, ctx.tgt_kp, ds, dt,
                                             options.sac_ia_randomness,
                                             options.max_correspondences));
    ctx.result.num_correspondences += ctx.matchings.back().best_pairs.size();
    ctx.EndStage("matching " + DescriptorName(d));
  }
  return true;
}

}  // namespace mmba::registration::internal
