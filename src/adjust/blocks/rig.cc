// The camera rig (Ladybug-style, on a vehicle): loading its calibration, frames with their
// GNSS/INS priors and its observations of the photo block's tie points, its factor groups and
// parameters, and its outputs (poses of every camera of every frame, the rig calibration).
// The MI registration of its panoramas is mi_init.cc.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <sstream>

#include <Eigen/Geometry>

#include "../output_support.h"
#include "blocks.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io/yaml_reader.h"

namespace mmba::adjust::internal {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

/// The rig calibration: body_from_rig (lever arm, boresight) and the cameras (Scene cameras
/// with ids from 2000001, their cam_from_rig).
void ReadRigCalibration(JointState* s, RigBlock* rig) {
  const CameraRig& config = *rig->config;
  const io::RigYaml calibration = io::ReadRigYaml(config.calibration);
  if (!calibration.body_from_rig) {
    throw InputError(config.calibration, 1, "body_from_rig", "nothing", "the key to be present");
  }
  rig->body_from_rig = *calibration.body_from_rig;
  uint64_t next_camera = 2000001;
  for (size_t k = 0; k < calibration.cameras.size(); ++k) {
    sensors::Camera camera = calibration.cameras[k];
    camera.camera_id = CameraId(next_camera++);
    s->scene.AddCamera(camera);
    rig->cameras.push_back(camera.camera_id);
    rig->camera_names.push_back(calibration.names[k]);
    s->scene.AddCamFromRig(camera.camera_id, calibration.cam_from_rig[k]);
    rig->cam_from_rig_initial.push_back(calibration.cam_from_rig[k]);
    rig->initial_params.push_back(camera.params);
  }
}

/// The frames of frames_file and their GNSS/INS pose priors (the trajectory through
/// body_from_rig), which are the Scene rig frames' initial values. Returns frame name → index.
std::map<std::string, size_t> ReadRigFrames(RigBlock* rig, Scene* scene) {
  const CameraRig& config = *rig->config;
  const std::vector<std::pair<double, Rigid3d>> trajectory = ReadTrajectory(config.trajectory);
  const io::CsvTable frames = io::CsvTable::Read(config.frames_file, {"frame", "time_s"});
  std::map<std::string, size_t> frame_index;
  for (const io::CsvTable::Row& row : frames.rows()) {
    const double time = frames.Double(row, "time_s");
    if (time < trajectory.front().first - 1.0 || time > trajectory.back().first + 1.0) {
      frames.Fail(row, "time_s", frames.String(row, "time_s"), "a time covered by the trajectory " + config.trajectory);
    }
    frame_index[frames.String(row, "frame")] = rig->frame_names.size();
    rig->frame_names.push_back(frames.String(row, "frame"));
    rig->frame_times.push_back(time);
    const Rigid3d world_from_rig = InterpolateTrajectory(trajectory, time) * rig->body_from_rig;
    scene->AddRigFrame(FrameId(rig->rig_prior.size()), world_from_rig.Inverse());
    rig->rig_prior.push_back(world_from_rig.Inverse());
  }
  return frame_index;
}

/// The observations file: image = <frame>_<camera>.<ext>, point ids of the tie block.
void ReadRigObservations(const JointState& s, const std::map<std::string, size_t>& frame_index, RigBlock* rig) {
  const CameraRig& config = *rig->config;
  const io::CsvTable table = io::CsvTable::Read(config.observations, {"image", "point_id", "x_px", "y_px"});
  for (const io::CsvTable::Row& row : table.rows()) {
    const std::string stem = fs::path(table.String(row, "image")).stem().string();
    const size_t underscore = stem.rfind('_');
    const std::string frame = underscore == std::string::npos ? "" : stem.substr(0, underscore);
    const std::string camera_name = underscore == std::string::npos ? "" : stem.substr(underscore + 1);
    const auto camera = std::find(rig->camera_names.begin(), rig->camera_names.end(), camera_name);
    if (!frame_index.count(frame) || camera == rig->camera_names.end()) {
      table.Fail(row, "image", table.String(row, "image"), "<frame>_<camera>.<ext> of a frame of " + config.frames_file +
                                                               " and a camera of " + config.calibration);
    }
    const double id = table.Double(row, "point_id");
    const Point3DId point3D_id(static_cast<uint64_t>(std::max(0.0, id)));
    if (id < 0 || id != std::floor(id) || !s.scene.HasPoint(point3D_id)) {
      table.Fail(row, "point_id", table.String(row, "point_id"), "a point3D id of photo collection '" + config.tie_block + "'");
    }
    const size_t k = camera - rig->camera_names.begin();
    const sensors::Camera& cam = s.scene.Camera(rig->cameras[k]);
    const Eigen::Vector2d xy(table.Double(row, "x_px"), table.Double(row, "y_px"));
    if (xy.x() < -0.5 || xy.y() < -0.5 || xy.x() > cam.width + 0.5 || xy.y() > cam.height + 0.5) {
      table.Fail(row, "x_px", table.String(row, "x_px") + ", " + table.String(row, "y_px"), "a pixel inside the image");
    }
    const double sigma = table.Double(row, "sigma_px", config.sigma_px);
    if (!(sigma > 0 && sigma <= 50)) table.Fail(row, "sigma_px", table.String(row, "sigma_px"), "a σ in (0, 50] px");
    rig->observations.push_back({frame_index.at(frame), k, point3D_id, xy, sigma});
    rig->sources.push_back(config.observations + ":" + std::to_string(row.line));
  }
}

}  // namespace

