#include "mmba/adjust/adjust.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <type_traits>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/core/error.h"
#include "mmba/core/progress.h"
#include "mmba/io/csv_table.h"
#include "mmba/io/gama_local.h"
#include "mmba/io/kitti.h"
#include "mmba/io/survey_csv.h"
#include "mmba/io/yaml_reader.h"
#include "mmba/problem/colmap_scene.h"
#include "mmba/survey/survey_group.h"

namespace mmba::adjust {
namespace internal {

std::string ProjectKey(const Project& project, int line, const std::string& key) {
  return project.path + ":" + std::to_string(line) + ": " + key;
}

Eigen::Vector3d WorldFromSurvey(const survey::SurveyNetwork&, const survey::SurveyPoint& p) { return p.coords; }

Eigen::Matrix3d SurveyPointCovariance(const stats::NetworkStatistics& st, const survey::SurveyNetwork&,
                                      const survey::SurveyPoint& p) {
  double* xy = const_cast<double*>(p.coords.data());
  const std::pair<double*, int> scalars[3] = {{xy, 0}, {xy, 1}, {xy + 2, 0}};
  Eigen::Matrix3d enu = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      enu(a, b) = st.Covariance(scalars[a].first, scalars[a].second, scalars[b].first, scalars[b].second);
    }
  }
  return enu;
}

}  // namespace internal

