#include "mmba/sim/simulate.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io/colmap_model.h"
#include "mmba/io/point_cloud.h"
#include "mmba/sim/survey.h"
#include "mmba/sim/texture.h"
#include "mmba/core/version.h"
#include "sim/random_internal.h"

namespace mmba::sim {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using Eigen::Vector2d;
using json = nlohmann::json;
constexpr double kDeg = M_PI / 180.0;

// ---------------------------------------------------------------- small helpers

// cam_from_world of a camera at `eye` looking at `target` (x right, y down, z forward),
// rolled by `roll_rad` about its axis.
Rigid3d LookAt(const Vector3d& eye, const Vector3d& target, double roll_rad = 0.0) {
  const Vector3d forward = (target - eye).normalized();
  Vector3d right = forward.cross(Vector3d::UnitZ());
  if (right.norm() < 1e-6) right = Vector3d::UnitX();
  right.normalize();
  const Vector3d down = forward.cross(right);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << right, down, forward;
  const Eigen::Matrix3d roll = Eigen::AngleAxisd(roll_rad, Vector3d::UnitZ()).toRotationMatrix();
  return Rigid3d(Eigen::Quaterniond(world_from_cam * roll), eye).Inverse();
}

Eigen::Quaterniond SmallRotation(internal::Rng* rng, double sigma_rad) {
  const Vector3d axis_angle(rng->Normal(sigma_rad), rng->Normal(sigma_rad), rng->Normal(sigma_rad));
  if (axis_angle.norm() < 1e-15) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(axis_angle.norm(), axis_angle.normalized()));
}

