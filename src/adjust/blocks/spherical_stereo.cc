// Spherical stereo pairs (DESIGN.md "Factor groups": spherical pair): loading the pair's
// calibration, station setups and observations of photo tie points, its factor groups and
// line-scan calibration parameters, and its outputs (poses of both spheres, the calibration,
// each station's dense cloud). The pair's initialisation on the LiDAR is sphere_init.cc.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "../las_output.h"
#include "../output_support.h"
#include "blocks.h"
#include "../sphere_dense.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/yaml_reader.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

/// The pair's calibration (calib/README.md): both equirectangular cameras into the scene, the
/// baseline vector and its prior. Returns the baseline length [m].
double ReadSphereCalibration(JointState* s, const SphericalStereo& config, SphereBlock* block_ptr) {
  SphereBlock& block = *block_ptr;
  const io::YamlReader r(config.calibration);
  const YAML::Node root = r.Load("spherical stereo calibration");
  std::string model;
  sensors::Camera cameras[2];
  double baseline_m = 0.0;
  r.Map(root, "", {{"model", [&](const YAML::Node& n, const std::string& f) {
                      model = r.String(n, f);
                      if (model != "EQUIRECTANGULAR") r.Fail(n, f, "EQUIRECTANGULAR", model);
                    }},
                   {"width", [&](const YAML::Node& n, const std::string& f) { cameras[0].width = cameras[1].width = r.Integer(n, f); }},
                   {"height", [&](const YAML::Node& n, const std::string& f) { cameras[0].height = cameras[1].height = r.Integer(n, f); }},
                   {"lower_params", [&](const YAML::Node& n, const std::string& f) {
                      cameras[0].params = r.NumberList(n, f);
                      if (cameras[0].params.size() != 3) r.Fail(n, f, "3 numbers (f, cx, cy)", std::to_string(cameras[0].params.size()) + " numbers");
                    }},
                   {"upper_params", [&](const YAML::Node& n, const std::string& f) {
                      cameras[1].params = r.NumberList(n, f);
                      if (cameras[1].params.size() != 3) r.Fail(n, f, "3 numbers (f, cx, cy)", std::to_string(cameras[1].params.size()) + " numbers");
                    }},
                   {"baseline_m", [&](const YAML::Node& n, const std::string& f) { baseline_m = r.Positive(n, f, 10.0, "m"); }}});
  r.Require(root, "", {"model", "width", "height", "lower_params", "upper_params", "baseline_m"});
  if (cameras[0].width < 2 || cameras[0].height < 1) r.Fail(root["width"], "width", "a panorama size in pixels", std::to_string(cameras[0].width));
  for (int k = 0; k < 2; ++k) {
    cameras[k].camera_id = k == 0 ? block.lower_camera : block.upper_camera;
    cameras[k].model_id = sensors::CameraModelId::kEquirectangular;
    s->scene.AddCamera(cameras[k]);
  }
  block.initial_lower_params = cameras[0].params;
  block.initial_upper_params = cameras[1].params;
  // The baseline vector in the lower sphere's frame (x right, y down, z forward): up = −y.
  block.baseline = block.baseline_prior = Eigen::Vector3d(0, -baseline_m, 0);
  return baseline_m;
}

/// The stations' setups (stations_file: centre ENU [m], heading [deg]) as lower-sphere images
/// with their given poses; every listed station must have a row.
void ReadSphereSetups(JointState* s, const Project& project, const SphericalStereo& config, SphereBlock* block_ptr) {
  SphereBlock& block = *block_ptr;
  const io::CsvTable setups = io::CsvTable::Read(config.stations_file, {"station", "east_m", "north_m", "up_m", "heading_deg"});
  uint64_t next_image = 3000000;
  for (const io::CsvTable::Row& row : setups.rows()) {
    const std::string& name = setups.String(row, "station");
    if (std::find(block.stations.begin(), block.stations.end(), name) == block.stations.end()) continue;
    const Eigen::Vector3d centre(setups.Double(row, "east_m"), setups.Double(row, "north_m"), setups.Double(row, "up_m"));
    const double h = setups.Double(row, "heading_deg") * M_PI / 180.0;
    Eigen::Matrix3d world_from_cam;
    world_from_cam.col(0) = Eigen::Vector3d(std::cos(h), -std::sin(h), 0);
    world_from_cam.col(1) = Eigen::Vector3d(0, 0, -1);
    world_from_cam.col(2) = Eigen::Vector3d(std::sin(h), std::cos(h), 0);
    const ImageId image_id(next_image++);
    s->scene.AddImage(image_id, block.lower_camera, Rigid3d(Eigen::Quaterniond(world_from_cam), centre).Inverse());
    block.lower_image[name] = image_id;
    block.initial_poses[image_id] = block.setup_poses[image_id] = s->scene.Image(image_id).cam_from_world;
  }
  for (const std::string& name : block.stations) {
    if (!block.lower_image.count(name)) {
      throw InputError::Message(ProjectKey(project, config.line, "stations"),
                                "station " + name + " has no row in " + config.stations_file);
    }
  }
}

