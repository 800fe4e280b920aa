// Stages of the cloud registration: keypoints, descriptors and their matches.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <exception>
#include <string>

#include "registration/cloud/keypoints.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

bool DetectKeypoints(RegistrationContext& ctx) {
  double& normal_radius = ctx.normal_radius;
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  Level& src_coarse = ctx.src_coarse;
  std::vector<int>& src_kp = ctx.src_kp;
  double& support_radius = ctx.support_radius;
  Level& tgt_coarse = ctx.tgt_coarse;
  std::vector<int>& tgt_kp = ctx.tgt_kp;
  // Keypoints.
  // The larger cloud gets keypoints in proportion to its coarse size (at most
  // min(4, larger_cloud_factor) × max_keypoints), so the part the smaller one overlaps is not
  // starved.
  const double size_ratio = static_cast<double>(std::max(src_coarse.points.size(), tgt_coarse.points.size())) /
                            static_cast<double>(std::max<size_t>(1, std::min(src_coarse.points.size(), tgt_coarse.points.size())));
  const int max_kp_large = static_cast<int>(options.max_keypoints *
                                            std::clamp(size_ratio, 1.0, std::min(4.0, options.larger_cloud_factor)));
  const bool src_is_large = src_coarse.points.size() > tgt_coarse.points.size();
  src_kp =
      SelectKeypoints(src_coarse, normal_radius, options,
                      src_is_large ? max_kp_large : options.max_keypoints, "source", &result.notes);
  tgt_kp =
      SelectKeypoints(tgt_coarse, normal_radius, options,
                      src_is_large ? options.max_keypoints : max_kp_large, "target", &result.notes);
  result.num_keypoints_source = src_kp.size();
  result.num_keypoints_target = tgt_kp.size();
  ctx.EndStage("keypoints");
  if (src_kp.size() < 3 || tgt_kp.size() < 3) {
    return ctx.Fail("too few keypoints (" + std::to_string(src_kp.size()) + " source, " +
                std::to_string(tgt_kp.size()) + " target; need 3)");
  }
  // Sparse for the support radius?
  {
    PointIndex tgt_coarse_index(tgt_coarse.points);
    std::vector<int> neighbours;
    std::vector<size_t> counts;
    for (size_t i = 0; i < tgt_kp.size(); i += std::max<size_t>(1, tgt_kp.size() / 50)) {
      tgt_coarse_index.Radius(tgt_coarse.points[tgt_kp[i]], support_radius, &neighbours);
      counts.push_back(neighbours.size());
    }
    std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
    if (counts[counts.size() / 2] < 16) {
      return ctx.Fail("cloud too sparse for the support radius " + std::to_string(support_radius) +
                  " m: median " + std::to_string(counts[counts.size() / 2]) +
                  " neighbours at the keypoints (need 16; give a larger --support-radius)");
    }
  }
  return true;
}

bool DescribeAndMatch(RegistrationContext& ctx) {
  std::vector<Matching>& matchings = ctx.matchings;
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  Level& src_coarse = ctx.src_coarse;
  std::vector<int>& src_kp = ctx.src_kp;
  double& support_radius = ctx.support_radius;
  Level& tgt_coarse = ctx.tgt_coarse;
  std::vector<int>& tgt_kp = ctx.tgt_kp;
  const Eigen::Vector3d*& up = ctx.up;
  // Descriptors and matching.
  std::vector<Descriptor> descriptors;
  if (options.descriptor == Descriptor::kAuto) {
    descriptors = {Descriptor::kFpfh, Descriptor::kShot};
  } else {
    descriptors = {options.descriptor};
  }
  up = options.gravity_aligned ? &options.up : nullptr;
  for (Descriptor d : descriptors) {
    Descriptors ds, dt;
    try {
      ds = internal::ComputeDescriptors(d, src_coarse.points, src_coarse.normals, src_kp,
                                        support_radius, up);
      dt = internal::ComputeDescriptors(d, tgt_coarse.points, tgt_coarse.normals, tgt_kp,
                                        support_radius, up);
    } catch (const std::exception& e) {  // PCL reports degenerate input by exceptions
      return ctx.Fail("descriptor " + DescriptorName(d) + " could not be computed: " + e.what());
    }
    ctx.EndStage("descriptors " + DescriptorName(d));
    matchings.push_back(MatchDescriptors(DescriptorName(d), src_coarse, tgt_coarse, src_kp,
                                         tgt_kp, ds, dt, options.sac_ia_randomness,
                                         options.max_correspondences));
    result.num_correspondences += matchings.back().best_pairs.size();
    ctx.EndStage("matching " + DescriptorName(d));
  }
  return true;
}

}  // namespace mmba::registration::internal