void LoadRig(JointState* s) {
  const Project& project = *s->project;
  if (project.rigs.empty()) return;
  if (project.rigs.size() > 1) {
    throw InputError::Message(ProjectKey(project, project.rigs[1].line, "sensors"),
                              "found a second camera_rig sensor with observations, expected one");
  }
  const CameraRig& config = project.rigs.front();
  if (!s->photos || s->photos->config->id != config.tie_block) {
    throw InputError::Message(ProjectKey(project, config.line, "tie_block"),
                              "found " + config.tie_block + ", expected the photo_collection whose tie points are observed");
  }
  RigBlock rig;
  rig.config = &config;
  ReadRigCalibration(s, &rig);
  const std::map<std::string, size_t> frame_index = ReadRigFrames(&rig, &s->scene);
  ReadRigObservations(*s, frame_index, &rig);
  Note(s, "camera rig '" + config.id + "': " + std::to_string(rig.frame_names.size()) + " frames x " +
              std::to_string(rig.cameras.size()) + " cameras, " + std::to_string(rig.observations.size()) +
              " tie-point observations; cam_from_rig " + PoseTreatmentName(config.cam_from_rig) + "; frame priors from " +
              config.trajectory + " (sigma " + std::to_string(config.trajectory_sigma_m) + " m, " +
              std::to_string(config.trajectory_sigma_deg) + " deg)");
  s->rig = std::move(rig);
}

namespace {

/// Rig cameras with fewer observations keep their calibration: their 8 fisheye parameters
/// would be undetermined and let the solver drift.
constexpr size_t kMinRigCameraObservations = 200;

/// Observations per rig camera.
std::vector<size_t> RigCameraObservations(const RigBlock& rig) {
  std::vector<size_t> count(rig.cameras.size(), 0);
  for (const RigObservation& o : rig.observations) ++count[o.camera];
  return count;
}

/// The rig cameras' parameter options: cam_from_rig held when fixed; the intrinsics indices
/// the rig's refine list holds (all of them for a camera with too few observations).
void SetRigParameterOptions(const JointState& s, ParameterOptions* options) {
  const RigBlock& rig = *s.rig;
  const RefineIntrinsics& refine = rig.config->refine;
  const std::vector<size_t> count = RigCameraObservations(rig);
  for (size_t k = 0; k < rig.cameras.size(); ++k) {
    if (rig.config->cam_from_rig == PoseTreatment::kFixed) options->constant_cams_from_rig.insert(rig.cameras[k]);
    const sensors::Camera& camera = s.scene.Camera(rig.cameras[k]);
    std::vector<int>& held = options->held_intrinsics[rig.cameras[k]];
    held.clear();
    if (count[k] < kMinRigCameraObservations) {
      for (size_t i = 0; i < camera.params.size(); ++i) held.push_back(static_cast<int>(i));
      continue;
    }
    const auto hold = [&](const std::vector<int>& idxs) { held.insert(held.end(), idxs.begin(), idxs.end()); };
    hold(sensors::CameraModelFixedIdxs(camera.model_id));
    if (!refine.focal) hold(sensors::CameraModelFocalIdxs(camera.model_id));
    if (!refine.principal_point) hold(sensors::CameraModelPrincipalIdxs(camera.model_id));
    const std::vector<int> extra = sensors::CameraModelExtraIdxs(camera.model_id);
    if (!refine.distortion) {
      hold(extra);
    } else if (refine.distortion_terms > 0 && static_cast<int>(extra.size()) > refine.distortion_terms) {
      hold(std::vector<int>(extra.begin() + refine.distortion_terms, extra.end()));
    }
  }
}

}  // namespace

