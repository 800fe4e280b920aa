#include "registration/mi/search.h"

#include <time.h>

#include <cmath>

#include "mmba/core/logging.h"
#include "registration/mi/mi_internal.h"

namespace mmba::registration::mi {

namespace internal {

double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

void StageClock::Mark(const std::string& name, int evaluations) {
  StageStat stat;
  stat.name = name;
  stat.seconds = timer_.ElapsedSeconds();
  const double cpu = ProcessCpuSeconds();
  stat.cpu_seconds = cpu - cpu_start_;
  stat.evaluations = evaluations;
  result_->evaluations += evaluations;
  result_->stages.push_back(stat);
  spdlog::debug("MI stage {}: {} evaluations, {:.3f} s (cpu {:.3f} s)", name, stat.evaluations,
                stat.seconds, stat.cpu_seconds);
  timer_.Restart();
  cpu_start_ = cpu;
}

SearchResult Search(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    int top_level, int bottom_level, const Vector6d& top_step,
                    double finest_tolerance, bool gradient,
                    const RegistrationOptions& options, StageClock* clock,
                    const std::string& stage_prefix, const Vector6d* visibility_at) {
  SearchResult search;
  const Vector6d bound = BoundVector(options);
  const int levels = evaluator.levels();
  Vector6d x = x0;
  for (int level = top_level; level >= bottom_level; --level) {
    NelderMeadOptions nm = options.nelder_mead;
    nm.lower = -bound;
    nm.upper = bound;
    nm.initial_step = top_step * std::pow(0.5, top_level - level);
    // Tolerance: the paper's at the coarsest level, halved per finer level.
    nm.parameter_tolerance =
        options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1 - level);
    if (level == bottom_level && finest_tolerance > 0) nm.parameter_tolerance = finest_tolerance;
    // Point samples with the visibility frozen at the pass's start: within one Nelder–Mead
    // run the metric is one fixed function of the correction. When the run ends more than
    // options.sample_rebuild_px (pixels of the level) from where the visibility was
    // decided, it is decided again there and the run repeated from that point with half the
    // simplex (at most kPasses runs per level).
    constexpr int kPasses = 3;
    const bool sampled = options.point_samples && evaluator.UsesSamples(options.metric);
    NelderMeadResult r;
    int level_iterations = 0, level_evaluations = 0;
    for (int pass = 0; pass < kPasses; ++pass) {
      FrameSetEvaluator::SampleSet samples;
      if (sampled) {
        // The first pass at the top level may take its visibility elsewhere (the restarts:
        // at the optimum they are expected to return to).
        const Vector6d& at =
            pass == 0 && level == top_level && visibility_at != nullptr ? *visibility_at : x;
        samples = evaluator.MakeSampleSet(ApplyCorrection(start, at), level,
                                          options.SamplePerPoint(level));
      }
      r = MaximizeNelderMead(
          [&](const Vector6d& y) {
            return evaluator
                .Evaluate(ApplyCorrection(start, y), level, options.metric,
                          sampled ? &samples : nullptr)
                .value;
          },
          x, nm);
      level_iterations += r.iterations;
      level_evaluations += r.evaluations;
      x = r.x;
      if (!sampled ||
          !(evaluator.SampleSetDisplacementPx(samples, ApplyCorrection(start, r.x)) >
            options.sample_rebuild_px)) {
        break;
      }
      nm.initial_step = (0.5 * nm.initial_step).cwiseMax(2.0 * nm.parameter_tolerance);
    }
    r.iterations = level_iterations;
    r.evaluations = level_evaluations;
    spdlog::debug("MI {}level {}: {} iterations, metric {:.6f}, correction [{:.3f} {:.3f} {:.3f} "
                  "{:.3f} {:.3f} {:.3f}]",
                  stage_prefix, level, r.iterations, r.value, r.x[0], r.x[1], r.x[2], r.x[3],
                  r.x[4], r.x[5]);
    search.value = r.value;
    search.iterations += r.iterations;
    search.evaluations += r.evaluations;
    if (clock != nullptr) clock->Mark(stage_prefix + "nelder-mead level " + std::to_string(level),
                                      r.evaluations);
  }
  // Gradient refinement on the B-spline histogram (smooth in the pose): steepest ascent in
  // the scaled units with a backtracking step.
  if (gradient) {
    MetricOptions smooth = options.metric;
    smooth.smoothing = Smoothing::kBSpline;
    int evaluations = 0;
    // Each iteration's samples have the visibility of its own start x.
    const bool sampled = options.point_samples && evaluator.UsesSamples(smooth);
    FrameSetEvaluator::SampleSet samples;
    auto f = [&](const Vector6d& y) {
      ++evaluations;
      return evaluator
          .Evaluate(ApplyCorrection(start, y), 0, smooth, sampled ? &samples : nullptr)
          .value;
    };
    Vector6d h;
    h << 0.005, 0.005, 0.005, 0.02, 0.02, 0.02;
    double fx = 0;
    double alpha = 0.05;  // units per unit of normalised gradient
    for (int it = 0; it < options.gradient_max_iterations && alpha > 1e-3; ++it) {
      if (sampled || it == 0) {
        if (sampled) {
          samples = evaluator.MakeSampleSet(ApplyCorrection(start, x), 0,
                                            options.SamplePerPoint(0));
        }
        fx = f(x);
      }
      Eigen::Matrix<double, 12, 1> sides;
      ParallelFor(12, options.threads, [&](int k) {
        Vector6d y = x;
        y[k / 2] += (k % 2 == 0 ? 1.0 : -1.0) * h[k / 2];
        sides[k] = evaluator
                       .Evaluate(ApplyCorrection(start, y), 0, smooth,
                                 sampled ? &samples : nullptr)
                       .value;
      });
      evaluations += 12;
      Vector6d g;
      for (int i = 0; i < 6; ++i) g[i] = (sides[2 * i] - sides[2 * i + 1]) / (2 * h[i]);
      if (!(g.norm() > 0)) break;
      const Vector6d direction = g / g.cwiseAbs().maxCoeff();
      bool improved = false;
      while (alpha > 1e-3) {
        const Vector6d y = (x + alpha * direction).cwiseMax(-bound).cwiseMin(bound);
        const double fy = f(y);
        if (fy > fx) {
          x = y;
          fx = fy;
          improved = true;
          alpha *= 1.5;
          break;
        }
        alpha *= 0.5;
      }
      ++search.iterations;
      if (!improved) break;
    }
    search.evaluations += evaluations;
    if (clock != nullptr) clock->Mark(stage_prefix + "gradient refinement", evaluations);
  }
  search.x = x;
  return search;
}

}  // namespace internal

}  // namespace mmba::registration::mi
