#include <algorithm>
#include <cmath>
#include <numeric>

#include "mmba/core/logging.h"
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

}  // namespace

namespace internal {

// The search of the main run. Without coarse starts: one coarse-to-fine Nelder–Mead from the
// start. With them (a multi-start global stage at the coarsest level, as the paper's
// single local search leaves a repeating façade or a paved ground on a secondary maximum):
// Nelder–Mead at the coarsest level from the start and from `coarse_starts` points spread over
// the box; the `coarse_candidates` best distinct coarse optima are each carried down to the
// finest Nelder–Mead level, and the one with the highest metric there wins (the coarse level
// may rank the basins wrongly: measured on the simulated panoramas, bench/RESULTS.md); then the
// gradient refinement of the winner.
SearchResult MainSearch(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                        const RegistrationOptions& options, StageClock* clock) {
  const Vector6d bound = BoundVector(options);
  const int levels = evaluator.levels();
  const int top = levels - 1;
  const int bottom = std::min(options.finest_nelder_mead_level, top);
  const Vector6d top_step = options.nelder_mead.initial_step.cwiseMin(bound);
  if (options.coarse_starts <= 0) {
    // Paths entering the pyramid at top, top − 1, ..., each with the full simplex (the
    // start's uncertainty does not depend on the level), ranked at `bottom`.
    const int paths = std::min(options.pyramid_paths, top - bottom + 1);
    if (paths <= 1) {
      return Search(evaluator, start, Vector6d::Zero(), top, bottom, top_step, -1.0,
                    options.gradient_refinement, options, clock, "");
    }
    std::vector<SearchResult> path(paths);
    std::vector<double> ranked(paths);
    auto run_path = [&](int k) {
      path[k] = Search(evaluator, start, Vector6d::Zero(), top - k, bottom, top_step, -1.0,
                       false, options, nullptr, "path " + std::to_string(k) + " ");
      ranked[k] = evaluator.Evaluate(ApplyCorrection(start, path[k].x), bottom).value;
    };
    int run = paths;      // paths ranked at `bottom`
    int entries = paths;  // entry levels searched
    int unranked_evaluations = 0, unranked_iterations = 0;
    if (options.pyramid_paths_adaptive && paths >= 3) {
      // The coarser entries first, each down to the level above the finest only; if they end
      // there within the restart tolerance of each other, the coarsest entry's path alone goes
      // on to the finest level (the single coarse-to-fine search, exactly). Otherwise a coarse
      // level may have led one astray: each goes on, and the finest entry (the dearest: the
      // full simplex at the finest level) is searched too.
      const int coarse_paths = paths - 1;
      const int above = bottom + 1;
      std::vector<SearchResult> upper(coarse_paths);
      ParallelFor(coarse_paths, options.threads, [&](int k) {
        upper[k] = Search(evaluator, start, Vector6d::Zero(), top - k, above, top_step, -1.0,
                          false, options, nullptr, "path " + std::to_string(k) + " ");
      });
      const Rigid3d first = ApplyCorrection(start, upper[0].x);
      const std::vector<FrameSetEvaluator::VisiblePoint> sample =
          evaluator.SampleVisiblePoints(first, 500);
      double spread = 0;
      for (int k = 1; k < coarse_paths; ++k) {
        spread = std::max(spread, evaluator.MedianPixelDistance(
                                      sample, first, ApplyCorrection(start, upper[k].x)));
      }
      spdlog::debug("MI paths: the coarser entries end {:.2f} px apart at level {}", spread,
                    above);
      const bool agree = spread <= options.restart_tolerance_px;
      run = agree ? 1 : paths;
      entries = agree ? coarse_paths : paths;
      for (int k = run; k < coarse_paths; ++k) {
        unranked_evaluations += upper[k].evaluations;
        unranked_iterations += upper[k].iterations;
      }
      ParallelFor(run, options.threads, [&](int i) {
        const int k = run - 1 - i;  // the finest entry first
        if (k == coarse_paths) {
          run_path(k);
          return;
        }
        // On from `above` to `bottom`: the same steps as one search from the entry level.
        const SearchResult down =
            Search(evaluator, start, upper[k].x, bottom, bottom,
                   top_step * std::pow(0.5, top - k - bottom), -1.0, false, options, nullptr,
                   "path " + std::to_string(k) + " ");
        path[k] = upper[k];
        path[k].x = down.x;
        path[k].value = down.value;
        path[k].iterations += down.iterations;
        path[k].evaluations += down.evaluations;
        ranked[k] = evaluator.Evaluate(ApplyCorrection(start, path[k].x), bottom).value;
      });
    } else {
      // The finest entry has the most work (the full simplex at the finest level): it starts
      // first, so that the coarser entries share the other thread (the same results in any
      // order: the paths are independent).
      ParallelFor(paths, options.threads, [&](int i) { run_path(paths - 1 - i); });
    }
    SearchResult result;
    int evaluations = unranked_evaluations, best = 0;
    result.iterations = unranked_iterations;
    for (int k = 0; k < run; ++k) {
      evaluations += path[k].evaluations + 1;
      result.iterations += path[k].iterations;
      spdlog::debug("MI path from level {}: metric {:.6f} at level {}, correction [{:.3f} {:.3f} "
                    "{:.3f} {:.3f} {:.3f} {:.3f}]",
                    top - k, ranked[k], bottom, path[k].x[0], path[k].x[1], path[k].x[2],
                    path[k].x[3], path[k].x[4], path[k].x[5]);
      if (ranked[k] > ranked[best]) best = k;
    }
    if (clock != nullptr) {
      clock->Mark("pyramid paths levels " + std::to_string(top) + ".." +
                      std::to_string(top - entries + 1) + " (best from level " +
                      std::to_string(top - best) + ")",
                  evaluations);
    }
    result.x = path[best].x;
    result.value = ranked[best];
    if (options.gradient_refinement) {
      const SearchResult g = Search(evaluator, start, result.x, -1, 0, top_step, -1.0, true,
                                    options, clock, "");
      result.x = g.x;
      result.iterations += g.iterations;
      result.evaluations += g.evaluations;
    }
    result.evaluations += evaluations;
    return result;
  }
  std::vector<Vector6d> starts = {Vector6d::Zero()};
  for (const Vector6d& x : SpreadStarts(options.coarse_starts, bound, options.coarse_start_spread)) {
    starts.push_back(x);
  }
  std::vector<SearchResult> coarse(starts.size());
  ParallelFor(static_cast<int>(starts.size()), options.threads, [&](int k) {
    coarse[k] = Search(evaluator, start, starts[k], top, top, top_step, -1.0, false, options,
                       nullptr, "coarse start " + std::to_string(k) + " ");
  });
  SearchResult result;
  int evaluations = 0;
  for (const SearchResult& r : coarse) {
    evaluations += r.evaluations;
    result.iterations += r.iterations;
  }
  if (clock != nullptr) {
    clock->Mark("coarse starts level " + std::to_string(top) + " (" +
                    std::to_string(starts.size()) + ")",
                evaluations);
  }
  // The start's own coarse optimum (the paper's search), then the best distinct other coarse
  // optima (distinct: apart by more than the coarse tolerance in some parameter). The
  // start's is always kept: the coarse level may rank a wrong basin above the true one
  // (measured: gate S1_upper, bench/RESULTS.md), the finest level ranks them.
  std::vector<int> order(coarse.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin() + 1, order.end(),
                   [&](int a, int b) { return coarse[a].value > coarse[b].value; });
  std::vector<Vector6d> candidates;
  for (int k : order) {
    if (static_cast<int>(candidates.size()) >= options.coarse_candidates) break;
    bool distinct = true;
    for (const Vector6d& c : candidates) {
      distinct = distinct && (coarse[k].x - c).cwiseAbs().maxCoeff() >
                                 options.nelder_mead.parameter_tolerance;
    }
    if (distinct) candidates.push_back(coarse[k].x);
  }
  std::vector<SearchResult> fine(candidates.size());
  if (top > bottom) {
    ParallelFor(static_cast<int>(candidates.size()), options.threads, [&](int k) {
      fine[k] = Search(evaluator, start, candidates[k], top - 1, bottom, 0.5 * top_step, -1.0,
                       false, options, nullptr, "candidate " + std::to_string(k) + " ");
    });
  } else {
    for (size_t k = 0; k < candidates.size(); ++k) {
      fine[k].x = candidates[k];
      fine[k].value = evaluator.Evaluate(ApplyCorrection(start, candidates[k]), bottom).value;
    }
  }
  evaluations = 0;
  int best = 0;
  for (size_t k = 0; k < fine.size(); ++k) {
    evaluations += fine[k].evaluations;
    result.iterations += fine[k].iterations;
    spdlog::debug("MI candidate {}: coarse [{:.3f} {:.3f} {:.3f} {:.3f} {:.3f} {:.3f}] -> metric "
                  "{:.6f} at level {}",
                  k, candidates[k][0], candidates[k][1], candidates[k][2], candidates[k][3],
                  candidates[k][4], candidates[k][5], fine[k].value, bottom);
    if (fine[k].value > fine[best].value) best = static_cast<int>(k);
  }
  if (clock != nullptr) {
    clock->Mark("candidates levels " + std::to_string(top - 1) + ".." + std::to_string(bottom) +
                    " (" + std::to_string(candidates.size()) + ")",
                evaluations);
  }
  result.x = fine[best].x;
  result.value = fine[best].value;
  if (options.gradient_refinement) {
    // No Nelder–Mead level (top < bottom): the gradient refinement alone.
    const SearchResult g = Search(evaluator, start, result.x, -1, 0, top_step, -1.0, true,
                                  options, clock, "");
    result.x = g.x;
    result.iterations += g.iterations;
  }
  return result;
}

}  // namespace internal

}  // namespace mmba::registration::mi