namespace {

namespace fs = std::filesystem;
using internal::JointState;
using internal::PhotoBlock;
using internal::SphereBlock;
using internal::RigBlock;
using internal::AdjustFailure;
using internal::LoadSpheres;
using internal::ProjectKey;
using internal::StatusOfSolve;
using internal::InterpolateTrajectory;

/// A stage's result: logged now and listed in the report.
void Note(JointState* s, const std::string& text) {
  spdlog::info("adjust: {}", text);
  s->log.push_back(text);
}



// ---- total station -----------------------------------------------------------------------

void LoadNetwork(JointState* s) {
  const Project& project = *s->project;
  if (project.total_stations.empty()) return;
  const TotalStation& ts = project.total_stations.front();
  const std::string ext = fs::path(ts.file).extension().string();
  survey::SurveyNetwork network = ext == ".csv" ? io::ReadSurveyCsv(ts.file) : io::ReadGamaLocal(ts.file);
  for (size_t i = 0; i < project.check_points.size(); ++i) {
    if (!network.Find(project.check_points[i])) {
      throw InputError::Message(project.path, "check_points[" + std::to_string(i) + "]: found " +
                                                  project.check_points[i] + ", expected a point of " + ts.file);
    }
  }
  for (const survey::SurveyPoint& p : network.points) {
    if (p.xy == survey::CoordStatus::kFixed && p.z == survey::CoordStatus::kFixed) s->surveyed_ids.insert(p.id);
  }
  for (const survey::Cluster& cluster : network.clusters) {
    for (const survey::Observation& o : cluster.observations) {
      if (!o.active) continue;
      for (const std::string* id : {&o.from, &o.to, &o.fs}) {
        if (!id->empty()) s->surveyed_ids.insert(*id);
      }
    }
  }
  for (const survey::SurveyPoint& p : network.points) {
    if (!s->surveyed_ids.count(p.id)) {
      s->warnings.push_back("point " + p.id + " of " + ts.file +
                            " has no total-station observation: not control, not a check point (its coordinates are approximate)");
    }
  }
  // Initialisation step 1: the network alone gives the control coordinates (and, for check
  // points, the surveyed coordinates they are compared with).
  s->surveyed = network;
  survey::SurveyAdjustOptions options;
  options.confidence = project.settings.confidence;
  s->surveyed_adjustment = survey::AdjustNetwork(&*s->surveyed, options);
  if (!s->surveyed_adjustment.converged) {
    throw AdjustFailure(AdjustStatus::kFailed, "total station network " + ts.file + " alone does not adjust: " +
                                      s->surveyed_adjustment.reason);
  }
  Note(s, "total station network alone: " + std::to_string(s->surveyed_adjustment.statistics.num_equations) +
                   " observations, sigma0 ratio " + std::to_string(s->surveyed_adjustment.statistics.sigma0_ratio));
  // The joint network starts from the adjusted coordinates; check points are withheld: their
  // coordinates leave the network and every observation of them is set passive.
  s->joint = *s->surveyed;
  const std::set<std::string> check(project.check_points.begin(), project.check_points.end());
  for (survey::SurveyPoint& p : s->joint->points) {
    if (check.count(p.id)) p.xy = p.z = survey::CoordStatus::kUnused;
  }
  for (survey::Cluster& cluster : s->joint->clusters) {
    for (survey::Observation& o : cluster.observations) {
      if (check.count(o.from) || check.count(o.to) || check.count(o.fs)) {
        o.active = false;
        o.passive_reason = "check point withheld";
      }
    }
  }
}

// ---- GNSS --------------------------------------------------------------------------------

void LoadGnss(JointState* s) {
  // Each control mark and each photo's antenna position once over all GNSS files: a second
  // row would silently stand beside (or replace) the first.
  std::map<std::pair<std::string, std::string>, std::string> first_row;  // (kind, id) -> file:line
  for (const Gnss& g : s->project->gnss) {
    const io::CsvTable table = io::CsvTable::Read(
        g.file, {"id", "kind", "latitude_deg", "longitude_deg", "height_m", "sigma_east_m", "sigma_north_m", "sigma_up_m"});
    for (const io::CsvTable::Row& row : table.rows()) {
      const std::string& kind = table.String(row, "kind");
      if (kind == "trajectory") {
        ++s->gnss_trajectory_rows;
        continue;
      }
      if (kind != "control" && kind != "camera") table.Fail(row, "kind", kind, "control, camera or trajectory");
      const auto [first, inserted] =
          first_row.emplace(std::make_pair(kind, table.String(row, "id")), g.file + ":" + std::to_string(row.line));
      if (!inserted) {
        table.Fail(row, "id", table.String(row, "id"), "each " + kind + " id once (also at " + first->second + ")");
      }
      geodesy::Geodetic geo{table.Double(row, "latitude_deg"), table.Double(row, "longitude_deg"),
                            table.Double(row, "height_m")};
      if (std::abs(geo.latitude_deg) > 90) table.Fail(row, "latitude_deg", table.String(row, "latitude_deg"), "[-90, 90] degrees");
      if (std::abs(geo.longitude_deg) > 180) table.Fail(row, "longitude_deg", table.String(row, "longitude_deg"), "[-180, 180] degrees");
      GnssPoint p;
      p.point_id = table.String(row, "id");
      p.enu = s->plane.EnuFromGeodetic(geo);
      if (p.enu.norm() > 50000) {
        table.Fail(row, "latitude_deg", table.String(row, "latitude_deg") + ", " + table.String(row, "longitude_deg"),
                   "a point within 50 km of the project origin (inconsistent origin or units?)");
      }
      const char* sigma_columns[3] = {"sigma_east_m", "sigma_north_m", "sigma_up_m"};
      for (int a = 0; a < 3; ++a) {
        p.sigma(a) = table.Double(row, sigma_columns[a]);
        if (!(p.sigma(a) > 0 && p.sigma(a) <= 10)) {
          table.Fail(row, sigma_columns[a], table.String(row, sigma_columns[a]), "a σ in (0, 10] m");
        }
      }
      p.source = g.file + ":" + std::to_string(row.line);
      if (kind == "camera") {  // the antenna position of a photo (id = image name)
        GnssCamera c;
        c.image = p.point_id;
        c.enu = p.enu;
        c.sigma = p.sigma;
        c.source = p.source;
        s->gnss_camera_rows.push_back(c);
        continue;
      }
      if (!s->joint || !s->joint->Find(p.point_id)) {
        s->warnings.push_back("GNSS point " + p.point_id + " (" + p.source + ") is not a point of the survey network: not used");
        continue;
      }
      if (std::count(s->project->check_points.begin(), s->project->check_points.end(), p.point_id)) {
        continue;  // withheld with the check point
      }
      s->gnss_points.push_back(p);
    }
  }
  if (s->gnss_trajectory_rows > 0) {
    s->warnings.push_back(std::to_string(s->gnss_trajectory_rows) +
                          " GNSS trajectory rows of the GNSS file not used (the rig and the mobile LiDAR take "
                          "their GNSS/INS poses from their trajectory files)");
  }
}

// ---- photos ------------------------------------------------------------------------------

std::string RunColmap(const PhotoCollection& p, const std::string& work, const sensors::Camera* calibration) {
  if (std::system("command -v colmap > /dev/null 2>&1") != 0) {
    throw AdjustFailure(AdjustStatus::kFailed, "photo collection '" + p.id + "' has no colmap_model and the colmap command is not installed");
  }
  fs::create_directories(fs::path(work) / "sparse");
  const auto quote = [](const std::string& s) { return "'" + s + "'"; };
  const std::string db = quote((fs::path(work) / "database.db").string());
  std::string camera_options = " --ImageReader.single_camera 1";
  if (calibration) {
    std::ostringstream params;
    for (size_t i = 0; i < calibration->params.size(); ++i) params << (i ? "," : "") << calibration->params[i];
    camera_options += " --ImageReader.camera_model " + calibration->ModelName() + " --ImageReader.camera_params " + params.str();
  }
  const std::string log = " >> " + quote((fs::path(work) / "colmap.log").string()) + " 2>&1";
  const std::vector<std::string> commands = {
      "QT_QPA_PLATFORM=offscreen colmap feature_extractor --database_path " + db + " --image_path " + quote(p.images) +
          camera_options + " --SiftExtraction.use_gpu 0" + log,
      "QT_QPA_PLATFORM=offscreen colmap exhaustive_matcher --database_path " + db + " --SiftMatching.use_gpu 0" + log,
      "QT_QPA_PLATFORM=offscreen colmap mapper --database_path " + db + " --image_path " + quote(p.images) +
          " --output_path " + quote((fs::path(work) / "sparse").string()) + log};
  for (const std::string& command : commands) {
    spdlog::info("adjust: {}", command);
    if (std::system(command.c_str()) != 0) {
      throw AdjustFailure(AdjustStatus::kFailed, "COLMAP failed on photo collection '" + p.id + "' (log: " + work + "/colmap.log)");
    }
  }
  const fs::path model = fs::path(work) / "sparse" / "0";
  if (!fs::exists(model / "images.bin")) {
    throw AdjustFailure(AdjustStatus::kFailed, "COLMAP reconstructed no model from photo collection '" + p.id + "'");
  }
  return model.string();
}

using internal::Triangulate;

/// Rays of the measurements of each point id, in the scene's current frame.
std::map<std::string, std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>> MeasurementRays(
    const Scene& scene, const std::vector<TargetMeasurement>& measurements) {
  std::map<std::string, std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>> rays;
  for (const TargetMeasurement& m : measurements) {
    const ImagePose& image = scene.Image(m.image_id);
    const Rigid3d world_from_cam = image.cam_from_world.Inverse();
    const Eigen::Vector3d d = world_from_cam.rotation * scene.Camera(image.camera_id).CamFromImg(m.xy);
    // A pixel outside the camera model's domain has no ray (NaN): it does not intersect.
    if (!d.allFinite() || !(d.norm() > 0)) continue;
    rays[m.point_id].emplace_back(world_from_cam.translation, d.normalized());
  }
  return rays;
}

void LoadPhotos(JointState* s, const std::string& work_dir) {
  const Project& project = *s->project;
  if (project.photos.empty()) {
    if (!s->gnss_camera_rows.empty()) {
      s->warnings.push_back(std::to_string(s->gnss_camera_rows.size()) + " GNSS camera rows (" +
                            s->gnss_camera_rows.front().source + ", ...) not used: the project has no photo_collection");
    }
    return;
  }
  if (project.photos.size() > 1) {
    throw InputError::Message(ProjectKey(project, project.photos[1].line, "sensors"),
                              "found a second photo_collection, expected one (this version adjusts one photo block)");
  }
  const PhotoCollection& p = project.photos.front();
  PhotoBlock block;
  block.config = &p;
  std::optional<sensors::Camera> calibration;
  if (!p.calibration.empty()) calibration = io::ReadCameraYaml(p.calibration).camera;
  const std::string model_dir =
      p.colmap_model.empty() ? RunColmap(p, (fs::path(work_dir) / ("colmap_" + p.id)).string(),
                                         calibration ? &*calibration : nullptr)
                             : p.colmap_model;
  block.model = io::ReadColmapModel(model_dir);
  if (block.model.cameras.empty() || block.model.images.empty()) {
    throw InputError::Message(model_dir, "the COLMAP model has no cameras or no images");
  }
  if (calibration) {
    for (auto& [id, camera] : block.model.cameras) {
      if (camera.model_id != calibration->model_id || camera.width != calibration->width ||
          camera.height != calibration->height) {
        throw InputError::Message(p.calibration,
                                  "model/size " + calibration->ModelName() + " " + std::to_string(calibration->width) + "x" +
                                      std::to_string(calibration->height) + " disagrees with COLMAP camera " +
                                      std::to_string(id.value) + " (" + camera.ModelName() + " " +
                                      std::to_string(camera.width) + "x" + std::to_string(camera.height) + ") of " + model_dir);
      }
      camera.params = calibration->params;
    }
  }
  block.ties = SceneFromColmap(block.model, p.sigma_px, &s->scene);
  std::map<std::string, ImageId> image_by_name;
  for (const auto& [id, image] : block.model.images) image_by_name[image.name] = id;
  for (GnssCamera c : s->gnss_camera_rows) {
    const auto image = image_by_name.find(c.image);
    if (image == image_by_name.end()) {
      throw InputError::Message(c.source, "field 'id': found '" + c.image + "', expected the name of an image of photo "
                                          "collection '" + p.id + "' (a camera row gives a photo's GNSS antenna position)");
    }
    c.image_id = image->second;
    c.lever_arm = p.gnss_lever_arm_m;
    block.gnss.push_back(c);
  }
  if (!p.control_measurements.empty()) {
    if (!s->joint) {
      throw InputError::Message(ProjectKey(project, p.line, "control_measurements"),
                                "image measurements of surveyed points need a total_station sensor");
    }
    const io::CsvTable table = io::CsvTable::Read(p.control_measurements, {"point_id", "image", "x_px", "y_px"});
    const std::set<std::string> check(project.check_points.begin(), project.check_points.end());
    std::vector<TargetMeasurement> check_measurements;
    for (const io::CsvTable::Row& row : table.rows()) {
      TargetMeasurement m;
      m.point_id = table.String(row, "point_id");
      if (!s->surveyed->Find(m.point_id)) {
        table.Fail(row, "point_id", m.point_id, "a point of " + project.total_stations.front().file);
      }
      const auto image = image_by_name.find(table.String(row, "image"));
      if (image == image_by_name.end()) table.Fail(row, "image", table.String(row, "image"), "an image of " + model_dir);
      m.image_id = image->second;
      m.xy = {table.Double(row, "x_px"), table.Double(row, "y_px")};
      const sensors::Camera& camera = block.model.cameras.at(block.model.images.at(m.image_id).camera_id);
      if (m.xy.x() < -0.5 || m.xy.y() < -0.5 || m.xy.x() > camera.width + 0.5 || m.xy.y() > camera.height + 0.5) {
        table.Fail(row, "x_px", table.String(row, "x_px") + ", " + table.String(row, "y_px"),
                   "a pixel inside the " + std::to_string(camera.width) + "x" + std::to_string(camera.height) + " image");
      }
      m.sigma_px = p.control_sigma_px > 0 ? p.control_sigma_px : table.Double(row, "sigma_px", p.sigma_px);
      if (!(m.sigma_px > 0 && m.sigma_px <= 50)) table.Fail(row, "sigma_px", std::to_string(m.sigma_px), "a σ in (0, 50] px");
      m.source = p.control_measurements + ":" + std::to_string(row.line);
      (check.count(m.point_id) ? check_measurements : block.control).push_back(m);
    }
    // Initialisation: the control targets intersected in the block's frame, then the
    // similarity block → world (Umeyama 1991) from their surveyed coordinates.
    std::vector<Eigen::Vector3d> from, to;
    std::vector<std::string> used;
    for (const auto& [id, rays] : MeasurementRays(s->scene, block.control)) {
      if (rays.size() < 2 || !s->surveyed_ids.count(id)) continue;
      from.push_back(Triangulate(rays));
      to.push_back(internal::WorldFromSurvey(*s->surveyed, *s->surveyed->Find(id)));
      used.push_back(id);
    }
    if (from.size() >= 3) {
      std::vector<size_t> all(from.size());
      for (size_t i = 0; i < all.size(); ++i) all[i] = i;
      const Sim3d world_from_block = internal::SimilarityFrom(from, to, all);
      const double scale = world_from_block.scale;
      double sum = 0.0;
      for (size_t i = 0; i < from.size(); ++i) sum += (world_from_block * from[i] - to[i]).squaredNorm();
      const double rms = std::sqrt(sum / from.size());
      s->scene.Transform(world_from_block);
      std::ostringstream g;
      g << "similarity from " << from.size() << " control targets: scale " << scale << ", RMS " << rms << " m";
      block.georeference = g.str();
    } else {
      block.georeference = "as given (fewer than 3 control targets measured in 2+ photos)";
      block.control_targets_intersected = from.size();
    }
    // Check points: image-only points of the scene, intersected after the georeference.
    uint64_t next = internal::kCheckPointIdBase;
    const auto rays = MeasurementRays(s->scene, check_measurements);
    for (const auto& [id, point_rays] : rays) {
      if (!s->surveyed_ids.count(id)) continue;  // warned above: nothing to compare with
      if (point_rays.size() < 2) {
        s->warnings.push_back("check point " + id + " is measured in fewer than 2 photos: not evaluated");
        continue;
      }
      const Point3DId point3D_id(next++);
      s->scene.AddPoint(point3D_id, Triangulate(point_rays));
      block.check_ids[id] = point3D_id;
    }
    for (const TargetMeasurement& m : check_measurements) {
      if (block.check_ids.count(m.point_id)) block.check.push_back({m.image_id, block.check_ids.at(m.point_id), m.xy, m.sigma_px});
    }
  } else {
    block.georeference = "as given (no control measurements)";
  }
  // MI registration results (`mmba register-mi` OUT.json per image, LiDAR frame = world).
  if (!p.mi_results.empty()) {
    for (const auto& [name, id] : image_by_name) {
      const fs::path file = fs::path(p.mi_results) / (fs::path(name).stem().string() + ".json");
      if (!fs::exists(file)) continue;
      MiResult result;
      std::string why;
      if (!internal::ReadMiResultFile(file.string(), &result, &why)) {
        s->warnings.push_back("MI result " + file.string() + " not used: " + why);
        continue;
      }
      result.image_id = id;
      block.mi.push_back(result);
    }
    Note(s, "MI results: " + std::to_string(block.mi.size()) + " pose priors from " + p.mi_results);
    // MI poses are in the LiDAR (= world) frame: the block is already georeferenced by them
    // when it has no control (not handled: the control similarity above is applied first).
  }
  for (const auto& [id, image] : s->scene.images()) block.initial_poses[id] = image.cam_from_world;
  block.initial_params = s->scene.cameras().begin()->second.params;
  Note(s, "photo block '" + p.id + "': " + std::to_string(block.model.images.size()) + " images, " +
                   std::to_string(block.model.points3D.size()) + " tie points, " + std::to_string(block.ties.size()) +
                   " observations; georeference: " + block.georeference);
  s->photos = std::move(block);
}

// ---- camera rig --------------------------------------------------------------------------

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
  // Calibration: body_from_rig (lever arm, boresight) and the cameras.
  const io::RigYaml calibration = io::ReadRigYaml(config.calibration);
  if (!calibration.body_from_rig) {
    throw InputError(config.calibration, 1, "body_from_rig", "nothing", "the key to be present");
  }
  rig.body_from_rig = *calibration.body_from_rig;
  uint64_t next_camera = 2000001;
  for (size_t k = 0; k < calibration.cameras.size(); ++k) {
    sensors::Camera camera = calibration.cameras[k];
    camera.camera_id = CameraId(next_camera++);
    s->scene.AddCamera(camera);
    rig.cameras.push_back(camera.camera_id);
    rig.camera_names.push_back(calibration.names[k]);
    rig.cam_from_rig.push_back(calibration.cam_from_rig[k]);
    rig.initial_params.push_back(camera.params);
  }
  rig.cam_from_rig_initial = rig.cam_from_rig;
  // Frames and their GNSS/INS pose priors.
  const std::vector<std::pair<double, Rigid3d>> trajectory = internal::ReadTrajectory(config.trajectory);
  const io::CsvTable frames = io::CsvTable::Read(config.frames_file, {"frame", "time_s"});
  std::map<std::string, size_t> frame_index;
  for (const io::CsvTable::Row& row : frames.rows()) {
    const double time = frames.Double(row, "time_s");
    if (time < trajectory.front().first - 1.0 || time > trajectory.back().first + 1.0) {
      frames.Fail(row, "time_s", frames.String(row, "time_s"), "a time covered by the trajectory " + config.trajectory);
    }
    frame_index[frames.String(row, "frame")] = rig.frame_names.size();
    rig.frame_names.push_back(frames.String(row, "frame"));
    rig.frame_times.push_back(time);
    const Rigid3d world_from_rig = InterpolateTrajectory(trajectory, time) * rig.body_from_rig;
    rig.rig_prior.push_back(world_from_rig.Inverse());
  }
  rig.rig_from_world = rig.rig_prior;
  // Observations.
  const io::CsvTable table = io::CsvTable::Read(config.observations, {"image", "point_id", "x_px", "y_px"});
  for (const io::CsvTable::Row& row : table.rows()) {
    const std::string stem = fs::path(table.String(row, "image")).stem().string();
    const size_t underscore = stem.rfind('_');
    const std::string frame = underscore == std::string::npos ? "" : stem.substr(0, underscore);
    const std::string camera_name = underscore == std::string::npos ? "" : stem.substr(underscore + 1);
    const auto camera = std::find(rig.camera_names.begin(), rig.camera_names.end(), camera_name);
    if (!frame_index.count(frame) || camera == rig.camera_names.end()) {
      table.Fail(row, "image", table.String(row, "image"), "<frame>_<camera>.<ext> of a frame of " + config.frames_file +
                                                               " and a camera of " + config.calibration);
    }
    const double id = table.Double(row, "point_id");
    const Point3DId point3D_id(static_cast<uint64_t>(std::max(0.0, id)));
    if (id < 0 || id != std::floor(id) || !s->scene.HasPoint(point3D_id)) {
      table.Fail(row, "point_id", table.String(row, "point_id"), "a point3D id of photo collection '" + config.tie_block + "'");
    }
    const size_t k = camera - rig.camera_names.begin();
    const sensors::Camera& cam = s->scene.Camera(rig.cameras[k]);
    const Eigen::Vector2d xy(table.Double(row, "x_px"), table.Double(row, "y_px"));
    if (xy.x() < -0.5 || xy.y() < -0.5 || xy.x() > cam.width + 0.5 || xy.y() > cam.height + 0.5) {
      table.Fail(row, "x_px", table.String(row, "x_px") + ", " + table.String(row, "y_px"), "a pixel inside the image");
    }
    const double sigma = table.Double(row, "sigma_px", config.sigma_px);
    if (!(sigma > 0 && sigma <= 50)) table.Fail(row, "sigma_px", table.String(row, "sigma_px"), "a σ in (0, 50] px");
    rig.observations.push_back({frame_index.at(frame), k, point3D_id, xy, sigma});
    rig.sources.push_back(config.observations + ":" + std::to_string(row.line));
  }
  Note(s, "camera rig '" + config.id + "': " + std::to_string(rig.frame_names.size()) + " frames x " +
              std::to_string(rig.cameras.size()) + " cameras, " + std::to_string(rig.observations.size()) +
              " tie-point observations; cam_from_rig " + config.cam_from_rig + "; frame priors from " + config.trajectory +
              " (sigma " + std::to_string(config.trajectory_sigma_m) + " m, " + std::to_string(config.trajectory_sigma_deg) + " deg)");
  s->rig = std::move(rig);
}

