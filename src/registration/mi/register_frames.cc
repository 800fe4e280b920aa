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
#include "registration/mi/mi_internal.h"
#include "registration/mi/search.h"

namespace mmba::registration::mi {

using internal::BoundVector;
using internal::CheckConfidence;
using internal::CurvatureAlong;
using internal::Fixed;
using internal::ImageDisplacements2;
using internal::ImagePoint;
using internal::ImagePredictedVariances;
using internal::MainSearch;
using internal::MeanOf;
using internal::Median;
using internal::MedianSqrtOf;
using internal::MiHessian;
using internal::OnBound;
using internal::ParallelFor;
using internal::PixelDisplacements2;
using internal::PixelJacobians;
using internal::Polish;
using internal::PolishResult;
using internal::PredictedPixelVariances;
using internal::RestartOffsets;
using internal::RestartOptions;
using internal::RestartStep;
using internal::SampleImagePoints;
using internal::Search;
using internal::SearchResult;
using internal::StageClock;

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

// One registration of a frame set (RegisterFrames): the search, then the acceptance checks in
// order, each a step below. Status "ok" needs every check to pass; by default the checks stop
// at the first failure (options.measure_all_checks): Decided() says the status is "failed"
// and the rest is not measured (the status, pose and an ok result's values are the same).
class FramesRegistration {
 public:
  FramesRegistration(const std::vector<Frame>& frames, const Rigid3d& cam_from_lidar_start,
                     const RegistrationOptions& options, const Timer& timer,
                     RegistrationResult* result)
      : frames(frames),
        cam_from_lidar_start(cam_from_lidar_start),
        options(options),
        timer(timer),
        result(*result),
        checks(result->checks),
        clock(result),
        evaluator(frames, cam_from_lidar_start, options),
        bound(BoundVector(options)),
        levels(evaluator.levels()),
        fail_fast(!options.measure_all_checks) {
    clock.Mark("prepare", 0);
  }
  RegistrationResult Run();

 private:
  RegistrationResult Fail(const std::string& reason);
  bool Decided(const char* stage);
  RegistrationResult Finished() { return Finish(result, failures, timer, evaluator); }
  void SearchAndPolish();
  void SearchEndChecks();
  void LaplaceCovariance();
  void PredictedSigma();
  void WholeImageSigma();
  void ShuffledBaseline();
  void Restarts();
  void Halves();
  void CalibrateCovariance();
  void AxisScans();

