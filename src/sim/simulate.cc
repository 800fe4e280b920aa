// mmba::sim::Simulate: builds the scene, runs the stages (simulate_*.cc) in a fixed order and
// writes the truth and the project file.

#include "mmba/sim/simulate.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/core/version.h"
#include "sim/simulate_internal.h"

namespace mmba::sim {
namespace {

using Eigen::Vector3d;
using internal::Context;
using internal::Framing;
using internal::VecJson;
using internal::WriteText;
using internal::kDeg;
using json = nlohmann::json;
namespace fs = std::filesystem;

SimScene BuildScene(const SimulateOptions& options) {
  if (options.scene == "gate") return MakeGateScene(options.gate, options.seed);
  if (options.scene == "cathedral") return MakeCathedralScene(options.cathedral, options.seed);
  Material material;
  material.name = "mesh_default";
  material.pattern = TexturePattern::kStone;
  TriangleMesh mesh = LoadMesh(options.mesh_path, material);
  return SceneFromMesh(std::move(mesh), fs::path(options.mesh_path).stem().string(), options.seed);
}

Framing FrameObject(const SimScene& scene) {
  Framing f;
  f.width = scene.object_max.x() - scene.object_min.x();
  f.height = scene.object_max.z() - scene.object_min.z();
  f.front_y = scene.object_min.y();
  f.centre = Vector3d(0.5 * (scene.object_min.x() + scene.object_max.x()), std::max(0.0, f.front_y),
                      scene.object_min.z() + 0.45 * f.height);
  return f;
}

// The photos' cam_from_world as the photo stage recorded them in the truth.
std::vector<Rigid3d> PhotoPoses(const json& truth) {
  std::vector<Rigid3d> photo_poses;
  if (truth.contains("photos")) {
    for (const auto& image : truth["photos"]["images"]) {
      const auto& q = image["cam_from_world"]["qvec_wxyz"];
      const auto& t = image["cam_from_world"]["tvec"];
      photo_poses.push_back(Rigid3d(Eigen::Quaterniond(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>()),
                                    Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>())));
    }
  }
  return photo_poses;
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

  internal::SimulatePhotos(&c);
  const std::vector<Rigid3d> photo_poses = PhotoPoses(c.truth);
  spdlog::info("simulate: photos done ({:.1f} s)", timer.ElapsedSeconds());
  const std::vector<internal::SphereStation> stations = internal::SphereStations(&c);
  internal::SimulateSpheres(&c, stations);
  spdlog::info("simulate: spherical stereo done ({:.1f} s)", timer.ElapsedSeconds());
  internal::SimulateRig(&c, trajectory);
  spdlog::info("simulate: rig done ({:.1f} s)", timer.ElapsedSeconds());
  internal::SimulateLidar(&c, trajectory, body_from_lidar);
  spdlog::info("simulate: LiDAR done ({:.1f} s)", timer.ElapsedSeconds());
  internal::SimulateSurvey(&c, trajectory);
  internal::SimulateClouds(&c, stations, photo_poses);
  spdlog::info("simulate: clouds done ({:.1f} s)", timer.ElapsedSeconds());

  // Truth and the project file.
  internal::RecordSceneTruth(&c, trajectory);
  internal::WriteTrueCameraYamls(c);
  RecordBuild(&c.truth);
  RecordBuild(&c.registration_truth);
  WriteText(c.out / "truth" / "truth.json", c.truth.dump(1) + "\n");
  WriteText(c.out / "ground_truth.json", c.registration_truth.dump(1) + "\n");
  WriteText(c.out / "project.yaml", internal::ProjectYaml(c));
  c.result.seconds = timer.ElapsedSeconds();
  return c.result;
}

}  // namespace mmba::sim