// ---- LiDAR -------------------------------------------------------------------------------

// A photo block without control: placed by the tie points the rig and the spherical stations
// see; else taken as given when a LiDAR can tie it (its surface association then needs it
// roughly in place), else it has no overlap with any other sensor (exit 3).
void PlacePhotoBlock(JointState* s) {
  if (!s->photos || s->photos->georeference.rfind("as given", 0) != 0) return;
  PhotoBlock& block = *s->photos;
  const Project& project = *s->project;
  const std::string& id = block.config->id;
  if (internal::PlacePhotoBlockByGnss(s) || internal::PlacePhotoBlockByTiePoints(s)) return;
  const std::string placed_by_nothing = std::to_string(block.control_targets_intersected) +
                                        " surveyed targets measured in 2+ photos (3 needed), fewer than 3 photos with GNSS "
                                        "positions, no tie points intersected by a camera rig or spherical stations";
  if (project.lidar_static.empty()) {
    throw AdjustFailure(AdjustStatus::kFailed, "photo collection '" + id + "' has no overlap with the control: " + placed_by_nothing +
                                      ", and no lidar_static sensor");
  }
  std::string reason;
  if (!internal::PlacePhotoBlockByLidar(s, &reason)) {
    throw AdjustFailure(AdjustStatus::kFailed, "photo collection '" + id + "' cannot be placed: " + placed_by_nothing +
                                      ", and its tie points' registration to the LiDAR failed: " + reason);
  }
  s->warnings.push_back("photo collection '" + id + "': " + std::to_string(block.control_targets_intersected) +
                        " control targets measured in 2+ photos and no tie points placed by other sensors; the block "
                        "is placed on the LiDAR alone (" + block.georeference + ")");
}

