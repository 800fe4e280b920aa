// The joint adjustment `mmba adjust`: the sensors loaded and initialised (each by its unit in
// blocks/), the joint problem built from their factor groups, the outer iterations of LiDAR
// association and solving, the statistics, data snooping and variance components. The outputs
// are outputs.cc.
#include "mmba/adjust/adjust.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include <spdlog/spdlog.h>

#include "blocks/blocks.h"
#include "mmba/core/error.h"
#include "mmba/core/progress.h"
#include "mmba/survey/survey_group.h"

namespace mmba::adjust {
namespace internal {

std::string ProjectKey(const Project& project, int line, const std::string& key) {
  return project.path + ":" + std::to_string(line) + ": " + key;
}

void Note(JointState* s, const std::string& text) {
  spdlog::info("adjust: {}", text);
  s->log.push_back(text);
}

std::string VarianceComponentExemption(const JointState& s, const FactorGroup& group, double redundancy) {
  if (!s.project->settings.variance_components) return "variance_components: false";
  if (&group == s.check_group) return "check points";
  if (group.role() == FactorRole::kConstraint) return "constraint";
  // Priors on parameters (a registration, a GNSS/INS trajectory, a nominal calibration): their
  // σ is the user's statement about the prior, and their few, correlated residuals shrink as
  // the prior is tightened, so Förstner's estimate runs away towards zero (the cathedral scans'
  // registration priors 0.14×, the rig's cam_from_rig priors 0.16× after four passes, while
  // the registrations were 3× off their new σ). The MI pose priors too: their covariance is
  // register-mi's, already calibrated by its halves' and restarts' scatter, and photos that see
  // the same part of the LiDAR model share its errors (the gate's photo priors tightened 0.30×
  // while their poses were a median 10 mm off the truth; the photo centres' RMSE 9.0 mm
  // re-weighted, 4.8 mm not). Not re-weighted; still tested and snooped.
  if (group.role() == FactorRole::kPrior) return "prior";
  if (redundancy < 5) return "redundancy below 5";
  return "";
}

}  // namespace internal

namespace {

namespace fs = std::filesystem;
using namespace internal;  // the adjustment's private units

/// The joint problem: every sensor's factor groups (in this order: report.json lists them so)
/// and parameter options, applied by Build(); then the survey points' constant blocks. The
/// datum comes from the control, GNSS and LiDAR (no gauge), or for image measurements without
/// control from PhotoMeasurementGauge.
void BuildProblem(JointState* s) {
  s->builder = std::make_unique<ProblemBuilder>(&s->scene);
  s->check_group = nullptr;
  const GroupWeights weights(*s);
  if (s->photos) AddPhotoGroups(s, weights);
  if (s->spheres) AddSphereGroups(s, weights);
  if (s->rig) AddRigGroups(s, weights);
  AddNetworkGroups(s, weights);
  if (!s->project->lidar_static.empty()) AddStaticLidarGroups(s, weights);
  if (s->mobile) AddMobileGroups(s, weights);
  if (s->measured) AddPhotoMeasurementGroups(s, weights);
  s->builder->set_gauge(PhotoMeasurementGauge(*s));  // kNone unless a block without control
  ceres::Problem& problem = s->builder->Build();
  if (s->joint) survey::SetSurveyParameterStates(&*s->joint, problem);
  if (s->rig) WarnHeldRigIntrinsics(s);
  for (const auto& group : s->builder->groups()) {
    group->set_outlier_threshold(s->project->settings.outlier_sigma);
  }
}

/// Levenberg–Marquardt iterations at most for a solve between re-associations.
constexpr int kAssociationSolveIterations = 30;

/// How far a solve goes. The solves between re-associations of the LiDAR correspondences only
/// bring the parameters close enough to associate again; the solve the statistics are taken
/// from goes to the minimum.
enum class SolvePhase { kAssociation, kFinal };

void SolveOnce(JointState* s, const AdjustOptions& options, SolvePhase phase) {
  BuildProblem(s);
  SolveOptions solve;
  solve.max_iterations = s->project->settings.max_iterations;
  solve.num_threads = options.num_threads;
  solve.log_progress = options.log_progress;
  if (phase == SolvePhase::kFinal) {
    // Tight tolerances: poses, principal points and rotations are strongly correlated, and a
    // relative cost change of 1e-8 stops Levenberg–Marquardt in that flat valley too early.
    solve.function_tolerance = 1e-12;
    solve.parameter_tolerance = 1e-12;
    solve.gradient_tolerance = 1e-12;
  } else {
    // Between associations a relative cost change of 1e-6 is close enough: the correspondences
    // change next anyway. With many observations in Huber's linear zone (wrong associations
    // at the first, wide gate) the Gauss–Newton model of Ceres overestimates the curvature
    // and the last digits come at a linear rate (on the 200-frame drive more than 100
    // iterations for a relative decrease of 5e-6).
    solve.function_tolerance = 1e-6;
    solve.parameter_tolerance = 1e-8;
    solve.gradient_tolerance = 1e-10;
    solve.max_iterations = std::min(solve.max_iterations, kAssociationSolveIterations);
  }
  s->solve = Solve(*s->builder, solve);
  s->total_iterations += s->solve.iterations;
  const bool usable = phase == SolvePhase::kAssociation && StatusOfSolve(s->solve) == AdjustStatus::kNoConvergence &&
                      std::isfinite(s->solve.final_cost) && s->solve.final_cost <= s->solve.initial_cost;
  if (!s->solve.converged && !usable) {
    throw AdjustFailure(StatusOfSolve(s->solve), "the joint adjustment did not converge: " + s->solve.reason);
  }
  std::ostringstream groups;
  for (const GroupEvaluation& e : s->solve.after) {
    groups << (groups.tellp() > 0 ? "; " : "") << e.name << " RMS " << e.rms_units << " " << e.unit;
  }
  Note(s, (s->solve.converged ? "solved in " : "stopped after ") + std::to_string(s->solve.iterations) +
              " iterations" + (phase == SolvePhase::kAssociation ? " (to re-associate)" : "") + ": " + groups.str());
}

stats::NetworkStatistics Statistics(JointState* s) {
  stats::StatisticsOptions options;
  options.confidence = s->project->settings.confidence;
  for (auto& [id, point] : s->scene.points()) {
    if (id.value < kCheckPointIdBase) options.eliminate.insert(point.data());
  }
  std::map<const double*, std::string> names;
  if (s->rig) {
    for (size_t f = 0; f < s->rig->frame_names.size(); ++f) {
      Rigid3d& pose = s->scene.RigFrame(FrameId(f));
      names[pose.rotation.coeffs().data()] = "rotation of rig frame " + s->rig->frame_names[f];
      names[pose.translation.data()] = "position of rig frame " + s->rig->frame_names[f];
    }
    for (size_t k = 0; k < s->rig->cameras.size(); ++k) {
      Rigid3d& pose = s->scene.CamFromRig(s->rig->cameras[k]);
      names[pose.rotation.coeffs().data()] = "cam_from_rig rotation of " + s->rig->camera_names[k];
      names[pose.translation.data()] = "cam_from_rig translation of " + s->rig->camera_names[k];
    }
  }
  if (s->mobile) {
    for (const TrajectoryNode& node : s->scene.trajectory_nodes()) {
      names[node.correction] = "trajectory correction at t = " + std::to_string(node.time_s) + " s";
    }
    names[s->scene.Mount(s->mobile->mount).rotation.coeffs().data()] = "camera-LiDAR extrinsic rotation";
    names[s->scene.Mount(s->mobile->mount).translation.data()] = "camera-LiDAR extrinsic translation";
  }
  std::map<ImageId, std::string> station_of;
  if (s->spheres) {
    for (const auto& [station, id] : s->spheres->lower_image) station_of[id] = "station " + station;
    names[s->spheres->baseline.data()] = "spherical stereo baseline";
  }
  for (const auto& [id, image] : s->scene.images()) {
    const std::string measured = PhotoMeasurementImageName(*s, id);
    const std::string name = station_of.count(id)                          ? station_of.at(id)
                             : !measured.empty()                             ? measured
                             : s->photos && s->photos->model.images.count(id) ? s->photos->model.images.at(id).name
                                                                             : std::to_string(id.value);
    names[image.cam_from_world.rotation.coeffs().data()] = "rotation of image " + name;
    names[image.cam_from_world.translation.data()] = "position of image " + name;
  }
  for (const auto& [id, camera] : s->scene.cameras()) names[camera.params.data()] = "intrinsics of camera " + std::to_string(id.value);
  for (const auto& [name, id] : s->photos ? s->photos->check_ids : std::map<std::string, Point3DId>()) {
    names[s->scene.Point(id).data()] = "check point " + name + " (image measurements)";
  }
  if (s->joint) {
    for (const survey::SurveyPoint& p : s->joint->points) {
      names[p.coords.data()] = "horizontal position of point " + p.id;
      names[p.coords.data() + 2] = "height of point " + p.id;
    }
  }
  options.describe = [names](const double* block, int index) {
    const auto it = names.find(block);
    return (it == names.end() ? std::string("a parameter") : it->second) + " (component " + std::to_string(index) + ")";
  };
  std::vector<const FactorGroup*> groups;
  for (const auto& g : s->builder->groups()) groups.push_back(g.get());
  try {
    MovePhotoMeasurementsToDatum(s);  // inner constraints of a block without control
    stats::NetworkStatistics st = stats::ComputeStatistics(s->builder->problem(), groups, options);
    TransformPhotoMeasurementCovariance(s, &st);
    return st;
  } catch (const stats::DegenerateNetworkError& e) {
    throw AdjustFailure(AdjustStatus::kFailed, std::string("degenerate configuration: ") + e.what());
  }
}

/// One observation of a group in words (file:line where there is one) for the blunder list.
std::string DescribeObservation(const JointState& s, const FactorGroup& group, size_t block) {
  const size_t index = group.block_observation_index()[block];
  const std::string name = group.name();
  for (const auto& describe : {DescribePhotoObservation, DescribeRigObservation, DescribeSphereObservation,
                               DescribeMobileObservation, DescribeStaticLidarObservation, DescribePhotoMeasurement}) {
    std::string text = describe(s, name, index);
    if (!text.empty()) return text;
  }
  std::string text = DescribeNetworkObservation(s, group, block);
  return text.empty() ? group.name() + " #" + std::to_string(index) : text;
}

/// Data snooping (Baarda 1968), one round: observations whose studentized residual exceeds
/// the critical value and whose whitened residual exceeds outlier_sigma are excluded (survey
/// observations set passive). Returns the number excluded.
size_t Snoop(JointState* s, const stats::NetworkStatistics& st) {
  const double threshold = s->project->settings.outlier_sigma;
  std::map<std::pair<size_t, size_t>, std::pair<double, double>> worst;  // (group, block) → (w, e)
  for (const stats::RowStatistic& row : st.rows) {
    if (!row.critical || std::abs(row.whitened) <= threshold) continue;
    auto& w = worst[{row.group, row.block}];
    if (std::abs(row.studentized) > std::abs(w.first)) w = {row.studentized, row.whitened};
  }
  const auto& groups = s->builder->groups();
  for (const auto& [key, value] : worst) {
    const FactorGroup& group = *groups[key.first];
    if (group.role() == FactorRole::kConstraint) continue;  // check points are evaluated, constraints not snooped
    const size_t index = group.block_observation_index()[key.second];
    s->blunders.push_back({group.name(), DescribeObservation(*s, group, key.second), value.second, value.first});
    if (const auto* sg = dynamic_cast<const survey::SurveyGroup*>(&group)) {
      const survey::BlockSpec& spec = sg->added_specs()[key.second];
      for (size_t o : spec.observations) {
        s->joint->clusters[spec.cluster].observations[o].active = false;
        s->joint->clusters[spec.cluster].observations[o].passive_reason = "blunder (data snooping)";
      }
    } else if (group.name() == kGnss) {
      // The group's observation index is 3·mark + axis; the list it is rebuilt from holds marks.
      s->excluded[kGnss].insert(index / 3);
    } else if (group.name() == kGnssCamera) {
      s->excluded[kGnssCamera].insert(index / 3);  // the photo's antenna position, all 3 axes
    } else {
      s->excluded[group.name()].insert(index);
    }
  }
  // Excluded observation indices refer to the full lists; the groups are rebuilt from them.
  return worst.size();
}

/// Variance-component estimation (Förstner 1979): each group's σ is multiplied by the square
/// root of its variance component σ̂²_k = Σe²/Σr (groups with Σr ≥ 5; the check points are
/// not weighted). Survey groups scale their observations' σ and cluster covariances in the
/// joint network; the others at the next BuildProblem. Returns false when every factor is
/// within 1 % of 1 (converged).
bool ApplyVarianceComponents(JointState* s, const stats::NetworkStatistics& st) {
  bool changed = false;
  const auto& groups = s->builder->groups();
  for (size_t g = 0; g < groups.size(); ++g) {
    const stats::GroupStatistic& gs = st.groups.at(g);
    if (!VarianceComponentExemption(*s, *groups[g], gs.redundancy).empty() ||
        !(gs.variance_component > 0)) {
      continue;
    }
    const double f = std::sqrt(gs.variance_component);
    if (std::abs(f - 1.0) < 0.01) continue;
    changed = true;
    auto [it, inserted] = s->sigma_factor.emplace(groups[g]->name(), 1.0);
    it->second *= f;
    if (const auto* sg = dynamic_cast<const survey::SurveyGroup*>(groups[g].get())) {
      for (const survey::BlockSpec& spec : sg->added_specs()) {
        survey::Cluster& cluster = s->joint->clusters[spec.cluster];
        for (size_t o : spec.observations) cluster.ScaleObservationSigma(o, f);
      }
    }
  }
  return changed;
}


/// Reads every sensor and initialises its poses, in the order each needs the others: the
/// network and GNSS give the control, the photos are georeferenced on it (or placed by the
/// spheres, the rig, GNSS or the LiDAR), the LiDAR is read around them, the spherical stations
/// and the rig frames are registered to it.
void LoadSensors(JointState* s, const std::string& work_dir) {
  const Project& project = *s->project;
  spdlog::info("adjust: reading sensors of {}", project.path);
  LoadNetwork(s);
  LoadGnss(s);
  LoadPhotoMeasurements(s);
  LoadPhotos(s, work_dir);
  LoadSpheres(s);
  LoadRig(s);
  PlacePhotoBlock(s);
  RegisterPhotoBlockToLidar(s);
  LoadLidar(s);
  RegisterSphereStations(s);
  LoadMobile(s);
  RegisterImagesByMi(s, MiStage::kRigFrames);
  for (const OtherSensor& o : project.other_sensors) {
    s->warnings.push_back("sensor '" + o.id + "' (" + o.type + ") validated but not adjusted: not implemented in this version");
  }
}

/// Outer iteration k (0-based; the log counts from 2): ties the tie points, the scans' samples
/// and the mobile points to the LiDAR surface within `gate`. Returns the number of
/// associations; AdjustFailure when too few tie points or mobile points are on the surface.
size_t AssociateWithLidar(JointState* s, int k, double gate) {
  const size_t n = AssociateTiePoints(s, gate);
  Note(s, "outer iteration " + std::to_string(k + 2) + ": " + std::to_string(n) +
              " tie points on the LiDAR surface (gate " + std::to_string(gate) + " m)");
  if (n < 10) {
    throw AdjustFailure(AdjustStatus::kFailed, "only " + std::to_string(n) + " tie points lie within " + std::to_string(gate) +
                                                   " m of the LiDAR surface: no overlap, or the photo block is far from the LiDAR frame");
  }
  size_t associated = n;
  if (!s->scans.empty()) {
    const size_t ns = AssociateScans(s, gate);
    Note(s, "outer iteration " + std::to_string(k + 2) + ": " + std::to_string(ns) +
                " scan-to-scan point-to-plane pairs (gate " + std::to_string(gate) + " m)");
    associated += ns;
  }
  if (s->mobile) {
    // The mobile points: their own first gate (GNSS/INS errors), then the same schedule.
    const double mobile_gate = std::max(gate, k == 0 ? s->mobile->config->max_distance_m : 0.0);
    const size_t nm = AssociateMobile(s, mobile_gate);
    Note(s, "outer iteration " + std::to_string(k + 2) + ": " + std::to_string(nm) + " of " +
                std::to_string(s->mobile->sample.size()) + " mobile LiDAR points on the static surface (gate " +
                std::to_string(mobile_gate) + " m)");
    if (nm < 100) throw AdjustFailure(AdjustStatus::kFailed, MobileOverlapFailure(*s, nm, mobile_gate));
    associated += nm;
  }
  return associated;
}

/// First the photo block on the control alone (the LiDAR association needs it near its final
/// place), then outer iterations: associate with the LiDAR surface (gate shrinking from
/// max_distance_m to 3σ), solve, until the association no longer changes; then the solve to
/// the minimum.
void SolveWithAssociation(JointState* s, const AdjustOptions& options) {
  const Project& project = *s->project;
  SolveOnce(s, options, s->surface ? SolvePhase::kAssociation : SolvePhase::kFinal);
  s->outer_iterations = 1;
  RegisterImagesByMi(s, MiStage::kPhotos);
  if (!s->surface) return;
  const LidarStatic& lidar = project.lidar_static.front();
  double gate = lidar.max_distance_m;
  const double final_gate = 3 * std::hypot(lidar.surface_sigma_m, lidar.range_sigma_m);
  size_t previous = 0;
  for (int k = 0; k < project.settings.outer_iterations; ++k) {
    const size_t associated = AssociateWithLidar(s, k, gate);
    if (k > 0 && associated == previous && gate <= final_gate) break;
    previous = associated;
    SolveOnce(s, options, SolvePhase::kAssociation);
    s->outer_iterations = k + 2;
    gate = std::max(0.5 * gate, final_gate);
  }
  SolveOnce(s, options, SolvePhase::kFinal);
}

/// Statistics, one round of data snooping (and the solve without the blunders), the σ0 test
/// with the project's σ, then up to 4 passes of variance components.
void TestAndReweight(JointState* s, const AdjustOptions& options) {
  s->statistics = Statistics(s);
  if (Snoop(s, s->statistics) > 0) {
    Note(s, std::to_string(s->blunders.size()) + " observation(s) flagged as blunders and excluded; solving again");
    SolveOnce(s, options, SolvePhase::kFinal);
    s->statistics = Statistics(s);
  }
  s->given_weights = s->statistics;  // σ0 and its test with the σ of the project
  s->given_weights.cofactor.Clear();
  s->given_weights.rows.clear();
  if (s->project->settings.variance_components) {
    for (int k = 0; k < 4 && ApplyVarianceComponents(s, s->statistics); ++k) {
      Note(s, "variance components: re-weighting the groups (pass " + std::to_string(k + 1) + ")");
      SolveOnce(s, options, SolvePhase::kFinal);
      s->statistics = Statistics(s);
    }
  }
}

}  // namespace

AdjustOutcome RunAdjustment(const Project& project, const AdjustOptions& options) {
  AdjustOutcome outcome;
  Timer timer;
  JointState s;
  s.project = &project;
  s.plane = geodesy::LocalTangentPlane(project.origin, project.crs ? project.crs->ellipsoid() : geodesy::Ellipsoid());
  // Checked and locked before any work; the result is staged beside it and swapped in whole.
  OutputFolder output(options.output_dir, "--output", "mmba adjust", ProjectInputs(project));
  const std::string work_dir = output.path().string() + ".work";
  try {
    LoadSensors(&s, work_dir);
    SolveWithAssociation(&s, options);
    TestAndReweight(&s, options);
  } catch (const AdjustFailure& e) {
    outcome.status = AdjustStatusName(e.status());
    outcome.reason = e.what();
    return outcome;
  }
  s.seconds = timer.ElapsedSeconds();
  outcome.status = AdjustStatusName(AdjustStatus::kConverged);
  outcome.ok = true;
  // Nothing half-written: should writing throw, `output` removes the staging folder and an
  // earlier output stays as it was.
  WriteOutputs(s, options, output.staging(), &outcome);
  output.Commit();
  std::error_code ignored;
  fs::remove_all(work_dir, ignored);
  return outcome;
}

}  // namespace mmba::adjust
