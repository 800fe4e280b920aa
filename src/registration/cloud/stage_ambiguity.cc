// Stage of the cloud registration: the rivals of the best pose and the intensity test.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <cmath>

#include "mmba/core/logging.h"
#include "registration/cloud/score_significance.h"

namespace mmba::registration::internal {

void TestAmbiguity(RegistrationContext& ctx) {
  Hypothesis& best = ctx.best;
  std::vector<Finalist>& finalists = ctx.finalists;
  Hypothesis& fine_check = ctx.fine_check;
  std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  double& fine_tau = ctx.fine_tau;
  const CloudRegistrationOptions& options = ctx.options;
  std::vector<IntensityBlocks>& photo = ctx.photo;
  CloudRegistrationResult& result = ctx.result;
  std::vector<std::pair<size_t, double>>& rivals = ctx.rivals;
  const io::PointCloud& source = *ctx.source;
  double& support_radius = ctx.support_radius;
  const io::PointCloud& target = *ctx.target;
  // The ambiguity test's rivals: every distinct finalist scoring above max_ambiguity × the
  // best that the visibility test does not contradict, with the paired block t of the best
  // over it. The t statistic itself is geometric (without the −1 terms of the free-space
  // violations): one region where a sensor sees through a real surface — glass for a LiDAR,
  // which a camera reconstructs — would otherwise dominate the block variance.
  for (size_t k = 1; k < finalists.size(); ++k) {
    if (!(finalists[k].h.score > options.max_ambiguity * finalists[0].h.score)) continue;
    if (ctx.Contradicted(finalists[k].h)) continue;
    rivals.emplace_back(k, ScoreSignificance(fine_src, finalists[0].residuals, finalists[0].agree,
                                             finalists[k].residuals, finalists[k].agree, fine_tau,
                                             support_radius));
  }
  // Intensity test (intensity_test.h). Only where the geometry leaves a tie (some rival within
  // min_significance of the best) and both clouds carry a brightness: the intensity t of the
  // best over each rival (jackknifed over the same blocks) joins the geometric one
  // (internal::CombinedSignificance). It only ever adds evidence for the geometric best:
  // letting it pick a geometric runner-up instead was tried, and on a fresh cathedral (seed 4)
  // it picked a plane-proxy part's pose 23.6 m off over one 0.68 m off (a proxy's per-face
  // brightness can fit a wrong placement best).
  const bool tie = std::any_of(rivals.begin(), rivals.end(), [&](const auto& r) {
    return r.second < options.min_significance;
  });
  if (!options.paper_only && options.intensity_test && tie) {
    const internal::IntensityAgreement brightness(source, target, fine_src, support_radius);
    if (brightness.available()) {
      for (const Finalist& f : finalists) {
        std::vector<bool> inlier(f.residuals.size());
        for (size_t i = 0; i < inlier.size(); ++i) {
          inlier[i] =
              std::isfinite(f.residuals[i]) && std::abs(f.residuals[i]) < fine_tau && f.agree[i];
        }
        photo.push_back(brightness.Measure(f.h.transform, inlier));
      }
      result.intensity_tested = true;
      result.intensity_correlation = photo[0].AbsCorrelation();
    }
  }
  spdlog::debug("registration: fine τ {:.4g} m, {} distinct finalists", fine_tau, finalists.size());
  best = finalists.front().h;
  fine_check = best;
  ctx.EndStage("icp+verify fine");
}

}  // namespace mmba::registration::internal
