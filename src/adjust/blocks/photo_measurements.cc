// A photogrammetric network from image measurements (`type: photo_measurements`): its files
// read through `columns`, the initial orientation without COLMAP (space resection from the
// control, relative orientation, forward intersection; orientation/block_initialisation.h),
// its factor groups (image points with σ = sigma_px, control coordinates, scale bars), the
// datum of a block without control, and its outputs (images.csv, points.csv, report.json
// `photo_measurements`).
#include "photo_measurements.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include <ceres/ceres.h>
#include <spdlog/spdlog.h>

#include "../output_support.h"
#include "blocks.h"
#include "mmba/core/error.h"
#include "mmba/factors/coordinate_observation.h"
#include "mmba/factors/distance_observation.h"
#include "mmba/factors/reprojection_error.h"
#include "mmba/geometry/opk.h"
#include "mmba/geometry/pose_manifold.h"
#include "mmba/io/column_text.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io/image_measurements.h"

namespace mmba::adjust::internal {
namespace {

using json = nlohmann::json;

/// Scene ids of the block: images and the points that the statistics eliminate (Schur; their
/// covariance is then formed in photo_measurements_datum.cc) from here, the points kept in the
/// statistics' cofactor (scale-bar ends, check points) from kCheckPointIdBase up.
constexpr uint64_t kImageIdBase = 3000000000ULL;
constexpr uint64_t kPointIdBase = 3000000000ULL;
constexpr uint64_t kFreePointIdBase = kCheckPointIdBase + 100000000ULL;
constexpr uint64_t kCameraId = 3000001;

/// The control coordinates of the photo block: weighted, fixed or withheld (check points).
class ControlGroup : public FactorGroup {
 public:
  ControlGroup(std::vector<ControlCoordinate> c, LossOptions loss, std::string name)
      : FactorGroup(std::move(name), "m", loss), c_(std::move(c)) {}
  void AddResiduals(Scene& scene, ceres::Problem& problem) override {
    for (size_t i = 0; i < c_.size(); ++i) {
      AddBlock(problem, new factors::ScalarPriorCost(c_[i].axis, c_[i].value_m, c_[i].sigma_m),
               {scene.Point(c_[i].point).data()}, c_[i].sigma_m, i);
    }
  }
  bool FixesDatum() const override { return true; }

 private:
  std::vector<ControlCoordinate> c_;
};

struct BarObservation {
  Point3DId from, to;
  double distance_m = 0.0;
  double sigma = 0.0;  ///< m (GroupWeights::Scaled scales `sigma`)
};

class ScaleBarGroup : public FactorGroup {
 public:
  ScaleBarGroup(std::vector<BarObservation> bars, std::string name)
      : FactorGroup(std::move(name), "m", LossOptions()), bars_(std::move(bars)) {}
  void AddResiduals(Scene& scene, ceres::Problem& problem) override {
    for (size_t i = 0; i < bars_.size(); ++i) {
      AddBlock(problem, new factors::DistanceCost(bars_[i].distance_m, bars_[i].sigma),
               {scene.Point(bars_[i].from).data(), scene.Point(bars_[i].to).data()}, bars_[i].sigma, i);
    }
  }