void LoadLidar(JointState* s) {
  if (s->project->lidar_static.empty() || !s->photos) return;
  const LidarStatic& l = s->project->lidar_static.front();
  if (s->project->lidar_static.size() > 1) {
    s->warnings.push_back("only the first lidar_static sensor's reference cloud ties the photos in this version");
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& [id, p] : s->scene.points()) {
    if (id.value >= internal::kCheckPointIdBase) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  s->surface = std::make_unique<LidarSurface>(l.reference_cloud, lo, hi, 1.0);
  if (s->surface->num_read() == 0) {
    throw InputError::Message(l.reference_cloud, "the reference cloud has no points (sensor '" + l.id + "')");
  }
  Note(s, "LiDAR reference " + l.reference_cloud + ": " + std::to_string(s->surface->num_read()) +
                   " points read, " + std::to_string(s->surface->size()) + " near the photo block kept");
  if (s->surface->size() < 100) {
    const std::string hint = CoordinateHint(s->surface->read_min(), s->surface->read_max(), lo, hi);
    throw AdjustFailure(AdjustStatus::kFailed, "lidar_static '" + l.id + "': the reference cloud " + l.reference_cloud +
                                      " does not overlap the photo block (" + std::to_string(s->surface->size()) +
                                      " points within 1 m of its tie points)" + (hint.empty() ? "" : ": " + hint));
  }
  if (l.AdjustsScans()) {
    internal::LoadScans(s, lo, hi);
  } else if (!l.scans.empty()) {
    s->warnings.push_back("lidar_static '" + l.id + "': the " + std::to_string(l.scans.size()) +
                          " scans carry no world_from_scan and no targets are given: not adjusted (the registered "
                          "reference cloud is used)");
  }
}

size_t Associate(JointState* s, double gate) {
  const LidarStatic& l = s->project->lidar_static.front();
  const double sigma = std::sqrt(l.surface_sigma_m * l.surface_sigma_m + l.range_sigma_m * l.range_sigma_m);
  s->planes.clear();
  for (const auto& [id, p] : s->scene.points()) {
    if (id.value >= internal::kCheckPointIdBase) continue;
    SurfacePlane plane;
    plane.point3D_id = id;
    if (internal::FitSurfacePlane(*s, p, gate, sigma, &plane)) s->planes.push_back(plane);
  }
  std::sort(s->planes.begin(), s->planes.end(),
            [](const SurfacePlane& a, const SurfacePlane& b) { return a.point3D_id < b.point3D_id; });
  return s->planes.size();
}

// ---- the joint problem -------------------------------------------------------------------

template <typename T>
std::vector<T> Without(const std::vector<T>& all, const std::set<size_t>& excluded) {
  std::vector<T> out;
  for (size_t i = 0; i < all.size(); ++i) {
    if (!excluded.count(i)) out.push_back(all[i]);
  }
  return out;
}

const char* kTies = "photos: tie points";
const char* kTargets = "photos: control targets";
const char* kCheck = "photos: check points";
const char* kGnss = "GNSS control";
const char* kGnssCamera = "photos: GNSS camera positions";
const char* kLidar = "LiDAR surface (tie points)";
const char* kScanToScan = "LiDAR: scan-to-scan";
const char* kScanPrior = "LiDAR: scan registration priors";
const char* kScanTargets = "LiDAR: targets in the scans";
const char* kSphereLower = "spheres: lower";
const char* kSphereUpper = "spheres: upper";
const char* kBaseline = "spheres: baseline prior";
const char* kRig = "rig: tie points";
const char* kMi = "photos: MI pose priors";
const char* kRigPrior = "rig: GNSS/INS frame priors";
const char* kRigMi = "rig: MI frame priors";
const char* kRigMiMobile = "rig: MI frame poses on the mobile LiDAR";
const char* kMiExtrinsic = "mobile: MI camera-LiDAR calibration";
const char* kRigCalibration = "rig: cam_from_rig priors";
const char* kMobile = "mobile LiDAR: points on the static surface";
const char* kTrajectoryPrior = "mobile: GNSS/INS trajectory prior";
const char* kSmoothness = "mobile: trajectory smoothness";
const char* kRigOnTrajectory = "rig: frames on the corrected trajectory";
const char* kExtrinsicPrior = "mobile: camera-LiDAR extrinsic prior";

void BuildProblem(JointState* s) {
  s->builder = std::make_unique<ProblemBuilder>(&s->scene);
  const auto excluded = [&](const char* name) {
    const auto it = s->excluded.find(name);
    return it == s->excluded.end() ? std::set<size_t>() : it->second;
  };
  const auto factor = [&](const char* name) {
    const auto it = s->sigma_factor.find(name);
    return it == s->sigma_factor.end() ? 1.0 : it->second;
  };
  // Observations of a group with its variance-component factor applied to σ.
  const auto scaled = [&](const char* name, auto list) {
    const auto it = s->sigma_factor.find(name);
    const double f = it == s->sigma_factor.end() ? 1.0 : it->second;
    for (auto& o : list) {
      if constexpr (std::is_same_v<std::decay_t<decltype(o)>, ReprojectionObservation>) o.sigma_px *= f;
      else if constexpr (std::is_same_v<std::decay_t<decltype(o)>, TargetMeasurement>) o.sigma_px *= f;
      else if constexpr (std::is_same_v<std::decay_t<decltype(o)>, UpperSphereObservation>) o.sigma_px *= f;
      else if constexpr (std::is_same_v<std::decay_t<decltype(o)>, RigObservation>) o.sigma_px *= f;
      else if constexpr (std::is_same_v<std::decay_t<decltype(o)>, SurfacePlane>) o.sigma_m *= f;
      else if constexpr (std::is_same_v<std::decay_t<decltype(o)>, MobilePoint>) o.sigma_m *= f;
      else if constexpr (std::is_same_v<std::decay_t<decltype(o)>, ScanPairPoint>) o.sigma_m *= f;
      else o.sigma *= f;
    }
    return list;
  };
  if (s->photos) {
    const PhotoCollection& p = *s->photos->config;
    s->builder->AddGroup(std::make_unique<ReprojectionGroup>(scaled(kTies, Without(s->photos->ties, excluded(kTies))), p.loss, kTies));
    if (!s->photos->control.empty()) {
      s->builder->AddGroup(std::make_unique<TargetReprojectionGroup>(
          &*s->joint, scaled(kTargets, Without(s->photos->control, excluded(kTargets))), p.loss, kTargets));
    }
    if (!s->photos->mi.empty()) {
      s->builder->AddGroup(std::make_unique<MiPriorGroup>(Without(s->photos->mi, excluded(kMi)),
                                                          factor(kMi) * factor(kMi), p.loss, kMi)).set_role(FactorRole::kPrior);
    }
    if (!s->photos->check.empty()) {
      s->builder->AddGroup(std::make_unique<ReprojectionGroup>(s->photos->check, LossOptions(), kCheck)).set_role(FactorRole::kConstraint);
    }
    if (!s->photos->gnss.empty()) {
      s->builder->AddGroup(std::make_unique<GnssCameraGroup>(scaled(kGnssCamera, Without(s->photos->gnss, excluded(kGnssCamera))),
                                                             s->project->gnss.front().loss, kGnssCamera));
    }
    ParameterOptions parameters;
    parameters.refine_focal = p.refine.focal;
    parameters.refine_principal_point = p.refine.principal_point;
    parameters.refine_extra = p.refine.distortion;
    s->builder->set_parameter_options(parameters);
  }
  if (s->spheres) {
    SphereBlock& sb = *s->spheres;
    const LossOptions& loss = sb.config->loss;
    s->builder->AddGroup(std::make_unique<ReprojectionGroup>(scaled(kSphereLower, Without(sb.lower, excluded(kSphereLower))), loss, kSphereLower));
    s->builder->AddGroup(std::make_unique<UpperSphereGroup>(scaled(kSphereUpper, Without(sb.upper, excluded(kSphereUpper))),
                                                            &sb.baseline, loss, kSphereUpper));
    s->builder->AddGroup(std::make_unique<VectorPriorGroup>(&sb.baseline, sb.baseline_prior,
                                                            factor(kBaseline) * sb.config->baseline_sigma_m, kBaseline));
  }
  if (s->rig) {
    RigBlock& rig = *s->rig;
    const CameraRig& c = *rig.config;
    s->builder->AddGroup(std::make_unique<RigReprojectionGroup>(scaled(kRig, Without(rig.observations, excluded(kRig))),
                                                                &rig.rig_from_world, &rig.cam_from_rig, rig.cameras, c.loss, kRig));
    if (s->mobile && s->mobile->with_rig) {
      // The frames ride on the mobile LiDAR's corrected trajectory (its nodes carry the
      // GNSS/INS prior).
      const LidarMobile& mc = *s->mobile->config;
      s->builder->AddGroup(std::make_unique<RigTrajectoryGroup>(
          s->mobile->frames, &rig.rig_from_world, &s->mobile->nodes, rig.body_from_rig, mc.frame_sigma_m,
          mc.frame_sigma_deg * M_PI / 180.0, LossOptions(), kRigOnTrajectory)).set_role(FactorRole::kConstraint);
    } else {
      std::vector<Rigid3d*> frames;
      for (Rigid3d& pose : rig.rig_from_world) frames.push_back(&pose);
      s->builder->AddGroup(std::make_unique<PosePriorGroup>(frames, rig.rig_prior, factor(kRigPrior) * c.trajectory_sigma_m,
                                                            factor(kRigPrior) * c.trajectory_sigma_deg * M_PI / 180.0, c.loss,
                                                            kRigPrior, rig.frame_times, c.trajectory_correlation_s)).set_role(FactorRole::kPrior);
    }
    if (!rig.mi.empty()) {
      std::vector<MiResult> mi = rig.mi;
      for (size_t i = 0; i < mi.size(); ++i) mi[i].pose = &rig.rig_from_world[rig.mi_frame[i]];
      s->builder->AddGroup(std::make_unique<MiPriorGroup>(Without(mi, excluded(kRigMi)), factor(kRigMi) * factor(kRigMi), c.loss, kRigMi)).set_role(FactorRole::kPrior);
    }
    if (c.cam_from_rig == "weighted") {
      std::vector<Rigid3d*> cameras;
      for (Rigid3d& pose : rig.cam_from_rig) cameras.push_back(&pose);
      s->builder->AddGroup(std::make_unique<PosePriorGroup>(
          cameras, rig.cam_from_rig_initial, factor(kRigCalibration) * c.cam_from_rig_sigma_m,
          factor(kRigCalibration) * c.cam_from_rig_sigma_deg * M_PI / 180.0, LossOptions(), kRigCalibration)).set_role(FactorRole::kPrior);
    }
  }
  if (s->joint) {
    for (auto& group : survey::MakeSurveyGroups(&*s->joint, s->project->total_stations.front().loss)) {
      s->builder->AddGroup(std::move(group));
    }
  }
  if (!s->gnss_points.empty()) {
    s->builder->AddGroup(std::make_unique<GnssPointGroup>(&*s->joint, scaled(kGnss, Without(s->gnss_points, excluded(kGnss))),
                                                          s->project->gnss.front().loss, kGnss));
  }
  if (!s->planes.empty()) {
    s->builder->AddGroup(std::make_unique<LidarSurfaceGroup>(scaled(kLidar, Without(s->planes, excluded(kLidar))),
                                                             s->project->lidar_static.front().loss, kLidar,
                                                             &s->scan_from_world));
  }
  if (!s->scans.empty()) {
    const LidarStatic& l = s->project->lidar_static.front();
    if (!s->scan_pairs.empty()) {
      s->builder->AddGroup(std::make_unique<ScanToScanGroup>(scaled(kScanToScan, Without(s->scan_pairs, excluded(kScanToScan))),
                                                             &s->scan_from_world, l.loss, kScanToScan));
    }
    if (!s->scan_targets.empty()) {
      s->builder->AddGroup(std::make_unique<ScanTargetGroup>(&*s->joint, scaled(kScanTargets, Without(s->scan_targets, excluded(kScanTargets))),
                                                             &s->scan_from_world, l.loss, kScanTargets));
    }
    std::vector<Rigid3d*> poses;
    std::vector<Rigid3d> priors;
    for (size_t k = 0; k < s->scans.size(); ++k) {
      if (!s->scans[k].has_prior) continue;  // placed by targets or feature registration: no observation
      poses.push_back(&s->scan_from_world[k]);
      priors.push_back(s->scans[k].prior);
    }
    if (!poses.empty()) s->builder->AddGroup(std::make_unique<PosePriorGroup>(poses, priors, factor(kScanPrior) * l.scan_sigma_m,
                                                          factor(kScanPrior) * l.scan_sigma_deg * M_PI / 180.0, l.loss,
                                                          kScanPrior)).set_role(FactorRole::kPrior);
  }
  if (s->mobile) {
    internal::MobileBlock& m = *s->mobile;
    const LidarMobile& mc = *m.config;
    s->builder->AddGroup(std::make_unique<TrajectoryPriorGroup>(&m.nodes, factor(kTrajectoryPrior) * mc.trajectory_sigma_m,
                                                                factor(kTrajectoryPrior) * mc.trajectory_sigma_deg * M_PI / 180.0,
                                                                mc.trajectory_correlation_s, mc.loss, kTrajectoryPrior)).set_role(FactorRole::kPrior);
    if (m.nodes.size() > 2 && (mc.smoothness_sigma_m > 0 || mc.smoothness_sigma_deg > 0)) {
      s->builder->AddGroup(std::make_unique<TrajectorySmoothnessGroup>(&m.nodes, mc.smoothness_sigma_m,
                                                                       mc.smoothness_sigma_deg * M_PI / 180.0, kSmoothness)).set_role(FactorRole::kConstraint);
    }
    if (!m.points.empty()) {
      s->builder->AddGroup(std::make_unique<MobileLidarGroup>(scaled(kMobile, Without(m.points, excluded(kMobile))), &m.nodes,
                                                              &m.vehicle_from_lidar, m.body_from_vehicle, mc.loss, kMobile,
                                                              &s->scan_from_world));
    }
    if (m.with_rig && s->rig && !s->rig->mi_mobile.empty()) {
      s->builder->AddGroup(std::make_unique<MobileMiPriorGroup>(
          Without(s->rig->mi_mobile, excluded(kRigMiMobile)), &s->rig->rig_from_world, &m.nodes, &m.vehicle_from_lidar,
          m.body_from_vehicle, m.body_from_lidar_nominal, factor(kRigMiMobile) * factor(kRigMiMobile), s->rig->config->loss,
          kRigMiMobile)).set_role(FactorRole::kPrior);
    }
    if (m.with_rig && !m.mi_extrinsic.empty()) {
      std::vector<MiResult> mi = m.mi_extrinsic;
      for (MiResult& r : mi) r.pose = &m.vehicle_from_lidar;
      s->builder->AddGroup(std::make_unique<MiPriorGroup>(Without(mi, excluded(kMiExtrinsic)),
                                                          factor(kMiExtrinsic) * factor(kMiExtrinsic), mc.loss, kMiExtrinsic)).set_role(FactorRole::kPrior);
    }
    if (m.with_rig && mc.extrinsic == "weighted") {
      s->builder->AddGroup(std::make_unique<PosePriorGroup>(
          std::vector<Rigid3d*>{&m.vehicle_from_lidar}, std::vector<Rigid3d>{m.vehicle_from_lidar_initial},
          factor(kExtrinsicPrior) * mc.extrinsic_sigma_m, factor(kExtrinsicPrior) * mc.extrinsic_sigma_deg * M_PI / 180.0,
          LossOptions(), kExtrinsicPrior)).set_role(FactorRole::kPrior);
    }
  }
  GaugeOptions gauge;
  gauge.kind = GaugeOptions::Kind::kNone;  // the datum comes from the control, GNSS and LiDAR
  s->builder->set_gauge(gauge);
  ceres::Problem& problem = s->builder->Build();
  if (s->joint) survey::SetSurveyParameterStates(&*s->joint, problem);
  for (Rigid3d& pose : s->scan_from_world) {
    if (problem.HasParameterBlock(pose.rotation.coeffs().data())) {
      problem.SetManifold(pose.rotation.coeffs().data(), new ceres::EigenQuaternionManifold);
    }
  }
  if (s->rig) {
    RigBlock& rig = *s->rig;
    for (Rigid3d& pose : rig.rig_from_world) {
      if (problem.HasParameterBlock(pose.rotation.coeffs().data())) {
        problem.SetManifold(pose.rotation.coeffs().data(), new ceres::EigenQuaternionManifold);
      }
    }
    for (Rigid3d& pose : rig.cam_from_rig) {
      double* q = pose.rotation.coeffs().data();
      if (!problem.HasParameterBlock(q)) continue;
      problem.SetManifold(q, new ceres::EigenQuaternionManifold);
      if (rig.config->cam_from_rig == "fixed") {
        problem.SetParameterBlockConstant(q);
        problem.SetParameterBlockConstant(pose.translation.data());
      }
    }
    // The rig cameras' intrinsics: the rig's own refine list; a camera with fewer than
    // kMinObservations observations keeps its calibration (its 8 fisheye parameters would be
    // undetermined and let the solver drift).
    constexpr size_t kMinObservations = 200;
    std::vector<size_t> count(rig.cameras.size(), 0);
    for (const RigObservation& o : rig.observations) ++count[o.camera];
    const RefineIntrinsics& refine = rig.config->refine;
    for (size_t k = 0; k < rig.cameras.size(); ++k) {
      sensors::Camera& camera = s->scene.Camera(rig.cameras[k]);
      double* params = camera.params.data();
      if (!problem.HasParameterBlock(params)) continue;
      if (count[k] < kMinObservations) {
        problem.SetParameterBlockConstant(params);
        const std::string warning = "rig camera " + rig.camera_names[k] + ": " + std::to_string(count[k]) +
                                    " observations, intrinsics held at the calibration (fewer than " +
                                    std::to_string(kMinObservations) + ")";
        if (std::find(s->warnings.begin(), s->warnings.end(), warning) == s->warnings.end()) s->warnings.push_back(warning);
        continue;
      }
      std::vector<int> constant;
      const auto hold = [&](const std::vector<int>& idxs) { constant.insert(constant.end(), idxs.begin(), idxs.end()); };
      if (!refine.focal) hold(sensors::CameraModelFocalIdxs(camera.model_id));
      if (!refine.principal_point) hold(sensors::CameraModelPrincipalIdxs(camera.model_id));
      const std::vector<int> extra = sensors::CameraModelExtraIdxs(camera.model_id);
      if (!refine.distortion) {
        hold(extra);
      } else if (refine.distortion_terms > 0 && static_cast<int>(extra.size()) > refine.distortion_terms) {
        hold(std::vector<int>(extra.begin() + refine.distortion_terms, extra.end()));
      }
      std::sort(constant.begin(), constant.end());
      if (constant.size() == camera.params.size()) {
        problem.SetParameterBlockConstant(params);
      } else {
        problem.SetParameterBlockVariable(params);
        problem.SetManifold(params, constant.empty() ? nullptr : new ceres::SubsetManifold(camera.params.size(), constant));
      }
    }
  }
  if (s->mobile) {
    internal::MobileBlock& m = *s->mobile;
    double* q = m.vehicle_from_lidar.rotation.coeffs().data();
    if (problem.HasParameterBlock(q)) {
      problem.SetManifold(q, new ceres::EigenQuaternionManifold);
      if (!m.with_rig || m.config->extrinsic == "fixed") {
        problem.SetParameterBlockConstant(q);
        problem.SetParameterBlockConstant(m.vehicle_from_lidar.translation.data());
      }
    }
  }
  if (s->spheres) {
    // The line-scan calibration: the vertical principal offsets cy of both spheres and the
    // horizontal offset cx of the upper one relative to the lower (a common cx shift of a full
    // panorama is a rotation about the sphere's axis — the station's heading — so the lower
    // cx is held as the datum); f (= W/2π for a full panorama) only when asked.
    const SphericalStereo& config = *s->spheres->config;
    for (CameraId id : {s->spheres->lower_camera, s->spheres->upper_camera}) {
      double* params = s->scene.Camera(id).params.data();
      if (!problem.HasParameterBlock(params)) continue;
      std::vector<int> constant;
      if (!config.refine_focal) constant.push_back(0);
      if (!config.refine_principal_point || id == s->spheres->lower_camera) constant.push_back(1);
      if (!config.refine_principal_point) constant.push_back(2);
      if (constant.size() == 3) {
        problem.SetParameterBlockConstant(params);
      } else {
        problem.SetParameterBlockVariable(params);
        problem.SetManifold(params, constant.empty() ? nullptr : new ceres::SubsetManifold(3, constant));
      }
    }
  }
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
    if (id.value < internal::kCheckPointIdBase) options.eliminate.insert(point.data());
  }
  std::map<const double*, std::string> names;
  if (s->rig) {
    for (size_t f = 0; f < s->rig->rig_from_world.size(); ++f) {
      names[s->rig->rig_from_world[f].rotation.coeffs().data()] = "rotation of rig frame " + s->rig->frame_names[f];
      names[s->rig->rig_from_world[f].translation.data()] = "position of rig frame " + s->rig->frame_names[f];
    }
    for (size_t k = 0; k < s->rig->cam_from_rig.size(); ++k) {
      names[s->rig->cam_from_rig[k].rotation.coeffs().data()] = "cam_from_rig rotation of " + s->rig->camera_names[k];
      names[s->rig->cam_from_rig[k].translation.data()] = "cam_from_rig translation of " + s->rig->camera_names[k];
    }
  }
  if (s->mobile) {
    for (const TrajectoryNode& node : s->mobile->nodes) {
      names[node.correction] = "trajectory correction at t = " + std::to_string(node.time_s) + " s";
    }
    names[s->mobile->vehicle_from_lidar.rotation.coeffs().data()] = "camera-LiDAR extrinsic rotation";
    names[s->mobile->vehicle_from_lidar.translation.data()] = "camera-LiDAR extrinsic translation";
  }
  std::map<ImageId, std::string> station_of;
  if (s->spheres) {
    for (const auto& [station, id] : s->spheres->lower_image) station_of[id] = "station " + station;
    names[s->spheres->baseline.data()] = "spherical stereo baseline";
  }
  for (const auto& [id, image] : s->scene.images()) {
    const std::string name = station_of.count(id) ? station_of.at(id)
                             : s->photos         ? s->photos->model.images.at(id).name
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
    return stats::ComputeStatistics(s->builder->problem(), groups, options);
  } catch (const stats::DegenerateNetworkError& e) {
    throw AdjustFailure(AdjustStatus::kFailed, std::string("degenerate configuration: ") + e.what());
  }
}

