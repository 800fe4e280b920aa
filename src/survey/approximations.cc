// Approximate coordinates of a survey network (ComputeApproximations, adjust.h): point by
// point from the observations that tie it to known points, as small least-squares problems
// solved from several starts.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <Eigen/SVD>

#include "adjust_internal.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/survey_group.h"
#include "removed_coordinates_internal.h"

namespace mmba::survey {
namespace {

using internal::Bearing;
using internal::EstimateOrientation;
using internal::NeedsXy;
using internal::NeedsZ;
using internal::PointsOf;

// The observation blocks that can approximate `point` (every point they need known, or
// being `point`), and what a start needs: the sets observing it by direction, its
// neighbours' coordinates and the lengths observed to it.
struct ApproximationInputs {
  std::vector<BlockSpec> specs;
  std::set<size_t> clusters_with_directions;
  std::vector<const SurveyPoint*> neighbours;
  std::vector<double> lengths;
};

ApproximationInputs CollectApproximationInputs(SurveyNetwork* net, SurveyPoint* point, bool solve_xy,
                                               bool solve_z) {
  auto known = [&](const SurveyPoint& p, bool xy) {
    if (&p == point) return xy ? (point->has_xy || solve_xy) : (point->has_z || solve_z);
    return xy ? p.has_xy : p.has_z;
  };
  ApproximationInputs in;
  for (size_t c = 0; c < net->clusters.size(); ++c) {
    const Cluster& cluster = net->clusters[c];
    for (size_t i = 0; i < cluster.observations.size(); ++i) {
      const Observation& o = cluster.observations[i];
      if (!o.active) continue;
      bool touches = false, usable = true;
      for (const std::string& id : PointsOf(o)) {
        const SurveyPoint& p = *net->Find(id);
        touches = touches || &p == point;
        if (NeedsXy(o.kind) && !known(p, true)) usable = false;
        if (NeedsZ(o.kind) && !known(p, false)) usable = false;
      }
      if (!usable) continue;
      if (!touches) {
        // Directions to known points fix the orientation of a set that also sees `point`.
        if (o.kind == ObsKind::kDirection) in.specs.push_back(BlockSpec{c, {i}});
        continue;
      }
      in.specs.push_back(BlockSpec{c, {i}});
      if (o.kind == ObsKind::kDirection) in.clusters_with_directions.insert(c);
      if (o.kind == ObsKind::kDistance || o.kind == ObsKind::kSlopeDistance) {
        in.lengths.push_back(o.value);
      }
      for (const std::string& id : PointsOf(o)) {
        const SurveyPoint* p = net->Find(id);
        if (p != point && p->has_xy) in.neighbours.push_back(p);
      }
    }
  }
  // Keep the orientation-only directions of the sets that see the point.
  in.specs.erase(std::remove_if(in.specs.begin(), in.specs.end(),
                                [&](const BlockSpec& s) {
                                  const Observation& o =
                                      net->clusters[s.cluster].observations[s.observations[0]];
                                  bool touches = false;
                                  for (const std::string& id : PointsOf(o)) {
                                    touches = touches || net->Find(id) == point;
                                  }
                                  return !touches && !in.clusters_with_directions.count(s.cluster);
                                }),
                 in.specs.end());
  return in;
}

// Adds the blocks to `problem` with only the point's unknowns and the orientations free;
// `blocks` gets the problem's parameter blocks. Returns the number of residuals, or −1 when
// they cannot determine the free parameters (fewer residuals, or a needed block missing).
int BuildApproximationProblem(SurveyNetwork* net, SurveyPoint* point, const std::vector<BlockSpec>& specs,
                              bool solve_xy, bool solve_z, ceres::Problem* problem,
                              std::vector<double*>* blocks) {
  int num_residuals = 0;
  for (const BlockSpec& spec : specs) {
    std::vector<double*> spec_blocks;
    Eigen::MatrixXd l;
    ceres::CostFunction* cost = CreateSurveyBlockCost(net, spec, &spec_blocks, &l);
    if (cost == nullptr) continue;
    problem->AddResidualBlock(cost, nullptr, spec_blocks);
    num_residuals += cost->num_residuals();
  }
  problem->GetParameterBlocks(blocks);
  int num_free = 0;
  for (double* block : *blocks) {
    const bool is_point_xy = block == point->xy_block();
    const bool is_point_z = block == point->z_block();
    bool is_orientation = false;
    for (const Cluster& c : net->clusters) is_orientation = is_orientation || block == &c.orientation;
    const bool free = (is_point_xy && solve_xy) || (is_point_z && solve_z) || is_orientation;
    if (!free) problem->SetParameterBlockConstant(block);
    else num_free += problem->ParameterBlockSize(block);
  }
  if (num_residuals < num_free) return -1;
  if (solve_xy && !problem->HasParameterBlock(point->xy_block())) return -1;
  if (solve_z && !problem->HasParameterBlock(point->z_block())) return -1;
  return num_residuals;
}

// Starting positions: the neighbours' centre (unless on a neighbour) and eight bearings at
// 1, 0.5 and 2 times the median observed length (else the neighbours' mean distance, ≥ 10 m;
// else 100 m) around it; the given position when only z is solved. *z0: the neighbours' mean z.
std::vector<Eigen::Vector2d> StartPositions(const SurveyPoint& point, const ApproximationInputs& in,
                                            bool solve_xy, double* z0) {
  const std::vector<const SurveyPoint*>& neighbours = in.neighbours;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  *z0 = 0.0;
  int nz = 0;
  for (const SurveyPoint* p : neighbours) centre += p->coords.head<2>();
  if (!neighbours.empty()) centre /= static_cast<double>(neighbours.size());
  for (const SurveyPoint* p : neighbours) {
    if (p->has_z) {
      *z0 += p->coords.z();
      ++nz;
    }
  }
  if (nz > 0) *z0 /= nz;
  double radius = 100.0;
  std::vector<double> lengths = in.lengths;
  if (!lengths.empty()) {
    std::sort(lengths.begin(), lengths.end());
    radius = lengths[lengths.size() / 2];
  } else if (!neighbours.empty()) {
    double sum = 0.0;
    for (const SurveyPoint* p : neighbours) sum += (p->coords.head<2>() - centre).norm();
    radius = std::max(10.0, sum / neighbours.size());
  }
  std::vector<Eigen::Vector2d> starts;
  if (!solve_xy) {
    starts.push_back(point.coords.head<2>());
    return starts;
  }
  bool centre_on_point = false;
  for (const SurveyPoint* p : neighbours) {
    centre_on_point = centre_on_point || (p->coords.head<2>() - centre).norm() < 1e-3;
  }
  if (!centre_on_point) starts.push_back(centre);
  for (double f : {1.0, 0.5, 2.0}) {
    for (int k = 0; k < 8; ++k) {
      const double t = k * M_PI / 4 + 0.1;
      starts.push_back(centre + f * radius * Eigen::Vector2d(std::cos(t), std::sin(t)));
    }
  }
  return starts;
}

// Solves from every start (orientations re-estimated at each) and leaves the point at the
// least-cost usable solution; returns that cost (infinity: none usable).
double SolveFromStarts(SurveyNetwork* net, SurveyPoint* point, const ApproximationInputs& in,
                       const std::vector<Eigen::Vector2d>& starts, bool solve_z, double z0,
                       ceres::Problem* problem) {
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 100;
  solver.function_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-14;
  solver.logging_type = ceres::SILENT;
  double best_cost = std::numeric_limits<double>::infinity();
  Eigen::Vector3d best = point->coords;
  for (const Eigen::Vector2d& start : starts) {
    point->coords.head<2>() = start;
    if (solve_z) point->coords.z() = z0;
    const bool had_xy = point->has_xy;
    point->has_xy = true;
    for (size_t c : in.clusters_with_directions) EstimateOrientation(net, &net->clusters[c]);
    point->has_xy = had_xy;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, problem, &summary);
    if (summary.IsSolutionUsable() && summary.final_cost < best_cost) {
      best_cost = summary.final_cost;
      best = point->coords;
    }
  }
  point->coords = best;
  return best_cost;
}

// Determined: the Jacobian over the point's unknowns (and the free orientations), columns
// normalised, has full rank (smallest singular value ≥ 1e-6 of the largest).
bool PointDetermined(SurveyPoint* point, const std::vector<double*>& blocks, bool solve_xy, bool solve_z,
                     ceres::Problem* problem) {
  SurveyPoint& p = *point;
  ceres::Problem::EvaluateOptions eval;
  std::vector<double*> point_blocks;
  if (solve_xy) point_blocks.push_back(p.xy_block());
  if (solve_z) point_blocks.push_back(p.z_block());
  for (double* block : blocks) {
    if (!problem->IsParameterBlockConstant(block) && block != p.xy_block() && block != p.z_block()) {
      point_blocks.push_back(block);
    }
  }
  eval.parameter_blocks = point_blocks;
  ceres::CRSMatrix crs;
  problem->Evaluate(eval, nullptr, nullptr, nullptr, &crs);
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) j(r, crs.cols[k]) = crs.values[k];
  }
  for (int c = 0; c < j.cols(); ++c) {
    const double norm = j.col(c).norm();
    if (norm > 0) j.col(c) /= norm;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(j);
  const Eigen::VectorXd sv = svd.singularValues();
  return !(sv.size() < j.cols() || sv(sv.size() - 1) < 1e-6 * std::max(1e-300, sv(0)));
}