// A 4×4 homogeneous matrix as four rows.
json MatrixJson(const Rigid3d& pose) {
  const Eigen::Matrix4d m = pose.ToMatrix4();
  json rows = json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

json PoseJson(const Rigid3d& pose) {
  return json{{"qvec_wxyz", {pose.rotation.w(), pose.rotation.x(), pose.rotation.y(), pose.rotation.z()}},
              {"tvec", {pose.translation.x(), pose.translation.y(), pose.translation.z()}},
              {"matrix", MatrixJson(pose)}};
}

json VecJson(const Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json CameraJson(const sensors::Camera& camera) {
  return json{{"model", camera.ModelName()}, {"width", camera.width}, {"height", camera.height},
              {"params", camera.params}};
}

void WriteText(const fs::path& path, const std::string& text) {
  WriteFileAtomically(path, [&](std::ostream& out) { out << text; });
}

std::string Fmt(double v, int precision = 6) {
  std::ostringstream s;
  s << std::setprecision(precision) << std::fixed << v;
  return s.str();
}

std::string YamlList(const std::vector<double>& values, int precision = 9) {
  std::ostringstream s;
  s << std::setprecision(precision) << "[";
  for (size_t i = 0; i < values.size(); ++i) s << (i ? ", " : "") << values[i];
  s << "]";
  return s.str();
}

std::string YamlPose(const Rigid3d& pose) {
  const auto& q = pose.rotation;
  return "{qvec_wxyz: " + YamlList({q.w(), q.x(), q.y(), q.z()}) +
         ", tvec: " + YamlList({pose.translation.x(), pose.translation.y(), pose.translation.z()}) + "}";
}

// Area-weighted samples on the triangles of the object (inside its bounds, ground excluded
// by the bounds' z and a margin), with their triangle.
struct SurfaceSample {
  Vector3d point;
  Vector3d normal;
  int triangle;
};

std::vector<SurfaceSample> SampleObjectSurface(const SimScene& scene, int count, uint64_t seed,
                                               uint64_t stream) {
  const TriangleMesh& mesh = scene.mesh;
  const Vector3d lo = scene.object_min - Vector3d::Constant(0.05);
  const Vector3d hi = scene.object_max + Vector3d::Constant(0.05);
  std::vector<double> cumulative;
  std::vector<int> index;
  double total = 0;
  for (size_t t = 0; t < mesh.NumTriangles(); ++t) {
    const Eigen::Vector3i& f = mesh.triangles[t];
    const Vector3d centroid = (mesh.vertices[f[0]] + mesh.vertices[f[1]] + mesh.vertices[f[2]]) / 3.0;
    if ((centroid.array() < lo.array()).any() || (centroid.array() > hi.array()).any()) continue;
    total += mesh.TriangleArea(t);
    cumulative.push_back(total);
    index.push_back(static_cast<int>(t));
  }
  std::vector<SurfaceSample> samples;
  if (index.empty()) return samples;
  internal::Rng rng(seed, stream);
  samples.reserve(count);
  for (int i = 0; i < count; ++i) {
    const double u = rng.Uniform() * total;
    const size_t k = std::min(index.size() - 1,
                              static_cast<size_t>(std::lower_bound(cumulative.begin(), cumulative.end(), u) -
                                                  cumulative.begin()));
    const int t = index[k];
    const Eigen::Vector3i& f = mesh.triangles[t];
    double a = rng.Uniform(), b = rng.Uniform();
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const Vector3d p = mesh.vertices[f[0]] + a * (mesh.vertices[f[1]] - mesh.vertices[f[0]]) +
                       b * (mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    samples.push_back({p, mesh.TriangleNormal(t), t});
  }
  return samples;
}

// True when `point` is the first surface seen from `eye` (within `tolerance_m`).
bool SeesPoint(const RayCaster& caster, const Vector3d& eye, const Vector3d& point,
               double tolerance_m = 2e-3) {
  const Vector3d d = point - eye;
  const double length = d.norm();
  const RayHit hit = caster.Intersect(eye, d / length, 1e-3, length + 1.0);
  return hit.hit && std::abs(hit.distance_m - length) < tolerance_m;
}

// ---------------------------------------------------------------- scene

SimScene BuildScene(const SimulateOptions& options) {
  if (options.scene == "gate") return MakeGateScene(options.gate, options.seed);
  if (options.scene == "cathedral") return MakeCathedralScene(options.cathedral, options.seed);
  Material material;
  material.name = "mesh_default";
  material.pattern = TexturePattern::kStone;
  TriangleMesh mesh = LoadMesh(options.mesh_path, material);
  return SceneFromMesh(std::move(mesh), fs::path(options.mesh_path).stem().string(), options.seed);
}

// A point in front of the object at which sensors look, and its size.
struct Framing {
  Vector3d centre;   // front-centre of the object, mid-height
  double width, height, front_y;
};

Framing FrameObject(const SimScene& scene) {
  Framing f;
  f.width = scene.object_max.x() - scene.object_min.x();
  f.height = scene.object_max.z() - scene.object_min.z();
  f.front_y = scene.object_min.y();
  f.centre = Vector3d(0.5 * (scene.object_min.x() + scene.object_max.x()), std::max(0.0, f.front_y),
                      scene.object_min.z() + 0.45 * f.height);
  return f;
}

}  // namespace

// ---------------------------------------------------------------- options

bool SimulateOptions::ApplyPreset(const std::string& name) {
  if (name == "small") {
    preset = name;
    return true;
  }
  if (name == "drive") {
    // The MI paper's drive had 814 panoramas and 226 M points; this is the scale the joint
    // adjustment is measured at (bench/RESULTS.md): 200 frames over 100 m, an HDL-64E-like
    // head at 0.1° steps turning for the whole drive.
    preset = name;
    rig.frames = 200;
    mobile_drive_m = 100.0;
    mobile_scan.azimuth_step_deg = 0.1;
    mobile_revolutions = static_cast<int>(std::ceil(mobile_drive_m / mobile_speed_mps * mobile_scan.rotation_hz));
    return true;
  }
  if (name != "full") return false;
  preset = name;
  photos.width = 1600;
  photos.height = 1200;
  photos.focal_px = 1400.0;
  photos.tie_points = 10000;
  spheres.width = 6284;  // Wang et al. 2012 used Ladybug panoramas of this order
  rig.width = 1232;      // Ladybug: 1616×1232 (portrait here: 1232×1540)
  rig.focal_px = 420.0;
  rig.frames = 6;
  rig.panorama_width = 6284;
  static_scan.azimuth_step_deg = 0.08;
  static_scan.elevation_step_deg = 0.08;  // ≈ 4500×1800 = 8.2 M rays per station
  mobile_scan.azimuth_step_deg = 0.08;    // HDL-64E at 10 Hz
  mobile_revolutions = 100;
  clouds.surface_samples = 2000000;
  return true;
}

bool SimulateOptions::Check(std::string* error) const {
  std::ostringstream e;
  std::string sub;
  if (scene != "gate" && scene != "cathedral" && mesh_path.empty()) e << "scene '" << scene << "' must be gate, cathedral, a .yaml scene file or a .obj/.ply mesh";
  else if (scene == "gate" && !gate.Check(&sub)) e << sub;
  else if (scene == "cathedral" && !cathedral.Check(&sub)) e << sub;
  else if (threads < 1 || threads > 256) e << "threads " << threads << " must be in [1, 256]";
  else if (photos.count < 0 || photos.count > 100000) e << "photos.count " << photos.count << " must be in [0, 100000]";
  else if (photos.width < 16 || photos.height < 16) e << "photos.width×height " << photos.width << "×" << photos.height << " must be at least 16×16";
  else if (!(photos.focal_px > 0)) e << "photos.focal_px " << photos.focal_px << " must be > 0";
  else if (photos.tie_points < 0) e << "photos.tie_points " << photos.tie_points << " must be >= 0";
  else if (!(photos.observation_sigma_px >= 0 && photos.pose_sigma_m >= 0 && photos.pose_sigma_deg >= 0 && photos.point_sigma_m >= 0)) e << "photos: perturbation σ must be >= 0";
  else if (spheres.stations < 0) e << "spheres.stations " << spheres.stations << " must be >= 0";
  else if (spheres.width < 16 || spheres.width % 2 != 0) e << "spheres.width " << spheres.width << " must be even and >= 16";
  else if (!(spheres.baseline_m > 0)) e << "spheres.baseline_m " << spheres.baseline_m << " must be > 0 (the upper sphere is above the lower)";
  else if (!(spheres.lower_height_m > 0)) e << "spheres.lower_height_m " << spheres.lower_height_m << " must be > 0";
  else if (!(spheres.principal_offset_px >= 0 && spheres.axis_tilt_deg >= 0)) e << "spheres: calibration errors must be >= 0";
  else if (rig.frames < 0) e << "rig.frames " << rig.frames << " must be >= 0";
  else if (rig.width < 16) e << "rig.width " << rig.width << " must be >= 16";
  else if (!(rig.focal_px > 0)) e << "rig.focal_px " << rig.focal_px << " must be > 0";
  else if (rig.panorama_width < 16 || rig.panorama_width % 2 != 0) e << "rig.panorama_width " << rig.panorama_width << " must be even and >= 16";
  else if (!(rig.stitch_distance_m > 0)) e << "rig.stitch_distance_m " << rig.stitch_distance_m << " must be > 0";
  else if (static_scans < 0) e << "lidar.static_scans " << static_scans << " must be >= 0";
  else if (!static_scan.Check(&sub)) e << sub;
  else if (!mobile_scan.Check(&sub)) e << sub;
  else if (mobile_revolutions < 0) e << "lidar.mobile_revolutions " << mobile_revolutions << " must be >= 0";
  else if (!(mobile_speed_mps > 0)) e << "lidar.mobile_speed_mps " << mobile_speed_mps << " must be > 0";
  else if (!(mobile_drive_m >= 0)) e << "lidar.mobile_drive_m " << mobile_drive_m << " must be >= 0 (0: the object's width + 8 m)";
  else if (scene == "gate" && mobile_drive_m > 2.0 * (gate.studio_half_size_m - 1.0)) e << "lidar.mobile_drive_m " << mobile_drive_m << " must stay inside the gate's studio (<= " << 2.0 * (gate.studio_half_size_m - 1.0) << " m)";
  else if (scene == "cathedral" && mobile_drive_m > 2.0 * (cathedral.ground_half_size_m - 1.0)) e << "lidar.mobile_drive_m " << mobile_drive_m << " must stay on the cathedral's ground (<= " << 2.0 * (cathedral.ground_half_size_m - 1.0) << " m)";
  else if (!render.Check(&sub)) e << sub;
  else if (total_station.setups < 0) e << "total_station.setups " << total_station.setups << " must be >= 0";
  else if (!(total_station.direction_sigma_cc > 0 && total_station.zenith_sigma_cc > 0 && total_station.distance_sigma_mm > 0 && total_station.distance_sigma_ppm >= 0)) e << "total_station: σ must be > 0";
  else if (!(gnss.control_sigma_horizontal_m > 0 && gnss.control_sigma_vertical_m > 0 && gnss.trajectory_rate_hz > 0)) e << "gnss: σ and rate must be > 0";
  else if (!(gnss.ins_position_error_m >= 0 && gnss.ins_attitude_error_deg >= 0)) e << "gnss: INS errors must be >= 0";
  else if (clouds.surface_samples < 0) e << "clouds.surface_samples " << clouds.surface_samples << " must be >= 0";
  else if (clouds.stereo_width_px < 16) e << "clouds.stereo_width_px " << clouds.stereo_width_px << " must be >= 16";
  else if (!(clouds.multi_view_keep > 0 && clouds.multi_view_keep <= 1)) e << "clouds.multi_view_keep " << clouds.multi_view_keep << " must be in (0, 1]";
  else if (!(clouds.plane_bin_m > 0 && clouds.plane_voxel_m > 0)) e << "clouds.plane_bin_m / plane_voxel_m must be > 0";
  else if (!(clouds.part_fraction > 0 && clouds.part_fraction < 1)) e << "clouds.part_fraction " << clouds.part_fraction << " must be in (0, 1)";
  else if (!(std::abs(origin.latitude_deg) <= 90 && std::abs(origin.longitude_deg) <= 180)) e << "origin latitude/longitude out of range";
  if (e.str().empty()) return true;
  if (error) *error = e.str();
  return false;
}

std::string SimulateResult::BriefReport() const {
  std::ostringstream s;
  s << "simulated " << out_dir << " in " << Fmt(seconds, 1) << " s: " << triangles << " triangles, "
    << photos << " photos (" << tie_points << " tie points, " << tie_observations << " observations), "
    << sphere_images << " sphere images, " << rig_images << " rig images + " << panoramas
    << " panoramas, " << static_points << " static + " << mobile_points << " mobile LiDAR points ("
    << ghost_points << " ghosts), " << ts_setups << " total-station setups with " << ts_observations
    << " observations, " << gnss_rows << " GNSS rows";
  return s.str();
}

// ---------------------------------------------------------------- the run

namespace {

struct Context {
  const SimulateOptions& options;
  const SimScene& scene;
  const RayCaster& caster;
  const geodesy::LocalTangentPlane& plane;
  fs::path out;
  Framing framing;
  json truth;
  json registration_truth;
  std::ostringstream project_sensors;
  SimulateResult result;
  /// The photos' tie points (COLMAP point3D id, true position): other image sensors observe
  /// the same ids, standing for features matched across sensors.
  std::vector<std::pair<uint64_t, Vector3d>> tie_points;
};

// ---- photos: an OPENCV camera on two rings in front of the object.
void SimulatePhotos(Context* c) {
  const PhotoOptions& o = c->options.photos;
  if (o.count == 0) return;
  sensors::Camera camera;
  camera.camera_id = CameraId(1);
  camera.model_id = sensors::CameraModelId::kOpenCV;
  camera.width = o.width;
  camera.height = o.height;
  camera.params = {o.focal_px, 1.002 * o.focal_px, 0.5 * o.width + 3.1, 0.5 * o.height - 2.3,
                   o.k1, o.k2, o.p1, o.p2};
  const double fov_h = 2.0 * std::atan(0.5 * o.width / o.focal_px);
  const double extent = std::max(c->framing.width, c->framing.height * o.width / o.height);
  const double distance = 0.75 * extent / (2.0 * std::tan(0.5 * fov_h)) + 2.0;
  internal::Rng rng(c->options.seed, 0xF0705);
  io::ColmapModel truth_model;
  truth_model.cameras[camera.camera_id] = camera;
  std::vector<Rigid3d> poses;
  const RayTable photo_rays = MakeRayTable(camera, c->options.render.samples_per_axis, c->options.threads);
  Progress progress("photos", o.count);
  for (int i = 0; i < o.count; ++i) {
    const double t = o.count == 1 ? 0.5 : static_cast<double>(i) / (o.count - 1);
    const double azimuth = (-65.0 + 130.0 * t) * kDeg;  // around the front, from the west
    const double height = (i % 2 == 0) ? 1.6 : 1.6 + 0.3 * c->framing.height;
    const double d = distance * (1.0 + 0.1 * rng.Uniform(-1, 1));
    const Vector3d eye(c->framing.centre.x() + d * std::sin(azimuth),
                       c->framing.front_y - d * std::cos(azimuth), height);
    const Vector3d target = c->framing.centre +
                            Vector3d(rng.Uniform(-0.15, 0.15) * c->framing.width, 0,
                                     rng.Uniform(-0.1, 0.1) * c->framing.height);
    const Rigid3d cam_from_world = LookAt(eye, target, rng.Normal(2.0 * kDeg));
    poses.push_back(cam_from_world);
    std::ostringstream name;
    name << "photo_" << std::setw(3) << std::setfill('0') << i << ".png";
    const GrayImage image = RenderImage(c->caster, c->scene, camera, cam_from_world,
                                        c->options.render, c->options.seed, 1000 + i,
                                        c->options.threads, &photo_rays);
    WritePng(image, (c->out / "images" / "photos" / name.str()).string());
    io::ColmapImage colmap_image;
    colmap_image.image_id = ImageId(i + 1);
    colmap_image.camera_id = camera.camera_id;
    colmap_image.name = name.str();
    colmap_image.cam_from_world = cam_from_world;
    truth_model.images[colmap_image.image_id] = colmap_image;
    progress.Step();
  }
  progress.Done();
  // Tie points: surface samples seen (first surface, inside the image) by ≥ 2 photos.
  const std::vector<SurfaceSample> samples =
      SampleObjectSurface(c->scene, 4 * o.tie_points, c->options.seed, 0x71E);
  uint64_t next_id = 1;
  for (const SurfaceSample& s : samples) {
    if (static_cast<int>(truth_model.points3D.size()) >= o.tie_points) break;
    const Material& m = c->scene.mesh.materials[c->scene.mesh.triangle_material[s.triangle]];
    if (m.material_class == MaterialClass::kGlass) continue;  // no stable features on glass
    std::vector<std::pair<int, Eigen::Vector2d>> seen;
    for (int i = 0; i < o.count; ++i) {
      const Vector3d p_cam = poses[i] * s.point;
      const auto xy = camera.ImgFromCam(p_cam);
      if (!xy || xy->x() < 0 || xy->y() < 0 || xy->x() >= o.width || xy->y() >= o.height) continue;
      if (!SeesPoint(c->caster, poses[i].Inverse().translation, s.point)) continue;
      seen.emplace_back(i, *xy);
    }
    if (seen.size() < 2) continue;
    io::ColmapPoint3D point;
    point.point3D_id = Point3DId(next_id++);
    point.xyz = s.point;
    const uint8_t grey = static_cast<uint8_t>(255 * Albedo(m, s.point, s.normal, c->options.seed));
    point.color = {grey, grey, grey};
    point.error = 0.0;
    for (const auto& [i, xy] : seen) {
      io::ColmapImage& image = truth_model.images.at(ImageId(i + 1));
      point.track.push_back({image.image_id, static_cast<uint32_t>(image.points2D.size())});
      image.points2D.push_back(xy);
      image.point3D_ids.push_back(point.point3D_id);
    }
    truth_model.points3D[point.point3D_id] = point;
  }
  c->result.photos = o.count;
  for (const auto& [id, point] : truth_model.points3D) c->tie_points.emplace_back(id.value, point.xyz);
  c->result.tie_points = truth_model.points3D.size();
  c->result.tie_observations = truth_model.NumObservations();
  // The perturbed model: nominal calibration, perturbed poses and points, noisy observations.
  io::ColmapModel perturbed = truth_model;
  sensors::Camera nominal = camera;
  nominal.params = {o.focal_px * (1 + o.nominal_focal_error), o.focal_px * (1 + o.nominal_focal_error),
                    0.5 * o.width, 0.5 * o.height, 0, 0, 0, 0};
  perturbed.cameras[camera.camera_id] = nominal;
  internal::Rng noise(c->options.seed, 0xBAD);
  for (auto& [id, image] : perturbed.images) {
    const Rigid3d world_from_cam = image.cam_from_world.Inverse();
    const Rigid3d moved(SmallRotation(&noise, o.pose_sigma_deg * kDeg) * world_from_cam.rotation,
                        world_from_cam.translation + Vector3d(noise.Normal(o.pose_sigma_m),
                                                              noise.Normal(o.pose_sigma_m),
                                                              noise.Normal(o.pose_sigma_m)));
    image.cam_from_world = moved.Inverse();
    for (auto& xy : image.points2D) {
      xy += Eigen::Vector2d(noise.Normal(o.observation_sigma_px), noise.Normal(o.observation_sigma_px));
    }
  }
  for (auto& [id, point] : perturbed.points3D) {
    point.xyz += Vector3d(noise.Normal(o.point_sigma_m), noise.Normal(o.point_sigma_m), noise.Normal(o.point_sigma_m));
    point.error = -1.0;
  }
  // Image measurements of the surveyed targets (the photogrammetrist's control/check point
  // measurements): every target inside a photo and in its line of sight, true projection +
  // N(0, σ) per axis from a stream of its own (the other outputs do not change with it).
  internal::Rng target_noise(c->options.seed, 0x7A6E7);
  std::ostringstream target_csv;
  target_csv << "# mmba simulate: image measurements of the surveyed targets (survey/network.xml ids)\n"
                "point_id,image,x_px,y_px,sigma_px\n";
  int target_measurements = 0;
  for (const ScenePoint& target : c->scene.targets) {
    for (int i = 0; i < o.count; ++i) {
      const auto xy = camera.ImgFromCam(poses[i] * target.point_in_world);
      if (!xy || xy->x() < 0 || xy->y() < 0 || xy->x() >= o.width || xy->y() >= o.height) continue;
      if (!SeesPoint(c->caster, poses[i].Inverse().translation, target.point_in_world)) continue;
      const Eigen::Vector2d measured = *xy + Eigen::Vector2d(target_noise.Normal(o.observation_sigma_px),
                                                             target_noise.Normal(o.observation_sigma_px));
      if (measured.x() < 0 || measured.y() < 0 || measured.x() >= o.width || measured.y() >= o.height) continue;
      target_csv << target.id << "," << truth_model.images.at(ImageId(i + 1)).name << "," << Fmt(measured.x(), 3)
                 << "," << Fmt(measured.y(), 3) << "," << o.observation_sigma_px << "\n";
      ++target_measurements;
    }
  }
  WriteText(c->out / "survey" / "image_points.csv", target_csv.str());
  io::WriteColmapModel(truth_model, (c->out / "truth" / "colmap_photos").string(), io::ColmapFormat::kText);
  io::WriteColmapModel(perturbed, (c->out / "colmap" / "photos").string(), io::ColmapFormat::kText);
  // Calibration and truth.
  WriteText(c->out / "calib" / "photo_camera.yaml",
            "# Nominal calibration of the photo camera (deliberately off: focal +" +
                Fmt(100 * o.nominal_focal_error, 1) + " %, no distortion, centred principal point).\n"
                "model: OPENCV\nwidth: " + std::to_string(o.width) + "\nheight: " + std::to_string(o.height) +
                "\nparams: " + YamlList(nominal.params) + "  # fx, fy, cx, cy, k1, k2, p1, p2\n");
  json photos = json::array();
  for (const auto& [id, image] : truth_model.images) {
    photos.push_back({{"name", image.name}, {"image_id", id.value}, {"cam_from_world", PoseJson(image.cam_from_world)}});
  }
  c->truth["photos"] = {{"camera", CameraJson(camera)}, {"images", photos},
                        {"colmap_model", "truth/colmap_photos"}, {"tie_points", truth_model.points3D.size()}};
  c->project_sensors << "  - id: photos\n    type: photo_collection\n    images: images/photos\n"
                        "    calibration: calib/photo_camera.yaml\n    colmap_model: colmap/photos\n"
                        "    control_measurements: survey/image_points.csv  # "
                     << target_measurements << " image measurements of surveyed targets\n"
                        "    sigma_px: " << o.observation_sigma_px << "\n";
}

// ---- spherical stereo pairs: two equirectangular spheres on a tilted mast per station.
struct SphereStation {
  std::string name;
  Rigid3d lower_from_world, upper_from_world;
};

std::vector<SphereStation> SphereStations(Context* c) {
  const SphereOptions& o = c->options.spheres;
  std::vector<SphereStation> stations;
  internal::Rng rng(c->options.seed, 0x5F4E);
  const double distance = std::max(6.0, 0.9 * c->framing.width);
  for (int s = 0; s < o.stations; ++s) {
    const double t = o.stations == 1 ? 0.5 : static_cast<double>(s) / (o.stations - 1);
    const double azimuth = (-40.0 + 80.0 * t) * kDeg;
    const Vector3d ground(c->framing.centre.x() + distance * std::sin(azimuth),
                          c->framing.front_y - distance * std::cos(azimuth), 0.0);
    // Upright sphere frame looking at the object (x right, y down, z forward), then the
    // mast tilt (the calibration error) about the two horizontal axes.
    const Vector3d lower = ground + Vector3d(0, 0, o.lower_height_m);
    const Rigid3d upright = LookAt(lower, Vector3d(c->framing.centre.x(), c->framing.front_y, lower.z()));
    const Eigen::Quaterniond tilt =
        Eigen::AngleAxisd(rng.Uniform(-o.axis_tilt_deg, o.axis_tilt_deg) * kDeg, Vector3d::UnitX()) *
        Eigen::AngleAxisd(rng.Uniform(-o.axis_tilt_deg, o.axis_tilt_deg) * kDeg, Vector3d::UnitZ());
    const Eigen::Quaterniond world_from_sphere = upright.Inverse().rotation * tilt;
    // The baseline runs along the sphere's own up axis (−y), i.e. along the tilted mast.
    const Vector3d upper = lower + o.baseline_m * (world_from_sphere * Vector3d(0, -1, 0));
    SphereStation station;
    station.name = "S" + std::to_string(s + 1);
    station.lower_from_world = Rigid3d(world_from_sphere, lower).Inverse();
    station.upper_from_world = Rigid3d(world_from_sphere, upper).Inverse();
    stations.push_back(station);
  }
  return stations;
}

void SimulateSpheres(Context* c, const std::vector<SphereStation>& stations) {
  const SphereOptions& o = c->options.spheres;
  if (stations.empty()) return;
  internal::Rng rng(c->options.seed, 0x5F4C);
  const int w = o.width, h = o.width / 2;
  sensors::Camera truth_cam[2];
  const auto nominal = sensors::EquirectangularModel::DefaultParams(w, h);
  for (int k = 0; k < 2; ++k) {
    truth_cam[k].camera_id = CameraId(k + 1);
    truth_cam[k].model_id = sensors::CameraModelId::kEquirectangular;
    truth_cam[k].width = w;
    truth_cam[k].height = h;
    truth_cam[k].params = {nominal[0], nominal[1] + rng.Uniform(-o.principal_offset_px, o.principal_offset_px),
                           nominal[2] + rng.Uniform(-o.principal_offset_px, o.principal_offset_px)};
  }
  json jstations = json::array();
  const RayTable sphere_rays[2] = {MakeRayTable(truth_cam[0], c->options.render.samples_per_axis, c->options.threads),
                                   MakeRayTable(truth_cam[1], c->options.render.samples_per_axis, c->options.threads)};
  for (size_t s = 0; s < stations.size(); ++s) {
    const Rigid3d poses[2] = {stations[s].lower_from_world, stations[s].upper_from_world};
    const char* which[2] = {"lower", "upper"};
    for (int k = 0; k < 2; ++k) {
      const GrayImage image = RenderImage(c->caster, c->scene, truth_cam[k], poses[k], c->options.render,
                                          c->options.seed, 2000 + 2 * s + k, c->options.threads,
                                          &sphere_rays[k]);
      WritePng(image, (c->out / "images" / "spherical" / (stations[s].name + "_" + which[k] + ".png")).string());
      ++c->result.sphere_images;
    }
    jstations.push_back({{"name", stations[s].name},
                         {"lower_from_world", PoseJson(poses[0])},
                         {"upper_from_world", PoseJson(poses[1])},
                         {"images", {"images/spherical/" + stations[s].name + "_lower.png",
                                     "images/spherical/" + stations[s].name + "_upper.png"}}});
  }
  // Tie-point observations of the spheres (the photos' tie points seen from a station, true
  // projection + N(0, 0.5 px)) and approximate station setups (position 5 cm, heading 1°).
  internal::Rng noise(c->options.seed, 0x5F51);
  std::ostringstream observations, setups;
  observations << "# mmba simulate: tie-point observations in the spherical images (point ids of colmap/photos)\n"
                  "image,point_id,x_px,y_px,sigma_px\n";
  setups << "# mmba simulate: approximate spherical station setups (lower sphere centre, heading of its forward axis from north)\n"
            "station,east_m,north_m,up_m,heading_deg\n";
  size_t num_observations = 0;
  for (size_t s = 0; s < stations.size(); ++s) {
    const Rigid3d poses[2] = {stations[s].lower_from_world, stations[s].upper_from_world};
    const char* which[2] = {"lower", "upper"};
    for (int k = 0; k < 2; ++k) {
      const Vector3d eye = poses[k].Inverse().translation;
      for (const auto& [id, point] : c->tie_points) {
        const auto xy = truth_cam[k].ImgFromCam(poses[k] * point);
        if (!xy || !SeesPoint(c->caster, eye, point)) continue;
        const Vector2d measured = *xy + Vector2d(noise.Normal(0.5), noise.Normal(0.5));
        if (measured.x() < 0 || measured.y() < 0 || measured.x() >= w || measured.y() >= h) continue;
        observations << stations[s].name << "_" << which[k] << ".png," << id << "," << Fmt(measured.x(), 3) << ","
                     << Fmt(measured.y(), 3) << ",0.5\n";
        ++num_observations;
      }
    }
    const Rigid3d world_from_lower = stations[s].lower_from_world.Inverse();
    const Vector3d forward = world_from_lower.rotation * Vector3d::UnitZ();
    const Vector3d centre = world_from_lower.translation + Vector3d(noise.Normal(0.05), noise.Normal(0.05), noise.Normal(0.05));
    setups << stations[s].name << "," << Fmt(centre.x(), 4) << "," << Fmt(centre.y(), 4) << "," << Fmt(centre.z(), 4) << ","
           << Fmt(std::atan2(forward.x(), forward.y()) / kDeg + noise.Normal(1.0), 3) << "\n";
  }
  if (!c->tie_points.empty()) {
    WriteText(c->out / "observations" / "spherical.csv", observations.str());
    WriteText(c->out / "spherical_stations.csv", setups.str());
  }
  c->truth["spherical_stereo"] = {{"lower_camera", CameraJson(truth_cam[0])},
                                  {"upper_camera", CameraJson(truth_cam[1])},
                                  {"baseline_m", o.baseline_m},
                                  {"stations", jstations}};
  WriteText(c->out / "calib" / "spherical_stereo.yaml",
            "# Nominal calibration of the spherical line-scan stereo pair (EQUIRECTANGULAR: f, cx, cy).\n"
            "# The true principal points differ by up to " + Fmt(o.principal_offset_px, 1) +
                " px and the mast is tilted by up to " + Fmt(o.axis_tilt_deg, 3) + " deg (truth/truth.json).\n"
            "model: EQUIRECTANGULAR\nwidth: " + std::to_string(w) + "\nheight: " + std::to_string(h) +
                "\nlower_params: " + YamlList({nominal[0], nominal[1], nominal[2]}) +
                "\nupper_params: " + YamlList({nominal[0], nominal[1], nominal[2]}) +
                "\nbaseline_m: " + Fmt(o.baseline_m) + "  # vertical, lower to upper sphere\n");
  c->project_sensors << "  - id: spherical\n    type: spherical_stereo\n    images: images/spherical\n"
                        "    calibration: calib/spherical_stereo.yaml\n    stations: [";
  for (size_t s = 0; s < stations.size(); ++s) c->project_sensors << (s ? ", " : "") << stations[s].name;
  c->project_sensors << "]\n    baseline_sigma_m: 0.001\n    sigma_px: 0.5\n";
  if (!c->tie_points.empty()) {
    c->project_sensors << "    stations_file: spherical_stations.csv\n    observations: observations/spherical.csv  # "
                       << num_observations << " tie-point observations\n    tie_block: photos\n";
  }
}

// ---- the Ladybug-style rig: 5 cameras around + 1 up, OPENCV_FISHEYE, on the vehicle.
void SimulateRig(Context* c, const Trajectory& trajectory) {
  const RigOptions& o = c->options.rig;
  if (o.frames == 0) return;
  // Rig frame: x right, y down, z forward (= vehicle forward); body: x fwd, y left, z up.
  Eigen::Matrix3d body_from_rig_rotation;
  body_from_rig_rotation << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Rigid3d body_from_rig(Eigen::Quaterniond(body_from_rig_rotation), Vector3d(0.2, 0, 2.3));
  std::vector<sensors::Camera> cameras;
  std::vector<Rigid3d> cam_from_rig;
  internal::Rng rng(c->options.seed, 0x1ADB);
  const int width = o.width, height = static_cast<int>(std::lround(1.25 * o.width));
  for (int k = 0; k < 6; ++k) {
    sensors::Camera camera;
    camera.camera_id = CameraId(k + 1);
    camera.model_id = sensors::CameraModelId::kOpenCVFisheye;
    camera.width = width;
    camera.height = height;
    camera.params = {o.focal_px * (1 + rng.Uniform(-0.01, 0.01)), o.focal_px * (1 + rng.Uniform(-0.01, 0.01)),
                     0.5 * width + rng.Uniform(-2, 2), 0.5 * height + rng.Uniform(-2, 2),
                     0.02 + rng.Uniform(-0.005, 0.005), -0.005, 0.001, 0.0};
    cameras.push_back(camera);
    // Rig-from-camera: cameras 0–4 yawed by 72° steps about the rig's down axis, 6 cm out;
    // camera 5 looks up (−y of the rig).
    Eigen::Matrix3d rig_from_cam;
    Vector3d centre;
    if (k < 5) {
      const double yaw = 2.0 * M_PI * k / 5.0;
      rig_from_cam = Eigen::AngleAxisd(yaw, Vector3d::UnitY()).toRotationMatrix();
      centre = rig_from_cam * Vector3d(0, 0, 0.06);
    } else {
      rig_from_cam = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()).toRotationMatrix();  // z → −y
      centre = Vector3d(0, -0.07, 0);
    }
    cam_from_rig.push_back(Rigid3d(Eigen::Quaterniond(rig_from_cam), centre).Inverse());
  }
  sensors::Camera pano;
  pano.model_id = sensors::CameraModelId::kEquirectangular;
  pano.width = o.panorama_width;
  pano.height = o.panorama_width / 2;
  const auto pano_params = sensors::EquirectangularModel::DefaultParams(pano.width, pano.height);
  pano.params.assign(pano_params.begin(), pano_params.end());
  std::vector<RayTable> rig_rays;
  for (const auto& camera : cameras) {
    rig_rays.push_back(MakeRayTable(camera, c->options.render.samples_per_axis, c->options.threads));
  }
  json frames = json::array();
  internal::Rng observation_noise(c->options.seed, 0x1AD0);
  std::ostringstream rig_observations, rig_frames;
  rig_observations << "# mmba simulate: tie-point observations in the rig images (point ids of colmap/photos)\n"
                      "image,point_id,x_px,y_px,sigma_px\n";
  rig_frames << "# mmba simulate: rig frames and their times (s) on the GNSS/INS trajectory\nframe,time_s\n";
  size_t num_rig_observations = 0;
  for (int f = 0; f < o.frames; ++f) {
    const double time = trajectory.duration_s() * (o.frames == 1 ? 0.5 : (0.1 + 0.8 * f / (o.frames - 1)));
    const Rigid3d world_from_rig = trajectory.WorldFromBodyTrue(time) * body_from_rig;
    const Rigid3d rig_from_world = world_from_rig.Inverse();
    std::vector<GrayImage> images;
    std::ostringstream frame_name;
    frame_name << "frame_" << std::setw(3) << std::setfill('0') << f;
    for (int k = 0; k < 6; ++k) {
      images.push_back(RenderImage(c->caster, c->scene, cameras[k], cam_from_rig[k] * rig_from_world,
                                   c->options.render, c->options.seed, 3000 + 6 * f + k, c->options.threads,
                                   &rig_rays[k]));
      WritePng(images.back(), (c->out / "images" / "rig" / (frame_name.str() + "_cam" + std::to_string(k) + ".png")).string());
      ++c->result.rig_images;
    }
    const GrayImage panorama = StitchPanorama(images, cameras, cam_from_rig, pano, o.stitch_distance_m, c->options.threads);
    WritePng(panorama, (c->out / "images" / "rig_panoramas" / (frame_name.str() + ".png")).string());
    ++c->result.panoramas;
    frames.push_back({{"name", frame_name.str()}, {"time_s", time}, {"rig_from_world", PoseJson(rig_from_world)}});
    // Tie-point observations of the rig images (true projection + N(0, 0.5 px)).
    for (int k = 0; k < 6; ++k) {
      const Rigid3d cam_from_world = cam_from_rig[k] * rig_from_world;
      const Vector3d eye = cam_from_world.Inverse().translation;
      for (const auto& [id, point] : c->tie_points) {
        const auto xy = cameras[k].ImgFromCam(cam_from_world * point);
        if (!xy || xy->x() < 0 || xy->y() < 0 || xy->x() >= width || xy->y() >= height) continue;
        if (!SeesPoint(c->caster, eye, point)) continue;
        const Vector2d measured = *xy + Vector2d(observation_noise.Normal(0.5), observation_noise.Normal(0.5));
        if (measured.x() < 0 || measured.y() < 0 || measured.x() >= width || measured.y() >= height) continue;
        rig_observations << frame_name.str() << "_cam" << k << ".png," << id << "," << Fmt(measured.x(), 3) << ","
                         << Fmt(measured.y(), 3) << ",0.5\n";
        ++num_rig_observations;
      }
    }
    rig_frames << frame_name.str() << "," << Fmt(time, 3) << "\n";
  }
  if (!c->tie_points.empty()) {
    WriteText(c->out / "observations" / "rig.csv", rig_observations.str());
    WriteText(c->out / "rig_frames.csv", rig_frames.str());
  }
  json jcams = json::array();
  std::ostringstream yaml;
  yaml << "# Nominal calibration of the Ladybug-style rig: 6 OPENCV_FISHEYE cameras\n"
          "# (fx, fy, cx, cy, k1, k2, k3, k4) and cam_from_rig; rig frame x right, y down, z forward\n"
          "# (vehicle forward). Intrinsics: design values; cam_from_rig: a factory calibration\n"
          "# (0.02°, 1 mm per axis); truth/truth.json holds the true ones.\n"
          "body_from_rig: " << YamlPose(body_from_rig) << "\ncameras:\n";
  // The rig's factory calibration of cam_from_rig: good to ~0.02° and 1 mm (σ per axis), the
  // σ the project states; the truth keeps the true poses.
  internal::Rng calibration_error(c->options.seed, 0x1ADC);
  for (int k = 0; k < 6; ++k) {
    jcams.push_back({{"camera", CameraJson(cameras[k])}, {"cam_from_rig", PoseJson(cam_from_rig[k])}});
    const Vector3d rotation_error(calibration_error.Normal(0.02 * kDeg), calibration_error.Normal(0.02 * kDeg),
                                  calibration_error.Normal(0.02 * kDeg));
    const Vector3d position_error(calibration_error.Normal(0.001), calibration_error.Normal(0.001),
                                  calibration_error.Normal(0.001));
    const Rigid3d nominal(Eigen::Quaterniond(Eigen::AngleAxisd(rotation_error.norm(), rotation_error.normalized())) *
                              cam_from_rig[k].rotation,
                          cam_from_rig[k].translation + position_error);
    yaml << "  - name: cam" << k << "\n    model: OPENCV_FISHEYE\n    width: " << width << "\n    height: " << height
         << "\n    params: " << YamlList({o.focal_px, o.focal_px, 0.5 * width, 0.5 * height, 0.02, -0.005, 0.001, 0.0})
         << "\n    cam_from_rig: " << YamlPose(nominal) << "\n";
  }
  WriteText(c->out / "calib" / "ladybug.yaml", yaml.str());
  c->truth["rig"] = {{"cameras", jcams}, {"body_from_rig", PoseJson(body_from_rig)},
                     {"panorama_camera", CameraJson(pano)}, {"stitch_distance_m", o.stitch_distance_m},
                     {"frames", frames}};
  c->project_sensors << "  - id: ladybug\n    type: camera_rig\n    images: images/rig\n"
                        "    panoramas: images/rig_panoramas\n    calibration: calib/ladybug.yaml\n"
                        "    trajectory: trajectory_ins.csv\n    sigma_px: 0.5\n";
  if (!c->tie_points.empty()) {
    c->project_sensors << "    frames_file: rig_frames.csv\n    observations: observations/rig.csv  # "
                       << num_rig_observations << " tie-point observations\n    tie_block: photos\n"
                          "    trajectory_sigma_m: 0.1\n    trajectory_sigma_deg: 1.0\n"
                          "    cam_from_rig_sigma_m: 0.001  # factory calibration\n    cam_from_rig_sigma_deg: 0.02\n";
  }
}

// ---- LiDAR.
// clouds/<name>.viewpoints.txt: the sensor positions of a cloud in its own frame, as its
// provider knows them (a scanner's stations in its registered model, a reconstruction's camera
// centres or stereo stations) — what register-eval's visibility (free-space) test reads
// (docs/commands/register-cloud.md). Not written for a model without a sensor.
void WriteViewpoints(Context* c, const std::string& name, const Rigid3d& cloud_from_world,
                     const std::vector<Vector3d>& sensors_in_world) {
  if (sensors_in_world.empty()) return;
  std::ostringstream text;
  text << "# sensor positions of clouds/" << name << ".ply in its own frame (x y z, m)\n"
       << std::setprecision(10);
  for (const Vector3d& v : sensors_in_world) {
    const Vector3d p = cloud_from_world * v;
    text << p.x() << " " << p.y() << " " << p.z() << "\n";
  }
  WriteText(c->out / "clouds" / (name + ".viewpoints.txt"), text.str());
}

void SimulateLidar(Context* c, const Trajectory& trajectory, const Rigid3d& body_from_lidar) {
  const SimulateOptions& o = c->options;
  io::PointCloud merged;
  json scans = json::array();
  internal::Rng rng(o.seed, 0x5CA);
  // The scans come registered as a scanner's software delivers them: a few millimetres and
  // hundredths of a degree off (target or cloud-to-cloud registration); the merged reference
  // cloud is built with these registrations, the truth keeps the true poses.
  internal::Rng registration_error(o.seed, 0x5CB);
  std::vector<Rigid3d> registrations;
  // The surveyed targets each scan sees (in range, line of sight): their centres in the scan's
  // frame as target-fitting software reports them, N(0, 2 mm) per axis.
  internal::Rng target_noise(o.seed, 0x5CC);
  std::ostringstream targets_csv;
  targets_csv << "# mmba simulate: surveyed targets measured in the static scans (scan frame)\n"
                 "scan,point_id,x_m,y_m,z_m,sigma_m\n";
  size_t num_target_observations = 0;
  const double distance = std::max(5.0, 0.7 * c->framing.width);
  for (int s = 0; s < o.static_scans; ++s) {
    const double t = o.static_scans == 1 ? 0.5 : static_cast<double>(s) / (o.static_scans - 1);
    const double azimuth = (-50.0 + 100.0 * t) * kDeg + rng.Uniform(-3, 3) * kDeg;
    const Vector3d position(c->framing.centre.x() + distance * std::sin(azimuth),
                            c->framing.front_y - distance * std::cos(azimuth), 1.6 + rng.Uniform(-0.1, 0.1));
    const Rigid3d world_from_scan(Eigen::Quaterniond(Eigen::AngleAxisd(rng.Uniform(0, 2 * M_PI), Vector3d::UnitZ())),
                                  position);
    const std::string name = "scan_" + std::to_string(s + 1);
    const LidarScan scan = SimulateStaticScan(c->caster, c->scene, world_from_scan, o.static_scan, name, o.seed, o.threads);
    io::WritePly(scan.cloud, (c->out / "clouds" / "scans" / (name + ".ply")).string());
    for (const ScenePoint& target : c->scene.targets) {
      if (target.kind != "target") continue;
      const Vector3d in_scan = world_from_scan.Inverse() * target.point_in_world;
      if (in_scan.norm() < o.static_scan.noise.min_range_m || in_scan.norm() > o.static_scan.noise.max_range_m) continue;
      if (!SeesPoint(c->caster, world_from_scan.translation, target.point_in_world)) continue;
      const Vector3d measured = in_scan + Vector3d(target_noise.Normal(0.002), target_noise.Normal(0.002), target_noise.Normal(0.002));
      targets_csv << name << "," << target.id << "," << Fmt(measured.x(), 5) << "," << Fmt(measured.y(), 5) << ","
                  << Fmt(measured.z(), 5) << ",0.002\n";
      ++num_target_observations;
    }
    const Vector3d rotation_error(registration_error.Normal(0.015 * kDeg), registration_error.Normal(0.015 * kDeg),
                                  registration_error.Normal(0.015 * kDeg));
    const Vector3d position_error(registration_error.Normal(0.004), registration_error.Normal(0.004),
                                  registration_error.Normal(0.004));
    const Eigen::Quaterniond rotation_delta =
        rotation_error.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(rotation_error.norm(), rotation_error.normalized()))
                                  : Eigen::Quaterniond::Identity();
    const Rigid3d registered(rotation_delta * world_from_scan.rotation, world_from_scan.translation + position_error);
    registrations.push_back(registered);
    for (size_t i = 0; i < scan.cloud.size(); ++i) {
      merged.points.push_back(registered * scan.cloud.points[i]);
      merged.intensity.push_back(scan.cloud.intensity[i]);
    }
    c->result.static_points += scan.cloud.size();
    c->result.ghost_points += scan.num_ghosts;
    scans.push_back({{"name", name}, {"file", "clouds/scans/" + name + ".ply"},
                     {"world_from_scan", PoseJson(world_from_scan)}, {"world_from_scan_registered", PoseJson(registered)},
                     {"points", scan.cloud.size()},
                     {"rays", scan.num_rays}, {"dropouts", scan.num_dropouts},
                     {"glass_pass", scan.num_glass_pass}, {"ghosts", scan.num_ghosts}});
  }
  if (!merged.empty()) {
    io::WritePly(merged, (c->out / "clouds" / "lidar.ply").string());
    c->registration_truth["world_from_lidar"] = MatrixJson(Rigid3d());
    std::vector<Vector3d> stations_registered;  // the model's own placement of each station
    for (const Rigid3d& r : registrations) stations_registered.push_back(r.translation);
    WriteViewpoints(c, "lidar", Rigid3d(), stations_registered);
  }
  json mobile;
  // The delivered cloud is georeferenced as a mobile-mapping system would: with its GNSS/INS
  // trajectory and its nominal mounting calibration, which is off by a typical residual
  // boresight (0.15°, −0.2°, 0.3°) and lever-arm (2, −1.5, 1 cm) error. Each point keeps its time.
  const Rigid3d body_from_lidar_nominal(
      body_from_lidar.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * kDeg, Vector3d::UnitZ()) *
                                                    Eigen::AngleAxisd(-0.2 * kDeg, Vector3d::UnitY()) *
                                                    Eigen::AngleAxisd(0.15 * kDeg, Vector3d::UnitX())),
      body_from_lidar.translation + Vector3d(0.02, -0.015, 0.01));
  if (o.mobile_revolutions > 0) {
    const LidarScan scan = SimulateMobileScan(c->caster, c->scene, trajectory, body_from_lidar, o.mobile_scan,
                                              o.mobile_revolutions, "mobile", o.seed, o.threads);
    io::WritePly(GeoreferenceMobileScan(scan, trajectory, body_from_lidar_nominal, true),
                 (c->out / "clouds" / "mobile_lidar.ply").string());
    io::WritePly(GeoreferenceMobileScan(scan, trajectory, body_from_lidar, false),
                 (c->out / "truth" / "mobile_lidar_true.ply").string());
    // Each cloud's sidecar (io::ReadScannerSidecar): the trajectory and mounting it was
    // georeferenced with, which place the scanner of each point (register-mi's incidence
    // correction finds them without options).
    WriteText(c->out / "clouds" / "mobile_lidar.scanner.yaml",
              "# The scanner of each point of mobile_lidar.ply: the pose at the point's time on the GNSS/INS\n"
              "# trajectory and the nominal mounting it was georeferenced with (paths relative to this file).\n"
              "trajectory: ../trajectory_ins.csv\nlidar_mount: ../calib/mobile_lidar.yaml\n");
    WriteText(c->out / "truth" / "mobile_lidar_mount_true.yaml",
              "# The true mounting of the mobile LiDAR head on the vehicle (body: x forward, y left, z up).\n"
              "body_from_lidar: " + YamlPose(body_from_lidar) + "\n");
    WriteText(c->out / "truth" / "mobile_lidar_true.scanner.yaml",
              "# The scanner of each point of mobile_lidar_true.ply: the pose at the point's time on the true\n"
              "# trajectory and the true mounting (paths relative to this file).\n"
              "trajectory: trajectory_true.csv\nlidar_mount: mobile_lidar_mount_true.yaml\n");
    c->result.mobile_points = scan.cloud.size();
    c->result.ghost_points += scan.num_ghosts;
    mobile = {{"file", "clouds/mobile_lidar.ply"}, {"true_file", "truth/mobile_lidar_true.ply"},
              {"body_from_lidar", PoseJson(body_from_lidar)}, {"body_from_lidar_nominal", PoseJson(body_from_lidar_nominal)},
              {"points", scan.cloud.size()},
              {"revolutions", o.mobile_revolutions}, {"ghosts", scan.num_ghosts}};
  }
  c->truth["lidar"] = {{"static_scans", scans}, {"mobile", mobile}};
  c->project_sensors << "  - id: tls\n    type: lidar_static\n    reference_cloud: clouds/lidar.ply\n    scans:\n";
  for (size_t k = 0; k < scans.size(); ++k) {
    c->project_sensors << "      - {file: " << scans[k]["file"].get<std::string>()
                       << ", world_from_scan: " << YamlPose(registrations[k]) << "}  # registration as delivered\n";
  }
  c->project_sensors << "    range_sigma_m: " << o.static_scan.noise.range_sigma_m << "\n"
                     << "    scan_sigma_m: 0.004  # the registrations' accuracy\n    scan_sigma_deg: 0.015\n";
  if (num_target_observations > 0) {
    fs::create_directories(c->out / "observations");
    WriteText(c->out / "observations" / "scan_targets.csv", targets_csv.str());
    c->project_sensors << "    targets: observations/scan_targets.csv  # " << num_target_observations
                       << " surveyed targets measured in the scans\n";
  }
  if (o.mobile_revolutions > 0) {
    c->project_sensors << "  - id: mls\n    type: lidar_mobile\n    cloud: clouds/mobile_lidar.ply\n"
                          "    trajectory: trajectory_ins.csv\n    calibration: calib/mobile_lidar.yaml\n"
                          "    range_sigma_m: " << o.mobile_scan.noise.range_sigma_m << "\n";
    if (c->truth.contains("rig") && !c->tie_points.empty()) {
      c->project_sensors << "    rig: ladybug  # on the same vehicle: camera-LiDAR extrinsic estimated\n";
    }
    WriteText(c->out / "calib" / "mobile_lidar.yaml",
              "# Mounting of the mobile LiDAR head on the vehicle (body: x forward, y left, z up).\n"
              "body_from_lidar: " + YamlPose(body_from_lidar_nominal) + "\nbeams: " + std::to_string(o.mobile_scan.beams) +
                  "\nelevation_deg: [" + Fmt(o.mobile_scan.elevation_min_deg, 2) + ", " +
                  Fmt(o.mobile_scan.elevation_max_deg, 2) + "]\nrotation_hz: " + Fmt(o.mobile_scan.rotation_hz, 2) + "\n");
  }
}

