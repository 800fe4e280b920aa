// The joint adjustment `mmba adjust PROJECT.yaml --output DIR`: every sensor of the project
// is a group of residual blocks of ONE Ceres problem (DESIGN.md), initialised by the existing
// pieces (survey network adjustment → control; control targets → photo block similarity),
// solved with robust losses, outer iterations re-associating the LiDAR surface, one round of
// data snooping, and the statistics of the survey module (σ0, χ², variance components,
// redundancy, studentized residuals, covariances) for every group.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "mmba/io_project/project.h"

namespace mmba::adjust {

struct AdjustOptions {
  std::string output_dir;    ///< new, empty or written by mmba (core/output_folder.h, else InputError); replaced whole only on success
  int num_threads = 2;
  bool log_progress = true;  ///< one log line per stage / solver iteration
};

/// How an adjustment ended.
enum class AdjustStatus { kConverged, kNoConvergence, kFailed };
/// "converged", "no_convergence", "failed": the text of report.json and of the CLI.
std::string AdjustStatusName(AdjustStatus status);

struct AdjustOutcome {
  bool ok = false;        ///< converged, statistics computed, outputs written
  std::string status;     ///< AdjustStatusName() of how it ended
  std::string reason;     ///< why not ok (a sentence for the user)
  nlohmann::json report;  ///< report.json as written (also on failure, not written then)
  std::string summary;    ///< a few lines for the terminal
};

/// Runs the adjustment. Bad input found in the sensors' files (unknown point or image ids,
/// malformed CSV rows, camera model mismatch) throws InputError; a failed adjustment
/// (no convergence, degenerate configuration, a sensor with no overlap) returns ok = false
/// and writes nothing, so an earlier good output in `output_dir` stays as it was.
AdjustOutcome RunAdjustment(const Project& project, const AdjustOptions& options);

}  // namespace mmba::adjust
