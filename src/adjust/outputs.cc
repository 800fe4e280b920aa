// Output files of `mmba adjust` and the report (report.json → report.html).
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/core/atomic_file.h"
#include "mmba/io/point_cloud.h"
#include "mmba/problem/colmap_scene.h"
#include "mmba/report/adjust_report.h"
#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"
#include "mmba/core/version.h"

namespace mmba::adjust::internal {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr double kDeg = 180.0 / M_PI;

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

double Num(double v) { return std::isfinite(v) ? v : 0.0; }

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// Covariance of a camera centre c = −Rᵀt from the pose blocks' covariance (rotation on
/// Ceres' EigenQuaternionManifold: R ⊞ δ = Exp(δ)·R, so ∂c/∂δ = −Rᵀ[t]×, ∂c/∂t = −Rᵀ).
Eigen::Matrix3d CentreCovariance(const stats::NetworkStatistics& st, const Rigid3d& cam_from_world) {
  const double* q = cam_from_world.rotation.coeffs().data();
  const double* t = cam_from_world.translation.data();
  if (!st.IsFree(q) && !st.IsFree(t)) return Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 6, 6> c = Eigen::Matrix<double, 6, 6>::Zero();
  const std::pair<const double*, int> s[6] = {{q, 0}, {q, 1}, {q, 2}, {t, 0}, {t, 1}, {t, 2}};
  for (int a = 0; a < 6; ++a) {
    for (int b = 0; b < 6; ++b) c(a, b) = st.Covariance(s[a].first, s[a].second, s[b].first, s[b].second);
  }
  const Eigen::Matrix3d rt = cam_from_world.rotation.toRotationMatrix().transpose();
  Eigen::Matrix<double, 3, 6> j;
  j << -rt * Skew(cam_from_world.translation), -rt;
  return j * c * j.transpose();
}

/// σ of each ambient parameter of `block` (its covariance in the tangent space mapped through
/// the manifold's Plus Jacobian: a SubsetManifold's constant entries get 0).
std::vector<double> ParameterSigmas(const stats::NetworkStatistics& st, const ceres::Problem& problem,
                                    const double* block) {
  if (!problem.HasParameterBlock(block)) return std::vector<double>(3, 0.0);
  const int n = problem.ParameterBlockSize(block);
  std::vector<double> sigma(n, 0.0);
  if (!st.IsFree(block)) return sigma;
  const int m = problem.ParameterBlockTangentSize(block);
  Eigen::MatrixXd tangent(m, m);
  for (int a = 0; a < m; ++a) {
    for (int b = 0; b < m; ++b) tangent(a, b) = st.Covariance(block, a, block, b);
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> plus(n, m);
  const ceres::Manifold* manifold = problem.GetManifold(block);
  if (manifold) {
    manifold->PlusJacobian(block, plus.data());
  } else {
    plus.setIdentity();
  }
  const Eigen::MatrixXd ambient = plus * tangent * plus.transpose();
  for (int i = 0; i < n; ++i) sigma[i] = std::sqrt(std::max(0.0, ambient(i, i)));
  return sigma;
}

Eigen::Matrix3d PointCovariance3(const stats::NetworkStatistics& st, const double* p) {
  Eigen::Matrix3d c;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) c(a, b) = st.Covariance(p, a, p, b);
  }
  return c;
}

/// Covariance of (rotation vector, translation) of the composed pose a·b (e.g. cam_from_lidar =
/// cam_from_rig · rig_from_lidar) from the blocks' joint covariance, by numerical first-order
/// propagation (rotation perturbations as on Ceres' quaternion manifold: Exp(δ)·R).
Eigen::Matrix<double, 6, 6> ComposedPoseCovariance(const stats::NetworkStatistics& st, const Rigid3d& a, const Rigid3d& b) {
  const double* blocks[4] = {a.rotation.coeffs().data(), a.translation.data(), b.rotation.coeffs().data(),
                             b.translation.data()};
  Eigen::Matrix<double, 12, 12> c;
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 12; ++j) c(i, j) = st.Covariance(blocks[i / 3], i % 3, blocks[j / 3], j % 3);
  }
  const Rigid3d base = a * b;
  const auto perturbed = [&](int k, double h) {
    Rigid3d pa = a, pb = b;
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[k % 3] = h;
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(d.norm(), d.normalized()));
    if (k < 3) pa.rotation = turn * a.rotation;
    else if (k < 6) pa.translation += d;
    else if (k < 9) pb.rotation = turn * b.rotation;
    else pb.translation += d;
    const Rigid3d p = pa * pb;
    const Eigen::AngleAxisd rot(p.rotation * base.rotation.conjugate());
    Eigen::Matrix<double, 6, 1> out;
    out << rot.angle() * rot.axis(), p.translation;
    return out;
  };
  Eigen::Matrix<double, 6, 12> jacobian;
  constexpr double h = 1e-6;
  for (int k = 0; k < 12; ++k) jacobian.col(k) = (perturbed(k, h) - perturbed(k, -h)) / (2 * h);
  return jacobian * c * jacobian.transpose();
}

/// Rotation error (deg) and translation error (m) of an estimated pose against the truth.
std::pair<double, double> PoseError(const Rigid3d& estimate, const Rigid3d& truth) {
  return {estimate.rotation.angularDistance(truth.rotation) * kDeg, (estimate.translation - truth.translation).norm()};
}

Rigid3d PoseFromJson(const json& j) {
  const std::vector<double> q = j["qvec_wxyz"], t = j["tvec"];
  return Rigid3d(Eigen::Quaterniond(q[0], q[1], q[2], q[3]), Eigen::Vector3d(t[0], t[1], t[2]));
}

std::string YamlPose(const Rigid3d& p) {
  std::ostringstream o;
  o << std::setprecision(10) << "{qvec_wxyz: [" << p.rotation.w() << ", " << p.rotation.x() << ", " << p.rotation.y()
    << ", " << p.rotation.z() << "], tvec: [" << p.translation.x() << ", " << p.translation.y() << ", "
    << p.translation.z() << "]}";
  return o.str();
}

json Ellipse(const Eigen::Matrix3d& enu) {
  const stats::ErrorEllipse e = stats::StandardEllipse(enu.topLeftCorner<2, 2>());
  // StandardEllipse's angle is from axis 1 (east) towards axis 2 (north); azimuth is from north
  // clockwise: 90° − angle.
  double azimuth = 90.0 - e.angle_rad * kDeg;
  if (azimuth < 0) azimuth += 180.0;
  return {{"a", Num(e.a)}, {"b", Num(e.b)}, {"azimuth_deg", azimuth}};
}

/// How the variance components treated a group (report.json `groups[].reweighting`).
std::string Reweighting(const JointState& s, const FactorGroup& group, double redundancy) {
  const std::string exemption = VarianceComponentExemption(s, group, redundancy);
  return exemption.empty() ? "variance components" : exemption + ": not re-weighted";
}

json Histogram(const FactorGroup& group) {
  json values = json::array();
  for (const ObservationResidual& o : group.Evaluate().observations) {
    for (double w : o.whitened) values.push_back(Num(w));
  }
  return values;
}

std::string Geo(const geodesy::LocalTangentPlane& plane, const Eigen::Vector3d& enu) {
  const geodesy::Geodetic g = plane.GeodeticFromEnu(enu);
  const geodesy::Utm u = geodesy::UtmFromGeodetic(g);
  std::ostringstream s;
  s << std::setprecision(10) << g.latitude_deg << "," << g.longitude_deg << "," << std::setprecision(4) << std::fixed
    << g.height_m << "," << u.zone << (u.northp ? "N" : "S") << "," << std::setprecision(4) << u.easting_m << ","
    << u.northing_m;
  return s.str();
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}