// ---- total station and GNSS.
void SimulateSurvey(Context* c, const Trajectory& trajectory) {
  const SimulateOptions& o = c->options;
  const SurveyNetwork network = SimulateTotalStation(c->caster, c->scene, c->plane, o.total_station, o.seed);
  WriteGamaLocalXml(network,
                    "mmba simulate: scene " + c->scene.name + ", seed " + std::to_string(o.seed) +
                        ". x = north, y = east, z = up of the local tangent plane at the project origin "
                        "(project.yaml); adj points carry approximate coordinates.",
                    (c->out / "survey" / "network.xml").string());
  c->result.ts_setups = network.setups.size();
  c->result.ts_observations = network.observations.size();
  json points = json::array();
  for (const SurveyPoint& p : network.points) {
    points.push_back({{"id", p.id}, {"kind", p.kind}, {"fixed", p.fixed}, {"point_in_world", VecJson(p.point_in_world)}});
  }
  json setups = json::array();
  for (const TotalStationSetup& s : network.setups) {
    setups.push_back({{"point", s.point_id}, {"instrument_height_m", s.instrument_height_m},
                      {"orientation_gon", s.orientation_gon}});
  }
  json observations = json::array();
  for (const TsObservation& ob : network.observations) {
    observations.push_back({{"from", ob.from}, {"to", ob.to},
                            {"kind", ob.kind == TsObservationKind::kDirection ? "direction"
                                     : ob.kind == TsObservationKind::kZenithAngle ? "z-angle" : "s-distance"},
                            {"value", ob.value}, {"true_value", ob.true_value}, {"sigma", ob.sigma},
                            {"target_height_m", ob.target_height_m}});
  }
  c->truth["survey"] = {{"points", points}, {"setups", setups}, {"observations", observations}};
  // GNSS: control marks (RTK) and the vehicle's GNSS/INS positions.
  internal::Rng rng(o.seed, 0x6755);
  std::ostringstream csv;
  csv << "# mmba simulate GNSS: WGS84 latitude/longitude (deg), ellipsoidal height (m), 1-sigma (m)\n";
  csv << "id,kind,time_s,latitude_deg,longitude_deg,height_m,sigma_east_m,sigma_north_m,sigma_up_m\n";
  csv << std::setprecision(10);
  size_t rows = 0;
  for (const SurveyPoint& p : network.points) {
    if (!p.fixed) continue;
    const Vector3d measured = p.point_in_world + Vector3d(rng.Normal(o.gnss.control_sigma_horizontal_m),
                                                          rng.Normal(o.gnss.control_sigma_horizontal_m),
                                                          rng.Normal(o.gnss.control_sigma_vertical_m));
    const geodesy::Geodetic g = c->plane.GeodeticFromEnu(measured);
    csv << p.id << ",control,," << g.latitude_deg << "," << g.longitude_deg << "," << g.height_m << ","
        << o.gnss.control_sigma_horizontal_m << "," << o.gnss.control_sigma_horizontal_m << ","
        << o.gnss.control_sigma_vertical_m << "\n";
    ++rows;
  }
  std::ostringstream ins, true_csv;
  ins << "# GNSS/INS trajectory of the vehicle body (x forward, y left, z up) in the world ENU frame\n"
         "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n" << std::setprecision(10);
  true_csv << ins.str();
  // Rows up to (at least) the end of the drive: every LiDAR point time lies within them.
  const int samples = static_cast<int>(std::ceil(trajectory.duration_s() * o.gnss.trajectory_rate_hz - 1e-9)) + 1;
  for (int i = 0; i < samples; ++i) {
    const double t = i / o.gnss.trajectory_rate_hz;
    const Rigid3d est = trajectory.WorldFromBodyIns(t);
    const Rigid3d tru = trajectory.WorldFromBodyTrue(t);
    const geodesy::Geodetic g = c->plane.GeodeticFromEnu(est.translation);
    csv << "T" << i << ",trajectory," << t << "," << g.latitude_deg << "," << g.longitude_deg << ","
        << g.height_m << ",0.05,0.05,0.08\n";
    ++rows;
    for (auto [stream, pose] : {std::pair<std::ostringstream*, Rigid3d>{&ins, est}, {&true_csv, tru}}) {
      *stream << t << "," << pose.translation.x() << "," << pose.translation.y() << "," << pose.translation.z()
              << "," << pose.rotation.w() << "," << pose.rotation.x() << "," << pose.rotation.y() << ","
              << pose.rotation.z() << "\n";
    }
  }
  WriteText(c->out / "gnss.csv", csv.str());
  WriteText(c->out / "trajectory_ins.csv", ins.str());
  WriteText(c->out / "truth" / "trajectory_true.csv", true_csv.str());
  c->result.gnss_rows = rows;
  c->project_sensors << "  - id: total_station\n    type: total_station\n    file: survey/network.xml\n"
                        "  - id: gnss\n    type: gnss\n    file: gnss.csv\n";
}