  const std::vector<Frame>& frames;
  const Rigid3d& cam_from_lidar_start;
  const RegistrationOptions& options;
  const Timer& timer;
  RegistrationResult& result;
  AcceptanceChecks& checks;
  StageClock clock;
  FrameSetEvaluator evaluator;
  const Vector6d bound;
  const int levels;
  const bool fail_fast;
  std::vector<std::string> failures;
  PolishResult polish;
  Vector6d x = Vector6d::Zero();  ///< the optimum's correction
  // The Laplace covariance.
  int covariance_level = 0;
  double min_eigen = 0, max_eigen = 0;  ///< of the information
  // The predicted pixel σ over a sample of the visible points.
  std::vector<FrameSetEvaluator::VisiblePoint> sample;
  double predicted_ms = 0;  ///< mean over the sample of trace(J Σ_L Jᵀ), px²
  /// The sample's pixel Jacobians at the optimum (also the covariance's pixel floor).
  std::vector<Eigen::Matrix<double, 2, 6>> sample_jacobians;
  bool sigma_failed = false;
  std::string sigma_failure;
  // The same over the whole image when the views are cuts of it.
  std::vector<ImagePoint> image_sample;
  double image_predicted_ms = 0;  ///< mean over the image sample of trace(J Σ_L Jᵀ), px²
  double image_factor_halves = std::numeric_limits<double>::quiet_NaN();
  double image_factor_restarts = std::numeric_limits<double>::quiet_NaN();
};

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

// (3) Restarts: the fine levels re-optimised from points around the optimum must come back
// to it (a clear maximum draws them back; a plateau or a ridge leaves them elsewhere).
void FramesRegistration::Restarts() {
  const Vector6d offset = RestartStep(options);
  const int restart_level = std::min(options.restart_level, levels - 1);
  // The restarts stop where the main run stopped: at its finest tolerance.
  const double tolerance =
      options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
  int evaluations = 0;
  checks.restart_spread_px = 0;
  checks.restart_best_gain = -std::numeric_limits<double>::infinity();
  const std::vector<Vector6d> starts = RestartOffsets(options);
  double restart_displacement2 = 0;
  size_t restart_displacement_count = 0;
  std::vector<SearchResult> restarts(options.restarts);
  std::vector<double> restart_values(options.restarts);
  const RegistrationOptions restart_options = RestartOptions(options);
  std::vector<double> restart_distances(options.restarts, 0.0);
  // Stopping at the first failure: a restart is not started once one before it (in index
  // order) is known to have ended too far; only the restarts up to the first that did are
  // reported, so the result does not depend on which thread finished first.
  std::atomic<int> first_far{options.restarts};
  std::vector<char> restart_run(options.restarts, 0);
  // The polish's last round ran these very restarts from this optimum (the same starts,
  // level, tolerance and options): their ends are taken, not searched again.
  const bool polished = polish.ends.size() == static_cast<size_t>(options.restarts);
  auto run_restart = [&](int k) {
    if (fail_fast && first_far.load() < k) return;
    if (polished) {
      restarts[k] = polish.ends[k];
      restart_values[k] = polish.values[k];
    } else {
      const Vector6d x0 = (x + starts[k]).cwiseMax(-bound).cwiseMin(bound);
      restarts[k] = Search(evaluator, cam_from_lidar_start, x0, restart_level, restart_level,
                           2.0 * offset, tolerance, false, restart_options, nullptr,
                           "restart " + std::to_string(k) + " ", &x);
      restart_values[k] =
          evaluator.Evaluate(ApplyCorrection(cam_from_lidar_start, restarts[k].x), 0).value;
    }
    restart_distances[k] = evaluator.MedianPixelDistance(
        sample, result.cam_from_lidar, ApplyCorrection(cam_from_lidar_start, restarts[k].x));
    restart_run[k] = 1;
    if (!(restart_distances[k] <= options.restart_tolerance_px)) {
      int seen = first_far.load();
      while (k < seen && !first_far.compare_exchange_weak(seen, k)) {
      }
    }
  };
  if (polished) {
    for (int k = 0; k < options.restarts; ++k) run_restart(k);
  } else {
    ParallelFor(options.restarts, options.threads, run_restart);
  }
  // The restarts reported: all, or (stopping at the first failure) those up to the first
  // that ended too far — each of which ran.
  int reported = options.restarts;
  if (fail_fast && first_far.load() < options.restarts) reported = first_far.load() + 1;
  for (int k = 0; k < reported; ++k) {
    // (Only the reported restarts' evaluations are counted: a later one that happened to
    // run on the other thread would make the count depend on the timing.)
    if (!polished) evaluations += restarts[k].evaluations + 1;  // else the polish's
    CHECK(restart_run[k]) << "restart " << k << " reported but not run";
    const Rigid3d pose = ApplyCorrection(cam_from_lidar_start, restarts[k].x);
    const double distance = restart_distances[k];
    const double gain = restart_values[k] - result.metric_after.value;
    checks.restart_spread_px = std::max(checks.restart_spread_px, distance);
    for (double d2 : PixelDisplacements2(evaluator, sample, result.cam_from_lidar, pose)) {
      restart_displacement2 += d2;
      ++restart_displacement_count;
    }
    checks.restart_best_gain = std::max(checks.restart_best_gain, gain);
    ++checks.restarts_run;
    spdlog::debug("MI restart {}: {:.2f} px from the optimum, metric {:+.6f}", k, distance,
                  gain);
  }
  if (!image_sample.empty() && options.restarts > 0) {
    double sum2 = 0;
    size_t count = 0;
    checks.image_restart_spread_px = 0;
    for (int k = 0; k < reported; ++k) {
      const std::vector<double> d2 = ImageDisplacements2(
          image_sample, result.cam_from_lidar,
          ApplyCorrection(cam_from_lidar_start, restarts[k].x));
      checks.image_restart_spread_px =
          std::max(checks.image_restart_spread_px, MedianSqrtOf(d2));
      sum2 += std::accumulate(d2.begin(), d2.end(), 0.0);
      count += d2.size();
    }
    if (count > 0 && image_predicted_ms > 0) {
      image_factor_restarts = sum2 / count / image_predicted_ms;
    }
  }
  if (restart_displacement_count > 0) {
    checks.restart_rms_px = std::sqrt(restart_displacement2 / restart_displacement_count);
    if (predicted_ms > 0) {
      checks.variance_factor_restarts =
          checks.restart_rms_px * checks.restart_rms_px / predicted_ms;
    }
  }
  if (checks.restarts_run > 0 && !(checks.restart_spread_px <= options.restart_tolerance_px)) {
    failures.push_back("restarts disagree: re-optimised from +-(" +
                       Fixed(options.restart_offset_m, 2) + " m, " +
                       Fixed(options.restart_offset_deg, 2) + " deg) around the optimum, one "
                       "ended " + Fixed(checks.restart_spread_px, 2) + " px away (tolerance " +
                       Fixed(options.restart_tolerance_px, 2) + " px)");
  }
  clock.Mark("restarts", evaluations);
}

// (4) Independent halves: does each part of the data put its own points where the joint
// optimum puts them? And how far apart are they, against the Laplace covariance?
void FramesRegistration::Halves() {
  std::string split_kind;
  const std::array<std::vector<Frame>, 2> halves = SplitIntoHalves(frames, &split_kind);
  if (options.split_check && !halves[0].empty() && !halves[1].empty()) {
    const Vector6d offset = RestartStep(options);
    const double tolerance =
        options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
    RegistrationOptions half_options = options;
    half_options.point_samples = options.point_samples && options.point_samples_in_checks;
    half_options.pyramid_levels = std::min(options.pyramid_levels, options.split_level + 1);
    const int split_level = std::min(options.split_level, levels - 1);
    std::array<double, 2> distance{}, displacement2{}, predicted2{};
    std::array<int, 2> half_evaluations{};
    std::array<size_t, 2> own_points{};
    std::array<Vector6d, 2> half_x;
    // One half per thread; a half's evaluations split over two threads once the other half
    // is done (CoreFreeForSplit).
    // Stopping at the first failure: the second half is not started once the first is
    // known to disagree, and is not reported when the first disagrees (as the restarts).
    std::atomic<bool> first_far{false};
    std::array<char, 2> half_run{0, 0};
    ParallelFor(2, options.threads, [&](int h) {
      if (fail_fast && h == 1 && first_far.load()) return;
      const FrameSetEvaluator half(halves[h], cam_from_lidar_start, half_options, &evaluator);
      const SearchResult r = Search(half, cam_from_lidar_start, x, split_level, split_level,
                                    2.0 * offset, tolerance, false, half_options, nullptr,
                                    "half " + std::to_string(h) + " ");
      half_x[h] = r.x;
      half_evaluations[h] = r.evaluations;
      const std::vector<FrameSetEvaluator::VisiblePoint> own =
          half.SampleVisiblePoints(result.cam_from_lidar, 2000);
      own_points[h] = own.size();
      const Rigid3d pose = ApplyCorrection(cam_from_lidar_start, r.x);
      distance[h] = half.MedianPixelDistance(own, result.cam_from_lidar, pose);
      for (double d2 : PixelDisplacements2(half, own, result.cam_from_lidar, pose)) {
        displacement2[h] += d2;
      }
      if (result.covariance_valid) {
        const std::vector<Eigen::Matrix<double, 2, 6>> own_jacobians =
            PixelJacobians(half, cam_from_lidar_start, x, own);
        for (double v : PredictedPixelVariances(own_jacobians, result.covariance_laplace)) {
          predicted2[h] += v;
        }
      }
      half_run[h] = 1;
      if (h == 0 && !(distance[0] <= options.split_tolerance_px)) first_far = true;
    });
    const int halves_reported = fail_fast && first_far.load() ? 1 : 2;
    if (halves_reported == 1) {  // the second half, if it ran, is not reported
      distance[1] = 0;
      displacement2[1] = 0;
      predicted2[1] = 0;
    }
    if (!image_sample.empty()) {
      double mean2 = 0;
      checks.image_split_spread_px = 0;
      for (int h = 0; h < halves_reported; ++h) {
        const std::vector<double> d2 =
            ImageDisplacements2(image_sample, result.cam_from_lidar,
                                ApplyCorrection(cam_from_lidar_start, half_x[h]));
        checks.image_split_spread_px = std::max(checks.image_split_spread_px, MedianSqrtOf(d2));
        mean2 += 0.5 * MeanOf(d2);
      }
      if (image_predicted_ms > 0) image_factor_halves = mean2 / image_predicted_ms;
    }
    checks.split_parts = halves_reported;
    checks.split_kind = split_kind;
    checks.split_spread_px = std::max(distance[0], distance[1]);
    if (result.covariance_valid && predicted2[0] + predicted2[1] > 0) {
      checks.variance_factor_halves =
          (displacement2[0] + displacement2[1]) / (predicted2[0] + predicted2[1]);
    }
    for (int h = 0; h < halves_reported; ++h) {
      spdlog::debug("MI half {} ({}): {:.2f} px from the optimum, correction [{:.3f} {:.3f} "
                    "{:.3f} {:.3f} {:.3f} {:.3f}], pixel rms {:.3f} px vs predicted {:.3f} px",
                    h, split_kind, distance[h], half_x[h][0], half_x[h][1], half_x[h][2],
                    half_x[h][3], half_x[h][4], half_x[h][5],
                    std::sqrt(displacement2[h] / std::max<size_t>(1, own_points[h])),
                    std::sqrt(predicted2[h] / std::max<size_t>(1, own_points[h])));
    }
    if (!(checks.split_spread_px <= options.split_tolerance_px)) {
      failures.push_back("independent halves disagree (" + split_kind + "): one re-optimised "
                         "alone puts its own points " + Fixed(checks.split_spread_px, 2) +
                         " px from the joint optimum (tolerance " +
                         Fixed(options.split_tolerance_px, 2) + " px)");
    }
    clock.Mark("independent halves",
               half_evaluations[0] + (halves_reported == 2 ? half_evaluations[1] : 0));
  }
}

void FramesRegistration::CalibrateCovariance() {
  // The σ check (measuring every check: here, after the halves); then the calibrated covariance
  // that is reported.
  if (result.covariance_valid) {
    if (!fail_fast && sigma_failed) failures.push_back(sigma_failure);
    checks.sigma_px_calibrated = checks.sigma_px;
    // The parts measured (the halves or the restarts may be switched off) add up.
    const bool halves_measured = std::isfinite(checks.variance_factor_halves);
    const bool restarts_measured = std::isfinite(checks.variance_factor_restarts);
    if (options.calibrate_covariance && (halves_measured || restarts_measured)) {
      checks.variance_factor =
          std::max(1.0, (halves_measured ? checks.variance_factor_halves : 0.0) +
                            (restarts_measured ? checks.variance_factor_restarts : 0.0));
      checks.covariance_factor = checks.variance_factor;
      result.covariance = checks.covariance_factor * result.covariance_laplace;
      checks.sigma_px_calibrated = checks.sigma_px * std::sqrt(checks.variance_factor);
      if (!(checks.sigma_px_calibrated <= options.max_calibrated_sigma_px)) {
        failures.push_back("the pose's own error estimate is too large: calibrated pixel sigma " +
                           Fixed(checks.sigma_px_calibrated, 2) + " px > " +
                           Fixed(options.max_calibrated_sigma_px, 2) + " px (the halves and the "
                           "restarts scatter " + Fixed(std::sqrt(checks.variance_factor), 1) +
                           "x more than the curvature predicts)");
      }
    }
  }
  // The calibrated σ over the whole image (the views' cuts of it).
  if (image_predicted_ms > 0) {
    double factor = 0;
    if (std::isfinite(image_factor_halves)) factor += image_factor_halves;
    if (std::isfinite(image_factor_restarts)) factor += image_factor_restarts;
    checks.image_variance_factor = options.calibrate_covariance ? std::max(1.0, factor) : 1.0;
    checks.image_sigma_px_calibrated =
        checks.image_sigma_px * std::sqrt(checks.image_variance_factor);
    // The reported covariance is the pose's, i.e. the whole image's: calibrated so that it
    // is not over-confident over the views' points nor over the whole image (one factor of
    // Σ_L estimated on each set; AcceptanceChecks::covariance_factor).
    if (options.calibrate_covariance && result.covariance_valid &&
        checks.image_variance_factor > checks.covariance_factor) {
      checks.covariance_factor = checks.image_variance_factor;
      result.covariance = checks.covariance_factor * result.covariance_laplace;
    }
    if (options.whole_image_checks &&
        !(checks.image_sigma_px_calibrated <= options.max_calibrated_sigma_px)) {
      failures.push_back("over the whole image the pose's own error estimate is too large: "
                         "calibrated pixel sigma " + Fixed(checks.image_sigma_px_calibrated, 3) +
                         " px > " + Fixed(options.max_calibrated_sigma_px, 2) + " px (restarts " +
                         Fixed(checks.image_restart_spread_px, 2) + " px, halves " +
                         Fixed(checks.image_split_spread_px, 2) + " px apart there)");
    }
  }
  // The reported covariance raised to the pixel-isotropic floor: at least as uncertain in
  // every direction as a pose error that moves the points by the calibrated mean squared
  // pixel distance. The Laplace shape alone is too narrow along the directions the MI
  // surface is sharpest in (bench/RESULTS.md, "MI priors on photos"). No status changes.
  if (options.calibrate_covariance && options.covariance_pixel_floor &&
      result.covariance_valid && predicted_ms > 0) {
    result.covariance = RaiseToPixelFloor(
        result.covariance, sample_jacobians,
        checks.covariance_factor * predicted_ms, &checks.covariance_floor_directions);
  }
}

// (5) Per-axis scans: flat or multi-peaked surfaces.
void FramesRegistration::AxisScans() {
  int evaluations = 0;
  const Vector6d weak = options.scan_weak_direction
                            ? WeaklyObservedDirection(sample_jacobians, bound)
                            : Vector6d::Zero();
  checks.scans_passed = CheckConfidence(evaluator, cam_from_lidar_start, x, weak, options,
                                        std::min(1, levels - 1), &checks.scans_reason,
                                        &evaluations);
  if (!checks.scans_passed) failures.push_back(checks.scans_reason);
  clock.Mark("axis scans", evaluations);
}

}  // namespace

RegistrationResult RegisterFrames(const std::vector<Frame>& frames,
                                  const Rigid3d& cam_from_lidar_start,
                                  const RegistrationOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = cam_from_lidar_start;
  result.metric_kind = options.metric.kind;
  const std::string problem = InputProblem(frames, options);
  if (!problem.empty()) {
    result.status = "failed";
    result.reason = problem;
    result.runtime_seconds = timer.ElapsedSeconds();
    return result;
  }
  FramesRegistration registration(frames, cam_from_lidar_start, options, timer, &result);
  return registration.Run();
}

}  // namespace mmba::registration::mi