/// Tries to determine the coordinates `solve_xy`, `solve_z` of `point` together from
/// observations to known points.
bool ApproximateCoordinates(SurveyNetwork* net, SurveyPoint* point, bool solve_xy, bool solve_z) {
  const ApproximationInputs in = CollectApproximationInputs(net, point, solve_xy, solve_z);
  if (in.specs.empty()) return false;
  ceres::Problem::Options problem_options;
  ceres::Problem problem(problem_options);
  std::vector<double*> blocks;
  const int num_residuals = BuildApproximationProblem(net, point, in.specs, solve_xy, solve_z, &problem, &blocks);
  if (num_residuals < 0) return false;
  double z0 = 0.0;
  const std::vector<Eigen::Vector2d> starts = StartPositions(*point, in, solve_xy, &z0);
  const double best_cost = SolveFromStarts(net, point, in, starts, solve_z, z0, &problem);
  if (!std::isfinite(best_cost)) return false;
  // Whitened RMS within 1000 σ: a usable approximation (blunders are for the adjustment).
  if (std::sqrt(2.0 * best_cost / std::max(1, num_residuals)) > 1000.0) return false;
  if (!PointDetermined(point, blocks, solve_xy, solve_z, &problem)) return false;
  if (solve_xy) point->has_xy = true;
  if (solve_z) point->has_z = true;
  return true;
}

