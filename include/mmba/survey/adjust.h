#pragma once

#include <string>
#include <vector>

#include "mmba/stats/statistics.h"
#include "mmba/survey/network.h"

namespace mmba::survey {

/// Options of a survey network adjustment.
struct SurveyAdjustOptions {
  double confidence = 0.0;   ///< (0, 1); 0 = the network's conf-pr
  int max_iterations = 100;  ///< Levenberg–Marquardt iterations, >= 1
  bool log_progress = false;
  bool Check(std::string* error) const;
};

/// Result of AdjustNetwork: Ceres' status, the statistics of every scalar observation and
/// where each statistics row came from.
struct SurveyAdjustment {
  bool converged = false;
  std::string status;  ///< "converged", "no_convergence", "failed"
  std::string reason;
  int iterations = 0;
  double solve_seconds = 0.0;       ///< Ceres' main solve
  double prepare_seconds = 0.0;     ///< approximations, robust pre-adjustment, datum check
  double statistics_seconds = 0.0;  ///< covariance, redundancy, tests
  std::string datum;   ///< how the datum was fixed, for the report
  stats::NetworkStatistics statistics;
  struct RowSource {
    size_t cluster = 0;
    size_t observation = 0;
  };
  std::vector<RowSource> rows;  ///< parallel to statistics.rows
  std::vector<std::string> removed;  ///< observations left out, with the reason
};

/// Computes approximate coordinates of adjusted points that have none (and of heights),
/// point by point from the observations that tie them to known points (polar, intersection,
/// resection, levelling, vectors … solved as small least-squares problems from several
/// starts), then approximate orientations of direction sets. Throws InputError naming the
/// point when its coordinates cannot be determined.
void ComputeApproximations(SurveyNetwork* network);

/// Marks observations passive as GNU Gama does: touching a point whose needed coordinate is
/// neither fixed nor adjusted; direction sets with fewer than two directions; absolute
/// terms larger than tol-abs at the approximate coordinates. Returns the reasons.
std::vector<std::string> ReviseObservations(SurveyNetwork* network, bool test_absolute_terms);

/// Adjusts the network (ComputeApproximations + ReviseObservations + one Ceres problem
/// built by ProblemBuilder from SurveyGroups + the minimum-norm datum for constrained
/// points + statistics). Coordinates and orientations in `network` are updated. Throws
/// InputError for bad input (e.g. a datum defect without constrained points, naming the
/// undetermined coordinates and their lines).
SurveyAdjustment AdjustNetwork(SurveyNetwork* network, const SurveyAdjustOptions& options);

/// Covariance (m², scaled by the σ0 used) of a point's (x, y, z) in the input axes; zero
/// rows/columns for coordinates that are not free.
Eigen::Matrix3d PointCovariance(const SurveyAdjustment& adjustment,
                                const SurveyNetwork& network, const SurveyPoint& point);

}  // namespace mmba::survey