// ---- reconstruction-like clouds of the other modalities (documented error models).
Rigid3d RandomBlockTransform(internal::Rng* rng) {
  const Eigen::Quaterniond rotation =
      Eigen::AngleAxisd(rng->Uniform(0, 2 * M_PI), Vector3d::UnitZ()) *
      Eigen::AngleAxisd(rng->Uniform(-5, 5) * kDeg, Vector3d::UnitX()) *
      Eigen::AngleAxisd(rng->Uniform(-5, 5) * kDeg, Vector3d::UnitY());
  return Rigid3d(rotation, Vector3d(rng->Uniform(-10, 10), rng->Uniform(-10, 10), rng->Uniform(-2, 2)));
}

void WriteBlockCloud(Context* c, const std::string& name, const io::PointCloud& cloud_in_world,
                     const std::vector<Vector3d>& sensors_in_world, internal::Rng* rng) {
  const Rigid3d world_from_cloud = RandomBlockTransform(rng);
  const Rigid3d cloud_from_world = world_from_cloud.Inverse();
  io::PointCloud cloud = cloud_in_world;
  for (auto& p : cloud.points) p = cloud_from_world * p;
  io::WritePly(cloud, (c->out / "clouds" / (name + ".ply")).string());
  WriteViewpoints(c, name, cloud_from_world, sensors_in_world);
  c->registration_truth["world_from_" + name] = MatrixJson(world_from_cloud);
  // Partial crop: the western part of the object.
  const double x_cut = c->scene.object_min.x() +
                       c->options.clouds.part_fraction * (c->scene.object_max.x() - c->scene.object_min.x());
  io::PointCloud part;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (cloud_in_world.points[i].x() > x_cut) continue;
    part.points.push_back(cloud.points[i]);
    if (cloud.has_intensity()) part.intensity.push_back(cloud.intensity[i]);
  }
  io::WritePly(part, (c->out / "clouds" / (name + "_part.ply")).string());
  c->registration_truth["world_from_" + name + "_part"] = MatrixJson(world_from_cloud);
}

