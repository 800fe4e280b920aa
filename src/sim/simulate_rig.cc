// The Ladybug-style camera rig of mmba::sim::Simulate: 5 cameras around + 1 up,
// OPENCV_FISHEYE, on the vehicle; per frame its six images, a stitched panorama and the
// tie-point observations; the rig's factory calibration.

#include <cmath>
#include <iomanip>
#include <sstream>

#include "mmba/sim/render.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// The rig on the vehicle. Rig frame: x right, y down, z forward (= vehicle forward); body:
// x forward, y left, z up.
Rigid3d BodyFromRig() {
  Eigen::Matrix3d body_from_rig_rotation;
  body_from_rig_rotation << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return Rigid3d(Eigen::Quaterniond(body_from_rig_rotation), Vector3d(0.2, 0, 2.3));
}

// The six true cameras (intrinsics within 1 % / 2 px of the design) and their cam_from_rig:
// cameras 0–4 yawed by 72° steps about the rig's down axis, 6 cm out; camera 5 looks up (−y).
std::vector<sensors::Camera> RigCameras(const Context& c, std::vector<Rigid3d>* cam_from_rig) {
  const RigOptions& o = c.options.rig;
  std::vector<sensors::Camera> cameras;
  Rng rng(c.options.seed, 0x1ADB);
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
    cam_from_rig->push_back(Rigid3d(Eigen::Quaterniond(rig_from_cam), centre).Inverse());
  }
  return cameras;
}

// The equirectangular camera of the stitched panoramas.
sensors::Camera PanoramaCamera(const RigOptions& o) {
  sensors::Camera pano;
  pano.model_id = sensors::CameraModelId::kEquirectangular;
  pano.width = o.panorama_width;
  pano.height = o.panorama_width / 2;
  const auto pano_params = sensors::EquirectangularModel::DefaultParams(pano.width, pano.height);
  pano.params.assign(pano_params.begin(), pano_params.end());
  return pano;
}

// The rig's cameras and poses, the frame's inputs to rendering and observing.
struct RigModel {
  std::vector<sensors::Camera> cameras;
  std::vector<Rigid3d> cam_from_rig;
  std::vector<RayTable> rays;
  sensors::Camera pano;
};

// Renders the six images of one frame into images/rig and their panorama into
// images/rig_panoramas.
void RenderRigFrame(Context* c, const RigModel& rig, const std::string& frame_name, int f,
                    const Rigid3d& rig_from_world) {
  std::vector<GrayImage> images;
  for (int k = 0; k < 6; ++k) {
    images.push_back(RenderImage(c->caster, c->scene, rig.cameras[k], rig.cam_from_rig[k] * rig_from_world,
                                 c->options.render, c->options.seed, 3000 + 6 * f + k, c->options.threads,
                                 &rig.rays[k]));
    WritePng(images.back(), (c->out / "images" / "rig" / (frame_name + "_cam" + std::to_string(k) + ".png")).string());
    ++c->result.rig_images;
  }
  const GrayImage panorama = StitchPanorama(images, rig.cameras, rig.cam_from_rig, rig.pano,
                                            c->options.rig.stitch_distance_m, c->options.threads);
  WritePng(panorama, (c->out / "images" / "rig_panoramas" / (frame_name + ".png")).string());
  ++c->result.panoramas;
}

// Tie-point observations of one frame's images (true projection + N(0, 0.5 px)) appended to
// `csv`; returns their number.
size_t ObserveRigFrame(const Context& c, const RigModel& rig, const std::string& frame_name,
                       const Rigid3d& rig_from_world, Rng* noise, std::ostringstream* csv) {
  size_t count = 0;
  for (int k = 0; k < 6; ++k) {
    const int width = rig.cameras[k].width, height = rig.cameras[k].height;
    const Rigid3d cam_from_world = rig.cam_from_rig[k] * rig_from_world;
    const Vector3d eye = cam_from_world.Inverse().translation;
    for (const auto& [id, point] : c.tie_points) {
      const auto xy = rig.cameras[k].ImgFromCam(cam_from_world * point);
      if (!xy || !InsideImage(*xy, width, height)) continue;
      if (!SeesPoint(c.caster, eye, point)) continue;
      const Vector2d measured = *xy + Vector2d(noise->Normal(0.5), noise->Normal(0.5));
      if (!InsideImage(measured, width, height)) continue;
      *csv << frame_name << "_cam" << k << ".png," << id << "," << Fmt(measured.x(), 3) << ","
           << Fmt(measured.y(), 3) << ",0.5\n";
      ++count;
    }
  }
  return count;
}