/// Tries to determine the unknown coordinates of `point` from observations to known points:
/// x, y and z together, else x, y alone (a height may be undetermined), else z alone.
bool ApproximatePoint(SurveyNetwork* net, SurveyPoint* point) {
  const auto unknown = [](CoordStatus s) { return s != CoordStatus::kUnused && s != CoordStatus::kRemoved; };
  const bool solve_xy = unknown(point->xy) && !point->has_xy;
  const bool solve_z = unknown(point->z) && !point->has_z;
  if (!solve_xy && !solve_z) return false;
  const Eigen::Vector3d start = point->coords;
  if (ApproximateCoordinates(net, point, solve_xy, solve_z)) return true;
  point->coords = start;
  if (!solve_xy || !solve_z) return false;
  if (ApproximateCoordinates(net, point, true, false)) return true;
  point->coords = start;
  if (ApproximateCoordinates(net, point, false, true)) return true;
  point->coords = start;
  return false;
}

}  // namespace

std::vector<RemovedCoordinate> ComputeApproximations(SurveyNetwork* net) {
  bool progress = true;
  while (progress) {
    progress = false;
    for (SurveyPoint& p : net->points) {
      if (ApproximatePoint(net, &p)) progress = true;
    }
  }
  // Gama's revision_points: a coordinate without approximate value leaves the adjustment.
  std::vector<RemovedCoordinate> removed;
  for (SurveyPoint& p : net->points) {
    if (p.xy != CoordStatus::kUnused && p.xy != CoordStatus::kRemoved && !p.has_xy) {
      removed.push_back(internal::RemoveCoordinate(
          &p, true, "missing x, y: the observations to known points cannot compute them"));
    }
    if (p.z != CoordStatus::kUnused && p.z != CoordStatus::kRemoved && !p.has_z) {
      removed.push_back(internal::RemoveCoordinate(
          &p, false, "missing z: no zenith angle, slope distance or height difference ties it to a known height"));
    }
  }
  for (Cluster& c : net->clusters) EstimateOrientation(net, &c);
  for (SurveyPoint& p : net->points) p.approx = p.coords;
  return removed;
}

}  // namespace mmba::survey