void SimulateClouds(Context* c, const std::vector<SphereStation>& stations,
                    const std::vector<Rigid3d>& photo_poses) {
  const CloudOptions& o = c->options.clouds;
  if (o.surface_samples == 0) return;
  const std::vector<SurfaceSample> samples = SampleObjectSurface(c->scene, o.surface_samples, c->options.seed, 0xC10D);
  internal::Rng rng(c->options.seed, 0xC10E);
  const TriangleMesh& mesh = c->scene.mesh;
  const auto albedo = [&](const SurfaceSample& s) {
    const Material& m = mesh.materials[mesh.triangle_material[s.triangle]];
    return static_cast<float>(Albedo(m, s.point, s.normal, c->options.seed));
  };
  const auto is_glass = [&](const SurfaceSample& s) {
    return mesh.materials[mesh.triangle_material[s.triangle]].material_class == MaterialClass::kGlass;
  };
  // (1) Spherical stereo: points seen by both spheres of a station; range error of a
  // vertical-baseline pair σ_r = r²·σ_d / (f·b·sin θ) (the depth error of stereo, Z²σ_d/(f b),
  // with the effective baseline b·sin θ perpendicular to the ray; θ from the vertical),
  // along the ray from the lower sphere. Rays within 12° of the vertical are dropped.
  const double f_sphere = o.stereo_width_px / (2 * M_PI);
  io::PointCloud stereo;
  for (const SurfaceSample& s : samples) {
    if (is_glass(s) || stations.empty()) continue;
    const SphereStation& st = stations[rng.Next() % stations.size()];
    const Vector3d lower = st.lower_from_world.Inverse().translation;
    const Vector3d upper = st.upper_from_world.Inverse().translation;
    if (!SeesPoint(c->caster, lower, s.point) || !SeesPoint(c->caster, upper, s.point)) continue;
    const Vector3d ray = s.point - lower;
    const double r = ray.norm();
    const double sin_theta = std::hypot(ray.x(), ray.y()) / r;
    if (sin_theta < std::sin(12 * kDeg)) continue;
    const double sigma = r * r * o.stereo_disparity_sigma_px / (f_sphere * c->options.spheres.baseline_m * sin_theta);
    stereo.points.push_back(s.point + rng.Normal(sigma) * ray / r);
    stereo.intensity.push_back(albedo(s));
  }
  // (2) Multi-view: points seen by ≥ 2 photos, a subset (coarser), isotropic noise growing
  // with the distance to the nearest camera (σ = multi_view_sigma_m · d / 10 m), holes
  // (spheres of 0.5–1.5 m removed: textureless or occluded parts), and uniform outliers.
  io::PointCloud multi_view;
  std::vector<Vector3d> holes;
  std::vector<double> hole_radii;
  for (int k = 0; k < o.multi_view_holes && !samples.empty(); ++k) {
    holes.push_back(samples[rng.Next() % samples.size()].point);
    hole_radii.push_back(rng.Uniform(0.5, 1.5));
  }
  for (const SurfaceSample& s : samples) {
    if (is_glass(s) || rng.Uniform() > o.multi_view_keep) continue;
    bool in_hole = false;
    for (size_t k = 0; k < holes.size(); ++k) in_hole |= (s.point - holes[k]).norm() < hole_radii[k];
    if (in_hole) continue;
    int seen = 0;
    double nearest = 1e9;
    for (const Rigid3d& pose : photo_poses) {
      const Vector3d eye = pose.Inverse().translation;
      const Vector3d p_cam = pose * s.point;
      if (p_cam.z() <= 0) continue;
      if (!SeesPoint(c->caster, eye, s.point)) continue;
      nearest = std::min(nearest, (eye - s.point).norm());
      if (++seen >= 2) break;
    }
    if (seen < 2) continue;
    const double sigma = o.multi_view_sigma_m * nearest / 10.0;
    multi_view.points.push_back(s.point + Vector3d(rng.Normal(sigma), rng.Normal(sigma), rng.Normal(sigma)));
    multi_view.intensity.push_back(albedo(s));
  }
  const size_t outliers = static_cast<size_t>(o.multi_view_outliers * multi_view.size());
  for (size_t k = 0; k < outliers; ++k) {
    multi_view.points.push_back(Vector3d(rng.Uniform(c->scene.object_min.x(), c->scene.object_max.x()),
                                         rng.Uniform(c->scene.object_min.y() - 2, c->scene.object_max.y()),
                                         rng.Uniform(c->scene.object_min.z(), c->scene.object_max.z())));
    multi_view.intensity.push_back(static_cast<float>(rng.Uniform()));
  }
  // (3) Plane proxy: surface samples binned by dominant normal axis and coordinate
  // (plane_bin_m); bins holding ≥ 0.5 % of the samples become an axis-aligned plane at the
  // bins' mean coordinate; points are projected onto it and thinned to one per voxel.
  io::PointCloud proxy;
  {
    std::map<std::pair<int, long>, std::vector<size_t>> bins;
    for (size_t i = 0; i < samples.size(); ++i) {
      if (is_glass(samples[i])) continue;
      int axis;
      samples[i].normal.cwiseAbs().maxCoeff(&axis);
      bins[{axis, std::lround(samples[i].point[axis] / o.plane_bin_m)}].push_back(i);
    }
    std::map<std::tuple<long, long, long>, bool> voxels;
    for (const auto& [key, members] : bins) {
      if (members.size() < 0.005 * samples.size()) continue;
      double mean = 0;
      for (size_t i : members) mean += samples[i].point[key.first];
      mean /= members.size();
      for (size_t i : members) {
        Vector3d p = samples[i].point;
        p[key.first] = mean;
        const auto voxel = std::make_tuple(std::lround(p.x() / o.plane_voxel_m), std::lround(p.y() / o.plane_voxel_m),
                                           std::lround(p.z() / o.plane_voxel_m));
        if (voxels.count(voxel)) continue;
        voxels[voxel] = true;
        proxy.points.push_back(p);
        proxy.intensity.push_back(albedo(samples[i]));
      }
    }
  }
  std::vector<Vector3d> stereo_stations, camera_centres;
  for (const SphereStation& st : stations) stereo_stations.push_back(st.lower_from_world.Inverse().translation);
  for (const Rigid3d& pose : photo_poses) camera_centres.push_back(pose.Inverse().translation);
  WriteBlockCloud(c, "spherical_stereo", stereo, stereo_stations, &rng);
  WriteBlockCloud(c, "multi_view", multi_view, camera_centres, &rng);
  WriteBlockCloud(c, "plane_proxy", proxy, {}, &rng);
  c->truth["clouds"] = {
      {"spherical_stereo", {{"points", stereo.size()}, {"model", "sigma_r = r^2 sigma_d / (f b sin(theta)) along the ray from the lower sphere"},
                            {"disparity_sigma_px", o.stereo_disparity_sigma_px},
                            {"stereo_width_px", o.stereo_width_px}, {"baseline_m", c->options.spheres.baseline_m}}},
      {"multi_view", {{"points", multi_view.size()}, {"model", "kept fraction, holes, isotropic sigma = multi_view_sigma_m * d / 10 m, uniform outliers"},
                      {"multi_view_sigma_m", o.multi_view_sigma_m}, {"holes", o.multi_view_holes},
                      {"outlier_fraction", o.multi_view_outliers}}},
      {"plane_proxy", {{"points", proxy.size()}, {"model", "axis-aligned planes fitted to binned surface samples, voxel-thinned"},
                       {"bin_m", o.plane_bin_m}, {"voxel_m", o.plane_voxel_m}}}};
}

