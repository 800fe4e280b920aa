#include "mmba/registration/mi/mi_registration.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <glog/logging.h>

#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "registration/mi/frames_registration.h"
#include "registration/mi/mi_internal.h"
#include "registration/mi/search.h"

namespace mmba::registration::mi::internal {

namespace {

// The status and reason of a registration from its failed checks (none: "ok").
RegistrationResult Finish(RegistrationResult& result, const std::vector<std::string>& failures,
                          const Timer& timer, const FrameSetEvaluator& evaluator) {
  const AcceptanceChecks& checks = result.checks;
  result.trusted = failures.empty();
  if (result.trusted) {
    result.confidence_reason =
        "single clear peak: predicted sigma " + Fixed(checks.sigma_px, 2) + " px, " +
        std::to_string(checks.restarts_run) + " restarts within " +
        Fixed(checks.restart_spread_px, 2) + " px, MI " + Fixed(checks.mi_bits, 4) +
        " bits vs shuffled " + Fixed(checks.mi_shuffled_bits, 4) + " bits";
  } else {
    std::string joined;
    for (const std::string& f : failures) joined += (joined.empty() ? "" : "; ") + f;
    result.confidence_reason = joined;
  }
  result.status = result.trusted ? "ok" : "failed";
  result.reason = result.trusted ? "" : result.confidence_reason;
  result.runtime_seconds = timer.ElapsedSeconds();
  spdlog::debug("MI evaluator: render {:.3f} s, histogram {:.3f} s; {} sample sets, {} "
                "evaluations from samples {:.3f} s",
                evaluator.render_seconds(), evaluator.histogram_seconds(),
                evaluator.sample_sets_built(), evaluator.sample_evaluations(),
                evaluator.sample_seconds());
  return result;
}

// Why the inputs cannot be registered (invalid options, no frames, a frame without points,
// intensity or image contrast); empty when they can.
std::string InputProblem(const std::vector<Frame>& frames, const RegistrationOptions& options) {
  std::string error;
  if (!options.Check(&error)) return ("invalid options: " + error);
  if (frames.empty()) return ("no frames");
  for (const Frame& frame : frames) {
    if (frame.points == nullptr || frame.points->size() == 0) {
      return ("frame '" + frame.name + "': empty cloud");
    }
    if (options.render.representation == Representation::kIntensity &&
        !frame.points->has_intensity()) {
      return ("frame '" + frame.name +
                  "': intensity representation asked for but the cloud has no intensity");
    }
    for (const View& view : frame.views) {
      const ImageContrast contrast = MeasureContrast(view.image);
      if (contrast.fraction_dark + contrast.fraction_saturated > options.max_dark_or_saturated ||
          contrast.stdev < options.min_photo_stdev) {
        return ("frame '" + frame.name + "' view '" + view.name +
                    "': image without usable contrast (" +
                    Fixed(100 * contrast.fraction_dark, 1) + " % black, " +
                    Fixed(100 * contrast.fraction_saturated, 1) + " % saturated, stdev " +
                    Fixed(contrast.stdev, 1) + " grey levels): overexposed or black");
      }
    }
  }
  return "";
}

}  // namespace

RegistrationResult FramesRegistration::Fail(const std::string& reason) {
  result.status = "failed";
  result.reason = reason;
  result.runtime_seconds = timer.ElapsedSeconds();
  return result;
}

bool FramesRegistration::Decided(const char* stage) {
  if (!fail_fast || failures.empty()) return false;
  if (checks.stopped_after.empty()) {
    checks.stopped_after = stage;
    spdlog::debug("MI acceptance: failed at {}, the later checks not measured", stage);
  }
  return true;
}

RegistrationResult FramesRegistration::Finished() {
  return Finish(result, failures, timer, evaluator);
}

RegistrationResult FramesRegistration::Run() {
  const double covered = evaluator.CoveredFraction(cam_from_lidar_start);
  if (covered < options.min_covered_fraction) {
    return Fail("image does not overlap the cloud: " + Fixed(100 * covered, 2) +
                " % of the view pixels see LiDAR points at the start pose (minimum " +
                Fixed(100 * options.min_covered_fraction, 2) + " %)");
  }
  result.metric_before = evaluator.Evaluate(cam_from_lidar_start, 0);
  clock.Mark("start checks", 2);
  SearchAndPolish();
  SearchEndChecks();
  if (Decided("the search's end")) return Finished();
  LaplaceCovariance();
  PredictedSigma();
  if (Decided("the covariance")) return Finished();
  WholeImageSigma();
  ShuffledBaseline();
  if (Decided("the shuffled baseline")) return Finished();
  Restarts();
  if (Decided("the restarts")) return Finished();
  Halves();
  if (Decided("the independent halves")) return Finished();
  CalibrateCovariance();
  if (Decided("the calibrated covariance")) return Finished();
  AxisScans();
  return Finished();
}

// Optimisation: Nelder–Mead coarse to fine (paper defaults at the coarsest level), then
// gradient ascent on the smooth histogram, then the polish by the restarts.
void FramesRegistration::SearchAndPolish() {
  const SearchResult main_search = MainSearch(evaluator, cam_from_lidar_start, options, &clock);
  result.iterations += main_search.iterations;
  polish = Polish(evaluator, cam_from_lidar_start, main_search.x, options, &clock, &result.iterations);
  x = polish.x;
  result.correction = x;
  result.cam_from_lidar = ApplyCorrection(cam_from_lidar_start, x);
  result.metric_after = evaluator.Evaluate(result.cam_from_lidar, 0);
}

void FramesRegistration::SearchEndChecks() {
  // The optimum must not be below the start in the full-resolution metric: a search that left
  // the start's maximum at a coarse level and ended on a lower one at full resolution has not
  // found the maximum it reports (measured: a simulated photo registered from its true pose
  // ended 10 cm / 0.19° away, NMI 1.03070 → 1.03009, and every other check passed).
  // Compared in the metric the search maximises: with point samples each pose's own samples
  // (its visibility, options.sample_block_px's placement), which differ from the rendered
  // histogram of metric_before/after by the footprint the samples leave out.
  double search_before = result.metric_before.value, search_after = result.metric_after.value;
  if (options.point_samples && evaluator.UsesSamples(options.metric)) {
    for (const auto& [pose, value] :
         {std::pair<const Rigid3d*, double*>{&cam_from_lidar_start, &search_before},
          std::pair<const Rigid3d*, double*>{&result.cam_from_lidar, &search_after}}) {
      const FrameSetEvaluator::SampleSet own =
          evaluator.MakeSampleSet(*pose, 0, options.SamplePerPoint(0));
      *value = evaluator.Evaluate(*pose, 0, options.metric, &own).value;
    }
  }
  checks.below_start = search_after < search_before;
  if (checks.below_start) {
    failures.push_back("the search ended below the start: metric " + Fixed(search_before, 5) +
                       " at the start, " + Fixed(search_after, 5) + " at the optimum found");
  }
  if (const int i = OnBound(x, bound); i >= 0) {
    checks.on_bound = true;
    failures.push_back(std::string("optimum on the search bound of ") + ParameterName(i) + " (" +
                       Fixed(x[i]) + ")");
  }
}

void FramesRegistration::LaplaceCovariance() {
  // ---- Uncertainty: Laplace approximation. N·MI (nats) is the log-likelihood ratio of the
  // joint against independent intensities (Roche et al. 2000), so the covariance of the
  // correction is (N_eff · (−∇²MI))⁻¹ with N_eff the distinct LiDAR points seen at the level
  // of the fit.
  covariance_level = std::min(options.covariance_level, levels - 1);
  // Correlated pixels are not independent samples: N_eff from Bartlett's inflation factor,
  // never more than the distinct points seen.
  const double visible_points =
      static_cast<double>(evaluator.VisiblePoints(result.cam_from_lidar, covariance_level));
  double n_eff = visible_points;
  if (options.effective_sample_max_lag > 0) {
    n_eff = std::min(n_eff, evaluator.EffectiveSamples(result.cam_from_lidar, covariance_level,
                                                       options.effective_sample_max_lag,
                                                       &checks.sample_inflation));
  }
  checks.effective_samples = n_eff;
  int hessian_evaluations = 0;
  // The fit's samples: the visibility at the optimum (the fit spans ±0.08 m / ±0.4°); one
  // weighted sample per visible point (options.covariance_per_point_samples: the searches'
  // samples, the same histogram weights) or one per covered pixel (the rendered histogram's).
  FrameSetEvaluator::SampleSet covariance_samples;
  if (evaluator.UsesSamples(options.metric)) {
    covariance_samples = evaluator.MakeSampleSet(result.cam_from_lidar, covariance_level,
                                                 options.covariance_per_point_samples);
  }
  const Eigen::Matrix<double, 6, 6> hessian =
      MiHessian(evaluator, cam_from_lidar_start, x, options.metric, covariance_level,
                &covariance_samples, options.threads, &hessian_evaluations);
  const Eigen::Matrix<double, 6, 6> information = -n_eff * hessian;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(information);
  min_eigen = eigen.eigenvalues().minCoeff();
  max_eigen = eigen.eigenvalues().maxCoeff();
  if (max_eigen > 0) {
    // Directions the curvature does not determine (no positive curvature, or less
    // information than the search box itself holds) get the variance of a uniform
    // distribution over the box: the only knowledge left. If they move pixels, the σ check
    // below fails.
    Eigen::Matrix<double, 6, 6> box_variance = Eigen::Matrix<double, 6, 6>::Zero();
    for (int i = 0; i < 6; ++i) box_variance(i, i) = bound[i] * bound[i] / 3.0;
    const Eigen::Matrix<double, 6, 6>& v = eigen.eigenvectors();
    for (int k = 0; k < 6; ++k) {
      const Vector6d direction = v.col(k);
      const double box = direction.dot(box_variance * direction);
      double lambda = eigen.eigenvalues()[k];
      if (!(lambda > 0 && 1.0 / lambda < box)) {
        // The 28-term fit is noisiest in its weakest direction: measure the curvature along
        // that one direction alone, a parabola fitted to 13 samples over ±0.3 units.
        lambda = -n_eff * CurvatureAlong(evaluator, cam_from_lidar_start, x, direction,
                                         options.metric, covariance_level,
                                         &covariance_samples, options.threads,
                                         &hessian_evaluations);
      }
      double variance;
      if (lambda > 0 && 1.0 / lambda < box) {
        variance = 1.0 / lambda;
      } else {
        variance = box;
        ++checks.weak_directions;
      }
      result.covariance += variance * direction * direction.transpose();
    }
    result.covariance_valid = true;
  }
  {
    std::ostringstream diag;
    diag << "MI Hessian (nats/unit^2) diagonal " << hessian.diagonal().transpose()
         << "; information eigenvalues " << eigen.eigenvalues().transpose() << "; N_eff "
         << n_eff << " at level " << covariance_level << "; weakest direction "
         << eigen.eigenvectors().col(0).transpose();
    spdlog::debug("{}", diag.str());
  }
  clock.Mark("covariance", hessian_evaluations + 1);
}

void FramesRegistration::PredictedSigma() {
  // (1) Predicted pixel σ: is the maximum well conditioned at the accuracy asked for? (The
  // check itself is made after the split below, on the calibrated covariance.)
  sample =
      evaluator.SampleVisiblePoints(result.cam_from_lidar, 2000);
  result.covariance_laplace = result.covariance;
  if (!result.covariance_valid) {
    failures.push_back("no maximum: the metric's curvature is not negative in any direction "
                       "(information eigenvalues " + Fixed(min_eigen, 1) + " .. " +
                       Fixed(max_eigen, 1) + ")");
  } else {
    sample_jacobians = PixelJacobians(evaluator, cam_from_lidar_start, x, sample);
    std::vector<double> sigmas = PredictedPixelVariances(sample_jacobians, result.covariance);
    for (double v : sigmas) predicted_ms += v / sigmas.size();
    for (double& v : sigmas) v = std::sqrt(v);
    checks.sigma_px = Median(sigmas);
  }
  // The σ check (conditioning: does the curvature determine the pose to the accuracy
  // asked?) on the Laplace covariance; made here when the checks stop at the first failure,
  // after the halves when every check is measured (CalibrateCovariance).
  sigma_failed = result.covariance_valid && !(checks.sigma_px <= options.max_sigma_px);
  sigma_failure =
      "pose not determined to the accuracy asked: predicted pixel sigma " +
      Fixed(checks.sigma_px, 2) + " px > " + Fixed(options.max_sigma_px, 2) + " px (" +
      std::to_string(checks.weak_directions) + " of 6 directions without curvature)";
  if (fail_fast && sigma_failed) failures.push_back(sigma_failure);
}

void FramesRegistration::WholeImageSigma() {
  // The same over the whole image when the views are cuts of it.
  image_sample =
      SampleImagePoints(frames, result.cam_from_lidar, options.render, 2000);
  if (!image_sample.empty() && result.covariance_valid) {
    const std::vector<double> variances =
        ImagePredictedVariances(image_sample, cam_from_lidar_start, x, result.covariance);
    image_predicted_ms = MeanOf(variances);
    checks.image_sigma_px = MedianSqrtOf(variances);
  }
}

// (2) Significance of the MI against the shuffled-pairing baseline (same samples, photo
// values permuted: what MI a pose without any relation to the photo would show).
void FramesRegistration::ShuffledBaseline() {
  std::vector<double> shuffled;
  evaluator.EvaluateShuffled(result.cam_from_lidar, 0, options.shuffles, &checks.mi_bits,
                             &shuffled);
  double mean = 0, var = 0;
  for (double v : shuffled) mean += v;
  mean /= shuffled.size();
  for (double v : shuffled) var += (v - mean) * (v - mean);
  checks.mi_shuffled_bits = mean;
  checks.mi_shuffled_sd_bits = std::sqrt(var / (shuffled.size() - 1));
  const double gain = checks.mi_bits - mean;
  checks.mi_significance = gain / std::max(checks.mi_shuffled_sd_bits, 1e-9);
  if (!(gain >= options.min_mi_gain_bits) ||
      !(checks.mi_significance >= options.min_mi_significance)) {
    failures.push_back("MI not significant: " + Fixed(checks.mi_bits, 4) + " bits vs " +
                       Fixed(mean, 4) + " +- " + Fixed(checks.mi_shuffled_sd_bits, 4) +
                       " bits with shuffled pairings");
  }
  clock.Mark("shuffled baseline", 1);
}

}  // namespace mmba::registration::mi::internal

namespace mmba::registration::mi {

RegistrationResult RegisterFrames(const std::vector<Frame>& frames,
                                  const Rigid3d& cam_from_lidar_start,
                                  const RegistrationOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = cam_from_lidar_start;
  result.metric_kind = options.metric.kind;
  const std::string problem = internal::InputProblem(frames, options);
  if (!problem.empty()) {
    result.status = "failed";
    result.reason = problem;
    result.runtime_seconds = timer.ElapsedSeconds();
    return result;
  }
  internal::FramesRegistration registration(frames, cam_from_lidar_start, options, timer, &result);
  return registration.Run();
}

}  // namespace mmba::registration::mi