 private:
  std::vector<BarObservation> bars_;
};

std::vector<BarObservation> Bars(const JointState& s) {
  std::vector<BarObservation> bars;
  for (size_t i = 0; i < s.project->scale_bars.size(); ++i) {
    const ScaleBar& b = s.project->scale_bars[i];
    bars.push_back({s.measured->bar_points[i].first, s.measured->bar_points[i].second, b.distance_m, b.sigma_m});
  }
  return bars;
}

/// Every measurement file read, checked against the camera's image.
std::vector<io::ImageMeasurement> ReadMeasurements(const PhotoMeasurements& p, const sensors::Camera& camera) {
  std::vector<io::ImageMeasurement> all;
  for (const io::MeasurementFile& f : p.measurements) {
    for (io::ImageMeasurement& m : io::ReadImageMeasurements(f)) {
      io::CheckInsideImage(m, camera.width, camera.height);
      all.push_back(std::move(m));
    }
  }
  return all;
}

/// The points of the project's control file (none without one).
std::vector<io::ControlPoint> ReadControlFile(const Project& project) {
  if (!project.control) return {};
  const ControlFile& c = *project.control;
  return io::ReadControlPoints(c.file, c.columns, c.sigma_m >= 0 ? std::optional<double>(c.sigma_m) : std::nullopt);
}

/// The control file and the gcp_lists: weighted and fixed points to `control`, check points withheld.
std::map<std::string, io::ControlPoint> ReadControl(const JointState& s, std::map<std::string, Eigen::Vector3d>* check) {
  const Project& project = *s.project;
  std::map<std::string, io::ControlPoint> control;
  for (io::ControlPoint& p : ReadControlFile(project)) {
    const int zero = (p.sigma_m.array() == 0).count();
    if (zero != 0 && zero != 3) {
      throw InputError(p.file, p.line, "sigma", "σ 0 on " + std::to_string(zero) + " of 3 coordinates (point " + p.id + ")",
                       "σ 0 on all three coordinates (fixed) or none (weighted)");
    }
    if (const auto crs = ProjectCrsFrame(project)) p.xyz_m = crs->WorldFromCrs(p.xyz_m);  // the project's crs → world
    control.emplace(p.id, std::move(p));
  }
  AppendGcpControl(project, &control);
  for (const std::string& id : project.check_points) {
    const auto it = control.find(id);
    if (it == control.end()) {
      if (!project.total_stations.empty()) continue;  // a point of the network
      throw InputError(project.path, 0, "check_points", id, "the id of a point of the control file or a gcp_list");
    }
    (*check)[id] = it->second.xyz_m;
    control.erase(it);
  }
  return control;
}

/// The prior EO file: image, x, y, z (projection centre, world metres), omega, phi, kappa
/// (degrees, geometry/opk.h) through its columns.
std::map<std::string, Rigid3d> ReadPriorEo(const PhotoMeasurements& p) {
  std::map<std::string, Rigid3d> poses;
  if (p.prior_eo.empty()) return poses;
  const std::vector<std::string>& c = p.prior_eo_columns;
  io::ForEachColumnLine(p.prior_eo, [&](int64_t line, const std::vector<std::string>& fields) {
    const io::ColumnRow row(p.prior_eo, line, &fields, &c);
    if (fields.size() != c.size()) row.Text(std::max(fields.size(), c.size()) - 1);
    const auto number = [&](const char* name) { return row.Number(io::ColumnIndex(c, name)); };
    OpkPose opk;
    opk.center_in_world = {number("x"), number("y"), number("z")};
    opk.omega_rad = number("omega") * M_PI / 180.0;
    opk.phi_rad = number("phi") * M_PI / 180.0;
    opk.kappa_rad = number("kappa") * M_PI / 180.0;
    poses[row.Text(io::ColumnIndex(c, "image"))] = CamFromWorldFromOpk(opk);
  });
  return poses;
}

/// The start camera refined on an initial block: its poses and points free (control points
/// held in a control frame, the first pose in an arbitrary one), the project's refine set
/// free, a Cauchy loss of scale 4 px against wrongly placed rays. The nominal camera's
/// distortion (DBAT's camcaldemo: 116 px at the corners) keeps images from the 8 px
/// resection; with this camera a second initialisation reaches them.
sensors::Camera RefineStartCamera(const sensors::Camera& camera, const orientation::BlockInput& input,
                                  const orientation::BlockResult& block, const std::vector<int>& free) {
  sensors::Camera refined = camera;
  std::map<std::string, Rigid3d> poses = block.cam_from_world;
  std::map<std::string, Eigen::Vector3d> points = block.points;
  ceres::Problem problem;
  for (const orientation::BlockMeasurement& m : input.measurements) {
    const auto pose = poses.find(m.image_id);
    const auto point = points.find(m.point_id);
    if (pose == poses.end() || point == points.end()) continue;
    problem.AddResidualBlock(factors::CreateReprojectionCost(refined.model_id, m.xy_px, 1.0, refined.params.data()),
                             new ceres::CauchyLoss(4.0), pose->second.rotation.coeffs().data(),
                             pose->second.translation.data(), point->second.data(), refined.params.data());
  }
  if (!problem.HasParameterBlock(refined.params.data())) return camera;
  for (auto& [image, pose] : poses) {
    if (problem.HasParameterBlock(pose.rotation.coeffs().data())) {
      problem.SetManifold(pose.rotation.coeffs().data(), CreateQuaternionManifold().release());
    }
  }
  const bool in_control_frame = block.frame.find("arbitrary") == std::string::npos;
  for (auto& [id, xyz] : points) {
    if (in_control_frame && input.control.count(id) && problem.HasParameterBlock(xyz.data())) {
      problem.SetParameterBlockConstant(xyz.data());
    }
  }
  if (!in_control_frame) {
    Rigid3d& first = poses.begin()->second;
    problem.SetParameterBlockConstant(first.rotation.coeffs().data());
    problem.SetParameterBlockConstant(first.translation.data());
  }
  std::vector<int> held;
  for (int k = 0; k < static_cast<int>(refined.params.size()); ++k) {
    if (std::find(free.begin(), free.end(), k) == free.end()) held.push_back(k);
  }
  problem.SetManifold(refined.params.data(), new ceres::SubsetManifold(static_cast<int>(refined.params.size()), held));
  ceres::Solver::Options options;
  options.max_num_iterations = 50;
  options.linear_solver_type = ceres::SPARSE_SCHUR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const bool finite = std::all_of(refined.params.begin(), refined.params.end(), [](double v) { return std::isfinite(v); });
  return summary.IsSolutionUsable() && finite ? refined : camera;
}

/// The initial block; while the camera leaves images unoriented or, with 3 or more control
/// points, the block in an arbitrary frame, the block again with the camera refined on the
/// previous one (RefineStartCamera; at most kCameraRounds times), kept while it orients more
/// images or reaches the control frame. `camera` becomes the camera of the block kept; `note`
/// says how often it was refined (empty when never).
orientation::BlockResult InitialiseSelfCalibrating(orientation::BlockInput input, const std::vector<int>& free,
                                                   sensors::Camera* camera, std::string* note) {
  constexpr int kCameraRounds = 3;
  input.camera = camera;
  orientation::BlockResult best = orientation::InitialiseBlock(input, orientation::BlockOptions{});
  const auto arbitrary = [&](const orientation::BlockResult& r) {
    return input.control.size() >= 3 && r.frame.find("arbitrary") != std::string::npos;
  };
  std::vector<std::string> rounds;
  for (int round = 0; round < kCameraRounds; ++round) {
    if ((best.failed_images.empty() && !arbitrary(best)) || free.empty() || best.cam_from_world.size() < 2) break;
    const sensors::Camera refined = RefineStartCamera(*camera, input, best, free);
    input.camera = &refined;
    orientation::BlockResult again = orientation::InitialiseBlock(input, orientation::BlockOptions{});
    if (again.cam_from_world.size() < best.cam_from_world.size() ||
        (again.cam_from_world.size() == best.cam_from_world.size() && arbitrary(again) >= arbitrary(best))) {
      break;
    }
    rounds.push_back(std::to_string(best.cam_from_world.size()) + " images (" + best.frame + ")");
    best = std::move(again);
    *camera = refined;
  }
  if (!rounds.empty()) {
    std::string text = "the start camera refined on a first block of " + rounds[0];
    for (size_t k = 1; k < rounds.size(); ++k) text += ", again on " + rounds[k];
    *note = text + "; the block initialised again with it";
    best.log.insert(best.log.begin(), *note);
  }
  return best;
}

/// Runs the initialisation and logs it; AdjustFailure when no image could be oriented.
void Initialise(JointState* s, sensors::Camera* camera, const std::vector<io::ImageMeasurement>& all,
                const std::map<std::string, io::ControlPoint>& control) {
  MeasurementBlock& b = *s->measured;
  orientation::BlockInput input;
  std::set<std::string> seen;
  for (const io::ImageMeasurement& m : all) {
    if (seen.insert(m.image_id).second) input.images.push_back(m.image_id);
    input.measurements.push_back({m.image_id, m.point_id, m.xy_px});
  }
  for (const auto& [id, p] : control) input.control[id] = p.xyz_m;
  input.prior_cam_from_world = ReadPriorEo(*b.config);
  std::string camera_note;
  b.initial = InitialiseSelfCalibrating(input, b.config->free_intrinsics, camera, &camera_note);
  for (const std::string& line : b.initial.log) spdlog::debug("adjust: {}: {}", b.config->id, line);
  const std::string& id = b.config->id;
  Note(s, "photo measurements '" + id + "': " + std::to_string(b.initial.cam_from_world.size()) + " of " +
              std::to_string(input.images.size()) + " images oriented without COLMAP (" + b.initial.frame + "), " +
              std::to_string(b.initial.points.size()) + " points, " + std::to_string(b.initial.outliers.size()) +
              " measurements off by more than the RANSAC threshold at the start (kept: the bundle's loss and data snooping judge them)" +
              (camera_note.empty() ? "" : "; " + camera_note));
  for (const orientation::InitialOutlier& o : b.initial.outliers) {
    spdlog::info("adjust: photo measurements '{}': point {} in image {} off by {:.1f} px at the initialisation ({})", id,
                 o.point_id, o.image_id, o.error_px, o.stage);
  }
  for (const auto& [image, reason] : b.initial.failed_images) {
    s->warnings.push_back("photo measurements '" + id + "': image " + image + " not oriented: " + reason);
  }
  for (const auto& [point, reason] : b.initial.failed_points) {
    s->warnings.push_back("photo measurements '" + id + "': point " + point + " not adjusted: " + reason);
  }
  if (b.initial.cam_from_world.empty()) {
    throw AdjustFailure(AdjustStatus::kFailed, "photo measurements '" + id + "': no image could be oriented (" +
                                                   (b.initial.log.empty() ? "no seed" : b.initial.log.back()) + ")");
  }
}

/// The Scene's camera, images and points from the initialisation; the observations kept.
void FillScene(JointState* s, const sensors::Camera& camera, const std::vector<io::ImageMeasurement>& all) {
  MeasurementBlock& b = *s->measured;
  std::set<std::string> bar_ends;
  for (const ScaleBar& bar : s->project->scale_bars) bar_ends.insert({bar.from, bar.to});
  size_t next_point = 0;
  for (const auto& [id, xyz] : b.initial.points) {
    const bool free = bar_ends.count(id) || b.check_reference.count(id);
    const Point3DId pid((free ? kFreePointIdBase : kPointIdBase) + next_point++);
    s->scene.AddPoint(pid, xyz);
    b.point_of[id] = pid;
    b.point_name[pid] = id;
  }
  for (const auto& [id, pose] : b.initial.cam_from_world) {
    const ImageId iid(kImageIdBase + b.image_names.size());
    b.image_names.push_back(id);
    b.image_of[id] = iid;
    s->scene.AddImage(iid, b.camera_id, pose);
    b.initial_poses[iid] = pose;
  }
  for (const io::ImageMeasurement& m : all) {
    // The initialisation's outliers stay: with the start camera's distortion unknown (DBAT's
    // camcaldemo: 116 px at the corners) most are good measurements; the bundle's robust loss
    // and data snooping judge them.
    if (!b.image_of.count(m.image_id) || !b.point_of.count(m.point_id)) continue;
    b.observations.push_back({b.image_of.at(m.image_id), b.point_of.at(m.point_id), m.xy_px, m.sigma_px.mean()});
    b.sources.push_back(m.file + ":" + std::to_string(m.line));
  }
}

/// 1 or 2 control points measured in the images: an input error naming the control file. They
/// fix no datum (2 points leave the rotation about their line free) and, held, contradict the
/// inner constraints that a block without control takes.
void CheckControlCount(const Project& project, const std::map<std::string, io::ControlPoint>& control,
                       const std::map<std::string, Point3DId>& measured) {
  std::vector<const io::ControlPoint*> used;
  for (const auto& [id, c] : control) {
    if (measured.count(id)) used.push_back(&c);
  }
  if (used.empty() || used.size() >= 3) return;
  std::string ids;
  for (const io::ControlPoint* c : used) ids += (ids.empty() ? "" : ", ") + c->id;
  throw InputError(used.front()->file, used.front()->line, "control",
                   std::to_string(used.size()) + " control point(s) measured in the images (" + ids + ")",
                   "3 or more control points measured in 2+ images, or none (inner constraints" +
                       std::string(project.scale_bars.empty() ? "" : " with the scale bars") + ")");
}

}  // namespace

void LoadPhotoMeasurements(JointState* s) {
  const Project& project = *s->project;
  if (project.photo_measurements.empty()) return;
  if (project.photo_measurements.size() > 1) {
    throw InputError(project.path, project.photo_measurements[1].line, "type", "photo_measurements",
                     "one photo_measurements sensor in this version");
  }
  const PhotoMeasurements& p = project.photo_measurements.front();
  s->measured = std::make_shared<MeasurementBlock>();
  MeasurementBlock& b = *s->measured;
  b.config = &p;
  sensors::Camera camera = io::ReadCameraFile(p.camera).camera;
  camera.camera_id = CameraId(kCameraId);
  if (!std::unique_ptr<ceres::CostFunction>(
          factors::CreateReprojectionCost(camera.model_id, Eigen::Vector2d::Zero(), 1.0, camera.params.data()))) {
    throw InputError(p.camera, 0, "model", camera.ModelName(), "a camera model with a reprojection residual");
  }
  b.camera_id = camera.camera_id;
  b.initial_params = camera.params;
  if (!p.images.empty()) b.image_files = io::ReadImageList(p.images);
  std::vector<io::ImageMeasurement> all = ReadMeasurements(p, camera);
  AppendGcpMeasurements(p, camera, b.image_files, &all);
  const std::map<std::string, io::ControlPoint> control = ReadControl(*s, &b.check_reference);
  Initialise(s, &camera, all, control);  // the camera refined when the start camera orients too few images
  s->scene.AddCamera(camera);
  FillScene(s, camera, all);
  for (const auto& [id, c] : control) {
    const auto it = b.point_of.find(id);
    if (it == b.point_of.end()) continue;  // not measured (or not intersected: a warning says so)
    s->scene.Point(it->second) = c.xyz_m;
    if (c.Fixed()) {
      b.fixed_points.insert(it->second);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      b.control.push_back({it->second, k, c.xyz_m[k], c.sigma_m[k], c.file + ":" + std::to_string(c.line)});
    }
  }
  for (const ScaleBar& bar : project.scale_bars) {
    for (const std::string& end : {bar.from, bar.to}) {
      if (!b.point_of.count(end)) {
        throw InputError(project.path, bar.line, "scale_bars.from/to", end,
                         "a point of the photo measurements with coordinates (measured in 2+ oriented images)");
      }
    }
    b.bar_points.push_back({b.point_of.at(bar.from), b.point_of.at(bar.to)});
  }
  CheckControlCount(project, control, b.point_of);
  if (b.fixed_points.size() + b.control.size() / 3 >= 3) {
    b.datum = "control: " + std::to_string(b.fixed_points.size()) + " fixed, " + std::to_string(b.control.size() / 3) +
              " weighted points";
    return;
  }
  // No control: the solve fixes a minimal datum — the first image's pose and, without a scale
  // bar, its distance to the second (the block's scale); with scale bars the first pose only —
  // and photo_measurements_datum.cc moves the solution and its covariance into the inner
  // constraints over the object points.
  b.gauge_needed = true;
  const ImageId first(kImageIdBase);
  const std::string points = std::to_string(b.point_of.size());
  if (!project.scale_bars.empty()) {
    b.gauge.kind = GaugeOptions::Kind::kFixedImages;
    b.gauge.fixed_images = {first};
    b.datum = "inner constraints: free network of minimum trace over the " + points +
              " points (rotation and translation w.r.t. their approximations), scale from " +
              std::to_string(project.scale_bars.size()) + " scale bar(s)";
  } else {
    b.gauge.kind = GaugeOptions::Kind::kTwoPoses;
    b.gauge.first = first;
    b.gauge.second = ImageId(kImageIdBase + 1);
    b.datum = "inner constraints: free network of minimum trace over the " + points +
              " points (rotation, translation and scale w.r.t. their approximations; arbitrary scale)";
  }
}

GaugeOptions PhotoMeasurementGauge(const JointState& s) {
  GaugeOptions none;
  none.kind = GaugeOptions::Kind::kNone;
  return s.measured && s.measured->gauge_needed ? s.measured->gauge : none;
}

void AddPhotoMeasurementGroups(JointState* s, const GroupWeights& w) {
  const MeasurementBlock& b = *s->measured;
  s->builder->AddGroup(std::make_unique<ReprojectionGroup>(w.Scaled(kMeasured, b.observations), b.config->loss, kMeasured));
  if (!b.control.empty()) {
    s->builder->AddGroup(std::make_unique<ControlGroup>(w.Kept(kMeasuredControl, b.control), LossOptions(), kMeasuredControl))
        .set_role(FactorRole::kPrior);
  }
  if (!b.bar_points.empty()) {
    s->builder->AddGroup(std::make_unique<ScaleBarGroup>(Bars(*s), kScaleBars)).set_role(FactorRole::kPrior);
  }
  ParameterOptions& parameters = s->builder->parameter_options();
  std::vector<int> held;
  const std::vector<int>& free = b.config->free_intrinsics;
  for (int k = 0; k < static_cast<int>(b.initial_params.size()); ++k) {
    if (std::find(free.begin(), free.end(), k) == free.end()) held.push_back(k);
  }
  parameters.held_intrinsics[b.camera_id] = held;
  parameters.constant_points.insert(b.fixed_points.begin(), b.fixed_points.end());
}

std::string DescribePhotoMeasurement(const JointState& s, const std::string& name, size_t index) {
  if (!s.measured) return "";
  const MeasurementBlock& b = *s.measured;
  if (name == kMeasured) {
    const ReprojectionObservation& o = b.observations[index];
    return "point " + b.point_name.at(o.point3D_id) + " in image " + PhotoMeasurementImageName(s, o.image_id) + " (" +
           b.sources[index] + ")";
  }
  if (name == kMeasuredControl) {
    const ControlCoordinate& c = b.control[index];
    return std::string(1, "xyz"[c.axis]) + " of control point " + b.point_name.at(c.point) + " (" + c.source + ")";
  }
  if (name == kScaleBars) {
    const ScaleBar& bar = s.project->scale_bars[index];
    return "scale bar " + bar.from + " - " + bar.to;
  }
  return "";
}

std::string PhotoMeasurementImageName(const JointState& s, ImageId id) {
  if (!s.measured || id.value < kImageIdBase || id.value - kImageIdBase >= s.measured->image_names.size()) return "";
  return s.measured->image_names[id.value - kImageIdBase];
}

}  // namespace mmba::adjust::internal
