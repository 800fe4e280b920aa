#include "mmba/survey/adjust.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/problem/problem_builder.h"
#include "mmba/problem/solve.h"
#include "mmba/survey/survey_group.h"
#include "removed_coordinates_internal.h"

namespace mmba::survey {

bool SurveyAdjustOptions::Check(std::string* error) const {
  if (confidence != 0.0 && !(confidence > 0.0 && confidence < 1.0)) {
    *error = "confidence: found " + std::to_string(confidence) + ", expected 0 < p < 1";
    return false;
  }
  if (max_iterations < 1) {
    *error = "max_iterations: found " + std::to_string(max_iterations) + ", expected >= 1";
    return false;
  }
  return true;
}

namespace {

bool NeedsXy(ObsKind kind) {
  return kind != ObsKind::kHeightDiff && kind != ObsKind::kCoordZ && kind != ObsKind::kVectorZ;
}
bool NeedsZ(ObsKind kind) {
  return kind == ObsKind::kSlopeDistance || kind == ObsKind::kZenithAngle ||
         kind == ObsKind::kHeightDiff || kind == ObsKind::kCoordZ || kind == ObsKind::kVectorZ;
}

std::vector<std::string> PointsOf(const Observation& o) {
  std::vector<std::string> ids = {o.from};
  if (!o.to.empty()) ids.push_back(o.to);
  if (!o.fs.empty()) ids.push_back(o.fs);
  return ids;
}

double Bearing(const SurveyPoint& a, const SurveyPoint& b) {
  return std::atan2(b.coords.x() - a.coords.x(), b.coords.y() - a.coords.y());
}

double Wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

/// Circular mean of bearing − direction over the set's directions to known points.
bool EstimateOrientation(SurveyNetwork* net, Cluster* cluster) {
  if (cluster->type != Cluster::Type::kStandpoint) return false;
  const SurveyPoint* station = net->Find(cluster->station);
  if (station == nullptr || !station->has_xy) return false;
  double s = 0.0, c = 0.0;
  int count = 0;
  for (const Observation& o : cluster->observations) {
    if (o.kind != ObsKind::kDirection || !o.active) continue;
    const SurveyPoint* target = net->Find(o.to);
    if (!target->has_xy) continue;
    const double w = Bearing(*station, *target) - o.value;
    s += std::sin(w);
    c += std::cos(w);
    ++count;
  }
  if (count == 0) return false;
  cluster->orientation = std::atan2(s, c);
  return true;
}

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

std::string Where(const SurveyNetwork& net, int line) {
  return net.source + ":" + std::to_string(line);
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

std::string RemovedCoordinateWarning(const std::string& source, const RemovedCoordinate& r) {
  return "warning: " + source + ":" + std::to_string(r.line) + ": point " + r.point + ": " +
         r.coordinates + " removed from the adjustment (" + r.reason + ")";
}

namespace {

// Makes `o` passive for `reason` and lists it in `removed` ("file:line: kind from -> to:
// reason").
void MakePassive(const SurveyNetwork& net, Observation* o, const std::string& reason,
                 std::vector<std::string>* removed) {
  o->active = false;
  o->passive_reason = reason;
  removed->push_back(Where(net, o->line) + ": " + ObsKindName(o->kind) + " " + o->from +
                     (o->to.empty() ? "" : " -> " + o->to) + ": " + reason);
}

// Observations of a point without the fixed or adjusted coordinates they need.
void PassivateOnUnusedPoints(SurveyNetwork* net, std::vector<std::string>* removed) {
  for (Cluster& cluster : net->clusters) {
    for (Observation& o : cluster.observations) {
      if (!o.active) continue;
      for (const std::string& id : PointsOf(o)) {
        const SurveyPoint& p = *net->Find(id);
        const bool no_xy = p.xy == CoordStatus::kUnused || p.xy == CoordStatus::kRemoved;
        const bool no_z = p.z == CoordStatus::kUnused || p.z == CoordStatus::kRemoved;
        if ((NeedsXy(o.kind) && no_xy) || (NeedsZ(o.kind) && no_z)) {
          const bool z = NeedsZ(o.kind) && no_z;
          const CoordStatus status = z ? p.z : p.xy;
          MakePassive(*net, &o, "point " + id + (status == CoordStatus::kRemoved ? " has its " : " has no fixed or adjusted ") +
                                    (z ? "z" : "x, y") +
                                    (status == CoordStatus::kRemoved ? " removed from the adjustment" : ""),
                      removed);
          break;
        }
      }
    }
  }
}

// A set with fewer than two active directions has no orientation: its direction is passive.
void CountDirections(SurveyNetwork* net, std::vector<std::string>* removed) {
  for (Cluster& cluster : net->clusters) {
    std::set<std::string> targets;
    for (const Observation& o : cluster.observations) {
      if (o.kind == ObsKind::kDirection && o.active) targets.insert(o.to);
    }
    cluster.has_orientation = targets.size() >= 2;
    if (!cluster.has_orientation) {
      for (Observation& o : cluster.observations) {
        if (o.kind == ObsKind::kDirection && o.active) {
          MakePassive(*net, &o, "the only direction of its set (an orientation needs two)",
                      removed);
        }
      }
    }
  }
}

// Gama's absolute term at the approximate values (network.cpp, TestAbsTermVisitor), mm:
// lengths in mm, angles as the transverse offset in mm.
double AbsoluteTermMm(const SurveyNetwork& net, const Cluster& cluster, const Observation& o) {
  const SurveyPoint& a = *net.Find(o.from);
  const SurveyPoint* b = o.to.empty() ? nullptr : net.Find(o.to);
  double mm = 0.0;
  const double d0 = b ? (b->coords.head<2>() - a.coords.head<2>()).norm() : 0.0;
  const double dz = b ? b->coords.z() - a.coords.z() : 0.0;
  const Eigen::Vector2d xy = net.axes.XyFromEn(a.coords.head<2>());
  const Eigen::Vector2d dxy =
      b ? net.axes.XyFromEn(b->coords.head<2>() - a.coords.head<2>()) : Eigen::Vector2d();
  switch (o.kind) {
    case ObsKind::kDirection:
      mm = std::abs(Wrap(Bearing(a, *b) - cluster.orientation - o.value)) * d0 * 1000;
      break;
    case ObsKind::kAngle:
      mm = std::abs(Wrap(Bearing(a, *net.Find(o.fs)) - Bearing(a, *b) - o.value)) * d0 *
           1000;
      break;
    case ObsKind::kAzimuth:
      mm = std::abs(Wrap(Bearing(a, *b) - o.value)) * d0 * 1000;
      break;
    case ObsKind::kDistance: mm = std::abs(o.value - d0) * 1000; break;
    case ObsKind::kSlopeDistance:
      mm = std::abs(std::hypot(d0, dz) - o.value) * 1000;
      break;
    case ObsKind::kZenithAngle:
      mm = std::abs(Wrap(std::atan2(d0, dz + o.to_dh - o.from_dh) - o.value)) *
           std::hypot(d0, dz) * 1000;
      break;
    case ObsKind::kHeightDiff: mm = std::abs(o.value - dz) * 1000; break;
    case ObsKind::kCoordX: mm = std::abs(xy.x() - o.value) * 1000; break;
    case ObsKind::kCoordY: mm = std::abs(xy.y() - o.value) * 1000; break;
    case ObsKind::kCoordZ: mm = std::abs(a.coords.z() - o.value) * 1000; break;
    case ObsKind::kVectorX: mm = std::abs(dxy.x() - o.value) * 1000; break;
    case ObsKind::kVectorY: mm = std::abs(dxy.y() - o.value) * 1000; break;
    case ObsKind::kVectorZ: mm = std::abs(dz - o.value) * 1000; break;
  }
  return mm;
}

}  // namespace

std::vector<std::string> ReviseObservations(SurveyNetwork* net, bool test_absolute_terms) {
  std::vector<std::string> removed;
  PassivateOnUnusedPoints(net, &removed);
  CountDirections(net, &removed);
  if (!test_absolute_terms) return removed;
  bool any = false;
  for (Cluster& cluster : net->clusters) {
    for (Observation& o : cluster.observations) {
      if (!o.active) continue;
      const double mm = AbsoluteTermMm(*net, cluster, o);
      if (mm > net->tol_abs_mm) {
        std::ostringstream reason;
        reason << "absolute term " << mm << " mm > tol-abs " << net->tol_abs_mm << " mm";
        MakePassive(*net, &o, reason.str(), &removed);
        any = true;
      }
    }
  }
  if (any) CountDirections(net, &removed);
  return removed;
}

namespace {

// Refines the approximations by a robust (Cauchy) pre-adjustment so that the test of
// absolute terms sees gross errors only, not the weakness of point-by-point approximations
// (Gama computes its approximations more carefully; its test is the same). An unusable
// solution leaves the `approximate` coordinates.
void RefineApproximations(SurveyNetwork* net, const std::vector<Eigen::Vector3d>& approximate) {
  ceres::Problem pre;
  for (size_t c = 0; c < net->clusters.size(); ++c) {
    for (size_t i = 0; i < net->clusters[c].observations.size(); ++i) {
      std::vector<double*> blocks;
      Eigen::MatrixXd l;
      ceres::CostFunction* cost = CreateSurveyBlockCost(net, BlockSpec{c, {i}}, &blocks, &l);
      if (cost) pre.AddResidualBlock(cost, new ceres::CauchyLoss(3.0), blocks);
    }
  }
  for (Cluster& c : net->clusters) {
    if (pre.HasParameterBlock(&c.orientation) && !c.has_orientation) {
      pre.SetParameterBlockConstant(&c.orientation);
    }
  }
  for (SurveyPoint& p : net->points) {
    if (pre.HasParameterBlock(p.xy_block()) && !p.xy_free()) pre.SetParameterBlockConstant(p.xy_block());
    if (pre.HasParameterBlock(p.z_block()) && !p.z_free()) pre.SetParameterBlockConstant(p.z_block());
  }
  ceres::Solver::Options solver;
  solver.max_num_iterations = 50;
  solver.logging_type = ceres::SILENT;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &pre, &summary);
  if (!summary.IsSolutionUsable()) {
    for (size_t i = 0; i < net->points.size(); ++i) net->points[i].coords = approximate[i];
  }
}

// A parameter named for the statistics' messages: "x of point P (line L)", or a set's
// orientation.
std::string DescribeParameter(const SurveyNetwork& net, const double* block, int index) {
  for (const SurveyPoint& p : net.points) {
    if (block == p.coords.data()) {
      const char* axis = net.axes.en_from_xy(0, 0) != 0.0 ? (index == 0 ? "x" : "y")
                                                          : (index == 0 ? "y" : "x");
      return std::string(axis) + " of point " + p.id + " (line " + std::to_string(p.line) + ")";
    }
    if (block == p.coords.data() + 2) {
      return "z of point " + p.id + " (line " + std::to_string(p.line) + ")";
    }
  }
  for (const Cluster& c : net.clusters) {
    if (block == &c.orientation) {
      return "orientation of <obs from=\"" + c.station + "\"> (line " +
             std::to_string(c.line) + ")";
    }
  }
  return "a parameter";
}

// The datum: fixed coordinates, or the minimum norm of the constrained coordinates' changes
// from their approximate values (GNU Gama's free-network regularisation). Fills the
// statistics options' minimum-norm coordinates, their `reference` values and the counts.
void CollectDatum(SurveyNetwork* net, const std::vector<Eigen::Vector3d>& approximate,
                  stats::StatisticsOptions* stats_options, std::vector<double>* reference, int* num_fixed,
                  int* num_constrained) {
  for (SurveyPoint& p : net->points) {
    *num_fixed += (p.xy == CoordStatus::kFixed) + (p.z == CoordStatus::kFixed);
    const Eigen::Vector3d& approx = approximate[&p - net->points.data()];
    if (p.xy == CoordStatus::kConstrained) {
      for (int k = 0; k < 2; ++k) {
        stats_options->minimum_norm.push_back({p.xy_block(), k});
        reference->push_back(approx[k]);
        ++*num_constrained;
      }
    }
    if (p.z == CoordStatus::kConstrained) {
      stats_options->minimum_norm.push_back({p.z_block(), 0});
      reference->push_back(approx.z());
      ++*num_constrained;
    }
  }
}

std::string DatumText(int defect, int num_fixed, int num_constrained) {
  std::ostringstream d;
  if (defect > 0) {
    d << "free network: datum defect " << defect << " removed by the minimum norm of "
      << num_constrained << " constrained coordinate(s)";
  } else {
    d << num_fixed << " fixed coordinate(s)"
      << (num_constrained ? " (constrained coordinates adjusted freely: no defect)" : "");
  }
  return d.str();
}

// Levenberg–Marquardt on the built problem (ceres::Solve directly: mmba::Solve() calls
// ProblemBuilder::Build() again, which would re-add every group's blocks after the constant
// blocks were set). Records iterations, time, status and convergence in `result`: converged,
// or stopped on the iteration limit with a usable solution whose cost no longer changes (Gama
// stops on small corrections the same way).
void SolveNetwork(const SurveyNetwork& net, const SurveyAdjustOptions& options, ceres::Problem* problem,
                  SurveyAdjustment* result) {
  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.max_num_iterations = options.max_iterations;
  solver.function_tolerance = 1e-14;
  solver.gradient_tolerance = 1e-16;
  solver.parameter_tolerance = 1e-14;
  solver.num_threads = 1;
  solver.logging_type = options.log_progress ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
  int num_parameters = 0;
  for (auto& p : net.points) num_parameters += p.xy_free() * 2 + p.z_free();
  solver.linear_solver_type =
      num_parameters < 600 ? ceres::DENSE_QR : ceres::SPARSE_NORMAL_CHOLESKY;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, problem, &summary);
  result->iterations = static_cast<int>(summary.iterations.size());
  result->solve_seconds = summary.total_time_in_seconds;
  result->reason = summary.message;
  if (summary.termination_type == ceres::CONVERGENCE) {
    result->status = "converged";
  } else if (summary.termination_type == ceres::NO_CONVERGENCE) {
    result->status = "no_convergence";
  } else {
    result->status = "failed";
  }
  const double change = summary.iterations.empty()
                            ? 0.0
                            : std::abs(summary.iterations.back().cost_change) /
                                  std::max(1e-300, summary.final_cost);
  result->converged = summary.termination_type == ceres::CONVERGENCE ||
                      (summary.termination_type == ceres::NO_CONVERGENCE && change < 1e-10);
}

// The statistics of the converged adjustment, points no observation determines (reported as
// removed), and each statistics row's observation.
void ComputeNetworkStatistics(const SurveyNetwork& net, const std::vector<SurveyGroup*>& groups,
                              const stats::StatisticsOptions& stats_options, ceres::Problem* problem,
                              SurveyAdjustment* result) {
  std::vector<const FactorGroup*> const_groups(groups.begin(), groups.end());
  try {
    result->statistics = stats::ComputeStatistics(*problem, const_groups, stats_options);
  } catch (const stats::DegenerateNetworkError& e) {
    throw InputError::Message(net.source, e.what());
  }
  for (const SurveyPoint& p : net.points) {
    const bool xy_missing = p.xy_free() && !result->statistics.IsFree(p.coords.data());
    const bool z_missing = p.z_free() && !result->statistics.IsFree(p.coords.data() + 2);
    if (xy_missing || z_missing) {
      result->removed.push_back(Where(net, p.line) + ": point " + p.id +
                                ": no observation determines its " +
                                (xy_missing ? "x, y" : "z") + " (left at the given values)");
    }
  }
  for (const stats::RowStatistic& row : result->statistics.rows) {
    const BlockSpec& spec = groups[row.group]->added_specs()[row.block];
    result->rows.push_back({spec.cluster, spec.observations[row.row]});
  }
}

}  // namespace

SurveyAdjustment AdjustNetwork(SurveyNetwork* net, const SurveyAdjustOptions& options) {
  std::string error;
  if (!options.Check(&error)) throw InputError::Message("survey options", error);
  SurveyAdjustment result;
  const auto start = std::chrono::steady_clock::now();
  auto seconds_since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  auto append = [](std::vector<std::string>* to, const std::vector<std::string>& more) {
    to->insert(to->end(), more.begin(), more.end());
  };
  result.removed = ReviseObservations(net, /*test_absolute_terms=*/false);
  result.removed_points = ComputeApproximations(net);
  append(&result.removed, ReviseObservations(net, /*test_absolute_terms=*/false));
  // Reference of the minimum-norm datum: the approximate (given) constrained coordinates.
  std::vector<Eigen::Vector3d> approximate;
  for (const SurveyPoint& p : net->points) approximate.push_back(p.coords);
  RefineApproximations(net, approximate);
  append(&result.removed, ReviseObservations(net, /*test_absolute_terms=*/true));
  for (Cluster& c : net->clusters) EstimateOrientation(net, &c);

  // The problem, rebuilt without the coordinates its design matrix cannot determine (and
  // their observations) until there are none, as Gama's project_equations does.
  std::unique_ptr<Scene> scene;  // survey parameters live in the SurveyNetwork
  std::unique_ptr<ProblemBuilder> builder;
  std::vector<SurveyGroup*> groups;
  while (true) {
    groups.clear();
    builder.reset();
    scene = std::make_unique<Scene>();
    builder = std::make_unique<ProblemBuilder>(scene.get());
    GaugeOptions gauge;
    gauge.kind = GaugeOptions::Kind::kNone;
    builder->set_gauge(gauge);
    for (auto& group : MakeSurveyGroups(net)) {
      groups.push_back(static_cast<SurveyGroup*>(&builder->AddGroup(std::move(group))));
    }
    ceres::Problem& built = builder->Build();
    SetSurveyParameterStates(net, built);
    const std::vector<RemovedCoordinate> singular = internal::RemoveSingularCoordinates(net, built);
    if (singular.empty()) break;
    result.removed_points.insert(result.removed_points.end(), singular.begin(), singular.end());
    append(&result.removed, ReviseObservations(net, /*test_absolute_terms=*/false));
    for (Cluster& c : net->clusters) EstimateOrientation(net, &c);
  }
  ceres::Problem& problem = builder->Build();

  stats::StatisticsOptions stats_options;
  stats_options.confidence = options.confidence > 0 ? options.confidence : net->confidence;
  stats_options.use_apriori_sigma0 = net->sigma_act_apriori;
  std::vector<double> reference;
  int num_fixed = 0, num_constrained = 0;
  CollectDatum(net, approximate, &stats_options, &reference, &num_fixed, &num_constrained);
  stats_options.describe = [net](const double* block, int index) -> std::string {
    return DescribeParameter(*net, block, index);
  };
  int defect = 0;
  try {
    defect = stats::CheckDatum(problem, stats_options);
  } catch (const stats::DegenerateNetworkError& e) {
    throw InputError::Message(net->source, e.what());
  }
  result.datum = DatumText(defect, num_fixed, num_constrained);

  result.prepare_seconds = seconds_since(start);
  SolveNetwork(*net, options, &problem, &result);
  if (!result.converged) return result;
  if (defect > 0) stats::ApplyMinimumNorm(problem, stats_options, reference);

  const auto statistics_start = std::chrono::steady_clock::now();
  ComputeNetworkStatistics(*net, groups, stats_options, &problem, &result);
  result.statistics_seconds = seconds_since(statistics_start);
  // Approximate values of constrained coordinates stay (Gama does not update them unless
  // update-constrained-coordinates="yes"; the minimum norm already used them).
  return result;
}

Eigen::Matrix3d PointCovariance(const SurveyAdjustment& adjustment,
                                const SurveyNetwork& network, const SurveyPoint& point) {
  const stats::NetworkStatistics& st = adjustment.statistics;
  double* xy = const_cast<double*>(point.coords.data());
  double* z = xy + 2;
  Eigen::Matrix3d enu = Eigen::Matrix3d::Zero();
  const std::pair<double*, int> scalars[3] = {{xy, 0}, {xy, 1}, {z, 0}};
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      enu(a, b) = st.Covariance(scalars[a].first, scalars[a].second, scalars[b].first,
                                scalars[b].second);
    }
  }
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();  // enu_from_input
  m.topLeftCorner<2, 2>() = network.axes.en_from_xy;
  return m.transpose() * enu * m;
}

}  // namespace mmba::survey