/// Truth evaluation of a simulated project (never used by the adjustment itself).
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
  if (s.photos && truth.contains("photos")) {
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
    out["photo_positions"] = {{"images", n}, {"rmse_m", n ? std::sqrt(sum / n) : 0.0}, {"max_m", worst},
                              {"max_rotation_deg", worst_rotation}};
    const std::vector<double> true_params = truth["photos"]["camera"]["params"];
    const std::vector<double>& params = s.scene.Camera(s.photos->model.cameras.begin()->first).params;
    out["photo_camera"] = {{"adjusted", params}, {"true", true_params}, {"initial", s.photos->initial_params}};
  }
  if (s.spheres && truth.contains("spherical_stereo")) {
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
    out["spheres"] = {{"max_position_m", worst}, {"max_rotation_deg_after_cx_datum", worst_rotation},
                      {"lower_params", {{"adjusted", s.scene.Camera(s.spheres->lower_camera).params},
                                        {"true", t["lower_camera"]["params"]}, {"initial", s.spheres->initial_lower_params}}},
                      {"upper_params", {{"adjusted", s.scene.Camera(s.spheres->upper_camera).params},
                                        {"true", t["upper_camera"]["params"]}, {"initial", s.spheres->initial_upper_params}}},
                      {"baseline", {{"adjusted", Vec(s.spheres->baseline)}, {"true_length_m", t["baseline_m"]}}}};
  }
  if (s.rig && truth.contains("rig")) {
    const json& t = truth["rig"];
    double worst = 0.0, worst_rotation = 0.0, worst_prior = 0.0;
    for (size_t f = 0; f < s.rig->frame_names.size(); ++f) {
      for (const json& frame : t["frames"]) {
        if (frame["name"] != s.rig->frame_names[f]) continue;
        const Rigid3d true_pose = PoseFromJson(frame["rig_from_world"]);
        worst = std::max(worst, (CameraCentre(s.rig->rig_from_world[f]) - CameraCentre(true_pose)).norm());
        worst_prior = std::max(worst_prior, (CameraCentre(s.rig->rig_prior[f]) - CameraCentre(true_pose)).norm());
        worst_rotation = std::max(worst_rotation, s.rig->rig_from_world[f].rotation.angularDistance(true_pose.rotation) * kDeg);
      }
    }
    double worst_cam_t = 0.0, worst_cam_r = 0.0, worst_focal = 0.0;
    for (size_t k = 0; k < s.rig->cameras.size() && k < t["cameras"].size(); ++k) {
      const json& c = t["cameras"][k];
      const Rigid3d true_pose = PoseFromJson(c["cam_from_rig"]);
      worst_cam_t = std::max(worst_cam_t, (CameraCentre(s.rig->cam_from_rig[k]) - CameraCentre(true_pose)).norm());
      worst_cam_r = std::max(worst_cam_r, s.rig->cam_from_rig[k].rotation.angularDistance(true_pose.rotation) * kDeg);
      const std::vector<double> params = c["camera"]["params"];
      worst_focal = std::max(worst_focal, std::abs(s.scene.Camera(s.rig->cameras[k]).params[0] - params[0]));
    }
    out["rig"] = {{"max_frame_position_m", worst}, {"max_frame_rotation_deg", worst_rotation},
                  {"max_prior_position_m", worst_prior}, {"max_cam_from_rig_position_m", worst_cam_t},
                  {"max_cam_from_rig_rotation_deg", worst_cam_r}, {"max_focal_error_px", worst_focal}};
  }
  if (s.mobile && truth.contains("lidar") && truth["lidar"].contains("mobile") && truth["lidar"]["mobile"].contains("body_from_lidar")) {
    const MobileBlock& m = *s.mobile;
    const Rigid3d true_body_from_lidar = PoseFromJson(truth["lidar"]["mobile"]["body_from_lidar"]);
    json mobile;
    const Rigid3d body_from_lidar = m.body_from_vehicle * m.vehicle_from_lidar;
    const auto [r0, t0] = PoseError(m.body_from_lidar_nominal, true_body_from_lidar);
    const auto [r1, t1] = PoseError(body_from_lidar, true_body_from_lidar);
    mobile["body_from_lidar"] = {{"initial_rotation_deg", r0}, {"initial_translation_m", t0},
                                 {"adjusted_rotation_deg", r1}, {"adjusted_translation_m", t1}};
    if (m.with_rig && s.rig && truth.contains("rig")) {
      // The camera–LiDAR extrinsic of each rig camera: cam_from_lidar = cam_from_rig · rig_from_lidar.
      const Rigid3d true_rig_from_lidar = PoseFromJson(truth["rig"]["body_from_rig"]).Inverse() * true_body_from_lidar;
      double worst_r = 0.0, worst_t = 0.0, worst_r0 = 0.0, worst_t0 = 0.0;
      for (size_t k = 0; k < s.rig->cameras.size() && k < truth["rig"]["cameras"].size(); ++k) {
        const Rigid3d true_cam_from_lidar = PoseFromJson(truth["rig"]["cameras"][k]["cam_from_rig"]) * true_rig_from_lidar;
        const auto [r, t] = PoseError(s.rig->cam_from_rig[k] * m.vehicle_from_lidar, true_cam_from_lidar);
        const auto [ri, ti] = PoseError(s.rig->cam_from_rig_initial[k] * m.vehicle_from_lidar_initial, true_cam_from_lidar);
        worst_r = std::max(worst_r, r);
        worst_t = std::max(worst_t, t);
        worst_r0 = std::max(worst_r0, ri);
        worst_t0 = std::max(worst_t0, ti);
      }
      // What the calibration is for: LiDAR points projected into each rig image with the
      // adjusted intrinsics and cam_from_lidar against the true ones (median offset, px).
      std::vector<double> offsets, offsets0;
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
        const Rigid3d cam_from_lidar = s.rig->cam_from_rig[k] * m.vehicle_from_lidar;
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
      const auto median = [](std::vector<double> v) {
        if (v.empty()) return 0.0;
        std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
        return v[v.size() / 2];
      };
      const auto [rr, rt] = PoseError(m.vehicle_from_lidar, true_rig_from_lidar);
      mobile["cam_from_lidar"] = {{"max_rotation_deg", worst_r}, {"max_translation_m", worst_t},
                                  {"initial_max_rotation_deg", worst_r0}, {"initial_max_translation_m", worst_t0},
                                  {"median_pixel_offset", median(offsets)}, {"initial_median_pixel_offset", median(offsets0)},
                                  {"projected_points", offsets.size()}};
      mobile["rig_from_lidar"] = {{"rotation_deg", rr}, {"translation_m", rt}};
    }
    // The corrected trajectory against the true one at the nodes (and the GNSS/INS before).
    // truth.json names the true trajectory relative to the simulation folder (its parent's parent).
    const fs::path true_file = truth.contains("trajectory") && truth["trajectory"].contains("true")
                                   ? fs::path(s.project->truth).parent_path().parent_path() /
                                         truth["trajectory"]["true"].get<std::string>()
                                   : fs::path();
    if (!true_file.empty() && fs::exists(true_file)) {
      const auto true_trajectory = ReadTrajectory(true_file.string());
      double sum = 0.0, sum_ins = 0.0, worst_r = 0.0, worst_r_ins = 0.0;
      for (size_t k = 0; k < m.nodes.size(); ++k) {
        const double t = m.nodes[k].time_s;
        const Rigid3d ins = InterpolateTrajectory(m.trajectory, t);
        const Rigid3d corrected = CorrectedPose(m.nodes, WeightAt(m.nodes, t), ins);
        const Rigid3d truth_pose = InterpolateTrajectory(true_trajectory, t);
        sum += (corrected.translation - truth_pose.translation).squaredNorm();
        sum_ins += (ins.translation - truth_pose.translation).squaredNorm();
        worst_r = std::max(worst_r, corrected.rotation.angularDistance(truth_pose.rotation) * kDeg);
        worst_r_ins = std::max(worst_r_ins, ins.rotation.angularDistance(truth_pose.rotation) * kDeg);
      }
      const double n = static_cast<double>(m.nodes.size());
      mobile["trajectory"] = {{"nodes", m.nodes.size()}, {"rmse_position_m", std::sqrt(sum / n)},
                              {"max_rotation_deg", worst_r}, {"ins_rmse_position_m", std::sqrt(sum_ins / n)},
                              {"ins_max_rotation_deg", worst_r_ins}};
    }
    out["mobile_lidar"] = mobile;
  }
  if (!s.scans.empty() && truth.contains("lidar") && truth["lidar"].contains("static_scans")) {
    double worst = 0.0, worst_r = 0.0, worst_prior = 0.0, worst_prior_r = 0.0;
    for (size_t k = 0; k < s.scans.size(); ++k) {
      for (const json& t : truth["lidar"]["static_scans"]) {
        if (t.value("name", "") != s.scans[k].name) continue;
        const Rigid3d true_pose = PoseFromJson(t["world_from_scan"]).Inverse();
        worst = std::max(worst, (CameraCentre(s.scan_from_world[k]) - CameraCentre(true_pose)).norm());
        worst_r = std::max(worst_r, s.scan_from_world[k].rotation.angularDistance(true_pose.rotation) * kDeg);
        worst_prior = std::max(worst_prior, (CameraCentre(s.scans[k].prior) - CameraCentre(true_pose)).norm());
        worst_prior_r = std::max(worst_prior_r, s.scans[k].prior.rotation.angularDistance(true_pose.rotation) * kDeg);
      }
    }
    out["static_scans"] = {{"max_position_m", worst}, {"max_rotation_deg", worst_r},
                           {"registration_max_position_m", worst_prior}, {"registration_max_rotation_deg", worst_prior_r}};
  }
  if (s.joint && truth.contains("survey")) {
    json points = json::array();
    for (const json& t : truth["survey"]["points"]) {
      const survey::SurveyPoint* p = s.joint->Find(t["id"].get<std::string>());
      if (!p || !(p->xy_free() || p->z_free())) continue;
      const std::vector<double> w = t["point_in_world"];
      const Eigen::Vector3d d = WorldFromSurvey(*s.joint, *p) - Eigen::Vector3d(w[0], w[1], w[2]);
      points.push_back({{"id", p->id}, {"d", Vec(d)}});
    }
    out["survey_points"] = points;
  }
  return out;
}

}  // namespace

