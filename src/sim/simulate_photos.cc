// The photo collection of mmba::sim::Simulate: an OPENCV camera on two rings in front of the
// object, its images, the true COLMAP model (tie points seen by ≥ 2 photos), the perturbed
// model a user would start from, image measurements of the surveyed targets and the nominal
// calibration.

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "mmba/core/progress.h"
#include "mmba/io/colmap_model.h"
#include "mmba/sim/render.h"
#include "mmba/sim/texture.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {
namespace {

using Eigen::Vector3d;

// The true camera: fy = 1.002·fx, principal point off centre, the options' distortion.
sensors::Camera PhotoCamera(const PhotoOptions& o) {
  sensors::Camera camera;
  camera.camera_id = CameraId(1);
  camera.model_id = sensors::CameraModelId::kOpenCV;
  camera.width = o.width;
  camera.height = o.height;
  camera.params = {o.focal_px, 1.002 * o.focal_px, 0.5 * o.width + 3.1, 0.5 * o.height - 2.3,
                   o.k1, o.k2, o.p1, o.p2};
  return camera;
}

// Renders the photos (poses on two rings around the front, the object filling ~3/4 of the
// view) into images/photos and adds them to `truth_model`; returns their cam_from_world.
std::vector<Rigid3d> RenderPhotos(Context* c, const sensors::Camera& camera, io::ColmapModel* truth_model) {
  const PhotoOptions& o = c->options.photos;
  const double fov_h = 2.0 * std::atan(0.5 * o.width / o.focal_px);
  const double extent = std::max(c->framing.width, c->framing.height * o.width / o.height);
  const double distance = 0.75 * extent / (2.0 * std::tan(0.5 * fov_h)) + 2.0;
  Rng rng(c->options.seed, 0xF0705);
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
    truth_model->images[colmap_image.image_id] = colmap_image;
    progress.Step();
  }
  progress.Done();
  return poses;
}

// Tie points: surface samples (not on glass: no stable features there) seen — first surface,
// inside the image — by ≥ 2 photos, up to photos.tie_points, with their exact projections.
void AddTiePoints(const Context& c, const sensors::Camera& camera, const std::vector<Rigid3d>& poses,
                  io::ColmapModel* truth_model) {
  const PhotoOptions& o = c.options.photos;
  const std::vector<SurfaceSample> samples =
      SampleObjectSurface(c.scene, 4 * o.tie_points, c.options.seed, 0x71E);
  uint64_t next_id = 1;
  for (const SurfaceSample& s : samples) {
    if (static_cast<int>(truth_model->points3D.size()) >= o.tie_points) break;
    const Material& m = c.scene.mesh.materials[c.scene.mesh.triangle_material[s.triangle]];
    if (m.material_class == MaterialClass::kGlass) continue;
    std::vector<std::pair<int, Eigen::Vector2d>> seen;
    for (int i = 0; i < o.count; ++i) {
      const Vector3d p_cam = poses[i] * s.point;
      const auto xy = camera.ImgFromCam(p_cam);
      if (!xy || !InsideImage(*xy, o.width, o.height)) continue;
      if (!SeesPoint(c.caster, poses[i].Inverse().translation, s.point)) continue;
      seen.emplace_back(i, *xy);
    }
    if (seen.size() < 2) continue;
    io::ColmapPoint3D point;
    point.point3D_id = Point3DId(next_id++);
    point.xyz = s.point;
    const uint8_t grey = static_cast<uint8_t>(255 * Albedo(m, s.point, s.normal, c.options.seed));
    point.color = {grey, grey, grey};
    point.error = 0.0;
    for (const auto& [i, xy] : seen) {
      io::ColmapImage& image = truth_model->images.at(ImageId(i + 1));
      point.track.push_back({image.image_id, static_cast<uint32_t>(image.points2D.size())});
      image.points2D.push_back(xy);
      image.point3D_ids.push_back(point.point3D_id);
    }
    truth_model->points3D[point.point3D_id] = point;
  }
}

