// Truth evaluation of a simulated project (report.json `truth_evaluation`): the adjusted poses,
// calibrations and points against the simulator's truth.json, per sensor. Never used by the
// adjustment itself.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <Eigen/Geometry>

#include "internal.h"
#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"
#include "output_support.h"

namespace mmba::adjust::internal {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

Rigid3d PoseFromJson(const json& j) {
  const std::vector<double> q = j["qvec_wxyz"], t = j["tvec"];
  return Rigid3d(Eigen::Quaterniond(q[0], q[1], q[2], q[3]), Eigen::Vector3d(t[0], t[1], t[2]));
}

/// The photo centres (RMSE, max) and rotations (max), the photo camera's parameters.
void EvaluatePhotos(const JointState& s, json& truth, json* out) {
  double sum = 0.0, worst = 0.0, worst_rotation = 0.0;
  size_t n = 0;
  std::map<std::string, ImageId> by_name;
  for (const auto& [id, image] : s.photos->model.images) by_name[image.name] = id;
  for (const json& t : truth["photos"]["images"]) {
    const auto it = by_name.find(t["name"].get<std::string>());
    if (it == by_name.end()) continue;
    const Rigid3d true_pose = PoseFromJson(t["cam_from_world"]);
    const Rigid3d& pose = s.scene.Image(it->second).cam_from_world;
    const double d = (CameraCentre(pose) - CameraCentre(true_pose)).norm();
    sum += d * d;
    worst = std::max(worst, d);
    worst_rotation = std::max(worst_rotation, pose.rotation.angularDistance(true_pose.rotation) * kDeg);
    ++n;
  }
  (*out)["photo_positions"] = {{"images", n}, {"rmse_m", n ? std::sqrt(sum / n) : 0.0}, {"max_m", worst},
                            {"max_rotation_deg", worst_rotation}};
  const std::vector<double> true_params = truth["photos"]["camera"]["params"];
  const std::vector<double>& params = s.scene.Camera(s.photos->model.cameras.begin()->first).params;
  (*out)["photo_camera"] = {{"adjusted", params}, {"true", true_params}, {"initial", s.photos->initial_params}};
}

/// The spherical stations' positions and rotations (after the lower cx datum), both spheres'
/// parameters and the baseline.
void EvaluateSpheres(const JointState& s, json& truth, json* out) {
  const json& t = truth["spherical_stereo"];
  double worst = 0.0, worst_rotation = 0.0;
  // The lower cx is the heading datum: a cx offset from the truth is a rotation about the
  // sphere's y axis by α = (cx_true − cx)/f, removed before comparing orientations.
  const std::vector<double> true_lower = t["lower_camera"]["params"];
  const std::vector<double>& lower = s.scene.Camera(s.spheres->lower_camera).params;
  const double alpha = (true_lower[1] - lower[1]) / lower[0];
  for (const json& station : t["stations"]) {
    const auto it = s.spheres->lower_image.find(station["name"].get<std::string>());
    if (it == s.spheres->lower_image.end()) continue;
    const Rigid3d true_pose = PoseFromJson(station["lower_from_world"]);
    const Rigid3d& pose = s.scene.Image(it->second).cam_from_world;
    worst = std::max(worst, (CameraCentre(pose) - CameraCentre(true_pose)).norm());
    const Eigen::Quaterniond expected = Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitY()) * true_pose.rotation;
    worst_rotation = std::max(worst_rotation, pose.rotation.angularDistance(expected) * kDeg);
  }
  (*out)["spheres"] = {{"max_position_m", worst}, {"max_rotation_deg_after_cx_datum", worst_rotation},
                    {"lower_params", {{"adjusted", s.scene.Camera(s.spheres->lower_camera).params},
                                      {"true", t["lower_camera"]["params"]}, {"initial", s.spheres->initial_lower_params}}},
                    {"upper_params", {{"adjusted", s.scene.Camera(s.spheres->upper_camera).params},
                                      {"true", t["upper_camera"]["params"]}, {"initial", s.spheres->initial_upper_params}}},
                    {"baseline", {{"adjusted", Vec(s.spheres->baseline)}, {"true_length_m", t["baseline_m"]}}}};
}

