#pragma once

// The search of the MI registration (private): coarse-to-fine Nelder–Mead on the pyramid,
// the pyramid paths and coarse starts of the main run, the gradient refinement, and the
// polish by the restarts.

#include <string>
#include <vector>

#include "mmba/core/progress.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi::internal {

/// CPU time of the process, all threads (the comparable figure on a shared machine).
double ProcessCpuSeconds();

/// Records the time and evaluations of consecutive stages into a result.
class StageClock {
 public:
  explicit StageClock(RegistrationResult* result)
      : result_(result), cpu_start_(ProcessCpuSeconds()) {}
  /// Closes a stage that made `evaluations` metric evaluations (added to the result).
  void Mark(const std::string& name, int evaluations);

 private:
  RegistrationResult* result_;
  Timer timer_;
  double cpu_start_;
};

struct SearchResult {
  Vector6d x = Vector6d::Zero();
  double value = 0;
  int iterations = 0;
  int evaluations = 0;
};

/// Coarse-to-fine search from x0: Nelder–Mead at levels top_level .. bottom_level with the
/// simplex `top_step` at the top level, halved at each finer one, and the tolerances of the
/// main run at each level (`finest_tolerance` > 0 replaces the one of bottom_level); then
/// (optionally) gradient ascent on the B-spline histogram at level 0. With point samples, the
/// visibility of the first Nelder–Mead run is decided at `visibility_at` (default: x0).
/// `clock` (optional) records the stages, named with `stage_prefix`.
SearchResult Search(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    int top_level, int bottom_level, const Vector6d& top_step,
                    double finest_tolerance, bool gradient,
                    const RegistrationOptions& options, StageClock* clock,
                    const std::string& stage_prefix, const Vector6d* visibility_at = nullptr);

/// The search of the main run (RegistrationOptions: pyramid_paths, coarse_starts): see
/// main_search.cc.
SearchResult MainSearch(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                        const RegistrationOptions& options, StageClock* clock);

/// The restarts' offset per parameter: restart_offset_m on the shifts, restart_offset_deg on
/// the angles.
Vector6d RestartStep(const RegistrationOptions& options);
/// The restarts' start points around an optimum (offset ±restart_offset per parameter,
/// deterministic signs, in opposite pairs).
std::vector<Vector6d> RestartOffsets(const RegistrationOptions& options);
/// The restarts' options: the search's, with point samples only if the checks use them.
RegistrationOptions RestartOptions(const RegistrationOptions& options);
/// The first parameter of x within 10 % of its search bound (the acceptance's "optimum on
/// the search bound"), or -1.
int OnBound(const Vector6d& x, const Vector6d& bound);

struct PolishResult {
  Vector6d x = Vector6d::Zero();
  std::vector<SearchResult> ends;  ///< the last round's restarts, run from `x` (the acceptance's own)
  std::vector<double> values;      ///< their full-resolution metric
};
/// RegistrationOptions::polish_rounds: see polish.cc. `iterations` counts the refinements.
PolishResult Polish(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    const RegistrationOptions& options, StageClock* clock, int* iterations);

}  // namespace mmba::registration::mi::internal