std::string ProjectYaml(const Context& c) {
  const SimulateOptions& o = c.options;
  std::ostringstream y;
  y << "# mmba project file (schema: docs/project-yaml.md). Paths are relative to this file.\n"
       "mmba_project: 1\n"
       "name: " << c.scene.name << "\n"
       "simulated: {seed: " << o.seed << ", preset: " << o.preset << ", truth: truth/truth.json}\n"
       "origin: {latitude_deg: " << std::setprecision(12) << o.origin.latitude_deg
    << ", longitude_deg: " << o.origin.longitude_deg << ", height_m: " << o.origin.height_m
    << "}  # world = local ENU tangent plane here\n";
  // Every third target the total station measures (a slope distance: its coordinates are
  // determined) is withheld from the joint adjustment as a check point.
  std::set<std::string> measured;
  if (c.truth.contains("survey")) {
    for (const auto& obs : c.truth["survey"]["observations"]) {
      if (obs["kind"] == "s-distance") measured.insert(obs["to"].get<std::string>());
    }
  }
  std::vector<std::string> checks;
  size_t seen = 0;
  for (const auto& target : c.scene.targets) {
    if (measured.count(target.id) && ++seen % 3 == 0) checks.push_back(target.id);
  }
  if (o.total_station.setups > 0 && !checks.empty()) {
    y << "check_points: [";
    for (size_t i = 0; i < checks.size(); ++i) y << (i ? ", " : "") << checks[i];
    y << "]  # surveyed targets withheld from the adjustment\n";
  }
  y << "sensors:\n" << c.project_sensors.str();
  return y.str();
}