std::string DescribeObservation(const JointState& s, const FactorGroup& group, size_t block) {
  const size_t index = group.block_observation_index()[block];
  const std::string name = group.name();
  if (name == kTies && s.photos) {
    const ReprojectionObservation& o = s.photos->ties[index];
    return "point " + std::to_string(o.point3D_id.value) + " in " + s.photos->model.images.at(o.image_id).name;
  }
  if (name == kTargets && s.photos) {
    const TargetMeasurement& m = s.photos->control[index];
    return "target " + m.point_id + " in " + s.photos->model.images.at(m.image_id).name + " (" + m.source + ")";
  }
  if (name == kRig && s.rig) {
    const RigObservation& o = s.rig->observations[index];
    return "point " + std::to_string(o.point3D_id.value) + " in " + s.rig->frame_names[o.frame] + "_" +
           s.rig->camera_names[o.camera] + " (" + s.rig->sources[index] + ")";
  }
  if (name == kMi && s.photos) return "MI pose of " + s.photos->model.images.at(s.photos->mi[index].image_id).name + " (" + s.photos->mi[index].source + ")";
  if (name == kRigPrior && s.rig) return "GNSS/INS prior of rig frame " + s.rig->frame_names[index];
  if (name == kRigMi && s.rig) return "MI pose of rig frame " + s.rig->frame_names[s.rig->mi_frame[index]] + " (" + s.rig->mi[index].source + ")";
  if (name == kMiExtrinsic && s.mobile) return "MI rig calibration rig_from_lidar (" + s.mobile->mi_extrinsic[index].source + ")";
  if (name == kRigMiMobile && s.rig) {
    return "MI pose of rig frame " + s.rig->frame_names[s.rig->mi_mobile[index].frame] + " on the mobile LiDAR (" +
           s.rig->mi_mobile[index].source + ")";
  }
  if (name == kRigCalibration && s.rig) return "cam_from_rig prior of " + s.rig->camera_names[index];
  if (name == kSphereLower && s.spheres) {
    return "point " + std::to_string(s.spheres->lower[index].point3D_id.value) + " (" + s.spheres->lower_source[index] + ")";
  }
  if (name == kSphereUpper && s.spheres) {
    return "point " + std::to_string(s.spheres->upper[index].point3D_id.value) + " (" + s.spheres->upper_source[index] + ")";
  }
  if (name == kGnssCamera && s.photos) {
    const GnssCamera& c = s.photos->gnss[index / 3];
    return "GNSS " + std::string(index % 3 == 0 ? "east" : index % 3 == 1 ? "north" : "up") + " of photo " + c.image +
           " (" + c.source + ")";
  }
  if (name == kGnss) {
    const GnssPoint& p = s.gnss_points[index / 3];
    return "GNSS " + std::string(index % 3 == 0 ? "east" : index % 3 == 1 ? "north" : "up") + " of " + p.point_id +
           " (" + p.source + ")";
  }
  if (name == kMobile && s.mobile) {
    const MobilePoint& p = s.mobile->points[index];
    return "mobile LiDAR point " + std::to_string(p.source) + " of " + s.mobile->config->cloud + " (t = " +
           std::to_string(p.time_s) + " s)";
  }
  if (name == kTrajectoryPrior && s.mobile) return "GNSS/INS prior at t = " + std::to_string(s.mobile->nodes[index].time_s) + " s";
  if (name == kRigOnTrajectory && s.rig) return "rig frame " + s.rig->frame_names[index] + " on the trajectory";
  if (name == kLidar) return "tie point " + std::to_string(s.planes[index].point3D_id.value) + " to the LiDAR surface";
  if (name == kScanToScan) {
    const ScanPairPoint& p = s.scan_pairs[index];
    return "a point of scan " + s.scans[p.from].name + " on scan " + s.scans[p.to].name;
  }
  if (name == kScanPrior) return "registration of scan " + s.scans[index].name;
  if (name == kScanTargets) return "target " + s.scan_targets[index].point_id + " in scan " + s.scans[s.scan_targets[index].scan].name;
  if (const auto* sg = dynamic_cast<const survey::SurveyGroup*>(&group)) {
    const survey::BlockSpec& spec = sg->added_specs()[block];
    const survey::Cluster& c = s.joint->clusters[spec.cluster];
    const survey::Observation& o = c.observations[spec.observations.front()];
    return std::string(survey::ObsKindName(o.kind)) + " " + o.from + " -> " + o.to + " (" + s.joint->source + ":" +
           std::to_string(o.line) + ")";
  }
  return group.name() + " #" + std::to_string(index);
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

}  // namespace