// The perturbed model: the nominal calibration `nominal`, poses moved by N(0, pose σ), points
// by N(0, point σ), observations with N(0, observation σ) noise.
io::ColmapModel PerturbedModel(const Context& c, const io::ColmapModel& truth_model,
                               const sensors::Camera& nominal) {
  const PhotoOptions& o = c.options.photos;
  io::ColmapModel perturbed = truth_model;
  perturbed.cameras[nominal.camera_id] = nominal;
  Rng noise(c.options.seed, 0xBAD);
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
  return perturbed;
}

// Image measurements of the surveyed targets (the photogrammetrist's control/check point
// measurements) into survey/image_points.csv: every target inside a photo and in its line of
// sight, true projection + N(0, σ) per axis from a stream of its own (the other outputs do not
// change with it). Returns the number of measurements.
int WriteTargetMeasurements(const Context& c, const sensors::Camera& camera, const std::vector<Rigid3d>& poses,
                            const io::ColmapModel& truth_model) {
  const PhotoOptions& o = c.options.photos;
  Rng target_noise(c.options.seed, 0x7A6E7);
  std::ostringstream target_csv;
  target_csv << "# mmba simulate: image measurements of the surveyed targets (survey/network.xml ids)\n"
                "point_id,image,x_px,y_px,sigma_px\n";
  int target_measurements = 0;
  for (const ScenePoint& target : c.scene.targets) {
    for (int i = 0; i < o.count; ++i) {
      const auto xy = camera.ImgFromCam(poses[i] * target.point_in_world);
      if (!xy || !InsideImage(*xy, o.width, o.height)) continue;
      if (!SeesPoint(c.caster, poses[i].Inverse().translation, target.point_in_world)) continue;
      const Eigen::Vector2d measured = *xy + Eigen::Vector2d(target_noise.Normal(o.observation_sigma_px),
                                                             target_noise.Normal(o.observation_sigma_px));
      if (!InsideImage(measured, o.width, o.height)) continue;
      target_csv << target.id << "," << truth_model.images.at(ImageId(i + 1)).name << "," << Fmt(measured.x(), 3)
                 << "," << Fmt(measured.y(), 3) << "," << o.observation_sigma_px << "\n";
      ++target_measurements;
    }
  }
  WriteText(c.out / "survey" / "image_points.csv", target_csv.str());
  return target_measurements;
}

// The nominal calibration file, the truth entry and the project's photo sensor.
void RecordPhotos(Context* c, const sensors::Camera& camera, const sensors::Camera& nominal,
                  const io::ColmapModel& truth_model, int target_measurements) {
  const PhotoOptions& o = c->options.photos;
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

}  // namespace

void SimulatePhotos(Context* c) {
  const PhotoOptions& o = c->options.photos;
  if (o.count == 0) return;
  const sensors::Camera camera = PhotoCamera(o);
  io::ColmapModel truth_model;
  truth_model.cameras[camera.camera_id] = camera;
  const std::vector<Rigid3d> poses = RenderPhotos(c, camera, &truth_model);
  AddTiePoints(*c, camera, poses, &truth_model);
  c->result.photos = o.count;
  for (const auto& [id, point] : truth_model.points3D) c->tie_points.emplace_back(id.value, point.xyz);
  c->result.tie_points = truth_model.points3D.size();
  c->result.tie_observations = truth_model.NumObservations();
  // Nominal calibration: focal off by nominal_focal_error, centred principal point, no distortion.
  sensors::Camera nominal = camera;
  nominal.params = {o.focal_px * (1 + o.nominal_focal_error), o.focal_px * (1 + o.nominal_focal_error),
                    0.5 * o.width, 0.5 * o.height, 0, 0, 0, 0};
  const io::ColmapModel perturbed = PerturbedModel(*c, truth_model, nominal);
  const int target_measurements = WriteTargetMeasurements(*c, camera, poses, truth_model);
  io::WriteColmapModel(truth_model, (c->out / "truth" / "colmap_photos").string(), io::ColmapFormat::kText);
  io::WriteColmapModel(perturbed, (c->out / "colmap" / "photos").string(), io::ColmapFormat::kText);
  RecordPhotos(c, camera, nominal, truth_model, target_measurements);
}

}  // namespace mmba::sim::internal