void AddRigGroups(JointState* s, const GroupWeights& w) {
  RigBlock& rig = *s->rig;
  const CameraRig& c = *rig.config;
  s->builder->AddGroup(std::make_unique<RigReprojectionGroup>(w.Scaled(kRig, rig.observations), rig.cameras, c.loss, kRig));
  if (s->mobile && s->mobile->with_rig) {
    // The frames ride on the mobile LiDAR's corrected trajectory (its nodes carry the
    // GNSS/INS prior).
    const LidarMobile& mc = *s->mobile->config;
    s->builder->AddGroup(std::make_unique<RigTrajectoryGroup>(
        s->mobile->frames, &s->scene.trajectory_nodes(), rig.body_from_rig, mc.frame_sigma_m,
        mc.frame_sigma_deg * M_PI / 180.0, LossOptions(), kRigOnTrajectory)).set_role(FactorRole::kConstraint);
  } else {
    std::vector<Rigid3d*> frames;
    for (size_t f = 0; f < rig.frame_names.size(); ++f) frames.push_back(&s->scene.RigFrame(FrameId(f)));
    s->builder->AddGroup(std::make_unique<PosePriorGroup>(frames, rig.rig_prior, w.Factor(kRigPrior) * c.trajectory_sigma_m,
                                                          w.Factor(kRigPrior) * c.trajectory_sigma_deg * M_PI / 180.0, c.loss,
                                                          kRigPrior, rig.frame_times, c.trajectory_correlation_s))
        .set_role(FactorRole::kPrior);
  }
  if (!rig.mi.empty()) {
    std::vector<MiResult> mi = rig.mi;
    for (size_t i = 0; i < mi.size(); ++i) mi[i].pose = &s->scene.RigFrame(FrameId(rig.mi_frame[i]));
    s->builder->AddGroup(std::make_unique<MiPriorGroup>(w.Kept(kRigMi, mi), w.Factor(kRigMi) * w.Factor(kRigMi), c.loss, kRigMi))
        .set_role(FactorRole::kPrior);
  }
  if (c.cam_from_rig == PoseTreatment::kWeighted) {
    std::vector<Rigid3d*> cameras;
    for (CameraId id : rig.cameras) cameras.push_back(&s->scene.CamFromRig(id));
    s->builder->AddGroup(std::make_unique<PosePriorGroup>(
        cameras, rig.cam_from_rig_initial, w.Factor(kRigCalibration) * c.cam_from_rig_sigma_m,
        w.Factor(kRigCalibration) * c.cam_from_rig_sigma_deg * M_PI / 180.0, LossOptions(), kRigCalibration))
        .set_role(FactorRole::kPrior);
  }
  SetRigParameterOptions(*s, &s->builder->parameter_options());
}

void WarnHeldRigIntrinsics(JointState* s) {
  const RigBlock& rig = *s->rig;
  const std::vector<size_t> count = RigCameraObservations(rig);
  for (size_t k = 0; k < rig.cameras.size(); ++k) {
    if (count[k] >= kMinRigCameraObservations ||
        !s->builder->problem().HasParameterBlock(s->scene.Camera(rig.cameras[k]).params.data())) {
      continue;
    }
    const std::string warning = "rig camera " + rig.camera_names[k] + ": " + std::to_string(count[k]) +
                                " observations, intrinsics held at the calibration (fewer than " +
                                std::to_string(kMinRigCameraObservations) + ")";
    if (std::find(s->warnings.begin(), s->warnings.end(), warning) == s->warnings.end()) s->warnings.push_back(warning);
  }
}

std::string DescribeRigObservation(const JointState& s, const std::string& name, size_t index) {
  if (!s.rig) return "";
  const RigBlock& rig = *s.rig;
  if (name == kRig) {
    const RigObservation& o = rig.observations[index];
    return "point " + std::to_string(o.point3D_id.value) + " in " + rig.frame_names[o.frame] + "_" +
           rig.camera_names[o.camera] + " (" + rig.sources[index] + ")";
  }
  if (name == kRigPrior) return "GNSS/INS prior of rig frame " + rig.frame_names[index];
  if (name == kRigMi) return "MI pose of rig frame " + rig.frame_names[rig.mi_frame[index]] + " (" + rig.mi[index].source + ")";
  if (name == kRigMiMobile) {
    return "MI pose of rig frame " + rig.frame_names[rig.mi_mobile[index].frame] + " on the mobile LiDAR (" +
           rig.mi_mobile[index].source + ")";
  }
  if (name == kRigCalibration) return "cam_from_rig prior of " + rig.camera_names[index];
  if (name == kRigOnTrajectory) return "rig frame " + rig.frame_names[index] + " on the trajectory";
  return "";
}