std::string FindImage(const std::string& folder, const std::string& stem) {
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file() && entry.path().stem() == stem) return entry.path().string();
  }
  return "";
}

std::vector<NamedPath> ProjectInputs(const Project& project) {
  std::vector<NamedPath> inputs = {{"the project file", project.path}, {"the project folder", project.dir}};
  const auto add = [&inputs](const std::string& id, const std::string& key, const std::string& path) {
    if (!path.empty()) inputs.push_back({"'" + key + "' of sensor '" + id + "'", path});
  };
  for (const PhotoCollection& p : project.photos) {
    for (const auto& [key, path] : {std::pair<const char*, const std::string&>{"images", p.images},
                                    {"calibration", p.calibration}, {"colmap_model", p.colmap_model},
                                    {"control_measurements", p.control_measurements}, {"mi_results", p.mi_results}}) {
      add(p.id, key, path);
    }
  }
  for (const TotalStation& t : project.total_stations) add(t.id, "file", t.file);
  for (const Gnss& g : project.gnss) add(g.id, "file", g.file);
  for (const LidarStatic& l : project.lidar_static) {
    add(l.id, "reference_cloud", l.reference_cloud);
    add(l.id, "targets", l.targets);
    for (const LidarScanFile& scan : l.scans) add(l.id, "scans", scan.file);
  }
  for (const SphericalStereo& p : project.spherical) {
    for (const auto& [key, path] : {std::pair<const char*, const std::string&>{"images", p.images},
                                    {"calibration", p.calibration}, {"stations_file", p.stations_file},
                                    {"observations", p.observations}}) {
      add(p.id, key, path);
    }
  }
  for (const CameraRig& r : project.rigs) {
    for (const auto& [key, path] : {std::pair<const char*, const std::string&>{"images", r.images},
                                    {"panoramas", r.panoramas}, {"mi_results", r.mi_results},
                                    {"calibration", r.calibration}, {"trajectory", r.trajectory},
                                    {"frames_file", r.frames_file}, {"observations", r.observations}}) {
      add(r.id, key, path);
    }
  }
  for (const LidarMobile& m : project.lidar_mobile) {
    add(m.id, "cloud", m.cloud);
    add(m.id, "trajectory", m.trajectory);
    add(m.id, "calibration", m.calibration);
  }
  if (!project.truth.empty()) inputs.push_back({"'truth' of the project", project.truth});
  return inputs;
}