/// The rig frames (and their GNSS/INS priors), cam_from_rig and focal lengths.
void EvaluateRig(const JointState& s, json& truth, json* out) {
  const json& t = truth["rig"];
  double worst = 0.0, worst_rotation = 0.0, worst_prior = 0.0;
  for (size_t f = 0; f < s.rig->frame_names.size(); ++f) {
    for (const json& frame : t["frames"]) {
      if (frame["name"] != s.rig->frame_names[f]) continue;
      const Rigid3d true_pose = PoseFromJson(frame["rig_from_world"]);
      worst = std::max(worst, (CameraCentre(s.scene.RigFrame(FrameId(f))) - CameraCentre(true_pose)).norm());
      worst_prior = std::max(worst_prior, (CameraCentre(s.rig->rig_prior[f]) - CameraCentre(true_pose)).norm());
      worst_rotation = std::max(worst_rotation, s.scene.RigFrame(FrameId(f)).rotation.angularDistance(true_pose.rotation) * kDeg);
    }
  }
  double worst_cam_t = 0.0, worst_cam_r = 0.0, worst_focal = 0.0;
  for (size_t k = 0; k < s.rig->cameras.size() && k < t["cameras"].size(); ++k) {
    const json& c = t["cameras"][k];
    const Rigid3d true_pose = PoseFromJson(c["cam_from_rig"]);
    worst_cam_t = std::max(worst_cam_t, (CameraCentre(s.scene.CamFromRig(s.rig->cameras[k])) - CameraCentre(true_pose)).norm());
    worst_cam_r = std::max(worst_cam_r, s.scene.CamFromRig(s.rig->cameras[k]).rotation.angularDistance(true_pose.rotation) * kDeg);
    const std::vector<double> params = c["camera"]["params"];
    worst_focal = std::max(worst_focal, std::abs(s.scene.Camera(s.rig->cameras[k]).params[0] - params[0]));
  }
  (*out)["rig"] = {{"max_frame_position_m", worst}, {"max_frame_rotation_deg", worst_rotation},
                {"max_prior_position_m", worst_prior}, {"max_cam_from_rig_position_m", worst_cam_t},
                {"max_cam_from_rig_rotation_deg", worst_cam_r}, {"max_focal_error_px", worst_focal}};
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// What the calibration is for: every 10th sample point of the mobile LiDAR projected into
/// each rig image with the adjusted (`offsets`) and initial (`offsets0`) intrinsics and
/// cam_from_lidar, against the true ones (px).
void ProjectedOffsets(const JointState& s, json& truth, const Rigid3d& true_rig_from_lidar,
                      std::vector<double>* offsets_out, std::vector<double>* offsets0_out) {
  const MobileBlock& m = *s.mobile;
  const Rigid3d& vehicle_from_lidar = s.scene.Mount(m.mount);
  std::vector<double>& offsets = *offsets_out;
  std::vector<double>& offsets0 = *offsets0_out;
  for (size_t k = 0; k < s.rig->cameras.size() && k < truth["rig"]["cameras"].size(); ++k) {
    const json& tc = truth["rig"]["cameras"][k];
    sensors::Camera true_camera;
    true_camera.model_id = sensors::CameraModelFromName(tc["camera"]["model"].get<std::string>());
    true_camera.width = tc["camera"]["width"];
    true_camera.height = tc["camera"]["height"];
    true_camera.params = tc["camera"]["params"].get<std::vector<double>>();
    sensors::Camera initial_camera = true_camera;
    initial_camera.params = s.rig->initial_params[k];
    const sensors::Camera& camera = s.scene.Camera(s.rig->cameras[k]);
    const Rigid3d true_cam_from_lidar = PoseFromJson(tc["cam_from_rig"]) * true_rig_from_lidar;
    const Rigid3d cam_from_lidar = s.scene.CamFromRig(s.rig->cameras[k]) * vehicle_from_lidar;
    const Rigid3d initial = s.rig->cam_from_rig_initial[k] * m.vehicle_from_lidar_initial;
    for (size_t i = 0; i < m.sample_lidar.size(); i += 10) {
      const auto truth_xy = true_camera.ImgFromCam(true_cam_from_lidar * m.sample_lidar[i]);
      if (!truth_xy || truth_xy->x() < 0 || truth_xy->y() < 0 || truth_xy->x() >= true_camera.width ||
          truth_xy->y() >= true_camera.height) {
        continue;
      }
      const auto xy = camera.ImgFromCam(cam_from_lidar * m.sample_lidar[i]);
      const auto xy0 = initial_camera.ImgFromCam(initial * m.sample_lidar[i]);
      if (xy) offsets.push_back((*xy - *truth_xy).norm());
      if (xy0) offsets0.push_back((*xy0 - *truth_xy).norm());
    }
  }
}

/// The camera–LiDAR extrinsic of each rig camera (cam_from_lidar = cam_from_rig ·
/// rig_from_lidar) and rig_from_lidar against the truth.
void EvaluateCamFromLidar(const JointState& s, json& truth, const Rigid3d& true_body_from_lidar, json* mobile) {
  const MobileBlock& m = *s.mobile;
  const Rigid3d& vehicle_from_lidar = s.scene.Mount(m.mount);
  const Rigid3d true_rig_from_lidar = PoseFromJson(truth["rig"]["body_from_rig"]).Inverse() * true_body_from_lidar;
  double worst_r = 0.0, worst_t = 0.0, worst_r0 = 0.0, worst_t0 = 0.0;
  for (size_t k = 0; k < s.rig->cameras.size() && k < truth["rig"]["cameras"].size(); ++k) {
    const Rigid3d true_cam_from_lidar = PoseFromJson(truth["rig"]["cameras"][k]["cam_from_rig"]) * true_rig_from_lidar;
    const auto [r, t] = PoseError(s.scene.CamFromRig(s.rig->cameras[k]) * vehicle_from_lidar, true_cam_from_lidar);
    const auto [ri, ti] = PoseError(s.rig->cam_from_rig_initial[k] * m.vehicle_from_lidar_initial, true_cam_from_lidar);
    worst_r = std::max(worst_r, r);
    worst_t = std::max(worst_t, t);
    worst_r0 = std::max(worst_r0, ri);
    worst_t0 = std::max(worst_t0, ti);
  }
  std::vector<double> offsets, offsets0;
  ProjectedOffsets(s, truth, true_rig_from_lidar, &offsets, &offsets0);
  const auto [rr, rt] = PoseError(vehicle_from_lidar, true_rig_from_lidar);
  (*mobile)["cam_from_lidar"] = {{"max_rotation_deg", worst_r}, {"max_translation_m", worst_t},
                                 {"initial_max_rotation_deg", worst_r0}, {"initial_max_translation_m", worst_t0},
                                 {"median_pixel_offset", Median(offsets)}, {"initial_median_pixel_offset", Median(offsets0)},
                                 {"projected_points", offsets.size()}};
  (*mobile)["rig_from_lidar"] = {{"rotation_deg", rr}, {"translation_m", rt}};
}

/// The corrected trajectory against the true one at the nodes (and the GNSS/INS before).
void EvaluateTrajectory(const JointState& s, json& truth, json* mobile_out) {
  const MobileBlock& m = *s.mobile;
  const std::vector<TrajectoryNode>& nodes = s.scene.trajectory_nodes();
  json& mobile = *mobile_out;
  // truth.json names the true trajectory relative to the simulation folder (its parent's parent).
  const fs::path true_file = truth.contains("trajectory") && truth["trajectory"].contains("true")
                                 ? fs::path(s.project->truth).parent_path().parent_path() /
                                       truth["trajectory"]["true"].get<std::string>()
                                 : fs::path();
  if (!true_file.empty() && fs::exists(true_file)) {
    const auto true_trajectory = ReadTrajectory(true_file.string());
    double sum = 0.0, sum_ins = 0.0, worst_r = 0.0, worst_r_ins = 0.0;
    for (size_t k = 0; k < nodes.size(); ++k) {
      const double t = nodes[k].time_s;
      const Rigid3d ins = InterpolateTrajectory(m.trajectory, t);
      const Rigid3d corrected = CorrectedPose(nodes, WeightAt(nodes, t), ins);
      const Rigid3d truth_pose = InterpolateTrajectory(true_trajectory, t);
      sum += (corrected.translation - truth_pose.translation).squaredNorm();
      sum_ins += (ins.translation - truth_pose.translation).squaredNorm();
      worst_r = std::max(worst_r, corrected.rotation.angularDistance(truth_pose.rotation) * kDeg);
      worst_r_ins = std::max(worst_r_ins, ins.rotation.angularDistance(truth_pose.rotation) * kDeg);
    }
    const double n = static_cast<double>(nodes.size());
    mobile["trajectory"] = {{"nodes", nodes.size()}, {"rmse_position_m", std::sqrt(sum / n)},
                            {"max_rotation_deg", worst_r}, {"ins_rmse_position_m", std::sqrt(sum_ins / n)},
                            {"ins_max_rotation_deg", worst_r_ins}};
  }
}

/// The mobile LiDAR's body_from_lidar, the rig's cam_from_lidar and the trajectory.
void EvaluateMobile(const JointState& s, json& truth, json* out) {
  const MobileBlock& m = *s.mobile;
  const Rigid3d& vehicle_from_lidar = s.scene.Mount(m.mount);
  const Rigid3d true_body_from_lidar = PoseFromJson(truth["lidar"]["mobile"]["body_from_lidar"]);
  json mobile;
  const Rigid3d body_from_lidar = m.body_from_vehicle * vehicle_from_lidar;
  const auto [r0, t0] = PoseError(m.body_from_lidar_nominal, true_body_from_lidar);
  const auto [r1, t1] = PoseError(body_from_lidar, true_body_from_lidar);
  mobile["body_from_lidar"] = {{"initial_rotation_deg", r0}, {"initial_translation_m", t0},
                               {"adjusted_rotation_deg", r1}, {"adjusted_translation_m", t1}};
  if (m.with_rig && s.rig && truth.contains("rig")) EvaluateCamFromLidar(s, truth, true_body_from_lidar, &mobile);
  EvaluateTrajectory(s, truth, &mobile);
  (*out)["mobile_lidar"] = mobile;
}

/// The adjusted static scans (and their registrations) against the true poses.
void EvaluateScans(const JointState& s, json& truth, json* out) {
  double worst = 0.0, worst_r = 0.0, worst_prior = 0.0, worst_prior_r = 0.0;
  for (size_t k = 0; k < s.scans.size(); ++k) {
    for (const json& t : truth["lidar"]["static_scans"]) {
      if (t.value("name", "") != s.scans[k].name) continue;
      const Rigid3d true_pose = PoseFromJson(t["world_from_scan"]).Inverse();
      worst = std::max(worst, (CameraCentre(s.scene.Scan(ScanId(k))) - CameraCentre(true_pose)).norm());
      worst_r = std::max(worst_r, s.scene.Scan(ScanId(k)).rotation.angularDistance(true_pose.rotation) * kDeg);
      worst_prior = std::max(worst_prior, (CameraCentre(s.scans[k].prior) - CameraCentre(true_pose)).norm());
      worst_prior_r = std::max(worst_prior_r, s.scans[k].prior.rotation.angularDistance(true_pose.rotation) * kDeg);
    }
  }
  (*out)["static_scans"] = {{"max_position_m", worst}, {"max_rotation_deg", worst_r},
                         {"registration_max_position_m", worst_prior}, {"registration_max_rotation_deg", worst_prior_r}};
}

/// The adjusted survey points' offsets from the truth.
void EvaluateSurvey(const JointState& s, json& truth, json* out) {
  json points = json::array();
  for (const json& t : truth["survey"]["points"]) {
    const survey::SurveyPoint* p = s.joint->Find(t["id"].get<std::string>());
    if (!p || !(p->xy_free() || p->z_free())) continue;
    const std::vector<double> w = t["point_in_world"];
    const Eigen::Vector3d d = WorldFromSurvey(*s.joint, *p) - Eigen::Vector3d(w[0], w[1], w[2]);
    points.push_back({{"id", p->id}, {"d", Vec(d)}});
  }
  (*out)["survey_points"] = points;
}

}  // namespace

json EvaluateTruth(const JointState& s) {
  io::RequireRegularFile(s.project->truth);
  std::ifstream in(s.project->truth);
  json truth;
  try {
    truth = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(s.project->truth, 0, "JSON", e.what(), "the simulator's truth.json");
  }
  json out;
  if (s.photos && truth.contains("photos")) EvaluatePhotos(s, truth, &out);
  if (s.spheres && truth.contains("spherical_stereo")) EvaluateSpheres(s, truth, &out);
  if (s.rig && truth.contains("rig")) EvaluateRig(s, truth, &out);
  if (s.mobile && truth.contains("lidar") && truth["lidar"].contains("mobile") &&
      truth["lidar"]["mobile"].contains("body_from_lidar")) {
    EvaluateMobile(s, truth, &out);
  }
  if (!s.scans.empty() && truth.contains("lidar") && truth["lidar"].contains("static_scans")) EvaluateScans(s, truth, &out);
  if (s.joint && truth.contains("survey")) EvaluateSurvey(s, truth, &out);
  return out;
}

}  // namespace mmba::adjust::internal
