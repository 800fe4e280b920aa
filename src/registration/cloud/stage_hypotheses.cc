// Stages of the cloud registration: the hypotheses (SAC-IA, max-clique, a known approximate
// pose) and their coarse ICP and verification.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <memory>
#include <random>
#include <string>

#include "registration/cloud/point_to_plane_icp.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {

bool GenerateHypotheses(RegistrationContext& ctx) {
  Eigen::Vector3d& centre = ctx.centre;
  std::vector<Hypothesis>& hypotheses = ctx.hypotheses;
  std::vector<Matching>& matchings = ctx.matchings;
  double& normal_radius = ctx.normal_radius;
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  std::vector<Eigen::Vector3d>& score_sample = ctx.score_sample;
  double& spacing = ctx.spacing;
  Level& src_coarse = ctx.src_coarse;
  double& support_radius = ctx.support_radius;
  double& tau_coarse = ctx.tau_coarse;
  Level& tgt_coarse = ctx.tgt_coarse;
  // Hypotheses: SAC-IA and the maximum consistent clique.
  ctx.tgt_coarse_index = std::make_unique<PointIndex>(tgt_coarse.points);
  const PointIndex& tgt_coarse_index = *ctx.tgt_coarse_index;
  centre = Eigen::Vector3d::Zero();
  for (const auto& p : src_coarse.points) centre += p;
  centre /= static_cast<double>(src_coarse.points.size());
  const std::vector<size_t> score_idx = StrideSample(src_coarse.points.size(), 300);
  score_sample = Pick(src_coarse.points, score_idx);
  std::shuffle(score_sample.begin(), score_sample.end(), std::mt19937_64(options.seed + 1));
  std::mt19937_64 rng(options.seed);
  tau_coarse = normal_radius;
  HypothesisPool pool(static_cast<size_t>(options.num_hypotheses), centre, normal_radius);
  for (const Matching& m : matchings) {
    SacIa(m, score_sample, tgt_coarse_index, options, spacing, support_radius / 2.0, tau_coarse,
          &rng, &pool);
  }
  ctx.EndStage("sac-ia");
  hypotheses = pool.hypotheses();
  if (options.paper_only && hypotheses.size() > 1) hypotheses.resize(1);
  if (!options.paper_only && options.use_max_clique) {
    for (const Matching& m : matchings) {
      std::vector<Hypothesis> cliques;
      CliqueHypotheses(m, options, spacing, options.num_cliques, &cliques, &result.notes);
      for (Hypothesis& h : cliques) {
        h.cost = AlignmentCost(score_sample, tgt_coarse_index, h.transform, tau_coarse);
        hypotheses.push_back(h);
      }
    }
    ctx.EndStage("max-clique");
  }
  // A known approximate pose (search window): it is a hypothesis itself — descriptors may
  // find nothing on a poor overlap — and every hypothesis outside the window is dropped.
  if (options.search_window_m > 0.0 && !options.paper_only) {
    Hypothesis h;
    h.origin = "approximate pose";
    h.descriptor = matchings.empty() ? "" : matchings.front().descriptor;
    h.cost = AlignmentCost(score_sample, tgt_coarse_index, h.transform, tau_coarse);
    hypotheses.push_back(h);
  }
  if (hypotheses.empty()) {
    return ctx.Fail("no hypothesis: no consistent descriptor matches (" +
                std::to_string(result.num_correspondences) + " correspondences)");
  }
  return true;
}

bool RefineCoarseHypotheses(RegistrationContext& ctx) {
  std::vector<Hypothesis>& hypotheses = ctx.hypotheses;
  std::vector<Eigen::Vector3d>& icp_src = ctx.icp_src;
  std::vector<Eigen::Vector3d>& icp_src_n = ctx.icp_src_n;
  const CloudRegistrationOptions& options = ctx.options;
  double& spacing = ctx.spacing;
  Level& src_coarse = ctx.src_coarse;
  double& support_radius = ctx.support_radius;
  double& tau = ctx.tau;
  Level& tgt_coarse = ctx.tgt_coarse;
  const PointIndex& tgt_coarse_index = *ctx.tgt_coarse_index;
  const Eigen::Vector3d*& up = ctx.up;
  // Refine each hypothesis with ICP on the coarse level, then verify.
  const std::vector<size_t> icp_idx = StrideSample(src_coarse.points.size(), 1500);
  icp_src = Pick(src_coarse.points, icp_idx);
  icp_src_n = Pick(src_coarse.normals, icp_idx);
  tau = options.inlier_distance_spacing * spacing;
  for (Hypothesis& h : hypotheses) {
    if (options.icp) {
      h.transform = PointToPlaneIcp(icp_src, tgt_coarse.points, tgt_coarse.normals,
                                    tgt_coarse_index, h.transform, support_radius / 2.0,
                                    options.icp_distance_spacing * spacing,
                                    std::min(options.icp_iterations, 20), up);  // ranking only
    }
    Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, h.transform, tau, &h);
  }
  hypotheses.erase(std::remove_if(hypotheses.begin(), hypotheses.end(),
                                  [&](const Hypothesis& h) { return !ctx.Inside(h.transform); }),
                   hypotheses.end());
  if (hypotheses.empty()) return ctx.Fail("no hypothesis within the search window");
  std::stable_sort(hypotheses.begin(), hypotheses.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.score > b.score; });
  ctx.EndStage("icp+verify coarse");
  return true;
}

}  // namespace mmba::registration::internal