void WriteOutputs(JointState& s, const AdjustOptions& options, const fs::path& stage, AdjustOutcome* outcome) {
  const Project& project = *s.project;
  const stats::NetworkStatistics& st = s.statistics;
  const fs::path out_dir = options.output_dir;
  fs::create_directories(stage / "calibration");
  json report;
  report["schema"] = "mmba-adjust-report-1";
  RecordBuild(&report);
  report["project"] = project.name;
  {
    std::time_t now = std::time(nullptr);
    char buffer[32];
    std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    report["generated_utc"] = buffer;
  }
  report["status"] = outcome->status;
  report["origin"] = {{"latitude_deg", project.origin.latitude_deg}, {"longitude_deg", project.origin.longitude_deg},
                      {"height_m", project.origin.height_m}};
  const geodesy::Utm origin_utm = geodesy::UtmFromGeodetic(project.origin);
  report["frame"] = "local ENU tangent plane at the project origin (metres); WGS84 and UTM in the CSV files";
  report["utm_zone"] = std::to_string(origin_utm.zone) + (origin_utm.northp ? "N" : "S");
  report["solver"] = {{"iterations", s.total_iterations}, {"outer_iterations", s.outer_iterations},
                      {"initial_cost", s.solve.initial_cost}, {"final_cost", s.solve.final_cost},
                      {"seconds", s.seconds}};
  if (s.photos) {
    report["photo_block"] = {{"id", s.photos->config->id},
                             {"images", s.photos->model.images.size()},
                             {"tie_points", s.photos->model.points3D.size()},
                             {"georeference", s.photos->georeference}};
    if (!s.photos->registration.is_null()) report["photo_block"]["registration_to_lidar"] = s.photos->registration;
  }
  report["sigma0"] = {{"apriori", 1.0}, {"aposteriori", st.sigma0_ratio}, {"dof", st.degrees_of_freedom},
                      {"confidence", st.confidence}, {"chi2_lower", st.chi2_lower}, {"chi2_upper", st.chi2_upper},
                      {"passed", st.chi2_passed}};
  const stats::NetworkStatistics& given = s.given_weights;
  report["sigma0_given_weights"] = {{"aposteriori", given.sigma0_ratio}, {"dof", given.degrees_of_freedom},
                                    {"chi2_lower", given.chi2_lower}, {"chi2_upper", given.chi2_upper},
                                    {"passed", given.chi2_passed}};
  // Groups.
  json groups = json::array();
  const auto& builder_groups = s.builder->groups();
  for (size_t g = 0; g < builder_groups.size(); ++g) {
    const FactorGroup& group = *builder_groups[g];
    const GroupEvaluation e = group.Evaluate();
    double max_norm = 0.0, sigma_sum = 0.0;
    for (const ObservationResidual& o : e.observations) max_norm = std::max(max_norm, o.norm_units);
    for (double sigma : group.block_sigmas()) sigma_sum += sigma;
    const stats::GroupStatistic& gs = st.groups.at(g);
    // Angles in mgon, as surveyors read them (the groups work in radians).
    const bool angle = group.unit() == "rad";
    const double k = angle ? 200000.0 / M_PI : 1.0;
    groups.push_back({{"name", group.name()}, {"unit", angle ? "mgon" : group.unit()}, {"observations", e.num_observations},
                      {"residuals", e.num_residuals}, {"rms", Num(k * e.rms_units)}, {"mean", Num(k * e.mean_norm_units)},
                      {"max", Num(k * max_norm)},
                      {"sigma", group.block_sigmas().empty() ? 0.0 : k * sigma_sum / group.block_sigmas().size()},
                      {"whitened_kind", "components"},
                      {"loss", group.loss().ToString()}, {"outliers", e.num_outliers},
                      {"variance_component", Num(gs.variance_component)}, {"redundancy", Num(gs.redundancy)},
                      {"sigma_factor", s.sigma_factor.count(group.name()) ? s.sigma_factor.at(group.name()) : 1.0},
                      {"reweighting", Reweighting(s, group, gs.redundancy)},
                      {"variance_component_given_weights",
                       g < given.groups.size() ? Num(given.groups[g].variance_component) : 0.0},
                      {"whitened", Histogram(group)}});
  }
  report["groups"] = groups;
  // Control and check points.
  json control = json::array();
  double check_sum[3] = {0, 0, 0}, expected_sum = 0.0;
  size_t check_count = 0;
  if (s.joint) {
    std::set<std::string> measured;
    if (s.photos) {
      for (const TargetMeasurement& m : s.photos->control) measured.insert(m.point_id);
    }
    for (const survey::SurveyPoint& p : s.joint->points) {
      const survey::SurveyPoint* before = s.surveyed->Find(p.id);
      const bool check = s.photos && s.photos->check_ids.count(p.id);
      if ((!check && !measured.count(p.id)) || !s.surveyed_ids.count(p.id)) continue;
      const Eigen::Vector3d surveyed = WorldFromSurvey(*s.surveyed, *before);
      const Eigen::Matrix3d surveyed_cov = SurveyPointCovariance(s.surveyed_adjustment.statistics, *s.surveyed, *before);
      Eigen::Vector3d adjusted;
      Eigen::Matrix3d cov;
      if (check) {
        const double* point = s.scene.Point(s.photos->check_ids.at(p.id)).data();
        adjusted = s.scene.Point(s.photos->check_ids.at(p.id));
        cov = PointCovariance3(st, point) + surveyed_cov;  // the difference of independent estimates
      } else {
        adjusted = WorldFromSurvey(*s.joint, p);
        cov = SurveyPointCovariance(st, *s.joint, p);
      }
      const Eigen::Vector3d d = adjusted - surveyed;
      const Eigen::Vector3d sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
      control.push_back({{"id", p.id}, {"role", check ? "check" : "control"}, {"surveyed", Vec(surveyed)},
                         {"adjusted", Vec(adjusted)}, {"d", Vec(d)}, {"sigma", Vec(sigma)}, {"ellipse", Ellipse(cov)}});
      if (check) {
        for (int a = 0; a < 3; ++a) check_sum[a] += d(a) * d(a);
        expected_sum += cov.trace();
        ++check_count;
      }
    }
  }
  report["control_points"] = control;
  if (check_count > 0) {
    const Eigen::Vector3d rmse(std::sqrt(check_sum[0] / check_count), std::sqrt(check_sum[1] / check_count),
                               std::sqrt(check_sum[2] / check_count));
    report["check_summary"] = {{"count", check_count}, {"rmse", Vec(rmse)}, {"rmse_3d", rmse.norm()},
                               {"expected_rmse_3d", std::sqrt(expected_sum / check_count)}};
  }
  json blunders = json::array();
  for (const Blunder& b : s.blunders) {
    blunders.push_back({{"group", b.group}, {"observation", b.observation}, {"studentized", b.studentized},
                        {"whitened", b.whitened}, {"downweighted", true}});
  }
  report["blunders"] = blunders;
  // Poses, corrections, calibration, files.
  json corrections = json::array();
  std::ostringstream poses;
  poses << "# mmba adjust: camera poses; position = camera centre in the world (local ENU at the project origin), "
           "q = cam_from_world (w, x, y, z); sigma from the adjustment's covariance (scaled by sigma0)\n"
           "image,sensor,east_m,north_m,up_m,qw,qx,qy,qz,latitude_deg,longitude_deg,height_m,utm_zone,utm_easting_m,"
           "utm_northing_m,sigma_east_m,sigma_north_m,sigma_up_m,d_position_m,d_rotation_deg\n";
  json calibrations = json::array();
  if (s.photos) {
    for (const auto& [id, image] : s.photos->model.images) {
      const ImagePose& pose = s.scene.Image(id);
      const Eigen::Vector3d c = CameraCentre(pose.cam_from_world);
      const Rigid3d& initial = s.photos->initial_poses.at(id);
      const Eigen::Vector3d d = c - CameraCentre(initial);
      const double d_rotation = pose.cam_from_world.rotation.angularDistance(initial.rotation) * kDeg;
      const Eigen::Vector3d sigma = CentreCovariance(st, pose.cam_from_world).diagonal().cwiseMax(0.0).cwiseSqrt();
      const Eigen::Quaterniond& q = pose.cam_from_world.rotation;
      poses << image.name << "," << s.photos->config->id << "," << std::setprecision(12) << c.x() << "," << c.y() << ","
            << c.z() << "," << q.w() << "," << q.x() << "," << q.y() << "," << q.z() << "," << Geo(s.plane, c) << ","
            << std::setprecision(6) << sigma.x() << "," << sigma.y() << "," << sigma.z() << "," << d.norm() << ","
            << d_rotation << "\n";
      corrections.push_back({{"image", image.name}, {"sensor", s.photos->config->id}, {"d", Vec(d)},
                             {"d_position_m", d.norm()}, {"d_rotation_deg", d_rotation}});
    }
    // Adjusted COLMAP model and calibration.
    io::ColmapModel model = s.photos->model;
    UpdateColmapFromScene(s.scene, &model);
    io::WriteColmapModel(model, (stage / "colmap" / s.photos->config->id).string(), io::ColmapFormat::kText);
    for (const auto& [id, model_camera] : s.photos->model.cameras) {
      const sensors::Camera& camera = s.scene.Camera(id);
      json parameters = json::array();
      std::ostringstream yaml;
      yaml << "# mmba adjust: calibration of photo collection '" << s.photos->config->id << "' (camera " << id.value
           << "), sigma from the adjustment\nmodel: " << camera.ModelName() << "\nwidth: " << camera.width
           << "\nheight: " << camera.height << "\nparams: [";
      std::ostringstream sigmas;
      const std::vector<double> camera_sigma = ParameterSigmas(st, s.builder->problem(), camera.params.data());
      // Parameter names in the model's order ("fx, fy, cx, cy, k1, ...").
      std::vector<std::string> names;
      std::stringstream info(sensors::CameraModelParamsInfo(camera.model_id));
      for (std::string name; std::getline(info, name, ',');) names.push_back(name.substr(name.find_first_not_of(' ')));
      for (size_t k = 0; k < camera.params.size(); ++k) {
        const double sigma = camera_sigma[k];
        yaml << (k ? ", " : "") << std::setprecision(10) << camera.params[k];
        sigmas << (k ? ", " : "") << std::setprecision(4) << sigma;
        parameters.push_back({{"name", k < names.size() ? names[k] : "p" + std::to_string(k)},
                              {"initial", s.photos->initial_params.at(k)},
                              {"adjusted", camera.params[k]}, {"sigma", sigma}});
      }
      yaml << "]\nsigma: [" << sigmas.str() << "]\n";
      WriteText(stage / "calibration" / (s.photos->config->id + "_camera.yaml"), yaml.str());
      calibrations.push_back({{"name", s.photos->config->id + " camera " + std::to_string(id.value) + " (" +
                                           camera.ModelName() + ")"},
                              {"parameters", parameters}});
    }
    // Georeferenced tie points (coloured from the images) and the LiDAR error map.
    io::PointCloud ties, errors;
    std::map<Point3DId, double> distance;
    for (const SurfacePlane& p : s.planes) {
      const Eigen::Vector3d x = p.scan < 0 ? s.scene.Point(p.point3D_id) : s.scan_from_world[p.scan] * s.scene.Point(p.point3D_id);
      distance[p.point3D_id] = p.normal.dot(x - p.point);
    }
    for (const auto& [id, point] : model.points3D) {
      ties.points.push_back(point.xyz);
      ties.colors.push_back(point.color);
      if (distance.count(id)) {
        errors.points.push_back(point.xyz);
        errors.intensity.push_back(static_cast<float>(distance.at(id)));
      }
    }
    io::WritePly(ties, (stage / "tie_points.ply").string());
    if (!errors.empty()) io::WritePly(errors, (stage / "error_map_lidar.ply").string());
  }
  if (s.spheres) {
    const SphereBlock& sb = *s.spheres;
    for (const auto& [station, id] : sb.lower_image) {
      const ImagePose& pose = s.scene.Image(id);
      const Rigid3d& initial = sb.initial_poses.at(id);
      for (int k = 0; k < 2; ++k) {
        // The upper sphere: same orientation, centre at the baseline (lower frame).
        const Rigid3d shift(Eigen::Quaterniond::Identity(), k == 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(-sb.baseline));
        const Rigid3d cam_from_world = shift * pose.cam_from_world;
        const Eigen::Vector3d c = CameraCentre(cam_from_world);
        const Eigen::Vector3d d = c - CameraCentre(shift * initial);
        const double d_rotation = pose.cam_from_world.rotation.angularDistance(initial.rotation) * kDeg;
        const Eigen::Vector3d sigma = CentreCovariance(st, pose.cam_from_world).diagonal().cwiseMax(0.0).cwiseSqrt();
        const Eigen::Quaterniond& q = cam_from_world.rotation;
        const std::string name = station + (k == 0 ? "_lower" : "_upper");
        poses << name << "," << sb.config->id << "," << std::setprecision(12) << c.x() << "," << c.y() << "," << c.z()
              << "," << q.w() << "," << q.x() << "," << q.y() << "," << q.z() << "," << Geo(s.plane, c) << ","
              << std::setprecision(6) << sigma.x() << "," << sigma.y() << "," << sigma.z() << "," << d.norm() << ","
              << d_rotation << "\n";
        if (k == 0) {
          corrections.push_back({{"image", name}, {"sensor", sb.config->id}, {"d", Vec(d)}, {"d_position_m", d.norm()},
                                 {"d_rotation_deg", d_rotation}});
        }
      }
    }
    // Line-scan calibration: principal offsets per sphere, baseline vector and its tilt.
    std::ostringstream yaml;
    json parameters = json::array();
    yaml << "# mmba adjust: calibration of the spherical stereo pair '" << sb.config->id
         << "', sigma from the adjustment\nmodel: EQUIRECTANGULAR\nwidth: " << s.scene.Camera(sb.lower_camera).width
         << "\nheight: " << s.scene.Camera(sb.lower_camera).height << "\n";
    const char* names[3] = {"f", "cx", "cy"};
    for (int k = 0; k < 2; ++k) {
      const sensors::Camera& camera = s.scene.Camera(k == 0 ? sb.lower_camera : sb.upper_camera);
      const std::vector<double>& initial = k == 0 ? sb.initial_lower_params : sb.initial_upper_params;
      yaml << (k == 0 ? "lower" : "upper") << "_params: [" << std::setprecision(10) << camera.params[0] << ", "
           << camera.params[1] << ", " << camera.params[2] << "]\n" << (k == 0 ? "lower" : "upper") << "_sigma: [";
      const std::vector<double> camera_sigma = ParameterSigmas(st, s.builder->problem(), camera.params.data());
      for (int i = 0; i < 3; ++i) {
        const double sigma = camera_sigma[i];
        yaml << (i ? ", " : "") << std::setprecision(4) << sigma;
        parameters.push_back({{"name", std::string(k == 0 ? "lower " : "upper ") + names[i]}, {"initial", initial[i]},
                              {"adjusted", camera.params[i]}, {"sigma", sigma}});
      }
      yaml << "]\n";
    }
    Eigen::Vector3d baseline_sigma;
    for (int i = 0; i < 3; ++i) {
      baseline_sigma(i) = std::sqrt(std::max(0.0, st.Covariance(sb.baseline.data(), i, sb.baseline.data(), i)));
    }
    const double tilt = std::acos(std::min(1.0, -sb.baseline.y() / sb.baseline.norm())) * kDeg;
    yaml << "baseline_m: " << std::setprecision(8) << sb.baseline.norm() << "\nbaseline_in_lower: [" << sb.baseline.x()
         << ", " << sb.baseline.y() << ", " << sb.baseline.z() << "]  # x right, y down, z forward\nbaseline_sigma: ["
         << std::setprecision(3) << baseline_sigma.x() << ", " << baseline_sigma.y() << ", " << baseline_sigma.z()
         << "]\naxis_tilt_deg: " << std::setprecision(5) << tilt << "  # baseline from the sphere's vertical (-y)\n";
    WriteText(stage / "calibration" / (sb.config->id + "_spherical.yaml"), yaml.str());
    parameters.push_back({{"name", "baseline length [m]"}, {"initial", sb.baseline_prior.norm()},
                          {"adjusted", sb.baseline.norm()}, {"sigma", baseline_sigma.y()}});
    parameters.push_back({{"name", "axis tilt [deg]"}, {"initial", 0.0}, {"adjusted", tilt},
                          {"sigma", std::hypot(baseline_sigma.x(), baseline_sigma.z()) / sb.baseline.norm() * kDeg}});
    calibrations.push_back({{"name", sb.config->id + " spherical stereo pair (line-scan calibration)"},
                            {"parameters", parameters}});
  }
  if (s.rig) {
    const RigBlock& rig = *s.rig;
    for (size_t f = 0; f < rig.rig_from_world.size(); ++f) {
      const Rigid3d& pose = rig.rig_from_world[f];
      const Eigen::Vector3d d = CameraCentre(pose) - CameraCentre(rig.rig_prior[f]);
      const double d_rotation = pose.rotation.angularDistance(rig.rig_prior[f].rotation) * kDeg;
      corrections.push_back({{"image", rig.frame_names[f]}, {"sensor", rig.config->id}, {"d", Vec(d)},
                             {"d_position_m", d.norm()}, {"d_rotation_deg", d_rotation}});
      const Eigen::Vector3d sigma = CentreCovariance(st, pose).diagonal().cwiseMax(0.0).cwiseSqrt();
      for (size_t k = 0; k < rig.cam_from_rig.size(); ++k) {
        const Rigid3d cam_from_world = rig.cam_from_rig[k] * pose;
        const Eigen::Vector3d c = CameraCentre(cam_from_world);
        const Eigen::Quaterniond& q = cam_from_world.rotation;
        poses << rig.frame_names[f] << "_" << rig.camera_names[k] << "," << rig.config->id << "," << std::setprecision(12)
              << c.x() << "," << c.y() << "," << c.z() << "," << q.w() << "," << q.x() << "," << q.y() << "," << q.z()
              << "," << Geo(s.plane, c) << "," << std::setprecision(6) << sigma.x() << "," << sigma.y() << ","
              << sigma.z() << "," << d.norm() << "," << d_rotation << "\n";
      }
    }
    // Rig calibration: cam_from_rig and intrinsics with σ, in the input schema.
    std::ostringstream yaml;
    json parameters = json::array();
    yaml << "# mmba adjust: calibration of the camera rig '" << rig.config->id << "' (cam_from_rig "
         << rig.config->cam_from_rig << "), sigma from the adjustment\nbody_from_rig: {qvec_wxyz: ["
         << std::setprecision(10) << rig.body_from_rig.rotation.w() << ", " << rig.body_from_rig.rotation.x() << ", "
         << rig.body_from_rig.rotation.y() << ", " << rig.body_from_rig.rotation.z() << "], tvec: ["
         << rig.body_from_rig.translation.x() << ", " << rig.body_from_rig.translation.y() << ", "
         << rig.body_from_rig.translation.z() << "]}\ncameras:\n";
    for (size_t k = 0; k < rig.cameras.size(); ++k) {
      const sensors::Camera& camera = s.scene.Camera(rig.cameras[k]);
      const Rigid3d& cr = rig.cam_from_rig[k];
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
    WriteText(stage / "calibration" / (rig.config->id + "_rig.yaml"), yaml.str());
    calibrations.push_back({{"name", rig.config->id + " camera rig"}, {"parameters", parameters}});
  }
  if (s.mobile) {
    const MobileBlock& m = *s.mobile;
    const Rigid3d body_from_lidar = m.body_from_vehicle * m.vehicle_from_lidar;
    // Calibration: the extrinsic with σ (and, with a rig, cam_from_lidar of every camera).
    const Eigen::Matrix<double, 6, 6> cov = ComposedPoseCovariance(st, Rigid3d(), m.vehicle_from_lidar);
    const auto sigma_text = [](const Eigen::Matrix<double, 6, 6>& c) {
      std::ostringstream o;
      o << std::setprecision(3) << "rotation_sigma_deg: [" << std::sqrt(std::max(0.0, c(0, 0))) * kDeg << ", "
        << std::sqrt(std::max(0.0, c(1, 1))) * kDeg << ", " << std::sqrt(std::max(0.0, c(2, 2))) * kDeg
        << "], tvec_sigma_m: [" << std::sqrt(std::max(0.0, c(3, 3))) << ", " << std::sqrt(std::max(0.0, c(4, 4))) << ", "
        << std::sqrt(std::max(0.0, c(5, 5))) << "]";
      return o.str();
    };
    std::ostringstream yaml;
    yaml << "# mmba adjust: camera-LiDAR calibration of '" << m.config->id << "' (extrinsic "
         << (m.with_rig ? m.config->extrinsic : std::string("held: no rig on the vehicle"))
         << "); sigma from the adjustment (rotation sigma about the target frame's axes)\n"
         << "body_from_lidar: " << YamlPose(body_from_lidar) << "\n";
    json parameters = json::array();
    const auto [dr, dt] = PoseError(m.vehicle_from_lidar, m.vehicle_from_lidar_initial);
    if (m.with_rig) {
      yaml << "rig_from_lidar: " << YamlPose(m.vehicle_from_lidar) << "\nrig_from_lidar_sigma: {" << sigma_text(cov)
           << "}\ncameras:\n";
      for (size_t k = 0; k < s.rig->cameras.size(); ++k) {
        const Rigid3d cam_from_lidar = s.rig->cam_from_rig[k] * m.vehicle_from_lidar;
        yaml << "  - name: " << s.rig->camera_names[k] << "\n    cam_from_lidar: " << YamlPose(cam_from_lidar)
             << "\n    cam_from_lidar_sigma: {"
             << sigma_text(ComposedPoseCovariance(st, s.rig->cam_from_rig[k], m.vehicle_from_lidar)) << "}\n";
      }
    }
    parameters.push_back({{"name", "extrinsic rotation change [deg]"}, {"initial", 0.0}, {"adjusted", dr},
                          {"sigma", std::sqrt(std::max(0.0, cov.topLeftCorner<3, 3>().trace())) * kDeg}});
    parameters.push_back({{"name", "extrinsic lever-arm change [m]"}, {"initial", 0.0}, {"adjusted", dt},
                          {"sigma", std::sqrt(std::max(0.0, cov.bottomRightCorner<3, 3>().trace()))}});
    WriteText(stage / "calibration" / (m.config->id + "_camera_lidar.yaml"), yaml.str());
    calibrations.push_back({{"name", m.config->id + " camera-LiDAR extrinsic"}, {"parameters", parameters}});
    // The trajectory corrections at the nodes, with σ.
    std::ostringstream trajectory;
    trajectory << "# mmba adjust: corrections of the GNSS/INS trajectory of '" << m.config->id
               << "' at the nodes (linear in between): world_from_body = (Exp(omega) R_ins, p_ins + delta)\n"
                  "time_s,omega_x_deg,omega_y_deg,omega_z_deg,delta_east_m,delta_north_m,delta_up_m,sigma_omega_deg,"
                  "sigma_delta_m,east_m,north_m,up_m,points,rig_frames\n";
    // What observes each node: the mobile points on the static surface and the rig frames whose
    // time falls in the node's two intervals. A node with neither follows the GNSS/INS prior's
    // model alone (extrapolated from its neighbours).
    std::vector<size_t> node_points(m.nodes.size(), 0), node_frames(m.nodes.size(), 0);
    const auto touch = [&](const NodeWeight& w, std::vector<size_t>* count) {
      if (w.alpha < 1.0) ++(*count)[w.node];
      if (w.alpha > 0.0 && w.node + 1 < count->size()) ++(*count)[w.node + 1];
    };
    for (const MobilePoint& p : m.points) touch(p.weight, &node_points);
    for (const FrameOnTrajectory& f : m.frames) touch(f.weight, &node_frames);
    json unobserved = json::array();
    double worst = 0.0;
    for (size_t i = 0; i < m.nodes.size(); ++i) {
      const TrajectoryNode& node = m.nodes[i];
      if (node_points[i] == 0 && node_frames[i] == 0) unobserved.push_back(node.time_s);
      double var_omega = 0.0, var_delta = 0.0;
      for (int k = 0; k < 3; ++k) {
        var_omega += st.Covariance(node.correction, k, node.correction, k);
        var_delta += st.Covariance(node.correction, 3 + k, node.correction, 3 + k);
      }
      const Rigid3d corrected = CorrectedPose(m.nodes, WeightAt(m.nodes, node.time_s), InterpolateTrajectory(m.trajectory, node.time_s));
      trajectory << std::setprecision(10) << node.time_s << std::setprecision(6);
      for (int k = 0; k < 3; ++k) trajectory << "," << node.correction[k] * kDeg;
      for (int k = 0; k < 3; ++k) trajectory << "," << node.correction[3 + k];
      trajectory << "," << std::sqrt(std::max(0.0, var_omega)) * kDeg << "," << std::sqrt(std::max(0.0, var_delta))
                 << std::setprecision(12) << "," << corrected.translation.x() << "," << corrected.translation.y() << ","
                 << corrected.translation.z() << "," << node_points[i] << "," << node_frames[i] << "\n";
      worst = std::max(worst, Eigen::Vector3d(node.correction[3], node.correction[4], node.correction[5]).norm());
    }
    WriteText(stage / (m.config->id + "_trajectory.csv"), trajectory.str());
    // The whole delivered cloud re-georeferenced with the corrected trajectory and extrinsic,
    // coloured from the adjusted rig images and photos where seen (colourise.cc: a first pass
    // builds the images' z-buffers from the cloud, the second colours), and the error map of
    // the points used (intensity = signed distance to the static surface).
    // Streamed: one chunk in memory at a time.
    const Rigid3d lidar_from_body_nominal = m.body_from_lidar_nominal.Inverse();
    const auto correct = [&](const io::PointCloud& chunk, io::PointCloud* corrected) {
      corrected->points.resize(chunk.size());
      corrected->intensity = chunk.intensity;
      corrected->time = chunk.time;
      for (size_t i = 0; i < chunk.size(); ++i) {
        const Rigid3d ins = InterpolateTrajectory(m.trajectory, chunk.time[i]);
        const Eigen::Vector3d in_lidar = lidar_from_body_nominal * (ins.Inverse() * chunk.points[i]);
        corrected->points[i] = CorrectedPose(m.nodes, WeightAt(m.nodes, chunk.time[i]), ins) * (body_from_lidar * in_lidar);
      }
    };
    MobileColouring colouring(s, options.num_threads);
    if (colouring.active()) {
      io::PointCloud corrected;
      io::StreamPointCloud(m.config->cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
        correct(chunk, &corrected);
        colouring.AddDepths(corrected);
      });
    }
    WriteFileAtomically(stage / (m.config->id + "_corrected.ply"), [&](std::ostream& out) {
      io::PointCloud corrected;
      io::StreamPointCloud(m.config->cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t first, size_t total) {
        correct(chunk, &corrected);
        colouring.Colour(&corrected);
        if (first == 0) io::WritePlyHeader(out, total, corrected);
        io::AppendPlyRecords(out, corrected);
      });
    }, /*binary=*/true);
    if (colouring.active()) report["mobile_lidar_coloured"] = colouring.Report(m.config->id + "_corrected.ply");
    io::PointCloud error_map;
    for (const MobilePoint& p : m.points) {
      const Eigen::Vector3d world = CorrectedPose(m.nodes, p.weight, p.ins) * (body_from_lidar * p.point_lidar);
      error_map.points.push_back(world);
      const Eigen::Vector3d on_plane = p.scan < 0 ? world : s.scan_from_world[p.scan] * world;
      error_map.intensity.push_back(static_cast<float>(p.normal.dot(on_plane - p.plane_point)));
    }
    io::WritePly(error_map, (stage / ("error_map_" + m.config->id + ".ply")).string());
    report["mobile_lidar"] = {{"sensor", m.config->id}, {"points", m.num_points}, {"used", m.sample.size()},
                              {"on_surface", m.points.size()}, {"nodes", m.nodes.size()},
                              {"max_position_correction_m", worst}, {"extrinsic", m.with_rig ? m.config->extrinsic : "held"},
                              {"extrinsic_rotation_change_deg", dr}, {"extrinsic_translation_change_m", dt},
                              {"unobserved_node_times_s", unobserved}};
    if (!unobserved.empty()) {
      s.warnings.push_back("lidar_mobile '" + m.config->id + "': " + std::to_string(unobserved.size()) + " of " +
                           std::to_string(m.nodes.size()) + " trajectory nodes (t = " + unobserved.front().dump() + " to " +
                           unobserved.back().dump() + " s) have no mobile point on the static surface and no rig frame: "
                           "their corrections are the GNSS/INS prior's extrapolation, see the points and rig_frames "
                           "columns of " + m.config->id + "_trajectory.csv");
    }
  }
  // Adjusted static scans: world_from_scan with σ and the change from the registration.
  if (!s.scans.empty()) {
    std::ostringstream csv;
    csv << std::setprecision(12)
        << "# mmba adjust: static scans, world_from_scan (scanner position in the world, local ENU; q = scan_from_world "
           "w, x, y, z); sigma from the adjustment; corrections from the registration given in the project\n"
           "scan,east_m,north_m,up_m,qw,qx,qy,qz,sigma_east_m,sigma_north_m,sigma_up_m,sigma_rotation_deg,"
           "d_position_m,d_rotation_deg\n";
    json scans = json::array();
    for (size_t k = 0; k < s.scans.size(); ++k) {
      const Rigid3d& pose = s.scan_from_world[k];
      const Eigen::Vector3d centre = CameraCentre(pose);
      const Eigen::Vector3d sigma = CentreCovariance(st, pose).diagonal().cwiseMax(0.0).cwiseSqrt();
      const double* q = pose.rotation.coeffs().data();
      double rotation_variance = 0.0;
      if (st.IsFree(q)) {
        for (int a = 0; a < 3; ++a) rotation_variance += st.Covariance(q, a, q, a);
      }
      const double sigma_rotation = std::sqrt(std::max(0.0, rotation_variance)) * kDeg;  // of the rotation vector
      const double dp = (centre - CameraCentre(s.scans[k].prior)).norm();
      const double dr = pose.rotation.angularDistance(s.scans[k].prior.rotation) * kDeg;
      csv << s.scans[k].name << "," << centre.x() << "," << centre.y() << "," << centre.z() << "," << pose.rotation.w()
          << "," << pose.rotation.x() << "," << pose.rotation.y() << "," << pose.rotation.z() << "," << sigma.x() << ","
          << sigma.y() << "," << sigma.z() << "," << sigma_rotation << "," << dp << "," << dr << "\n";
      // In the report's calibration tables: the scanner position and the rotation change.
      const Eigen::Vector3d registered = CameraCentre(s.scans[k].prior);
      json parameters = json::array();
      const char* axes[3] = {"scanner east [m]", "scanner north [m]", "scanner up [m]"};
      for (int a = 0; a < 3; ++a) {
        parameters.push_back({{"name", axes[a]}, {"initial", registered[a]}, {"adjusted", centre[a]}, {"sigma", sigma[a]}});
      }
      parameters.push_back({{"name", "rotation change [deg]"}, {"initial", 0.0}, {"adjusted", dr}, {"sigma", sigma_rotation}});
      const ScanInitialisation& init = s.scans[k].initialisation;
      calibrations.push_back({{"name", "static scan " + s.scans[k].name + " (world_from_scan; initial = " +
                                           (init.method == "given" ? std::string("the registration") : init.method) + ")"},
                              {"parameters", parameters}});
      scans.push_back({{"name", s.scans[k].name}, {"file", s.scans[k].file}, {"position_m", Vec(centre)},
                       {"sigma_position_m", Vec(sigma)}, {"sigma_rotation_deg", sigma_rotation},
                       {"position_correction_m", dp}, {"rotation_correction_deg", dr},
                       {"initialisation", init.method}, {"initialisation_detail", init.detail},
                       {"registration_prior", s.scans[k].has_prior}});
    }
    WriteText(stage / "scans.csv", csv.str());
    report["static_scans"] = {{"scans", scans}, {"scan_to_scan_pairs", s.scan_pairs.size()}};
  }
  WriteText(stage / "poses.csv", poses.str());
  report["pose_corrections"] = corrections;
  report["calibrations"] = calibrations;
  // Survey points.
  if (s.joint) {
    std::ostringstream points;
    points << "# mmba adjust: surveyed points in the world (local ENU at the project origin); sigma and ellipse "
              "(1 sigma, azimuth from north) from the joint adjustment\n"
              "id,role,east_m,north_m,up_m,sigma_east_m,sigma_north_m,sigma_up_m,ellipse_a_m,ellipse_b_m,"
              "ellipse_azimuth_deg,latitude_deg,longitude_deg,height_m,utm_zone,utm_easting_m,utm_northing_m\n";
    for (const survey::SurveyPoint& p : s.joint->points) {
      const bool check = std::count(project.check_points.begin(), project.check_points.end(), p.id) > 0;
      if (check && !(s.photos && s.photos->check_ids.count(p.id))) continue;
      const Eigen::Vector3d x = check ? s.scene.Point(s.photos->check_ids.at(p.id)) : WorldFromSurvey(*s.joint, p);
      const Eigen::Matrix3d cov = check ? PointCovariance3(st, s.scene.Point(s.photos->check_ids.at(p.id)).data())
                                        : SurveyPointCovariance(st, *s.joint, p);
      const Eigen::Vector3d sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
      const json e = Ellipse(cov);
      const std::string role = check ? "check (photos only)" : (p.xy_free() || p.z_free()) ? "adjusted" : "fixed";
      points << p.id << "," << role << "," << std::setprecision(12) << x.x() << "," << x.y() << "," << x.z() << ","
             << std::setprecision(6) << sigma.x() << "," << sigma.y() << "," << sigma.z() << ","
             << e["a"].get<double>() << "," << e["b"].get<double>() << "," << e["azimuth_deg"].get<double>() << ","
             << Geo(s.plane, x) << "\n";
    }
    WriteText(stage / "points.csv", points.str());
  }
  // Observations.
  {
    std::ostringstream obs;
    obs << "# mmba adjust: every residual row; residual = adjusted - observed in the group's unit; w = studentized\n"
           "group,block,row,residual,whitened,sigma,redundancy,studentized,critical\n";
    for (const stats::RowStatistic& r : st.rows) {
      obs << '"' << builder_groups[r.group]->name() << "\"," << r.block << "," << r.row << "," << std::setprecision(6)
          << r.residual << "," << r.whitened << "," << r.sigma << "," << r.redundancy << "," << r.studentized << ","
          << (r.critical ? 1 : 0) << "\n";
    }
    WriteText(stage / "observations.csv", obs.str());
  }
  if (!project.truth.empty()) report["truth_evaluation"] = EvaluateTruth(s);
  json files = json::array({json{{"name", "report.html"}, {"description", "this report"}},
                            json{{"name", "report.json"}, {"description", "the report's data"}},
                            json{{"name", "poses.csv"}, {"description", "camera poses: local ENU, WGS84, UTM, sigma"}},
                            json{{"name", "observations.csv"}, {"description", "every residual with redundancy and studentized residual"}}});
  if (s.rig) {
    files.push_back({{"name", "calibration/" + s.rig->config->id + "_rig.yaml"},
                     {"description", "rig calibration (cam_from_rig, intrinsics) with sigma"}});
  }
  if (s.spheres) {
    files.push_back({{"name", "calibration/" + s.spheres->config->id + "_spherical.yaml"},
                     {"description", "line-scan calibration of the spherical pair with sigma"}});
  }
  if (s.mobile) {
    const std::string id = s.mobile->config->id;
    files.push_back({{"name", "calibration/" + id + "_camera_lidar.yaml"}, {"description", "camera-LiDAR extrinsic with sigma"}});
    files.push_back({{"name", id + "_trajectory.csv"}, {"description", "trajectory corrections at the nodes with sigma"}});
    files.push_back({{"name", id + "_corrected.ply"}, {"description", "the mobile cloud re-georeferenced (corrected trajectory and extrinsic), coloured from the adjusted rig images and photos where seen (grey: not seen)"}});
    files.push_back({{"name", "error_map_" + id + ".ply"}, {"description", "mobile points used, intensity = signed distance to the static surface (m)"}});
  }
  if (s.joint) files.push_back({{"name", "points.csv"}, {"description", "surveyed points with sigma and error ellipses"}});
  if (s.photos) {
    files.push_back({{"name", "colmap/" + s.photos->config->id}, {"description", "adjusted COLMAP model (text)"}});
    files.push_back({{"name", "calibration/" + s.photos->config->id + "_camera.yaml"}, {"description", "camera calibration with sigma"}});
    files.push_back({{"name", "tie_points.ply"}, {"description", "georeferenced tie points, coloured from the images"}});
    if (!s.planes.empty()) files.push_back({{"name", "error_map_lidar.ply"}, {"description", "tie points, intensity = signed distance to the LiDAR surface (m)"}});
    if (!s.scans.empty()) files.push_back({{"name", "scans.csv"}, {"description", "adjusted static scans: world_from_scan with sigma and the correction of the registration"}});
  }
  std::vector<StepStatus> dense_status;  // per entry of report["spherical_dense"]
  if (s.spheres && s.spheres->config->dense_cloud) {
    report["spherical_dense"] = WriteSphereDense(s, stage, &files, &dense_status);
  }
  if (s.surface) {
    const json coloured = WriteColouredLidar(s, stage, &files);
    if (!coloured.empty()) report["lidar_coloured"] = coloured;
  }
  if (!s.mi_registration.empty()) {
    // The MI registrations the adjustment ran, and where the adjustment ended against them
    // (the MI paper's camera-pose corrections, Fig. 13).
    json registration = json::array();
    for (size_t i = 0; i < s.mi_registration.size(); ++i) {
      json e = s.mi_registration[i];
      if (e.value("prior", false)) {
        // The MI rig calibration found rig_from_lidar: against the adjusted extrinsic.
        const Rigid3d adjusted = e.value("extrinsic", false) ? s.mobile->vehicle_from_lidar
                                 : e.contains("frame")       ? s.rig->rig_from_world.at(e["frame"].get<size_t>())
                                                             : s.scene.Image(ImageId(e["image_id"].get<uint64_t>())).cam_from_world;
        const Rigid3d& registered = s.mi_registered[i];
        e["adjusted_minus_registered_m"] = (CameraCentre(adjusted) - CameraCentre(registered)).norm();
        e["adjusted_minus_registered_deg"] = adjusted.rotation.angularDistance(registered.rotation) * kDeg;
      }
      e.erase("frame");
      e.erase("image_id");
      e.erase("extrinsic");
      registration.push_back(e);
    }
    report["mi_registration"] = registration;
    fs::create_directories(stage / "mi");
    for (const auto& [name, result] : s.mi_files) WriteText(stage / "mi" / (name + ".json"), result.dump(2) + "\n");
    if (!s.mi_files.empty()) {
      files.push_back({{"name", "mi/"}, {"description", "the MI registrations run by the adjustment (mi_register), one register-mi result per image"}});
    }
  }
  if (s.spheres && !s.spheres->registration.empty()) {
    json registration = json::array();
    for (const auto& [station, entry] : s.spheres->registration) {
      json e = entry;
      if (s.spheres->registration_status.at(station) == StepStatus::kOk) {
        // Where the adjustment ended against where the registration put the station.
        const ImageId id = s.spheres->lower_image.at(station);
        const Rigid3d& adjusted = s.scene.Image(id).cam_from_world;
        const Rigid3d& registered = s.spheres->initial_poses.at(id);
        const double dp = (CameraCentre(adjusted) - CameraCentre(registered)).norm();
        const double dr = adjusted.rotation.angularDistance(registered.rotation) * kDeg;
        e["adjusted_minus_registered_m"] = dp;
        e["adjusted_minus_registered_deg"] = dr;
        // The registration is an initial value only; the adjustment (tie points, control) is
        // the judge. A registration that ended far from it was wrong although it passed.
        const double resolution = e["resolution_m"].is_number() ? e["resolution_m"].get<double>() : 0.0;
        if (dp > std::max(0.05, 3 * resolution) || dr > 0.5) {
          std::ostringstream w;
          w << "spherical station " << station << ": its dense cloud's registration to the LiDAR (the initial pose) is "
            << dp << " m, " << dr << " deg from the adjusted pose: that registration was wrong";
          s.warnings.push_back(w.str());
          e["disagrees_with_adjustment"] = true;
        }
      }
      registration.push_back(e);
    }
    report["spherical_registration"] = registration;
  }
  report["files"] = files;
  json warnings = json::array();
  for (const std::string& w : s.warnings) warnings.push_back(w);
  report["warnings"] = warnings;
  json log = json::array();
  for (const std::string& l : s.log) log.push_back(l);
  report["log"] = log;
  WriteText(stage / "report.json", report.dump(1));
  WriteText(stage / "report.html", report::RenderAdjustReportHtml(report));
  outcome->report = report;
  // Terminal summary.
  std::ostringstream sum;
  sum << "adjust " << project.name << ": converged, " << s.total_iterations << " iterations (" << s.outer_iterations
      << " outer), " << std::fixed << std::setprecision(1) << s.seconds << " s\n"
      << "  sigma0 " << std::setprecision(3) << st.sigma0_ratio << ", chi2 test at " << st.confidence << ": ["
      << st.chi2_lower << ", " << st.chi2_upper << "] -> " << (st.chi2_passed ? "passed" : "FAILED") << ", dof "
      << st.degrees_of_freedom << "\n"
      << "  with the project's sigma: sigma0 " << given.sigma0_ratio << " -> "
      << (given.chi2_passed ? "passed" : "FAILED") << (s.sigma_factor.empty() ? "" : "; groups re-weighted by variance components")
      << "\n";
  for (const json& g : groups) {
    sum << "  " << std::left << std::setw(44) << g["name"].get<std::string>() << std::right << std::setw(7)
        << g["observations"].get<size_t>() << " obs  RMS " << std::setprecision(4) << g["rms"].get<double>() << " "
        << g["unit"].get<std::string>() << "  variance component " << std::setprecision(3)
        << g["variance_component_given_weights"].get<double>();
    if (g["reweighting"] == "variance components") {
      sum << " (sigma x " << g["sigma_factor"].get<double>() << ")\n";
    } else {
      sum << " (" << g["reweighting"].get<std::string>() << ")\n";
    }
  }
  if (report.contains("check_summary")) {
    const json& c = report["check_summary"];
    sum << "  check points: " << c["count"].get<size_t>() << ", RMSE 3D " << std::setprecision(4)
        << c["rmse_3d"].get<double>() << " m (expected " << c["expected_rmse_3d"].get<double>() << " m)\n";
  }
  sum << "  blunders flagged and excluded: " << s.blunders.size() << "\n";
  if (report.contains("spherical_registration")) {
    for (const json& d : report["spherical_registration"]) {
      sum << "  station " << d["station"].get<std::string>() << " initialised by its dense cloud on the LiDAR: "
          << d["status"].get<std::string>();
      if (s.spheres->registration_status.at(d["station"].get<std::string>()) == StepStatus::kOk) {
        sum << " (setup moved " << std::setprecision(3) << d["shift_from_setup_m"].get<double>() << " m, "
            << d["rotation_from_setup_deg"].get<double>() << " deg)";
      }
      sum << "\n";
    }
  }
  if (report.contains("spherical_dense")) {
    for (size_t k = 0; k < dense_status.size(); ++k) {
      const json& d = report["spherical_dense"][k];
      if (dense_status[k] != StepStatus::kOk) {
        sum << "  dense cloud of station " << d["station"].get<std::string>() << ": " << d["status"].get<std::string>()
            << "\n";
        continue;
      }
      sum << "  dense cloud of station " << d["station"].get<std::string>() << ": " << d["points"].get<size_t>()
          << " points, median range " << std::setprecision(3) << d["median_range_m"].get<double>() << " m (sigma "
          << d["median_range_sigma_m"].get<double>() << " m)";
      if (d.contains("median_abs_distance_to_lidar_m")) {
        sum << ", " << d["lidar_compared"].get<size_t>() << " on the LiDAR surface: median |distance| "
            << d["median_abs_distance_to_lidar_m"].get<double>() << " m";
      }
      sum << "\n";
    }
  }
  for (const std::string& w : s.warnings) sum << "  warning: " << w << "\n";
  sum << "  report: " << (out_dir / "report.html").string();
  outcome->summary = sum.str();
}

}  // namespace mmba::adjust::internal