// truth/cameras/<images subfolder>/<image stem>.yaml: the true camera and pose of each panorama,
// rig camera and photo in register-mi's camera YAML (calib/README.md), cam_from_lidar being the pose
// against the world frame of truth/mobile_lidar_true.ply and clouds/lidar.ply — so that
// `mmba register-mi --lidar truth/mobile_lidar_true.ply --image IMAGE --camera YAML --perturb …`
// starts from the truth moved by the given correction and reports the pixel offsets to it.
void WriteTrueCameraYamls(const Context& c) {
  // A pose of truth.json (PoseJson) as its 4×4 matrix.
  const auto matrix = [](const json& pose) {
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) m(i / 4, i % 4) = pose.at("matrix").at(i / 4).at(i % 4).get<double>();
    return m;
  };
  const auto write = [&](const std::string& image, const json& camera, const Eigen::Matrix4d& cam_from_world) {
    const fs::path rel(image);  // images/<kind>/<file>
    const fs::path yaml = c.out / "truth" / "cameras" / rel.parent_path().filename() / (rel.stem().string() + ".yaml");
    fs::create_directories(yaml.parent_path());
    std::ostringstream text;
    text << std::setprecision(17) << "# The true camera and pose of " << image
         << " against the world frame (truth/mobile_lidar_true.ply,\n"
            "# clouds/lidar.ply): mmba register-mi --camera (calib/README.md).\n"
         << "model: " << camera.at("model").get<std::string>() << "\nwidth: " << camera.at("width").get<int>()
         << "\nheight: " << camera.at("height").get<int>() << "\nparams: [";
    const auto params = camera.at("params").get<std::vector<double>>();
    for (size_t i = 0; i < params.size(); ++i) text << (i ? ", " : "") << params[i];
    text << "]\ncam_from_lidar: [";
    for (int i = 0; i < 16; ++i) text << (i ? ", " : "") << cam_from_world(i / 4, i % 4);
    text << "]\n";
    WriteText(yaml, text.str());
  };
  if (c.truth.contains("spherical_stereo")) {
    const json& s = c.truth.at("spherical_stereo");
    for (const json& station : s.at("stations")) {
      const auto images = station.at("images").get<std::vector<std::string>>();
      write(images.at(0), s.at("lower_camera"), matrix(station.at("lower_from_world")));
      write(images.at(1), s.at("upper_camera"), matrix(station.at("upper_from_world")));
    }
  }
  if (c.truth.contains("rig")) {
    const json& rig = c.truth.at("rig");
    for (const json& frame : rig.at("frames")) {
      const std::string name = frame.at("name").get<std::string>();
      const Eigen::Matrix4d rig_from_world = matrix(frame.at("rig_from_world"));
      if (rig.contains("panorama_camera")) {
        write("images/rig_panoramas/" + name + ".png", rig.at("panorama_camera"), rig_from_world);
      }
      // Each rig camera's image alone (a fisheye): cam_from_world = cam_from_rig · rig_from_world.
      const json& cameras = rig.at("cameras");
      for (size_t k = 0; k < cameras.size(); ++k) {
        write("images/rig/" + name + "_cam" + std::to_string(k) + ".png", cameras[k].at("camera"),
              matrix(cameras[k].at("cam_from_rig")) * rig_from_world);
      }
    }
  }
  if (c.truth.contains("photos")) {
    const json& photos = c.truth.at("photos");
    for (const json& photo : photos.at("images")) {
      write("images/photos/" + photo.at("name").get<std::string>(), photos.at("camera"),
            matrix(photo.at("cam_from_world")));
    }
  }
}

}  // namespace