namespace {

/// calibration/<id>_rig.yaml: cam_from_rig and intrinsics with σ, in the input schema; and the
/// rig's calibration table.
void WriteRigCalibration(const JointState& s, OutputSink* out) {
  const RigBlock& rig = *s.rig;
  const stats::NetworkStatistics& st = s.statistics;
  std::ostringstream yaml;
  json parameters = json::array();
  yaml << "# mmba adjust: calibration of the camera rig '" << rig.config->id << "' (cam_from_rig "
       << PoseTreatmentName(rig.config->cam_from_rig) << "), sigma from the adjustment\nbody_from_rig: {qvec_wxyz: ["
       << std::setprecision(10) << rig.body_from_rig.rotation.w() << ", " << rig.body_from_rig.rotation.x() << ", "
       << rig.body_from_rig.rotation.y() << ", " << rig.body_from_rig.rotation.z() << "], tvec: ["
       << rig.body_from_rig.translation.x() << ", " << rig.body_from_rig.translation.y() << ", "
       << rig.body_from_rig.translation.z() << "]}\ncameras:\n";
  for (size_t k = 0; k < rig.cameras.size(); ++k) {
    const sensors::Camera& camera = s.scene.Camera(rig.cameras[k]);
    const Rigid3d& cr = s.scene.CamFromRig(rig.cameras[k]);
    const std::vector<double> sigma = ParameterSigmas(st, s.builder->problem(), camera.params.data());
    const std::vector<double> t_sigma = ParameterSigmas(st, s.builder->problem(), cr.translation.data());
    yaml << "  - name: " << rig.camera_names[k] << "\n    model: " << camera.ModelName() << "\n    width: "
         << camera.width << "\n    height: " << camera.height << "\n    params: [";
    for (size_t i = 0; i < camera.params.size(); ++i) yaml << (i ? ", " : "") << std::setprecision(10) << camera.params[i];
    yaml << "]\n    sigma: [";
    for (size_t i = 0; i < sigma.size(); ++i) yaml << (i ? ", " : "") << std::setprecision(4) << sigma[i];
    yaml << "]\n    cam_from_rig: {qvec_wxyz: [" << std::setprecision(10) << cr.rotation.w() << ", " << cr.rotation.x()
         << ", " << cr.rotation.y() << ", " << cr.rotation.z() << "], tvec: [" << cr.translation.x() << ", "
         << cr.translation.y() << ", " << cr.translation.z() << "]}\n    cam_from_rig_tvec_sigma: [" << std::setprecision(4)
         << t_sigma[0] << ", " << t_sigma[1] << ", " << t_sigma[2] << "]\n";
    parameters.push_back({{"name", rig.camera_names[k] + " f"}, {"initial", rig.initial_params[k][0]},
                          {"adjusted", camera.params[0]}, {"sigma", sigma[0]}});
    parameters.push_back({{"name", rig.camera_names[k] + " cam_from_rig shift [m]"}, {"initial", 0.0},
                          {"adjusted", (CameraCentre(cr) - CameraCentre(rig.cam_from_rig_initial[k])).norm()},
                          {"sigma", std::sqrt(t_sigma[0] * t_sigma[0] + t_sigma[1] * t_sigma[1] + t_sigma[2] * t_sigma[2])}});
  }
  WriteText(out->stage / "calibration" / (rig.config->id + "_rig.yaml"), yaml.str());
  out->calibrations.push_back({{"name", rig.config->id + " camera rig"}, {"parameters", parameters}});
}

}  // namespace

void WriteRigOutputs(const JointState& s, OutputSink* out) {
  const RigBlock& rig = *s.rig;
  for (size_t f = 0; f < rig.frame_names.size(); ++f) {
    const Rigid3d& pose = s.scene.RigFrame(FrameId(f));
    const Eigen::Vector3d d = CameraCentre(pose) - CameraCentre(rig.rig_prior[f]);
    const double d_rotation = pose.rotation.angularDistance(rig.rig_prior[f].rotation) * kDeg;
    out->corrections.push_back({{"image", rig.frame_names[f]}, {"sensor", rig.config->id}, {"d", Vec(d)},
                                {"d_position_m", d.norm()}, {"d_rotation_deg", d_rotation}});
    const Eigen::Vector3d sigma = CentreCovariance(s.statistics, pose).diagonal().cwiseMax(0.0).cwiseSqrt();
    for (size_t k = 0; k < rig.cameras.size(); ++k) {
      const Rigid3d cam_from_world = s.scene.CamFromRig(rig.cameras[k]) * pose;
      AppendPoseRow(*out->poses, rig.frame_names[f] + "_" + rig.camera_names[k], rig.config->id,
                    CameraCentre(cam_from_world), cam_from_world.rotation, s.plane, sigma, d.norm(), d_rotation);
    }
  }
  WriteRigCalibration(s, out);
}

}  // namespace mmba::adjust::internal
