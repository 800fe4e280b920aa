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
#include "adjust_internal.h"
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

using internal::Bearing;
using internal::EstimateOrientation;
using internal::NeedsXy;
using internal::NeedsZ;
using internal::PointsOf;
using internal::Wrap;

std::string Where(const SurveyNetwork& net, int line) {
  return net.source + ":" + std::to_string(line);
}

}  // namespace

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