SimulateResult Simulate(const SimulateOptions& options, const std::string& out_dir) {
  std::string error;
  if (!options.Check(&error)) throw InputError::Message("mmba simulate", error);
  Timer timer;
  const SimScene scene = BuildScene(options);
  scene.mesh.Validate(options.mesh_path.empty() ? "scene " + options.scene : options.mesh_path);
  RayCaster caster(scene.mesh);
  const geodesy::LocalTangentPlane plane(options.origin);
  fs::create_directories(out_dir);
  Context c{options, scene, caster, plane, fs::path(out_dir), FrameObject(scene), json::object(),
            json::object(), {}, {}, {}};
  c.result.out_dir = out_dir;
  c.result.triangles = scene.mesh.NumTriangles();
  spdlog::info("simulate: scene {} ({} triangles), seed {}, preset {}", scene.name,
               scene.mesh.NumTriangles(), options.seed, options.preset);
  // The vehicle drives past the front of the object (mobile LiDAR, rig, GNSS/INS).
  const double half = options.mobile_drive_m > 0 ? 0.5 * options.mobile_drive_m : 0.5 * c.framing.width + 4.0;
  const double lane_y = c.framing.front_y - std::max(4.0, 0.4 * c.framing.width);
  const Trajectory trajectory(c.framing.centre.x() - half, c.framing.centre.x() + half, lane_y,
                              options.mobile_speed_mps, options.gnss.ins_position_error_m,
                              options.gnss.ins_attitude_error_deg, options.seed);
  const Rigid3d body_from_lidar(Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * kDeg, Vector3d::UnitZ())),
                                Vector3d(0.4, 0.0, 1.9));

  SimulatePhotos(&c);
  std::vector<Rigid3d> photo_poses;
  if (c.truth.contains("photos")) {
    for (const auto& image : c.truth["photos"]["images"]) {
      const auto& q = image["cam_from_world"]["qvec_wxyz"];
      const auto& t = image["cam_from_world"]["tvec"];
      photo_poses.push_back(Rigid3d(Eigen::Quaterniond(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>()),
                                    Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>())));
    }
  }
  spdlog::info("simulate: photos done ({:.1f} s)", timer.ElapsedSeconds());
  const std::vector<SphereStation> stations = SphereStations(&c);
  SimulateSpheres(&c, stations);
  spdlog::info("simulate: spherical stereo done ({:.1f} s)", timer.ElapsedSeconds());
  SimulateRig(&c, trajectory);
  spdlog::info("simulate: rig done ({:.1f} s)", timer.ElapsedSeconds());
  SimulateLidar(&c, trajectory, body_from_lidar);
  spdlog::info("simulate: LiDAR done ({:.1f} s)", timer.ElapsedSeconds());
  SimulateSurvey(&c, trajectory);
  SimulateClouds(&c, stations, photo_poses);
  spdlog::info("simulate: clouds done ({:.1f} s)", timer.ElapsedSeconds());

  // Truth and the project file.
  WriteObj(scene.mesh, (c.out / "truth" / "mesh.obj").string());
  json materials = json::array();
  for (const Material& m : scene.mesh.materials) {
    materials.push_back({{"name", m.name}, {"class", MaterialClassName(m.material_class)}});
  }
  c.truth["schema"] = "mmba-sim-truth-1";
  c.truth["scene"] = {{"name", scene.name}, {"seed", options.seed}, {"preset", options.preset},
                      {"mesh", "truth/mesh.obj"}, {"materials", materials},
                      {"object_min", VecJson(scene.object_min)}, {"object_max", VecJson(scene.object_max)}};
  c.truth["frames"] = "world = ENU tangent plane at origin (metres); cameras x right, y down, z forward; "
                      "poses target_from_source; qvec w, x, y, z";
  c.truth["origin"] = {{"latitude_deg", options.origin.latitude_deg}, {"longitude_deg", options.origin.longitude_deg},
                       {"height_m", options.origin.height_m}};
  c.truth["trajectory"] = {{"true", "truth/trajectory_true.csv"}, {"ins", "trajectory_ins.csv"},
                           {"duration_s", trajectory.duration_s()}};
  c.truth["registration"] = c.registration_truth;
  WriteTrueCameraYamls(c);
  RecordBuild(&c.truth);
  RecordBuild(&c.registration_truth);
  WriteText(c.out / "truth" / "truth.json", c.truth.dump(1) + "\n");
  WriteText(c.out / "ground_truth.json", c.registration_truth.dump(1) + "\n");
  WriteText(c.out / "project.yaml", ProjectYaml(c));
  c.result.seconds = timer.ElapsedSeconds();
  return c.result;
}

}  // namespace mmba::sim
