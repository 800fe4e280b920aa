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

/// A coordinate the observations cannot determine, left out of the adjustment as GNU Gama
/// does (LocalNetwork::removed: missing xy/z approximations, singular xy, no observation).
struct RemovedCoordinate {
  std::string point;
  int line = 0;             ///< line of the point's definition
  std::string coordinates;  ///< "xy" or "z"
  std::string reason;       ///< why it cannot be determined
};

/// "warning: file:line: point P: xy removed from the adjustment (reason)".
std::string RemovedCoordinateWarning(const std::string& source, const RemovedCoordinate& removed);

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
  /// Coordinates left out because the observations cannot determine them (their status is
  /// CoordStatus::kRemoved, observations needing them are passive and in `removed`).
  std::vector<RemovedCoordinate> removed_points;
};

/// Computes approximate coordinates of adjusted points that have none (and of heights),
/// point by point from the observations that tie them to known points (polar, intersection,
/// resection, levelling, vectors … solved as small least-squares problems from several
/// starts), then approximate orientations of direction sets. An adjusted or constrained
/// coordinate that cannot be computed so is set CoordStatus::kRemoved and returned (Gama's
/// revision_points: "missing xy", "missing z").
std::vector<RemovedCoordinate> ComputeApproximations(SurveyNetwork* network);

/// Marks observations passive as GNU Gama does: touching a point whose needed coordinate is
/// neither fixed nor adjusted (unused or removed); direction sets with fewer than two directions; absolute
/// terms larger than tol-abs at the approximate coordinates. Returns the reasons.
std::vector<std::string> ReviseObservations(SurveyNetwork* network, bool test_absolute_terms);

/// Adjusts the network (ComputeApproximations + ReviseObservations + one Ceres problem
/// built by ProblemBuilder from SurveyGroups + the minimum-norm datum for constrained
/// points + statistics). Coordinates and orientations in `network` are updated. Coordinates
/// the observations cannot determine (no approximation, x and y columns of the design matrix
/// parallel, no observation) are removed from the adjustment as Gama does and listed in
/// `removed_points`. Throws InputError for bad input (e.g. a datum defect without
/// constrained points that removing such coordinates does not cure, naming the undetermined
/// coordinates and their lines).
SurveyAdjustment AdjustNetwork(SurveyNetwork* network, const SurveyAdjustOptions& options);

/// Covariance (m², scaled by the σ0 used) of a point's (x, y, z) in the input axes; zero
/// rows/columns for coordinates that are not free.
Eigen::Matrix3d PointCovariance(const SurveyAdjustment& adjustment,
                                const SurveyNetwork& network, const SurveyPoint& point);

}  // namespace mmba::survey
