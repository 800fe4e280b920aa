#include <cmath>
#include <random>

#include "mmba/core/logging.h"
#include "registration/mi/mi_internal.h"
#include "registration/mi/search.h"

namespace mmba::registration::mi {

namespace internal {

// The restarts' offset per parameter: restart_offset_m on the shifts, restart_offset_deg on
// the angles.
Vector6d RestartStep(const RegistrationOptions& options) {
  return PerParameter(options.restart_offset_m, options.restart_offset_deg);
}

// The restarts' start points around an optimum (offset ±restart_offset per parameter,
// deterministic signs, in opposite pairs), as check (3) uses them.
std::vector<Vector6d> RestartOffsets(const RegistrationOptions& options) {
  const Vector6d offset = RestartStep(options);
  std::mt19937 rng(6);
  std::vector<Vector6d> starts;
  for (int k = 0; k < options.restarts; ++k) {
    Vector6d signs;
    for (int i = 0; i < 6; ++i) signs[i] = (rng() & 1u) ? 1.0 : -1.0;
    if (k % 2 == 1) signs = -starts.back().cwiseQuotient(offset).cwiseSign();  // opposite pair
    starts.push_back(signs.cwiseProduct(offset));
  }
  return starts;
}

// The restarts' options: the search's, with point samples only if the checks use them.
RegistrationOptions RestartOptions(const RegistrationOptions& options) {
  RegistrationOptions restart_options = options;
  restart_options.point_samples = options.point_samples && options.point_samples_in_checks;
  return restart_options;
}

// The first parameter of x within 10 % of its search bound (the acceptance's "optimum on the
// search bound"), or -1.
int OnBound(const Vector6d& x, const Vector6d& bound) {
  for (int i = 0; i < 6; ++i) {
    if (std::abs(x[i]) >= 0.9 * bound[i]) return i;
  }
  return -1;
}

// RegistrationOptions::polish_rounds: the restarts of check (3) run from the optimum x; the one
// ending highest in the full-resolution metric, if above x and beyond the restart tolerance, is
// refined at level 0 (and by the gradient when the main search was) and replaces x when it is
// still higher and not on the search bound. Not run from an optimum on the bound: the
// acceptance refuses it whatever the polish does, and the climb only runs on along the bound
// (measured: a cathedral rig panorama from 0.3 m / 2°, 12.65 → 17.20 px, 1.8 → 5.8 s CPU, failed
// both ways). `iterations` counts the refinements only (the restarts are the acceptance's work,
// which was not counted before either).
PolishResult Polish(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    const RegistrationOptions& options, StageClock* clock, int* iterations) {
  PolishResult out;
  out.x = x0;
  Vector6d& x = out.x;
  const Vector6d bound = BoundVector(options);
  if (options.polish_rounds <= 0 || options.restarts <= 0 || OnBound(x0, bound) >= 0) return out;
  const RegistrationOptions restart_options = RestartOptions(options);
  const int levels = evaluator.levels();
  const int restart_level = std::min(options.restart_level, levels - 1);
  const double tolerance = options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
  const Vector6d offset = RestartStep(options);
  const std::vector<Vector6d> starts = RestartOffsets(options);
  int evaluations = 0;
  for (int round = 0; round < options.polish_rounds; ++round) {
    const double current = evaluator.Evaluate(ApplyCorrection(start, x), 0).value;
    std::vector<SearchResult> ends(starts.size());
    std::vector<double> values(starts.size());
    ParallelFor(static_cast<int>(starts.size()), options.threads, [&](int k) {
      const Vector6d from = (x + starts[k]).cwiseMax(-bound).cwiseMin(bound);
      ends[k] = Search(evaluator, start, from, restart_level, restart_level, 2.0 * offset,
                       tolerance, false, restart_options, nullptr,
                       "restart " + std::to_string(k) + " ", &x);
      values[k] = evaluator.Evaluate(ApplyCorrection(start, ends[k].x), 0).value;
    });
    out.ends = ends;
    out.values = values;
    // Only a restart that the check would count as disagreeing (beyond its tolerance) moves
    // the optimum: one nearer is the same maximum, to within the tolerance.
    const Rigid3d pose = ApplyCorrection(start, x);
    const std::vector<FrameSetEvaluator::VisiblePoint> sample =
        evaluator.SampleVisiblePoints(pose, 2000);
    int best = -1;
    for (size_t k = 0; k < ends.size(); ++k) {
      evaluations += ends[k].evaluations + 1;
      if (!(values[k] > current) || (best >= 0 && values[k] <= values[best])) continue;
      const double distance =
          evaluator.MedianPixelDistance(sample, pose, ApplyCorrection(start, ends[k].x));
      if (distance > options.restart_tolerance_px) best = static_cast<int>(k);
    }
    evaluations += 1;
    if (best < 0) break;
    const SearchResult refined = Search(evaluator, start, ends[best].x, 0, 0, 2.0 * offset,
                                        tolerance, options.gradient_refinement, options, nullptr,
                                        "polish ");
    evaluations += refined.evaluations + 1;
    *iterations += refined.iterations;
    const double value = evaluator.Evaluate(ApplyCorrection(start, refined.x), 0).value;
    spdlog::debug("MI polish round {}: a restart ends {:+.6f} above the optimum; refined {:+.6f}",
                  round, values[best] - current, value - current);
    if (!(value > current) || OnBound(refined.x, bound) >= 0) break;
    x = refined.x;
    out.ends.clear();  // run about the previous optimum
    out.values.clear();
  }
  if (clock != nullptr) clock->Mark("polish", evaluations);
  return out;
}

}  // namespace internal

}  // namespace mmba::registration::mi