/// The observations of the photo block's tie points in the panoramas (<station>_lower/_upper).
void ReadSphereObservations(const JointState& s, const SphericalStereo& config, SphereBlock* block_ptr) {
  SphereBlock& block = *block_ptr;
  const sensors::Camera& panorama = s.scene.Camera(block.lower_camera);
  const io::CsvTable table = io::CsvTable::Read(config.observations, {"image", "point_id", "x_px", "y_px"});
  for (const io::CsvTable::Row& row : table.rows()) {
    const std::string stem = fs::path(table.String(row, "image")).stem().string();
    const size_t underscore = stem.rfind('_');
    const std::string station = underscore == std::string::npos ? "" : stem.substr(0, underscore);
    const std::string which = underscore == std::string::npos ? "" : stem.substr(underscore + 1);
    if (!block.lower_image.count(station) || (which != "lower" && which != "upper")) {
      table.Fail(row, "image", table.String(row, "image"), "<station>_lower.<ext> or <station>_upper.<ext> of a listed station");
    }
    const double id = table.Double(row, "point_id");
    const Point3DId point3D_id(static_cast<uint64_t>(id));
    if (id < 0 || id != std::floor(id) || !s.scene.HasPoint(point3D_id)) {
      table.Fail(row, "point_id", table.String(row, "point_id"), "a point3D id of photo collection '" + config.tie_block + "'");
    }
    const Eigen::Vector2d xy(table.Double(row, "x_px"), table.Double(row, "y_px"));
    if (xy.x() < -0.5 || xy.y() < -0.5 || xy.x() > panorama.width + 0.5 || xy.y() > panorama.height + 0.5) {
      table.Fail(row, "x_px", table.String(row, "x_px") + ", " + table.String(row, "y_px"), "a pixel inside the panorama");
    }
    const double sigma = table.Double(row, "sigma_px", config.sigma_px);
    if (!(sigma > 0 && sigma <= 50)) table.Fail(row, "sigma_px", table.String(row, "sigma_px"), "a σ in (0, 50] px");
    const std::string source = config.observations + ":" + std::to_string(row.line);
    if (which == "lower") {
      block.lower.push_back({block.lower_image.at(station), point3D_id, xy, sigma});
      block.lower_source.push_back(source);
    } else {
      block.upper.push_back({block.lower_image.at(station), block.upper_camera, point3D_id, xy, sigma});
      block.upper_source.push_back(source);
    }
  }
}

}  // namespace

void LoadSpheres(JointState* s) {
  const Project& project = *s->project;
  if (project.spherical.empty()) return;
  if (project.spherical.size() > 1) {
    throw InputError::Message(ProjectKey(project, project.spherical[1].line, "sensors"),
                              "found a second spherical_stereo sensor with observations, expected one");
  }
  const SphericalStereo& config = project.spherical.front();
  if (!s->photos || s->photos->config->id != config.tie_block) {
    throw InputError::Message(ProjectKey(project, config.line, "tie_block"),
                              "found " + config.tie_block + ", expected the photo_collection whose tie points are observed");
  }
  SphereBlock block;
  block.config = &config;
  block.stations = config.stations;
  const double baseline_m = ReadSphereCalibration(s, config, &block);
  ReadSphereSetups(s, project, config, &block);
  ReadSphereObservations(*s, config, &block);
  Note(s, "spherical stereo '" + config.id + "': " + std::to_string(block.stations.size()) + " stations, " +
              std::to_string(block.lower.size()) + " lower + " + std::to_string(block.upper.size()) +
              " upper observations of photo tie points, baseline " + std::to_string(baseline_m) + " m (prior σ " +
              std::to_string(config.baseline_sigma_m) + " m)");
  s->spheres = std::move(block);
}

