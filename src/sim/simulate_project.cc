// The files of mmba::sim::Simulate that describe the whole run: the scene's truth entries,
// project.yaml, and a register-mi camera YAML with the true pose of every simulated image.

#include <iomanip>
#include <set>
#include <sstream>

#include "sim/simulate_internal.h"

namespace mmba::sim::internal {

void RecordSceneTruth(Context* c, const Trajectory& trajectory) {
  WriteObj(c->scene.mesh, (c->out / "truth" / "mesh.obj").string());
  json materials = json::array();
  for (const Material& m : c->scene.mesh.materials) {
    materials.push_back({{"name", m.name}, {"class", MaterialClassName(m.material_class)}});
  }
  c->truth["schema"] = "mmba-sim-truth-1";
  c->truth["scene"] = {{"name", c->scene.name}, {"seed", c->options.seed}, {"preset", c->options.preset},
                       {"mesh", "truth/mesh.obj"}, {"materials", materials},
                       {"object_min", VecJson(c->scene.object_min)}, {"object_max", VecJson(c->scene.object_max)}};
  c->truth["frames"] = "world = ENU tangent plane at origin (metres); cameras x right, y down, z forward; "
                       "poses target_from_source; qvec w, x, y, z";
  c->truth["origin"] = {{"latitude_deg", c->options.origin.latitude_deg}, {"longitude_deg", c->options.origin.longitude_deg},
                        {"height_m", c->options.origin.height_m}};
  c->truth["trajectory"] = {{"true", "truth/trajectory_true.csv"}, {"ins", "trajectory_ins.csv"},
                            {"duration_s", trajectory.duration_s()}};
  c->truth["registration"] = c->registration_truth;
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

}  // namespace mmba::sim::internal
