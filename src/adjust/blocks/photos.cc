// The photo collection: loading (its COLMAP model, or COLMAP run on its images), its control
// and check measurements, the georeference on its control targets and the placement of a block
// without control, its factor groups, and its outputs (poses, adjusted COLMAP model, camera
// calibration, tie points, error map). Initialisation by GNSS, other sensors' tie points and the
// LiDAR is photo_init.cc.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "../las_output.h"
#include "../output_support.h"
#include "blocks.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io/yaml_reader.h"
#include "mmba/problem/colmap_scene.h"

namespace mmba::adjust::internal {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

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
/// The block's COLMAP model (read, or reconstructed by COLMAP into `work_dir`), its cameras
/// given the project's calibration when there is one; the model enters the Scene. Returns the
/// model's folder.
std::string ReadPhotoModel(JointState* s, PhotoBlock* block, const std::string& work_dir) {
  const PhotoCollection& p = *block->config;
  std::optional<sensors::Camera> calibration;
  if (!p.calibration.empty()) calibration = io::ReadCameraYaml(p.calibration).camera;
  const std::string model_dir =
      p.colmap_model.empty() ? RunColmap(p, (fs::path(work_dir) / ("colmap_" + p.id)).string(),
                                         calibration ? &*calibration : nullptr)
                             : p.colmap_model;
  block->model = io::ReadColmapModel(model_dir);
  if (block->model.cameras.empty() || block->model.images.empty()) {
    throw InputError::Message(model_dir, "the COLMAP model has no cameras or no images");
  }
  if (calibration) {
    for (auto& [id, camera] : block->model.cameras) {
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
  block->ties = SceneFromColmap(block->model, p.sigma_px, &s->scene);
  return model_dir;
}

/// The GNSS `camera` rows, each resolved to the photo it names.
void AttachGnssCameras(const JointState& s, const std::map<std::string, ImageId>& image_by_name, PhotoBlock* block) {
  const PhotoCollection& p = *block->config;
  for (GnssCamera c : s.gnss_camera_rows) {
    const auto image = image_by_name.find(c.image);
    if (image == image_by_name.end()) {
      throw InputError::Message(c.source, "field 'id': found '" + c.image + "', expected the name of an image of photo "
                                          "collection '" + p.id + "' (a camera row gives a photo's GNSS antenna position)");
    }
    c.image_id = image->second;
    c.lever_arm = p.gnss_lever_arm_m;
    block->gnss.push_back(c);
  }
}

/// control_measurements: measurements of control targets into block->control, of check points
/// into `check_measurements`.
void ReadControlMeasurements(const JointState& s, const std::map<std::string, ImageId>& image_by_name,
                             const std::string& model_dir, PhotoBlock* block,
                             std::vector<TargetMeasurement>* check_measurements) {
  const Project& project = *s.project;
  const PhotoCollection& p = *block->config;
  if (!s.joint) {
    throw InputError::Message(ProjectKey(project, p.line, "control_measurements"),
                              "image measurements of surveyed points need a total_station sensor");
  }
  const io::CsvTable table = io::CsvTable::Read(p.control_measurements, {"point_id", "image", "x_px", "y_px"});
  const std::set<std::string> check(project.check_points.begin(), project.check_points.end());
  for (const io::CsvTable::Row& row : table.rows()) {
    TargetMeasurement m;
    m.point_id = table.String(row, "point_id");
    if (!s.surveyed->Find(m.point_id)) {
      table.Fail(row, "point_id", m.point_id, "a point of " + project.total_stations.front().file);
    }
    const auto image = image_by_name.find(table.String(row, "image"));
    if (image == image_by_name.end()) table.Fail(row, "image", table.String(row, "image"), "an image of " + model_dir);
    m.image_id = image->second;
    m.xy = {table.Double(row, "x_px"), table.Double(row, "y_px")};
    const sensors::Camera& camera = block->model.cameras.at(block->model.images.at(m.image_id).camera_id);
    if (m.xy.x() < -0.5 || m.xy.y() < -0.5 || m.xy.x() > camera.width + 0.5 || m.xy.y() > camera.height + 0.5) {
      table.Fail(row, "x_px", table.String(row, "x_px") + ", " + table.String(row, "y_px"),
                 "a pixel inside the " + std::to_string(camera.width) + "x" + std::to_string(camera.height) + " image");
    }
    m.sigma_px = p.control_sigma_px > 0 ? p.control_sigma_px : table.Double(row, "sigma_px", p.sigma_px);
    if (!(m.sigma_px > 0 && m.sigma_px <= 50)) table.Fail(row, "sigma_px", std::to_string(m.sigma_px), "a σ in (0, 50] px");
    m.source = p.control_measurements + ":" + std::to_string(row.line);
    (check.count(m.point_id) ? *check_measurements : block->control).push_back(m);
  }
}

/// Initialisation: the control targets intersected in the block's frame, then the similarity
/// block → world (Umeyama 1991) from their surveyed coordinates moves the Scene; with fewer
/// than 3 the block stays as given.
void GeoreferenceByControl(JointState* s, PhotoBlock* block) {
  std::vector<Eigen::Vector3d> from, to;
  for (const auto& [id, rays] : MeasurementRays(s->scene, block->control)) {
    if (rays.size() < 2 || !s->surveyed_ids.count(id)) continue;
    from.push_back(Triangulate(rays));
    to.push_back(WorldFromSurvey(*s->surveyed, *s->surveyed->Find(id)));
  }
  if (from.size() < 3) {
    block->georeference = "as given (fewer than 3 control targets measured in 2+ photos)";
    block->control_targets_intersected = from.size();
    return;
  }
  std::vector<size_t> all(from.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  const Sim3d world_from_block = SimilarityFrom(from, to, all);
  const double scale = world_from_block.scale;
  double sum = 0.0;
  for (size_t i = 0; i < from.size(); ++i) sum += (world_from_block * from[i] - to[i]).squaredNorm();
  const double rms = std::sqrt(sum / from.size());
  s->scene.Transform(world_from_block);
  std::ostringstream g;
  g << "similarity from " << from.size() << " control targets: scale " << scale << ", RMS " << rms << " m";
  block->georeference = g.str();
}

/// Check points: image-only points of the Scene (ids from kCheckPointIdBase), intersected
/// after the georeference, and their measurements.
void IntersectCheckPoints(JointState* s, const std::vector<TargetMeasurement>& check_measurements, PhotoBlock* block) {
  uint64_t next = kCheckPointIdBase;
  const auto rays = MeasurementRays(s->scene, check_measurements);
  for (const auto& [id, point_rays] : rays) {
    if (!s->surveyed_ids.count(id)) continue;  // warned by LoadNetwork: nothing to compare with
    if (point_rays.size() < 2) {
      s->warnings.push_back("check point " + id + " is measured in fewer than 2 photos: not evaluated");
      continue;
    }
    const Point3DId point3D_id(next++);
    s->scene.AddPoint(point3D_id, Triangulate(point_rays));
    block->check_ids[id] = point3D_id;
  }
  for (const TargetMeasurement& m : check_measurements) {
    if (block->check_ids.count(m.point_id)) block->check.push_back({m.image_id, block->check_ids.at(m.point_id), m.xy, m.sigma_px});
  }
}

/// MI registration results (`mmba register-mi` OUT.json per image, LiDAR frame = world) as
/// pose priors. They are in the world frame: a block without control is not georeferenced by
/// them (the control similarity is applied first).
void ReadPhotoMiResults(JointState* s, const std::map<std::string, ImageId>& image_by_name, PhotoBlock* block) {
  const PhotoCollection& p = *block->config;
  for (const auto& [name, id] : image_by_name) {
    const fs::path file = fs::path(p.mi_results) / (fs::path(name).stem().string() + ".json");
    MiResult result;
    if (!ReadMiResultFile(s, file.string(), &result)) continue;
    result.image_id = id;
    block->mi.push_back(result);
  }
  Note(s, "MI results: " + std::to_string(block->mi.size()) + " pose priors from " + p.mi_results);
}

}  // namespace

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
  const std::string model_dir = ReadPhotoModel(s, &block, work_dir);
  std::map<std::string, ImageId> image_by_name;
  for (const auto& [id, image] : block.model.images) image_by_name[image.name] = id;
  AttachGnssCameras(*s, image_by_name, &block);
  if (!p.control_measurements.empty()) {
    std::vector<TargetMeasurement> check_measurements;
    ReadControlMeasurements(*s, image_by_name, model_dir, &block, &check_measurements);
    GeoreferenceByControl(s, &block);
    IntersectCheckPoints(s, check_measurements, &block);
  } else {
    block.georeference = "as given (no control measurements)";
  }
  if (!p.mi_results.empty()) ReadPhotoMiResults(s, image_by_name, &block);
  for (const auto& [id, image] : s->scene.images()) block.initial_poses[id] = image.cam_from_world;
  block.initial_params = s->scene.cameras().begin()->second.params;
  Note(s, "photo block '" + p.id + "': " + std::to_string(block.model.images.size()) + " images, " +
                   std::to_string(block.model.points3D.size()) + " tie points, " + std::to_string(block.ties.size()) +
                   " observations; georeference: " + block.georeference);
  s->photos = std::move(block);
}

// A photo block without control: placed by the tie points the rig and the spherical stations
// see; else taken as given when a LiDAR can tie it (its surface association then needs it
// roughly in place), else it has no overlap with any other sensor (exit 3).
void PlacePhotoBlock(JointState* s) {
  if (!s->photos || s->photos->georeference.rfind("as given", 0) != 0) return;
  PhotoBlock& block = *s->photos;
  const Project& project = *s->project;
  const std::string& id = block.config->id;
  if (PlacePhotoBlockByGnss(s) || PlacePhotoBlockByTiePoints(s)) return;
  const std::string placed_by_nothing = std::to_string(block.control_targets_intersected) +
                                        " surveyed targets measured in 2+ photos (3 needed), fewer than 3 photos with GNSS "
                                        "positions, no tie points intersected by a camera rig or spherical stations";
  if (project.lidar_static.empty()) {
    throw AdjustFailure(AdjustStatus::kFailed, "photo collection '" + id + "' has no overlap with the control: " + placed_by_nothing +
                                      ", and no lidar_static sensor");
  }
  std::string reason;
  if (!PlacePhotoBlockByLidar(s, &reason)) {
    throw AdjustFailure(AdjustStatus::kFailed, "photo collection '" + id + "' cannot be placed: " + placed_by_nothing +
                                      ", and its tie points' registration to the LiDAR failed: " + reason);
  }
  s->warnings.push_back("photo collection '" + id + "': " + std::to_string(block.control_targets_intersected) +
                        " control targets measured in 2+ photos and no tie points placed by other sensors; the block "
                        "is placed on the LiDAR alone (" + block.georeference + ")");
}

void AddPhotoGroups(JointState* s, const GroupWeights& w) {
  const PhotoBlock& block = *s->photos;
  const PhotoCollection& p = *block.config;
  s->builder->AddGroup(std::make_unique<ReprojectionGroup>(w.Scaled(kTies, block.ties), p.loss, kTies));
  if (!block.control.empty()) {
    s->builder->AddGroup(std::make_unique<TargetReprojectionGroup>(&*s->joint, w.Scaled(kTargets, block.control), p.loss, kTargets));
  }
  if (!block.mi.empty()) {
    s->builder->AddGroup(std::make_unique<MiPriorGroup>(w.Kept(kMi, block.mi), w.Factor(kMi) * w.Factor(kMi), p.loss, kMi))
        .set_role(FactorRole::kPrior);
  }
  if (!block.check.empty()) {
    // Check points are evaluated, never weighted or snooped.
    FactorGroup& check = s->builder->AddGroup(std::make_unique<ReprojectionGroup>(block.check, LossOptions(), kCheck));
    check.set_role(FactorRole::kConstraint);
    s->check_group = &check;
  }
  if (!block.gnss.empty()) {
    s->builder->AddGroup(std::make_unique<GnssCameraGroup>(w.Scaled(kGnssCamera, block.gnss), s->project->gnss.front().loss,
                                                           kGnssCamera));
  }
  ParameterOptions& parameters = s->builder->parameter_options();
  parameters.refine_focal = p.refine.focal;
  parameters.refine_principal_point = p.refine.principal_point;
  parameters.refine_extra = p.refine.distortion;
}

std::string DescribePhotoObservation(const JointState& s, const std::string& name, size_t index) {
  if (!s.photos) return "";
  const PhotoBlock& block = *s.photos;
  if (name == kTies) {
    const ReprojectionObservation& o = block.ties[index];
    return "point " + std::to_string(o.point3D_id.value) + " in " + block.model.images.at(o.image_id).name;
  }
  if (name == kTargets) {
    const TargetMeasurement& m = block.control[index];
    return "target " + m.point_id + " in " + block.model.images.at(m.image_id).name + " (" + m.source + ")";
  }
  if (name == kMi) return "MI pose of " + block.model.images.at(block.mi[index].image_id).name + " (" + block.mi[index].source + ")";
  if (name == kGnssCamera) {
    const GnssCamera& c = block.gnss[index / 3];
    return "GNSS " + std::string(index % 3 == 0 ? "east" : index % 3 == 1 ? "north" : "up") + " of photo " + c.image +
           " (" + c.source + ")";
  }
  return "";
}

namespace {

/// calibration/<id>_camera.yaml of each camera of the block, and its calibration table.
void WritePhotoCalibration(const JointState& s, OutputSink* out) {
  const PhotoBlock& block = *s.photos;
  for (const auto& [id, model_camera] : block.model.cameras) {
    const sensors::Camera& camera = s.scene.Camera(id);
    json parameters = json::array();
    std::ostringstream yaml;
    yaml << "# mmba adjust: calibration of photo collection '" << block.config->id << "' (camera " << id.value
         << "), sigma from the adjustment\nmodel: " << camera.ModelName() << "\nwidth: " << camera.width
         << "\nheight: " << camera.height << "\nparams: [";
    std::ostringstream sigmas;
    const std::vector<double> camera_sigma = ParameterSigmas(s.statistics, s.builder->problem(), camera.params.data());
    // Parameter names in the model's order ("fx, fy, cx, cy, k1, ...").
    std::vector<std::string> names;
    std::stringstream info(sensors::CameraModelParamsInfo(camera.model_id));
    for (std::string name; std::getline(info, name, ',');) names.push_back(name.substr(name.find_first_not_of(' ')));
    for (size_t k = 0; k < camera.params.size(); ++k) {
      const double sigma = camera_sigma[k];
      yaml << (k ? ", " : "") << std::setprecision(10) << camera.params[k];
      sigmas << (k ? ", " : "") << std::setprecision(4) << sigma;
      parameters.push_back({{"name", k < names.size() ? names[k] : "p" + std::to_string(k)},
                            {"initial", block.initial_params.at(k)},
                            {"adjusted", camera.params[k]}, {"sigma", sigma}});
    }
    yaml << "]\nsigma: [" << sigmas.str() << "]\n";
    WriteText(out->stage / "calibration" / (block.config->id + "_camera.yaml"), yaml.str());
    out->calibrations.push_back({{"name", block.config->id + " camera " + std::to_string(id.value) + " (" +
                                              camera.ModelName() + ")"},
                                 {"parameters", parameters}});
  }
}

/// tie_points.ply (georeferenced, coloured from the images) and error_map_lidar.ply (the tie
/// points on the LiDAR surface, intensity = signed distance, m), each with its LAS 1.4 in the
/// output CRS (the error map's distance as the extra field distance_m).
void WriteTiePointClouds(const JointState& s, const io::ColmapModel& model, const fs::path& stage) {
  io::PointCloud ties, errors;
  std::map<Point3DId, double> distance;
  for (const SurfacePlane& p : s.planes) {
    const Eigen::Vector3d x = p.scan < 0 ? s.scene.Point(p.point3D_id) : s.scene.Scan(ScanId(p.scan)) * s.scene.Point(p.point3D_id);
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
  WriteLasBeside(s, ties, stage / "tie_points.ply");
  if (!errors.empty()) {
    io::WritePly(errors, (stage / "error_map_lidar.ply").string());
    WriteErrorMapLas(s, errors, stage / "error_map_lidar.ply", "signed distance to LiDAR surface");
  }
}

}  // namespace

void WritePhotoOutputs(const JointState& s, OutputSink* out) {
  const PhotoBlock& block = *s.photos;
  for (const auto& [id, image] : block.model.images) {
    const ImagePose& pose = s.scene.Image(id);
    const Eigen::Vector3d c = CameraCentre(pose.cam_from_world);
    const Rigid3d& initial = block.initial_poses.at(id);
    const Eigen::Vector3d d = c - CameraCentre(initial);
    const double d_rotation = pose.cam_from_world.rotation.angularDistance(initial.rotation) * kDeg;
    const Eigen::Vector3d sigma = CentreCovariance(s.statistics, pose.cam_from_world).diagonal().cwiseMax(0.0).cwiseSqrt();
    AppendPoseRow(*out->poses, image.name, block.config->id, c, pose.cam_from_world.rotation, s.plane, sigma, d.norm(),
                  d_rotation);
    out->corrections.push_back({{"image", image.name}, {"sensor", block.config->id}, {"d", Vec(d)},
                                {"d_position_m", d.norm()}, {"d_rotation_deg", d_rotation}});
  }
  // The adjusted COLMAP model and calibration.
  io::ColmapModel model = block.model;
  UpdateColmapFromScene(s.scene, &model);
  io::WriteColmapModel(model, (out->stage / "colmap" / block.config->id).string(), io::ColmapFormat::kText);
  WritePhotoCalibration(s, out);
  WriteTiePointClouds(s, model, out->stage);
}

}  // namespace mmba::adjust::internal