namespace internal {

std::string VarianceComponentExemption(const JointState& s, const FactorGroup& group, double redundancy) {
  if (!s.project->settings.variance_components) return "variance_components: false";
  if (group.name() == kCheck) return "check points";
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
    if (!internal::VarianceComponentExemption(*s, *groups[g], gs.redundancy).empty() ||
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

}  // namespace

AdjustOutcome RunAdjustment(const Project& project, const AdjustOptions& options) {
  AdjustOutcome outcome;
  Timer timer;
  JointState s;
  s.project = &project;
  s.plane = geodesy::LocalTangentPlane(project.origin);
  // Checked and locked before any work; the result is staged beside it and swapped in whole.
  OutputFolder output(options.output_dir, "--output", "mmba adjust", internal::ProjectInputs(project));
  const std::string work_dir = output.path().string() + ".work";
  try {
    spdlog::info("adjust: reading sensors of {}", project.path);
    LoadNetwork(&s);
    LoadGnss(&s);
    LoadPhotos(&s, work_dir);
    LoadSpheres(&s);
    LoadRig(&s);
    PlacePhotoBlock(&s);
    internal::RegisterPhotoBlockToLidar(&s);
    LoadLidar(&s);
    internal::RegisterSphereStations(&s);
    internal::LoadMobile(&s);
    internal::RegisterImagesByMi(&s, internal::MiStage::kRigFrames);
    if (!project.other_sensors.empty()) {
      for (const OtherSensor& o : project.other_sensors) {
        s.warnings.push_back("sensor '" + o.id + "' (" + o.type + ") validated but not adjusted: not implemented in this version");
      }
    }
    // First the photo block on the control alone (the LiDAR association needs it near its
    // final place), then outer iterations: associate tie points with the LiDAR surface (gate
    // shrinking from max_distance_m to 3σ), solve, until the association no longer changes.
    SolveOnce(&s, options, s.surface ? SolvePhase::kAssociation : SolvePhase::kFinal);
    s.outer_iterations = 1;
    internal::RegisterImagesByMi(&s, internal::MiStage::kPhotos);
    if (s.surface) {
      const LidarStatic& lidar = project.lidar_static.front();
      double gate = lidar.max_distance_m;
      const double final_gate = 3 * std::hypot(lidar.surface_sigma_m, lidar.range_sigma_m);
      size_t previous = 0;
      for (int k = 0; k < project.settings.outer_iterations; ++k) {
        const size_t n = Associate(&s, gate);
        Note(&s, "outer iteration " + std::to_string(k + 2) + ": " + std::to_string(n) +
                     " tie points on the LiDAR surface (gate " + std::to_string(gate) + " m)");
        if (n < 10) {
          throw AdjustFailure(AdjustStatus::kFailed, "only " + std::to_string(n) + " tie points lie within " + std::to_string(gate) +
                                            " m of the LiDAR surface: no overlap, or the photo block is far from the LiDAR frame");
        }
        size_t associated = n;
        if (!s.scans.empty()) {
          const size_t ns = internal::AssociateScans(&s, gate);
          Note(&s, "outer iteration " + std::to_string(k + 2) + ": " + std::to_string(ns) +
                       " scan-to-scan point-to-plane pairs (gate " + std::to_string(gate) + " m)");
          associated += ns;
        }
        if (s.mobile) {
          // The mobile points: their own first gate (GNSS/INS errors), then the same schedule.
          const double mobile_gate = std::max(gate, k == 0 ? s.mobile->config->max_distance_m : 0.0);
          const size_t nm = internal::AssociateMobile(&s, mobile_gate);
          Note(&s, "outer iteration " + std::to_string(k + 2) + ": " + std::to_string(nm) + " of " +
                       std::to_string(s.mobile->sample.size()) + " mobile LiDAR points on the static surface (gate " +
                       std::to_string(mobile_gate) + " m)");
          if (nm < 100) {
            // A units mistake in the trajectory and the cloud: the sample, scaled to metres
            // about the world origin, would lie on the static surface.
            const internal::MobileBlock& m = *s.mobile;
            const double sigma = std::hypot(m.config->range_sigma_m, m.config->surface_sigma_m);
            std::string hint;
            size_t best = nm;
            for (const auto& [scale, unit] : {std::pair<double, const char*>{0.001, "millimetres"}, {0.01, "centimetres"},
                                              {0.3048, "feet (international or US survey)"}}) {
              size_t on = 0;
              for (size_t i = 0; i < m.sample.size(); ++i) {
                SurfacePlane plane;
                const Eigen::Vector3d delivered = m.sample_ins[i] * (m.body_from_lidar_nominal * m.sample_lidar[i]);
                on += internal::FitSurfacePlane(s, scale * delivered, mobile_gate, sigma, &plane) ? 1 : 0;
              }
              if (on >= 100 && on > 10 * best) {
                best = on;
                hint = std::string(" (") + m.config->cloud + " with " + m.config->trajectory + ": its coordinates look like " +
                       unit + ": scaled to metres, " + std::to_string(on) + " of the points would lie on the surface)";
              }
            }
            throw AdjustFailure(AdjustStatus::kFailed, "lidar_mobile '" + s.mobile->config->id + "': only " + std::to_string(nm) +
                                              " of its points lie within " + std::to_string(mobile_gate) +
                                              " m of the static LiDAR surface: no overlap, or its trajectory/calibration is far off" +
                                              hint);
          }
          associated += nm;
        }
        if (k > 0 && associated == previous && gate <= final_gate) break;
        previous = associated;
        SolveOnce(&s, options, SolvePhase::kAssociation);
        s.outer_iterations = k + 2;
        gate = std::max(0.5 * gate, final_gate);
      }
    }
    // The association settled: solve to the minimum. Statistics, one round of data snooping,
    // and the final solve and statistics.
    if (s.surface) SolveOnce(&s, options, SolvePhase::kFinal);
    s.statistics = Statistics(&s);
    if (Snoop(&s, s.statistics) > 0) {
      Note(&s, std::to_string(s.blunders.size()) + " observation(s) flagged as blunders and excluded; solving again");
      SolveOnce(&s, options, SolvePhase::kFinal);
      s.statistics = Statistics(&s);
    }
    s.given_weights = s.statistics;  // σ0 and its test with the σ of the project
    s.given_weights.cofactor.Clear();
    s.given_weights.rows.clear();
    if (project.settings.variance_components) {
      for (int k = 0; k < 4 && ApplyVarianceComponents(&s, s.statistics); ++k) {
        Note(&s, "variance components: re-weighting the groups (pass " + std::to_string(k + 1) + ")");
        SolveOnce(&s, options, SolvePhase::kFinal);
        s.statistics = Statistics(&s);
      }
    }
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
