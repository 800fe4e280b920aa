// Stage of the cloud registration: the result's figures and the verdict ("ok", or failed with
// the reason).

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "mmba/core/logging.h"
#include "mmba/registration/cloud/robust_estimators.h"

namespace mmba::registration::internal {

namespace {

// A hypothesis as the result lists it: origin (with `stage` appended), pose and scores.
RegistrationHypothesis Reported(const Hypothesis& h, const std::string& stage) {
  RegistrationHypothesis r;
  r.origin = h.origin + stage;
  r.target_from_source = h.transform;
  r.fitness = h.fitness;
  r.inlier_rmse = h.rmse;
  r.normal_agreement = h.normal_agreement;
  r.score = h.score;
  return r;
}

}  // namespace

void ReportFinalists(RegistrationContext& ctx) {
  Hypothesis& best = ctx.best;
  std::vector<Finalist>& finalists = ctx.finalists;
  Hypothesis& fine_check = ctx.fine_check;
  double& fine_tau = ctx.fine_tau;
  std::vector<Hypothesis>& hypotheses = ctx.hypotheses;
  std::vector<IntensityBlocks>& photo = ctx.photo;
  CloudRegistrationResult& result = ctx.result;
  Level& src_fine = ctx.src_fine;
  bool& visibility = ctx.visibility;
  // Verdict.
  result.descriptor = best.descriptor;
  result.target_from_source = best.transform;
  result.fitness = fine_check.fitness;
  result.inlier_rmse = fine_check.rmse;
  result.normal_agreement = fine_check.normal_agreement;
  result.num_inliers = static_cast<size_t>(
      std::llround(fine_check.fitness * static_cast<double>(src_fine.points.size())));
  result.fine_inlier_distance_m = fine_tau;
  result.conflict = fine_check.conflict;
  result.visibility_tested = visibility;
  result.violation = fine_check.violation;
  for (size_t k = 0; k < finalists.size(); ++k) {
    const Hypothesis& h = finalists[k].h;
    RegistrationHypothesis r = Reported(h, " (fine)");
    if (!photo.empty()) r.intensity_correlation = photo[k].AbsCorrelation();
    r.conflict = h.conflict;
    r.violation = h.violation;
    result.hypotheses.push_back(r);
    spdlog::debug("registration: finalist {}: score {:.4g}, fitness {:.3g}, normals {:.3g}, "
                  "free-space violations {:.3g}",
                  h.origin, h.score, h.fitness, h.normal_agreement, h.violation);
  }
  for (const Hypothesis& h : hypotheses) {
    result.hypotheses.push_back(Reported(h, " (coarse)"));
  }
}

namespace {

// The distinct finalist the best pose beats by the fewest standard errors, with its t
// statistics (geometric, intensity).
struct Rival {
  const RegistrationHypothesis* runner = nullptr;
  double geometric_t = 0.0, intensity_t = 0.0;
};

// Ambiguity: the best pose must beat every distinct finalist that scores above
// max_ambiguity × its score by at least min_significance standard errors of the paired block
// score difference — the test PoseResolution applies to small displacements, applied here to
// the distinct poses found: a pseudo-symmetric turn, or a shift by one period of a repeated
// structure (the runner-up need not score close to the best: a noisy source shifted by one
// bay may score 70 % of the truth and still not be told from it). Sets the result's
// `significance` (the smallest of these t statistics, +inf when no distinct finalist is left),
// its intensity significance and its confidence (1 − runner-up score / best score).
Rival FindRival(RegistrationContext& ctx) {
  const std::vector<IntensityBlocks>& photo = ctx.photo;
  CloudRegistrationResult& result = ctx.result;
  Rival rival;
  double runner_up = 0.0;
  result.significance = std::numeric_limits<double>::infinity();
  if (ctx.finalists.size() > 1) runner_up = ctx.finalists[1].h.score;
  for (const auto& [k, tg] : ctx.rivals) {
    const double ti =
        photo.empty() ? 0.0 : internal::IntensityAgreement::Significance(photo[0], photo[k]);
    const double t = photo.empty() ? tg : internal::CombinedSignificance(tg, ti);
    if (t < result.significance) {
      result.significance = t;
      rival.runner = &result.hypotheses[k];
      rival.geometric_t = tg;
      rival.intensity_t = ti;
    }
  }
  if (!photo.empty() && rival.runner != nullptr) result.intensity_significance = rival.intensity_t;
  const double best_score = ctx.best.score;
  result.confidence = best_score > 0 ? std::clamp(1.0 - runner_up / best_score, 0.0, 1.0) : 0.0;
  return rival;
}

// The best pose fits: enough overlap, not contradicted by the sensors' free space, normals
// agreeing. False (the result failed with the reason) otherwise.
bool CheckFit(RegistrationContext& ctx) {
  const Hypothesis& best = ctx.best;
  const Hypothesis& fine_check = ctx.fine_check;
  const double fine_tau = ctx.fine_tau;
  const CloudRegistrationOptions& options = ctx.options;
  const bool visibility = ctx.visibility;
  std::ostringstream why;
  why << std::setprecision(3);
  // With the target's sensors known, a small overlap is not by itself evidence against the
  // pose: the source points off the target are checked against the target's free space
  // (they must lie where its sensors did not look). The pose is contradicted when the points
  // in observed free space exceed max_violation_ratio × the inliers, and then only a floor of
  // min_fitness_visible remains for the statistics. Without the target's sensors (a plane
  // proxy has none) the source's sensors test only the other direction — target points off
  // the source — and the overlap floor min_fitness stays: a stereo part moved 30 m along the
  // cathedral's bays onto the proxy (fitness 0.26) contradicts none of its stations' rays.
  const double fitness_floor = visibility && !options.target_viewpoints.empty()
                                   ? options.min_fitness_visible
                                   : options.min_fitness;
  if (fine_check.fitness < fitness_floor) {
    why << "best hypothesis (" << best.origin << ") makes only " << 100 * fine_check.fitness
        << "% of the source lie within " << fine_tau << " m of the target (need "
        << 100 * fitness_floor << "%): the clouds do not overlap, no hypothesis is right, or they overlap "
        << "less than that (--min-fitness lowers the bar, at the risk of a wrong pose on a partial fit)";
    return ctx.Fail(why.str());
  }
  if (ctx.Contradicted(fine_check)) {
    why << "visibility: " << 100 * fine_check.violation
        << "% of the source lies in space a sensor observed as empty (allowed: "
        << options.max_violation_ratio << " x the " << 100 * fine_check.fitness
        << "% inliers): the pose contradicts the data";
    return ctx.Fail(why.str());
  }
  if (!options.paper_only && fine_check.normal_agreement < options.min_normal_agreement) {
    why << "normals disagree: only " << 100 * fine_check.normal_agreement
        << "% of the inliers have matching normals (need "
        << 100 * options.min_normal_agreement << "%)";
    return ctx.Fail(why.str());
  }
  return true;
}

// The best pose is the only one: no distinct finalist within min_significance standard errors.
bool CheckAmbiguity(RegistrationContext& ctx, const Rival& rival) {
  const Hypothesis& best = ctx.best;
  const CloudRegistrationOptions& options = ctx.options;
  const CloudRegistrationResult& result = ctx.result;
  const RegistrationHypothesis* runner = rival.runner;
  const double best_score = best.score;
  std::ostringstream why;
  why << std::setprecision(3);
  if (!options.paper_only && runner != nullptr && result.significance < options.min_significance) {
    const Eigen::Matrix3d r = runner->target_from_source.topLeftCorner<3, 3>().transpose() *
                              best.transform.topLeftCorner<3, 3>();
    const double shift =
        (Apply(runner->target_from_source, ctx.centre) - Apply(best.transform, ctx.centre)).norm();
    why << "ambiguous: a different pose fits almost as well (scores " << best_score << " and "
        << runner->score << "; " << RotationAngleDeg(r) << "° and " << shift
        << " m apart at the source ctx.centre); the best is better by only " << result.significance
        << " standard errors (need " << options.min_significance << ")";
    if (!ctx.photo.empty()) {
      why << " with the intensity test (geometry " << rival.geometric_t << ", intensity "
          << rival.intensity_t << ")";
    }
    why << ": a (pseudo-)symmetric or repeated structure — give "
        << (options.gravity_aligned ? "" : "--gravity-aligned, ")
        << "more overlap or an approximate pose (--search-window)";
    return ctx.Fail(why.str());
  }
  return true;
}

// Scale agreement: a chosen pose that the coarse level ranked well below another distinct
// finalist is contradicted by the coarse evidence (fine ICP can leave a good coarse start on
// a dense, noisy cloud; the fine score then sees a symmetric twin fit better).
bool CheckScaleAgreement(RegistrationContext& ctx) {
  const Hypothesis& best = ctx.best;
  const std::vector<Finalist>& finalists = ctx.finalists;
  const CloudRegistrationOptions& options = ctx.options;
  const double best_score = best.score;
  std::ostringstream why;
  why << std::setprecision(3);
  if (!options.paper_only && options.min_coarse_agreement > 0 &&
      std::isfinite(finalists[0].coarse_score)) {
    size_t leader = 0;
    for (size_t k = 1; k < finalists.size(); ++k) {
      // A pose the visibility test contradicts is no evidence against the chosen one (as in
      // the ambiguity test).
      if (std::isfinite(finalists[k].coarse_score) && !ctx.Contradicted(finalists[k].h) &&
          !(finalists[k].coarse_score <= finalists[leader].coarse_score)) {
        leader = k;
      }
    }
    if (leader != 0 &&
        finalists[0].coarse_score < options.min_coarse_agreement * finalists[leader].coarse_score) {
      const Finalist& l = finalists[leader];
      const Eigen::Matrix3d r =
          l.h.transform.topLeftCorner<3, 3>().transpose() * best.transform.topLeftCorner<3, 3>();
      const double shift = (Apply(l.h.transform, ctx.centre) - Apply(best.transform, ctx.centre)).norm();
      why << "scales disagree: the coarse level prefers a pose " << RotationAngleDeg(r) << "° and "
          << shift << " m away (coarse scores " << l.coarse_score << " against "
          << finalists[0].coarse_score << " for this one), the fine level this one (fine scores "
          << best_score << " against " << l.h.score
          << "): a dense noisy cloud or a (pseudo-)symmetric structure — give an approximate "
             "pose (--search-window)";
      return ctx.Fail(why.str());
    }
  }
  return true;
}

// The pose is fixed: resolved to within max_resolution_spacing × the fine spacing along every
// motion, its least-constrained motion told apart within its bound, and (when checked) the
// fit's uncertainty small enough.
bool CheckResolution(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  const CloudRegistrationResult& result = ctx.result;
  const double axis_resolution = ctx.axis_resolution;
  const double support_radius = ctx.support_radius;
  const std::string& weak_motion = ctx.weak_motion;
  std::ostringstream why;
  why << std::setprecision(3);
  if (!options.paper_only &&
      !(axis_resolution <= options.max_resolution_spacing * result.fine_spacing_m)) {
    why << "pose not resolved: the fine verification cannot tell it from displacements of "
        << axis_resolution << " m RMS (need <= " << options.max_resolution_spacing
        << " x the fine spacing " << result.fine_spacing_m
        << " m); a noisy, planar or featureless overlap";
    return ctx.Fail(why.str());
  }
  // The fit's least-constrained motion must be told apart within its bound. Not at all up to
  // R_s: the data leave it free (or the pose is off the score's maximum along it). Only
  // beyond the bound: it is fixed by too little (a few edges or steps) to call the pose
  // known — on the simulated cathedral a proxy part slid along the facade was "ok"
  // 0.46–0.58 m off, resolved to 1.28–2.56 m (bench/RESULTS.md "The verification's thresholds").
  const double weak_bound = options.max_weak_motion_resolution_spacing * result.fine_spacing_m;
  if (!options.paper_only && !(result.weak_motion_resolution_m <= weak_bound)) {
    why << "pose not determined: the fit's least-constrained motion (" << weak_motion
        << ", " << options.max_resolution_spacing * result.fine_spacing_m
        << " m RMS over the source) is ";
    if (std::isfinite(result.weak_motion_resolution_m)) {
      why << "told apart by the fine verification only at " << result.weak_motion_resolution_m
          << " m RMS (need <= " << options.max_weak_motion_resolution_spacing
          << " x the fine spacing " << result.fine_spacing_m << " m = " << weak_bound
          << " m); the overlap fixes it by a few edges or steps only";
    } else {
      why << "not told apart by the fine verification at any displacement up to R_s = "
          << support_radius << " m; a planar or featureless overlap";
    }
    return ctx.Fail(why.str());
  }
  if (!options.paper_only && options.check_fit_uncertainty &&
      !(options.resolution_t * result.sigma_rms_m <=
                               options.max_resolution_spacing * result.fine_spacing_m)) {
    why << "pose not determined: the inliers of the fit leave " << result.weakest_motion
        << " (" << result.sigma_rms_m << " m RMS over the source; need " << options.resolution_t
        << " sigma <= " << options.max_resolution_spacing << " x the fine spacing "
        << result.fine_spacing_m << " m): a planar or featureless overlap";
    return ctx.Fail(why.str());
  }
  return true;
}

}  // namespace

bool Verdict(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  CloudRegistrationResult& result = ctx.result;
  const Rival rival = FindRival(ctx);
  if (!CheckFit(ctx)) return false;
  // The best pose fits; what follows asks whether it is the only one and whether it is fixed.
  result.best_pose_fits = true;
  if (!CheckAmbiguity(ctx, rival)) return false;
  if (!CheckScaleAgreement(ctx)) return false;
  if (!CheckResolution(ctx)) return false;
  if (options.paper_only) {
    // The paper's pipeline has no verification: its result is not claimed as "ok".
    result.status = "unverified";
    result.reason = "paper pipeline (best SAC-IA + ICP) without hypothesis verification";
    return true;
  }
  result.status = "ok";
  result.reason.clear();
  return true;
}

}  // namespace mmba::registration::internal