// Renders and observes every frame (times spread over the middle 80 % of the drive); writes
// observations/rig.csv and rig_frames.csv when there are tie points. Returns the frames' truth
// and the number of observations.
std::pair<json, size_t> SimulateRigFrames(Context* c, const Trajectory& trajectory, const Rigid3d& body_from_rig,
                                          const RigModel& rig) {
  const RigOptions& o = c->options.rig;
  json frames = json::array();
  Rng observation_noise(c->options.seed, 0x1AD0);
  std::ostringstream rig_observations, rig_frames;
  rig_observations << "# mmba simulate: tie-point observations in the rig images (point ids of colmap/photos)\n"
                      "image,point_id,x_px,y_px,sigma_px\n";
  rig_frames << "# mmba simulate: rig frames and their times (s) on the GNSS/INS trajectory\nframe,time_s\n";
  size_t num_rig_observations = 0;
  for (int f = 0; f < o.frames; ++f) {
    const double time = trajectory.duration_s() * (o.frames == 1 ? 0.5 : (0.1 + 0.8 * f / (o.frames - 1)));
    const Rigid3d world_from_rig = trajectory.WorldFromBodyTrue(time) * body_from_rig;
    const Rigid3d rig_from_world = world_from_rig.Inverse();
    std::ostringstream frame_name;
    frame_name << "frame_" << std::setw(3) << std::setfill('0') << f;
    RenderRigFrame(c, rig, frame_name.str(), f, rig_from_world);
    frames.push_back({{"name", frame_name.str()}, {"time_s", time}, {"rig_from_world", PoseJson(rig_from_world)}});
    num_rig_observations += ObserveRigFrame(*c, rig, frame_name.str(), rig_from_world, &observation_noise,
                                            &rig_observations);
    rig_frames << frame_name.str() << "," << Fmt(time, 3) << "\n";
  }
  if (!c->tie_points.empty()) {
    WriteText(c->out / "observations" / "rig.csv", rig_observations.str());
    WriteText(c->out / "rig_frames.csv", rig_frames.str());
  }
  return {frames, num_rig_observations};
}

// calib/ladybug.yaml: design intrinsics and the factory calibration of cam_from_rig, good to
// ~0.02° and 1 mm (σ per axis), the σ the project states. Returns the cameras' truth.
json WriteRigCalibration(const Context& c, const Rigid3d& body_from_rig, const RigModel& rig) {
  const RigOptions& o = c.options.rig;
  const int width = rig.cameras[0].width, height = rig.cameras[0].height;
  json jcams = json::array();
  std::ostringstream yaml;
  yaml << "# Nominal calibration of the Ladybug-style rig: 6 OPENCV_FISHEYE cameras\n"
          "# (fx, fy, cx, cy, k1, k2, k3, k4) and cam_from_rig; rig frame x right, y down, z forward\n"
          "# (vehicle forward). Intrinsics: design values; cam_from_rig: a factory calibration\n"
          "# (0.02°, 1 mm per axis); truth/truth.json holds the true ones.\n"
          "body_from_rig: " << YamlPose(body_from_rig) << "\ncameras:\n";
  Rng calibration_error(c.options.seed, 0x1ADC);
  for (int k = 0; k < 6; ++k) {
    jcams.push_back({{"camera", CameraJson(rig.cameras[k])}, {"cam_from_rig", PoseJson(rig.cam_from_rig[k])}});
    const Vector3d rotation_error(calibration_error.Normal(0.02 * kDeg), calibration_error.Normal(0.02 * kDeg),
                                  calibration_error.Normal(0.02 * kDeg));
    const Vector3d position_error(calibration_error.Normal(0.001), calibration_error.Normal(0.001),
                                  calibration_error.Normal(0.001));
    const Rigid3d nominal(Eigen::Quaterniond(Eigen::AngleAxisd(rotation_error.norm(), rotation_error.normalized())) *
                              rig.cam_from_rig[k].rotation,
                          rig.cam_from_rig[k].translation + position_error);
    yaml << "  - name: cam" << k << "\n    model: OPENCV_FISHEYE\n    width: " << width << "\n    height: " << height
         << "\n    params: " << YamlList({o.focal_px, o.focal_px, 0.5 * width, 0.5 * height, 0.02, -0.005, 0.001, 0.0})
         << "\n    cam_from_rig: " << YamlPose(nominal) << "\n";
  }
  WriteText(c.out / "calib" / "ladybug.yaml", yaml.str());
  return jcams;
}

}  // namespace

void SimulateRig(Context* c, const Trajectory& trajectory) {
  const RigOptions& o = c->options.rig;
  if (o.frames == 0) return;
  const Rigid3d body_from_rig = BodyFromRig();
  RigModel rig;
  rig.cameras = RigCameras(*c, &rig.cam_from_rig);
  rig.pano = PanoramaCamera(o);
  for (const auto& camera : rig.cameras) {
    rig.rays.push_back(MakeRayTable(camera, c->options.render.samples_per_axis, c->options.threads));
  }
  const auto [frames, num_rig_observations] = SimulateRigFrames(c, trajectory, body_from_rig, rig);
  const json jcams = WriteRigCalibration(*c, body_from_rig, rig);
  c->truth["rig"] = {{"cameras", jcams}, {"body_from_rig", PoseJson(body_from_rig)},
                     {"panorama_camera", CameraJson(rig.pano)}, {"stitch_distance_m", o.stitch_distance_m},
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

}  // namespace mmba::sim::internal