/// The dense cloud of every spherical station (vertical-baseline stereo on the adjusted pair:
/// its calibration, baseline and pose), georeferenced, written as <id>_<station>_dense.ply
/// with intensity from the lower panorama; compared with the LiDAR surface where there is
/// one. Returns the report's entry (with the median range σ).
json WriteSphereDense(const JointState& s, const fs::path& stage, json* files, std::vector<StepStatus>* statuses) {
  json stations = json::array();
  const SphereBlock& sb = *s.spheres;
  for (const auto& [station, id] : sb.lower_image) {
    const std::string lower_path = FindImage(sb.config->images, station + "_lower");
    const std::string upper_path = FindImage(sb.config->images, station + "_upper");
    if (lower_path.empty() || upper_path.empty()) {
      stations.push_back({{"station", station}, {"status", "no panoramas " + station + "_lower/_upper in " + sb.config->images}});
      statuses->push_back(StepStatus::kNotAttempted);
      continue;
    }
    spdlog::info("adjust: dense cloud of spherical station {}", station);
    DenseStereoCloud dense;
    try {
      dense = DenseSphericalStereo(lower_path, upper_path, s.scene.Camera(sb.lower_camera), s.scene.Camera(sb.upper_camera),
                                   sb.baseline);
    } catch (const std::exception& e) {
      // A by-product: a panorama that cannot be matched costs its cloud, not the adjustment.
      stations.push_back({{"station", station}, {"status", StepStatusText(StepStatus::kFailed, e.what())}});
      statuses->push_back(StepStatus::kFailed);
      spdlog::warn("adjust: no dense cloud for spherical station {}: {}", station, e.what());
      continue;
    }
    const Rigid3d world_from_lower = s.scene.Image(id).cam_from_world.Inverse();
    io::PointCloud cloud = dense.cloud;
    for (Eigen::Vector3d& p : cloud.points) p = world_from_lower * p;
    std::vector<double> ranges;
    for (const Eigen::Vector3d& p : dense.cloud.points) ranges.push_back(p.norm());
    const auto median = [](std::vector<double> v) {
      if (v.empty()) return 0.0;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    json entry = {{"station", station}, {"status", StepStatusText(StepStatus::kOk)}, {"points", cloud.size()}, {"match_width_px", dense.match_width},
                  {"matched_pixels", dense.matched_pixels}, {"median_range_m", median(ranges)},
                  {"median_range_sigma_m", median(dense.range_sigma_m)}};
    if (s.surface && !cloud.empty()) {
      // Distance along the LiDAR surface's normal for an even sample; |d|/σ_range should be
      // about 0.67 at the median when the σ and the adjusted pose are right.
      std::vector<double> distance, normalised;
      const size_t step = std::max<size_t>(1, cloud.size() / 20000);
      for (size_t i = 0; i < cloud.size(); i += step) {
        Eigen::Vector3d n, c;
        const double gate = std::max(0.1, 3 * dense.range_sigma_m[i]);
        if (!s.surface->FitPlane(cloud.points[i], gate, 12, &n, &c, nullptr)) continue;
        const double d = std::abs(n.dot(cloud.points[i] - c));
        distance.push_back(d);
        normalised.push_back(d / std::max(dense.range_sigma_m[i], 1e-6));
      }
      entry["lidar_compared"] = distance.size();  // points over the cropped LiDAR surface
      if (!distance.empty()) {
        entry["median_abs_distance_to_lidar_m"] = median(distance);
        entry["median_abs_distance_over_sigma"] = median(normalised);
      }
    }
    const std::string name = sb.config->id + "_" + station + "_dense.ply";
    io::WritePly(cloud, (stage / name).string());
    WriteLasBeside(s, cloud, stage / name);
    files->push_back({{"name", name},
                      {"description", "dense cloud of spherical station " + station +
                                          " (vertical-baseline stereo), georeferenced; intensity from the lower panorama"}});
    files->push_back(LasFileEntry(s, name, "dense cloud of spherical station " + station));
    stations.push_back(entry);
    statuses->push_back(StepStatus::kOk);
  }
  return stations;
}

void AddSphereGroups(JointState* s, const GroupWeights& w) {
  SphereBlock& sb = *s->spheres;
  const LossOptions& loss = sb.config->loss;
  s->builder->AddGroup(std::make_unique<ReprojectionGroup>(w.Scaled(kSphereLower, sb.lower), loss, kSphereLower));
  s->builder->AddGroup(std::make_unique<UpperSphereGroup>(w.Scaled(kSphereUpper, sb.upper), &sb.baseline, loss, kSphereUpper));
  s->builder->AddGroup(std::make_unique<VectorPriorGroup>(&sb.baseline, sb.baseline_prior,
                                                          w.Factor(kBaseline) * sb.config->baseline_sigma_m, kBaseline));
  // The line-scan calibration: the vertical principal offsets cy of both spheres and the
  // horizontal offset cx of the upper one relative to the lower (a common cx shift of a full
  // panorama is a rotation about the sphere's axis — the station's heading — so the lower
  // cx is held as the datum); f (= W/2π for a full panorama) only when asked. Parameters
  // (f, cx, cy).
  const SphericalStereo& config = *sb.config;
  for (CameraId id : {sb.lower_camera, sb.upper_camera}) {
    std::vector<int>& held = s->builder->parameter_options().held_intrinsics[id];
    held.clear();
    if (!config.refine_focal) held.push_back(0);
    if (!config.refine_principal_point || id == sb.lower_camera) held.push_back(1);
    if (!config.refine_principal_point) held.push_back(2);
  }
}

std::string DescribeSphereObservation(const JointState& s, const std::string& name, size_t index) {
  if (!s.spheres) return "";
  if (name == kSphereLower) {
    return "point " + std::to_string(s.spheres->lower[index].point3D_id.value) + " (" + s.spheres->lower_source[index] + ")";
  }
  if (name == kSphereUpper) {
    return "point " + std::to_string(s.spheres->upper[index].point3D_id.value) + " (" + s.spheres->upper_source[index] + ")";
  }
  return "";
}

namespace {

/// calibration/<id>_spherical.yaml, the line-scan calibration: principal offsets per sphere,
/// the baseline vector and its tilt; and the pair's calibration table.
void WriteSphereCalibration(const JointState& s, OutputSink* out) {
  const SphereBlock& sb = *s.spheres;
  const stats::NetworkStatistics& st = s.statistics;
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
  WriteText(out->stage / "calibration" / (sb.config->id + "_spherical.yaml"), yaml.str());
  parameters.push_back({{"name", "baseline length [m]"}, {"initial", sb.baseline_prior.norm()},
                        {"adjusted", sb.baseline.norm()}, {"sigma", baseline_sigma.y()}});
  parameters.push_back({{"name", "axis tilt [deg]"}, {"initial", 0.0}, {"adjusted", tilt},
                        {"sigma", std::hypot(baseline_sigma.x(), baseline_sigma.z()) / sb.baseline.norm() * kDeg}});
  out->calibrations.push_back({{"name", sb.config->id + " spherical stereo pair (line-scan calibration)"},
                               {"parameters", parameters}});
}

}  // namespace

void WriteSphereOutputs(const JointState& s, OutputSink* out) {
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
      const Eigen::Vector3d sigma = CentreCovariance(s.statistics, pose.cam_from_world).diagonal().cwiseMax(0.0).cwiseSqrt();
      const std::string name = station + (k == 0 ? "_lower" : "_upper");
      AppendPoseRow(*out->poses, name, sb.config->id, c, cam_from_world.rotation, s.plane, sigma, d.norm(), d_rotation);
      if (k == 0) {
        out->corrections.push_back({{"image", name}, {"sensor", sb.config->id}, {"d", Vec(d)}, {"d_position_m", d.norm()},
                                    {"d_rotation_deg", d_rotation}});
      }
    }
  }
  WriteSphereCalibration(s, out);
}

}  // namespace mmba::adjust::internal
