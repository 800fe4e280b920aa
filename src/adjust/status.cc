// Status names of the adjustment and of its optional steps, as report.json and the CLI give them.
#include <cmath>
#include <string>

#include "internal.h"
#include "mmba/adjust/adjust.h"

namespace mmba::adjust {

std::string AdjustStatusName(AdjustStatus status) {
  switch (status) {
    case AdjustStatus::kConverged:
      return "converged";
    case AdjustStatus::kNoConvergence:
      return "no_convergence";
    case AdjustStatus::kFailed:
      break;
  }
  return "failed";
}

namespace internal {

std::string StepStatusText(StepStatus status, const std::string& reason) {
  switch (status) {
    case StepStatus::kOk:
      return "ok";
    case StepStatus::kAsGiven:
      return "as given";
    case StepStatus::kFailed:
      return "failed: " + reason;
    case StepStatus::kNotAttempted:
      break;
  }
  return "not attempted: " + reason;
}

AdjustStatus StatusOfSolve(const SolveResult& solve) {
  if (solve.converged) return AdjustStatus::kConverged;
  if (solve.summary.termination_type == ceres::NO_CONVERGENCE && std::isfinite(solve.summary.final_cost)) {
    return AdjustStatus::kNoConvergence;
  }
  return AdjustStatus::kFailed;
}

}  // namespace internal
}  // namespace mmba::adjust
