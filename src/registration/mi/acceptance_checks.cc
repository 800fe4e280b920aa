#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>

#include <glog/logging.h>

#include "mmba/core/logging.h"
#include "registration/mi/frames_registration.h"

// The acceptance checks of FramesRegistration that re-optimise or calibrate: restarts,
// independent halves, the calibrated covariance and the per-axis scans.
namespace mmba::registration::mi::internal {

// The restarts, in parallel, or their ends taken from the polish's last round when it ran
// these very restarts from this optimum (the same starts, level, tolerance and options).
RestartEnds FramesRegistration::RunRestarts() {
  const Vector6d offset = RestartStep(options);
  const int restart_level = std::min(options.restart_level, levels - 1);
  // The restarts stop where the main run stopped: at its finest tolerance.
  const double tolerance =
      options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
  const std::vector<Vector6d> starts = RestartOffsets(options);
  RestartEnds out;
  std::vector<SearchResult>& restarts = out.ends;
  std::vector<double>& restart_values = out.values;
  std::vector<double>& restart_distances = out.distances;
  restarts.resize(options.restarts);
  restart_values.resize(options.restarts);
  restart_distances.assign(options.restarts, 0.0);
  const RegistrationOptions restart_options = RestartOptions(options);
  // Stopping at the first failure: a restart is not started once one before it (in index
  // order) is known to have ended too far; only the restarts up to the first that did are
  // reported, so the result does not depend on which thread finished first.
  std::atomic<int> first_far{options.restarts};
  std::vector<char> restart_run(options.restarts, 0);
  const bool polished = polish.ends.size() == static_cast<size_t>(options.restarts);
  out.polished = polished;
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
  out.reported = options.restarts;
  if (fail_fast && first_far.load() < options.restarts) out.reported = first_far.load() + 1;
  for (int k = 0; k < out.reported; ++k) {
    CHECK(restart_run[k]) << "restart " << k << " reported but not run";
  }
  return out;
}

// (3) Restarts: the fine levels re-optimised from points around the optimum must come back
// to it (a clear maximum draws them back; a plateau or a ridge leaves them elsewhere).
void FramesRegistration::Restarts() {
  int evaluations = 0;
  checks.restart_spread_px = 0;
  checks.restart_best_gain = -std::numeric_limits<double>::infinity();
  double restart_displacement2 = 0;
  size_t restart_displacement_count = 0;
  const RestartEnds ends = RunRestarts();
  const std::vector<SearchResult>& restarts = ends.ends;
  const int reported = ends.reported;
  for (int k = 0; k < reported; ++k) {
    // (Only the reported restarts' evaluations are counted: a later one that happened to
    // run on the other thread would make the count depend on the timing.)
    if (!ends.polished) evaluations += restarts[k].evaluations + 1;  // else the polish's
    const Rigid3d pose = ApplyCorrection(cam_from_lidar_start, restarts[k].x);
    const double distance = ends.distances[k];
    const double gain = ends.values[k] - result.metric_after.value;
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
  RestartImageSpread(ends);
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

// The restarts' spread over the whole image when the views are cuts of it, and their
// variance factor there.
void FramesRegistration::RestartImageSpread(const RestartEnds& ends) {
  if (!image_sample.empty() && options.restarts > 0) {
    double sum2 = 0;
    size_t count = 0;
    checks.image_restart_spread_px = 0;
    for (int k = 0; k < ends.reported; ++k) {
      const std::vector<double> d2 = ImageDisplacements2(
          image_sample, result.cam_from_lidar,
          ApplyCorrection(cam_from_lidar_start, ends.ends[k].x));
      checks.image_restart_spread_px =
          std::max(checks.image_restart_spread_px, MedianSqrtOf(d2));
      sum2 += std::accumulate(d2.begin(), d2.end(), 0.0);
      count += d2.size();
    }
    if (count > 0 && image_predicted_ms > 0) {
      image_factor_restarts = sum2 / count / image_predicted_ms;
    }
  }
}

// (4) Independent halves' re-optimisation, one half per thread; a half's evaluations split
// over two threads once the other half is done (CoreFreeForSplit). Stopping at the first
// failure: the second half is not started once the first is known to disagree, and is not
// reported when the first disagrees (as the restarts).
std::array<HalfEnd, 2> FramesRegistration::RunHalves(const std::array<std::vector<Frame>, 2>& halves,
                                                     int* reported) {
  const Vector6d offset = RestartStep(options);
  const double tolerance = options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
  RegistrationOptions half_options = options;
  half_options.point_samples = options.point_samples && options.point_samples_in_checks;
  half_options.pyramid_levels = std::min(options.pyramid_levels, options.split_level + 1);
  const int split_level = std::min(options.split_level, levels - 1);
  std::array<HalfEnd, 2> ends;
  std::atomic<bool> first_far{false};
  ParallelFor(2, options.threads, [&](int h) {
    if (fail_fast && h == 1 && first_far.load()) return;
    HalfEnd& end = ends[h];
    const FrameSetEvaluator half(halves[h], cam_from_lidar_start, half_options, &evaluator);
    const SearchResult r = Search(half, cam_from_lidar_start, x, split_level, split_level,
                                  2.0 * offset, tolerance, false, half_options, nullptr,
                                  "half " + std::to_string(h) + " ");
    end.x = r.x;
    end.evaluations = r.evaluations;
    const std::vector<FrameSetEvaluator::VisiblePoint> own =
        half.SampleVisiblePoints(result.cam_from_lidar, 2000);
    end.own_points = own.size();
    const Rigid3d pose = ApplyCorrection(cam_from_lidar_start, r.x);
    end.distance = half.MedianPixelDistance(own, result.cam_from_lidar, pose);
    for (double d2 : PixelDisplacements2(half, own, result.cam_from_lidar, pose)) {
      end.displacement2 += d2;
    }
    if (result.covariance_valid) {
      const std::vector<Eigen::Matrix<double, 2, 6>> own_jacobians =
          PixelJacobians(half, cam_from_lidar_start, x, own);
      for (double v : PredictedPixelVariances(own_jacobians, result.covariance_laplace)) {
        end.predicted2 += v;
      }
    }
    if (h == 0 && !(end.distance <= options.split_tolerance_px)) first_far = true;
  });
  *reported = fail_fast && first_far.load() ? 1 : 2;
  if (*reported == 1) {  // the second half, if it ran, is not reported
    ends[1].distance = 0;
    ends[1].displacement2 = 0;
    ends[1].predicted2 = 0;
  }
  return ends;
}

// The halves' spread over the whole image when the views are cuts of it.
void FramesRegistration::HalvesImageSpread(const std::array<HalfEnd, 2>& ends, int reported) {
  if (image_sample.empty()) return;
  double mean2 = 0;
  checks.image_split_spread_px = 0;
  for (int h = 0; h < reported; ++h) {
    const std::vector<double> d2 = ImageDisplacements2(image_sample, result.cam_from_lidar,
                                                       ApplyCorrection(cam_from_lidar_start, ends[h].x));
    checks.image_split_spread_px = std::max(checks.image_split_spread_px, MedianSqrtOf(d2));
    mean2 += 0.5 * MeanOf(d2);
  }
  if (image_predicted_ms > 0) image_factor_halves = mean2 / image_predicted_ms;
}

// (4) Independent halves: does each part of the data put its own points where the joint
// optimum puts them? And how far apart are they, against the Laplace covariance?
void FramesRegistration::Halves() {
  std::string split_kind;
  const std::array<std::vector<Frame>, 2> halves = SplitIntoHalves(frames, &split_kind);
  if (!options.split_check || halves[0].empty() || halves[1].empty()) return;
  int reported = 0;
  const std::array<HalfEnd, 2> ends = RunHalves(halves, &reported);
  HalvesImageSpread(ends, reported);
  checks.split_parts = reported;
  checks.split_kind = split_kind;
  checks.split_spread_px = std::max(ends[0].distance, ends[1].distance);
  const double predicted2 = ends[0].predicted2 + ends[1].predicted2;
  if (result.covariance_valid && predicted2 > 0) {
    checks.variance_factor_halves = (ends[0].displacement2 + ends[1].displacement2) / predicted2;
  }
  for (int h = 0; h < reported; ++h) {
    const HalfEnd& e = ends[h];
    spdlog::debug("MI half {} ({}): {:.2f} px from the optimum, correction [{:.3f} {:.3f} "
                  "{:.3f} {:.3f} {:.3f} {:.3f}], pixel rms {:.3f} px vs predicted {:.3f} px",
                  h, split_kind, e.distance, e.x[0], e.x[1], e.x[2], e.x[3], e.x[4], e.x[5],
                  std::sqrt(e.displacement2 / std::max<size_t>(1, e.own_points)),
                  std::sqrt(e.predicted2 / std::max<size_t>(1, e.own_points)));
  }
  if (!(checks.split_spread_px <= options.split_tolerance_px)) {
    failures.push_back("independent halves disagree (" + split_kind + "): one re-optimised "
                       "alone puts its own points " + Fixed(checks.split_spread_px, 2) +
                       " px from the joint optimum (tolerance " +
                       Fixed(options.split_tolerance_px, 2) + " px)");
  }
  clock.Mark("independent halves", ends[0].evaluations + (reported == 2 ? ends[1].evaluations : 0));
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


}  // namespace mmba::registration::mi::internal
