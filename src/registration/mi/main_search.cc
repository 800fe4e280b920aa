#include <algorithm>
#include <cmath>
#include <numeric>

#include "mmba/core/logging.h"
#include "mmba/core/parallel_for.h"
#include "registration/mi/mi_internal.h"
#include "registration/mi/search.h"

namespace mmba::registration::mi {

namespace {

// Points spread over the box ±spread·bound for the coarse global stage: a Halton sequence
// (bases 2, 3, 5, 7, 11, 13; Halton 1960) mapped to [−1, 1]⁶, each point followed by its
// opposite so that the set is symmetric about the start. Deterministic.
std::vector<Vector6d> SpreadStarts(int count, const Vector6d& bound, double spread) {
  static const int kBases[6] = {2, 3, 5, 7, 11, 13};
  std::vector<Vector6d> starts;
  for (int k = 1; static_cast<int>(starts.size()) < count; ++k) {
    Vector6d u;
    for (int i = 0; i < 6; ++i) {
      double f = 1.0, r = 0.0;
      for (int n = k; n > 0; n /= kBases[i]) {
        f /= kBases[i];
        r += f * (n % kBases[i]);
      }
      u[i] = 2.0 * r - 1.0;
    }
    const Vector6d x = spread * u.cwiseProduct(bound);
    starts.push_back(x);
    if (static_cast<int>(starts.size()) < count) starts.push_back(-x);
  }
  return starts;
}

// The levels of the main run's Nelder–Mead: from `top` (the coarsest) down to `bottom` (the
// finest Nelder–Mead level), the simplex `top_step` at `top`, halved per finer level.
struct Levels {
  Vector6d bound;
  int top = 0;
  int bottom = 0;
  Vector6d top_step;
};

// The coarse-to-fine paths entering the pyramid at top, top − 1, …: each one's search and its
// metric at `bottom`; `run` of them are ranked there, `entries` entry levels were searched.
struct Paths {
  explicit Paths(int count) : path(count), ranked(count), run(count), entries(count) {}
  std::vector<internal::SearchResult> path;
  std::vector<double> ranked;
  int run;
  int entries;
  int unranked_evaluations = 0;  ///< of coarser entries searched but not carried on
  int unranked_iterations = 0;
};

using internal::BoundVector;
using internal::Search;
using internal::SearchResult;
using internal::StageClock;

// Path k: the search entering at top − k with the full simplex (the start's uncertainty does
// not depend on the level) down to `bottom`, ranked there.
void RunPath(const FrameSetEvaluator& evaluator, const Rigid3d& start, const RegistrationOptions& options,
             const Levels& l, int k, Paths* paths) {
  paths->path[k] = Search(evaluator, start, Vector6d::Zero(), l.top - k, l.bottom, l.top_step, -1.0, false, options,
                          nullptr, "path " + std::to_string(k) + " ");
  paths->ranked[k] = evaluator.Evaluate(ApplyCorrection(start, paths->path[k].x), l.bottom).value;
}

// The coarser entries first, each down to the level above the finest only; if they end there
// within the restart tolerance of each other, the coarsest entry's path alone goes on to the
// finest level (the single coarse-to-fine search, exactly). Otherwise a coarse level may have
// led one astray: each goes on, and the finest entry (the dearest: the full simplex at the
// finest level) is searched too.
void AdaptivePaths(const FrameSetEvaluator& evaluator, const Rigid3d& start, const RegistrationOptions& options,
                   const Levels& l, Paths* paths) {
  const int count = static_cast<int>(paths->path.size());
  const int coarse_paths = count - 1;
  const int above = l.bottom + 1;
  std::vector<SearchResult> upper(coarse_paths);
  ParallelFor(coarse_paths, options.threads, [&](int k) {
    upper[k] = Search(evaluator, start, Vector6d::Zero(), l.top - k, above, l.top_step, -1.0, false, options, nullptr,
                      "path " + std::to_string(k) + " ");
  });
  const Rigid3d first = ApplyCorrection(start, upper[0].x);
  const std::vector<FrameSetEvaluator::VisiblePoint> sample = evaluator.SampleVisiblePoints(first, 500);
  double spread = 0;
  for (int k = 1; k < coarse_paths; ++k) {
    spread = std::max(spread, evaluator.MedianPixelDistance(sample, first, ApplyCorrection(start, upper[k].x)));
  }
  spdlog::debug("MI paths: the coarser entries end {:.2f} px apart at level {}", spread, above);
  const bool agree = spread <= options.restart_tolerance_px;
  const int run = agree ? 1 : count;
  paths->run = run;
  paths->entries = agree ? coarse_paths : count;
  for (int k = run; k < coarse_paths; ++k) {
    paths->unranked_evaluations += upper[k].evaluations;
    paths->unranked_iterations += upper[k].iterations;
  }
  ParallelFor(run, options.threads, [&](int i) {
    const int k = run - 1 - i;  // the finest entry first
    if (k == coarse_paths) {
      RunPath(evaluator, start, options, l, k, paths);
      return;
    }
    // On from `above` to `bottom`: the same steps as one search from the entry level.
    const SearchResult down = Search(evaluator, start, upper[k].x, l.bottom, l.bottom,
                                     l.top_step * std::pow(0.5, l.top - k - l.bottom), -1.0, false, options, nullptr,
                                     "path " + std::to_string(k) + " ");
    SearchResult& path = paths->path[k];
    path = upper[k];
    path.x = down.x;
    path.value = down.value;
    path.iterations += down.iterations;
    path.evaluations += down.evaluations;
    paths->ranked[k] = evaluator.Evaluate(ApplyCorrection(start, path.x), l.bottom).value;
  });
}

// The best ranked path, the stage marked, then the gradient refinement.
SearchResult BestPath(const FrameSetEvaluator& evaluator, const Rigid3d& start, const RegistrationOptions& options,
                      const Levels& l, const Paths& paths, StageClock* clock) {
  SearchResult result;
  int evaluations = paths.unranked_evaluations, best = 0;
  result.iterations = paths.unranked_iterations;
  for (int k = 0; k < paths.run; ++k) {
    const SearchResult& path = paths.path[k];
    evaluations += path.evaluations + 1;
    result.iterations += path.iterations;
    spdlog::debug("MI path from level {}: metric {:.6f} at level {}, correction [{:.3f} {:.3f} "
                  "{:.3f} {:.3f} {:.3f} {:.3f}]",
                  l.top - k, paths.ranked[k], l.bottom, path.x[0], path.x[1], path.x[2], path.x[3], path.x[4],
                  path.x[5]);
    if (paths.ranked[k] > paths.ranked[best]) best = k;
  }
  if (clock != nullptr) {
    clock->Mark("pyramid paths levels " + std::to_string(l.top) + ".." + std::to_string(l.top - paths.entries + 1) +
                    " (best from level " + std::to_string(l.top - best) + ")",
                evaluations);
  }
  result.x = paths.path[best].x;
  result.value = paths.ranked[best];
  if (options.gradient_refinement) {
    const SearchResult g = Search(evaluator, start, result.x, -1, 0, l.top_step, -1.0, true, options, clock, "");
    result.x = g.x;
    result.iterations += g.iterations;
    result.evaluations += g.evaluations;
  }
  result.evaluations += evaluations;
  return result;
}

// Without coarse starts: the paths entering at top, top − 1, … (options.pyramid_paths of
// them), ranked at `bottom`; one path is the single coarse-to-fine search.
SearchResult PyramidPathsSearch(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                                const RegistrationOptions& options, const Levels& l, StageClock* clock) {
  const int count = std::min(options.pyramid_paths, l.top - l.bottom + 1);
  if (count <= 1) {
    return Search(evaluator, start, Vector6d::Zero(), l.top, l.bottom, l.top_step, -1.0, options.gradient_refinement,
                  options, clock, "");
  }
  Paths paths(count);
  if (options.pyramid_paths_adaptive && count >= 3) {
    AdaptivePaths(evaluator, start, options, l, &paths);
  } else {
    // The finest entry has the most work (the full simplex at the finest level): it starts
    // first, so that the coarser entries share the other thread (the same results in any
    // order: the paths are independent).
    ParallelFor(count, options.threads, [&](int i) { RunPath(evaluator, start, options, l, count - 1 - i, &paths); });
  }
  return BestPath(evaluator, start, options, l, paths, clock);
}

// The start's own coarse optimum (the paper's search), then the best distinct other coarse
// optima (distinct: apart by more than the coarse tolerance in some parameter), at most
// options.coarse_candidates. The start's is always kept: the coarse level may rank a wrong
// basin above the true one (bench/RESULTS.md "Pyramid paths as the default"), the finest level
// ranks them.
std::vector<Vector6d> DistinctCandidates(const std::vector<SearchResult>& coarse, const RegistrationOptions& options) {
  std::vector<int> order(coarse.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin() + 1, order.end(), [&](int a, int b) { return coarse[a].value > coarse[b].value; });
  std::vector<Vector6d> candidates;
  for (int k : order) {
    if (static_cast<int>(candidates.size()) >= options.coarse_candidates) break;
    bool distinct = true;
    for (const Vector6d& c : candidates) {
      distinct = distinct && (coarse[k].x - c).cwiseAbs().maxCoeff() > options.nelder_mead.parameter_tolerance;
    }
    if (distinct) candidates.push_back(coarse[k].x);
  }
  return candidates;
}

// Nelder–Mead at the coarsest level from the start and from the spread starts; the stage
// marked. `result` receives their iterations.
std::vector<SearchResult> CoarseStarts(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                                       const RegistrationOptions& options, const Levels& l, StageClock* clock,
                                       SearchResult* result) {
  std::vector<Vector6d> starts = {Vector6d::Zero()};
  for (const Vector6d& x : SpreadStarts(options.coarse_starts, l.bound, options.coarse_start_spread)) {
    starts.push_back(x);
  }
  std::vector<SearchResult> coarse(starts.size());
  ParallelFor(static_cast<int>(starts.size()), options.threads, [&](int k) {
    coarse[k] = Search(evaluator, start, starts[k], l.top, l.top, l.top_step, -1.0, false, options, nullptr,
                       "coarse start " + std::to_string(k) + " ");
  });
  int evaluations = 0;
  for (const SearchResult& r : coarse) {
    evaluations += r.evaluations;
    result->iterations += r.iterations;
  }
  if (clock != nullptr) {
    clock->Mark("coarse starts level " + std::to_string(l.top) + " (" + std::to_string(starts.size()) + ")",
                evaluations);
  }
  return coarse;
}

// With coarse starts: the candidates carried down to the finest Nelder–Mead level, the one
// with the highest metric there, then the gradient refinement of it.
SearchResult CoarseStartsSearch(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                                const RegistrationOptions& options, const Levels& l, StageClock* clock) {
  SearchResult result;
  const std::vector<Vector6d> candidates =
      DistinctCandidates(CoarseStarts(evaluator, start, options, l, clock, &result), options);
  std::vector<SearchResult> fine(candidates.size());
  if (l.top > l.bottom) {
    ParallelFor(static_cast<int>(candidates.size()), options.threads, [&](int k) {
      fine[k] = Search(evaluator, start, candidates[k], l.top - 1, l.bottom, 0.5 * l.top_step, -1.0, false, options,
                       nullptr, "candidate " + std::to_string(k) + " ");
    });
  } else {
    for (size_t k = 0; k < candidates.size(); ++k) {
      fine[k].x = candidates[k];
      fine[k].value = evaluator.Evaluate(ApplyCorrection(start, candidates[k]), l.bottom).value;
    }
  }
  int evaluations = 0;
  int best = 0;
  for (size_t k = 0; k < fine.size(); ++k) {
    evaluations += fine[k].evaluations;
    result.iterations += fine[k].iterations;
    spdlog::debug("MI candidate {}: coarse [{:.3f} {:.3f} {:.3f} {:.3f} {:.3f} {:.3f}] -> metric "
                  "{:.6f} at level {}",
                  k, candidates[k][0], candidates[k][1], candidates[k][2], candidates[k][3], candidates[k][4],
                  candidates[k][5], fine[k].value, l.bottom);
    if (fine[k].value > fine[best].value) best = static_cast<int>(k);
  }
  if (clock != nullptr) {
    clock->Mark("candidates levels " + std::to_string(l.top - 1) + ".." + std::to_string(l.bottom) + " (" +
                    std::to_string(candidates.size()) + ")",
                evaluations);
  }
  result.x = fine[best].x;
  result.value = fine[best].value;
  if (options.gradient_refinement) {
    // No Nelder–Mead level (top < bottom): the gradient refinement alone.
    const SearchResult g = Search(evaluator, start, result.x, -1, 0, l.top_step, -1.0, true, options, clock, "");
    result.x = g.x;
    result.iterations += g.iterations;
  }
  return result;
}

}  // namespace

namespace internal {

// The search of the main run. Without coarse starts: one coarse-to-fine Nelder–Mead from the
// start (or several paths, PyramidPathsSearch). With them (a multi-start global stage at the
// coarsest level, as the paper's single local search leaves a repeating façade or a paved
// ground on a secondary maximum): Nelder–Mead at the coarsest level from the start and from
// `coarse_starts` points spread over the box; the `coarse_candidates` best distinct coarse
// optima are each carried down to the finest Nelder–Mead level, and the one with the highest
// metric there wins (the coarse level may rank the basins wrongly: bench/RESULTS.md "Pyramid paths as the
// default"); then the gradient refinement of the winner.
SearchResult MainSearch(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                        const RegistrationOptions& options, StageClock* clock) {
  Levels l;
  l.bound = BoundVector(options);
  l.top = evaluator.levels() - 1;
  l.bottom = std::min(options.finest_nelder_mead_level, l.top);
  l.top_step = options.nelder_mead.initial_step.cwiseMin(l.bound);
  if (options.coarse_starts <= 0) return PyramidPathsSearch(evaluator, start, options, l, clock);
  return CoarseStartsSearch(evaluator, start, options, l, clock);
}

}  // namespace internal

}  // namespace mmba::registration::mi
