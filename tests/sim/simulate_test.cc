#include "mmba/sim/simulate.h"

#include <expat.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/io/colmap_model.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/trajectory.h"
#include "mmba/sim/survey.h"

namespace mmba::sim {
namespace {

namespace fs = std::filesystem;

SimulateOptions Tiny() {
  SimulateOptions o;
  o.scene = "gate";
  o.seed = 11;
  o.threads = 2;
  o.photos.count = 4;
  o.photos.width = 160;
  o.photos.height = 120;
  o.photos.focal_px = 140;
  o.photos.tie_points = 150;
  o.spheres.stations = 1;
  o.spheres.width = 256;
  o.rig.frames = 1;
  o.rig.width = 48;
  o.rig.focal_px = 20;
  o.rig.panorama_width = 128;
  o.static_scans = 1;
  o.static_scan.azimuth_step_deg = 3;
  o.static_scan.elevation_step_deg = 3;
  o.mobile_revolutions = 2;
  o.mobile_scan.azimuth_step_deg = 3;
  o.clouds.surface_samples = 4000;
  return o;
}

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path OutDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("mmba_sim_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

class SimulateTiny : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(OutDir("a"));
    result_ = new SimulateResult(Simulate(Tiny(), dir_->string()));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete result_;
  }
  static fs::path* dir_;
  static SimulateResult* result_;
};
fs::path* SimulateTiny::dir_ = nullptr;
SimulateResult* SimulateTiny::result_ = nullptr;

TEST_F(SimulateTiny, WritesTheDocumentedLayout) {
  for (const char* file :
       {"project.yaml", "gnss.csv", "trajectory_ins.csv", "ground_truth.json", "survey/network.xml",
        "clouds/lidar.ply", "clouds/mobile_lidar.ply", "clouds/spherical_stereo.ply", "clouds/multi_view.ply",
        "clouds/plane_proxy.ply", "clouds/spherical_stereo_part.ply", "clouds/scans/scan_1.ply",
        "images/photos/photo_000.png", "images/spherical/S1_lower.png", "images/spherical/S1_upper.png",
        "images/rig/frame_000_cam5.png", "images/rig_panoramas/frame_000.png", "calib/photo_camera.yaml",
        "calib/spherical_stereo.yaml", "calib/ladybug.yaml", "calib/mobile_lidar.yaml",
        "colmap/photos/images.txt", "truth/colmap_photos/points3D.txt", "truth/truth.json",
        "truth/mesh.obj", "truth/trajectory_true.csv"}) {
    EXPECT_TRUE(fs::exists(*dir_ / file)) << file;
  }
  const auto registration = nlohmann::json::parse(Slurp(*dir_ / "ground_truth.json"));
  for (const char* key : {"world_from_lidar", "world_from_spherical_stereo", "world_from_multi_view",
                          "world_from_plane_proxy", "world_from_multi_view_part"}) {
    ASSERT_TRUE(registration.contains(key)) << key;
    ASSERT_EQ(registration[key].size(), 4u) << key;
    EXPECT_EQ(registration[key][3], nlohmann::json({0.0, 0.0, 0.0, 1.0})) << key;
  }
  EXPECT_GT(result_->tie_points, 20u);
  EXPECT_GT(result_->static_points, 1000u);
  // Sensor positions of each cloud in its own frame (register-eval's visibility test): the
  // multi-view cloud's are the photos' centres moved into its frame; the proxy has none.
  EXPECT_FALSE(fs::exists(*dir_ / "clouds/plane_proxy.viewpoints.txt"));
  EXPECT_TRUE(fs::exists(*dir_ / "clouds/lidar.viewpoints.txt"));
  EXPECT_TRUE(fs::exists(*dir_ / "clouds/spherical_stereo.viewpoints.txt"));
  std::istringstream lines(Slurp(*dir_ / "clouds/multi_view.viewpoints.txt"));
  std::vector<Eigen::Vector3d> viewpoints;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    Eigen::Vector3d v;
    in >> v.x() >> v.y() >> v.z();
    viewpoints.push_back(v);
  }
  const auto truth = nlohmann::json::parse(Slurp(*dir_ / "truth/truth.json"));
  const auto& photos = truth["photos"]["images"];
  ASSERT_EQ(viewpoints.size(), photos.size());
  Eigen::Matrix4d world_from_cloud, cam_from_world;
  for (int r = 0; r < 4; ++r) {
    for (int k = 0; k < 4; ++k) {
      world_from_cloud(r, k) = registration["world_from_multi_view"][r][k];
      cam_from_world(r, k) = photos[0]["cam_from_world"]["matrix"][r][k];
    }
  }
  const Eigen::Vector3d centre = -cam_from_world.topLeftCorner<3, 3>().transpose() *
                                 cam_from_world.topRightCorner<3, 1>();
  const Eigen::Vector3d in_world = world_from_cloud.topLeftCorner<3, 3>() * viewpoints[0] +
                                   world_from_cloud.topRightCorner<3, 1>();
  EXPECT_LT((in_world - centre).norm(), 1e-6);
}

// Each mobile cloud names, in its sidecar, the trajectory and mounting it was georeferenced
// with (register-mi's incidence correction reads them): with them every point lies, seen from
// its scanner at its time, within the head's beam elevations (0.1°) — a wrong trajectory,
// mounting or time base would put points outside them (on the full gate, the INS trajectory
// for the true cloud: 0.63° above the top beam; an identity mounting: 25°).
TEST_F(SimulateTiny, MobileCloudsNameTheScannerOfEachPoint) {
  const SimulateOptions o = Tiny();
  const double elevation[2] = {o.mobile_scan.elevation_min_deg, o.mobile_scan.elevation_max_deg};
  for (const char* name : {"clouds/mobile_lidar.ply", "truth/mobile_lidar_true.ply"}) {
    const std::optional<io::ScannerSidecar> sidecar = io::ReadScannerSidecar((*dir_ / name).string());
    ASSERT_TRUE(sidecar.has_value()) << name;
    const auto trajectory = io::ReadTrajectory(sidecar->trajectory);
    const Rigid3d body_from_lidar = io::ReadLidarMountYaml(sidecar->lidar_mount);
    const io::PointCloud cloud = io::ReadPointCloud((*dir_ / name).string());
    ASSERT_TRUE(cloud.has_time()) << name;
    ASSERT_GT(cloud.size(), 1000u) << name;
    double lowest = 90, highest = -90;
    for (size_t i = 0; i < cloud.size(); ++i) {
      ASSERT_GE(cloud.time[i], trajectory.front().first) << name;
      ASSERT_LE(cloud.time[i], trajectory.back().first) << name;
      const Rigid3d world_from_lidar = io::InterpolateTrajectory(trajectory, cloud.time[i]) * body_from_lidar;
      const Eigen::Vector3d in_lidar = world_from_lidar.Inverse() * cloud.points[i];
      const double e = std::atan2(in_lidar.z(), in_lidar.head<2>().norm()) * 180.0 / M_PI;
      lowest = std::min(lowest, e);
      highest = std::max(highest, e);
    }
    EXPECT_GT(lowest, elevation[0] - 0.1) << name;
    EXPECT_LT(highest, elevation[1] + 0.1) << name;
    EXPECT_LT(lowest, elevation[0] + 2) << name;
    EXPECT_GT(highest, elevation[1] - 2) << name;
  }
}

// Each photo's camera YAML (truth/cameras/photos/…) holds the pose of the true COLMAP model
// (whose tie points project exactly: TrueColmapModelProjectsExactly…); the panoramas' and the
// rig cameras' are written too.
TEST_F(SimulateTiny, TrueCameraYamlsHoldTheTruePoses) {
  const io::ColmapModel truth = io::ReadColmapModel((*dir_ / "truth" / "colmap_photos").string());
  size_t checked = 0;
  for (const auto& [id, image] : truth.images) {
    const fs::path yaml = *dir_ / "truth" / "cameras" / "photos" / (fs::path(image.name).stem().string() + ".yaml");
    ASSERT_TRUE(fs::exists(yaml)) << yaml;
    const std::string text = Slurp(yaml);
    const size_t at = text.find("cam_from_lidar: [");
    ASSERT_NE(at, std::string::npos) << text;
    std::istringstream numbers(text.substr(at + 17));
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) {
      numbers >> m(i / 4, i % 4);
      numbers.ignore(1);  // ',' or ']'
    }
    EXPECT_LT((m - image.cam_from_world.ToMatrix4()).cwiseAbs().maxCoeff(), 1e-12) << image.name;
    ++checked;
  }
  EXPECT_EQ(checked, 4u);
  for (const char* kind : {"spherical", "rig_panoramas", "rig"}) {
    EXPECT_FALSE(fs::is_empty(*dir_ / "truth" / "cameras" / kind)) << kind;
  }
}

TEST_F(SimulateTiny, SameSeedSameBytes) {
  const fs::path other = OutDir("b");
  Simulate(Tiny(), other.string());
  size_t compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(*dir_)) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), *dir_);
    ASSERT_TRUE(fs::exists(other / rel)) << rel;
    EXPECT_EQ(Slurp(entry.path()), Slurp(other / rel)) << rel;
    ++compared;
  }
  EXPECT_GT(compared, 25u);
  fs::remove_all(other);
}

TEST_F(SimulateTiny, TrueColmapModelProjectsExactlyAndPerturbedOneReads) {
  const io::ColmapModel truth = io::ReadColmapModel((*dir_ / "truth" / "colmap_photos").string());
  const io::ColmapModel perturbed = io::ReadColmapModel((*dir_ / "colmap" / "photos").string());
  EXPECT_EQ(truth.images.size(), 4u);
  EXPECT_EQ(perturbed.NumObservations(), truth.NumObservations());
  double max_error = 0;
  for (const auto& [id, image] : truth.images) {
    const sensors::Camera& camera = truth.cameras.at(image.camera_id);
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      const auto xy = camera.ImgFromCam(image.cam_from_world * truth.points3D.at(image.point3D_ids[k]).xyz);
      ASSERT_TRUE(xy.has_value());
      max_error = std::max(max_error, (*xy - image.points2D[k]).norm());
    }
  }
  EXPECT_LT(max_error, 1e-4);  // text precision of COLMAP's writer
}

// Counts the elements of network.xml with expat (a real XML parser).
std::map<std::string, int> CountXmlElements(const std::string& text, bool* ok) {
  std::map<std::string, int> counts;
  XML_Parser parser = XML_ParserCreate(nullptr);
  XML_SetUserData(parser, &counts);
  XML_SetStartElementHandler(parser, [](void* data, const XML_Char* name, const XML_Char**) {
    ++(*static_cast<std::map<std::string, int>*>(data))[name];
  });
  *ok = XML_Parse(parser, text.data(), static_cast<int>(text.size()), 1) == XML_STATUS_OK;
  XML_ParserFree(parser);
  return counts;
}

TEST_F(SimulateTiny, NetworkXmlParsesWithTheRightCountsAndRecomputesFromTruth) {
  bool ok = false;
  const auto counts = CountXmlElements(Slurp(*dir_ / "survey" / "network.xml"), &ok);
  ASSERT_TRUE(ok);
  const auto truth = nlohmann::json::parse(Slurp(*dir_ / "truth" / "truth.json"));
  const auto& survey = truth["survey"];
  EXPECT_EQ(counts.at("gama-local"), 1);
  EXPECT_EQ(counts.at("point"), static_cast<int>(survey["points"].size()));
  EXPECT_EQ(counts.at("obs"), static_cast<int>(survey["setups"].size()));
  const int n_obs = static_cast<int>(survey["observations"].size());
  EXPECT_EQ(counts.at("direction") + counts.at("z-angle") + counts.at("s-distance"), n_obs);
  EXPECT_EQ(counts.at("direction"), counts.at("s-distance"));
  EXPECT_EQ(static_cast<int>(result_->ts_observations), n_obs);
  ASSERT_GT(n_obs, 10);
  // Every observation recomputes from the true coordinates within 5σ.
  const geodesy::LocalTangentPlane plane(SimulateOptions().origin);
  std::map<std::string, Eigen::Vector3d> points;
  for (const auto& p : survey["points"]) {
    points[p["id"]] = Eigen::Vector3d(p["point_in_world"][0], p["point_in_world"][1], p["point_in_world"][2]);
  }
  std::map<std::string, std::pair<double, double>> setups;
  for (const auto& s : survey["setups"]) setups[s["point"]] = {s["instrument_height_m"], s["orientation_gon"]};
  for (const auto& o : survey["observations"]) {
    const auto& [hi, orientation] = setups.at(o["from"]);
    double direction, zenith, distance;
    ComputeTsObservation(plane, points.at(o["from"]), hi, orientation, points.at(o["to"]),
                         o["target_height_m"], &direction, &zenith, &distance);
    const std::string kind = o["kind"];
    const double value = o["value"], sigma = o["sigma"];
    if (kind == "direction") {
      double d = std::fmod(value - direction + 600.0, 400.0) - 200.0;
      EXPECT_LT(std::abs(d), 5 * sigma * 1e-4) << o.dump();
    } else if (kind == "z-angle") {
      EXPECT_LT(std::abs(value - zenith), 5 * sigma * 1e-4) << o.dump();
    } else {
      EXPECT_LT(std::abs(value - distance), 5 * sigma * 1e-3) << o.dump();
    }
  }
}

Rigid3d FromRows(const nlohmann::json& rows) {
  Eigen::Matrix<double, 3, 4> matrix;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) matrix(r, c) = rows[r][c].get<double>();
  return Rigid3d::FromMatrix(matrix);
}

TEST_F(SimulateTiny, StaticScanLiesOnTheMeshAndCloudsMatchTheirTransforms) {
  const auto truth = nlohmann::json::parse(Slurp(*dir_ / "truth" / "truth.json"));
  const TriangleMesh mesh = LoadMesh((*dir_ / "truth" / "mesh.obj").string(), Material());
  RayCaster caster(mesh);
  const auto& scan_truth = truth["lidar"]["static_scans"][0];
  const Rigid3d world_from_scan = FromRows(scan_truth["world_from_scan"]["matrix"]);
  const io::PointCloud scan = io::ReadPly((*dir_ / "clouds" / "scans" / "scan_1.ply").string());
  ASSERT_TRUE(scan.has_intensity());
  size_t on_surface = 0;
  for (const auto& p_scan : scan.points) {
    const Eigen::Vector3d p = world_from_scan * p_scan;
    const Eigen::Vector3d o = world_from_scan.translation;
    const RayHit hit = caster.Intersect(o, (p - o).normalized());
    // Within 5σ of the first surface (σ = 3 mm + 20 ppm); glass passes and ghosts aside.
    if (hit.hit && std::abs((p - o).norm() - hit.distance_m) < 5 * (0.003 + 20e-6 * hit.distance_m)) ++on_surface;
  }
  EXPECT_GT(static_cast<double>(on_surface) / scan.size(), 0.97);
  // The spherical stereo cloud maps onto the mesh with its ground-truth transform.
  const auto registration = nlohmann::json::parse(Slurp(*dir_ / "ground_truth.json"));
  const Rigid3d world_from_stereo = FromRows(registration["world_from_spherical_stereo"]);
  const io::PointCloud stereo = io::ReadPly((*dir_ / "clouds" / "spherical_stereo.ply").string());
  ASSERT_GT(stereo.size(), 100u);
  const Eigen::Vector3d eye =
      FromRows(truth["spherical_stereo"]["stations"][0]["lower_from_world"]["matrix"]).Inverse().translation;
  // Range error within 5σ, σ_r = r²·σ_d / (f·b·sin θ) (the documented model).
  const auto& model = truth["clouds"]["spherical_stereo"];
  const double f = model["stereo_width_px"].get<double>() / (2 * M_PI);
  const double b = model["baseline_m"], sigma_d = model["disparity_sigma_px"];
  size_t close = 0;
  for (const auto& p_block : stereo.points) {
    const Eigen::Vector3d p = world_from_stereo * p_block;
    const Eigen::Vector3d ray = p - eye;
    const RayHit hit = caster.Intersect(eye, ray.normalized());
    const double r = ray.norm(), sin_theta = std::hypot(ray.x(), ray.y()) / r;
    const double sigma = r * r * sigma_d / (f * b * sin_theta);
    if (hit.hit && std::abs(r - hit.distance_m) < 5 * sigma) ++close;
  }
  EXPECT_GT(static_cast<double>(close) / stereo.size(), 0.97);
}

TEST(Simulate, ImpossibleParametersAreInputErrors) {
  SimulateOptions o = Tiny();
  o.spheres.baseline_m = -0.6;
  try {
    Simulate(o, OutDir("bad").string());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("baseline_m"), std::string::npos) << e.what();
  }
  o = Tiny();
  o.photos.width = 0;
  EXPECT_THROW(Simulate(o, OutDir("bad").string()), InputError);
  const fs::path dir = OutDir("scenefile");
  fs::create_directories(dir);
  std::ofstream(dir / "bad.yaml") << "scene: gate\nphotos:\n  count: many\n";
  try {
    ReadSceneFile((dir / "bad.yaml").string(), &o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("photos.count"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "unknown.yaml") << "scene: gate\nphotoz: 3\n";
  EXPECT_THROW(ReadSceneFile((dir / "unknown.yaml").string(), &o), InputError);
  // The lighting of the rendered images: ambient 1 = albedo only (no sun shading).
  std::ofstream(dir / "flat.yaml") << "scene: gate\nrender: {ambient: 1.0}\n";
  SimulateOptions flat = Tiny();
  ReadSceneFile((dir / "flat.yaml").string(), &flat);
  EXPECT_EQ(flat.render.ambient, 1.0);
  std::ofstream(dir / "bright.yaml") << "scene: gate\nrender: {ambient: 1.5}\n";
  try {
    ReadSceneFile((dir / "bright.yaml").string(), &flat);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ambient"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "empty.obj") << "# no faces\n";
  std::ofstream(dir / "mesh.yaml") << "mesh: empty.obj\n";
  SimulateOptions from_file = Tiny();
  ReadSceneFile((dir / "mesh.yaml").string(), &from_file);
  EXPECT_THROW(Simulate(from_file, (dir / "out").string()), InputError);
  fs::remove_all(dir);
}

// The drive preset is the joint adjustment's scale case: 200 rig frames, a 100 m drive the
// LiDAR turns through from end to end at a density that gives >= 50 M points on the cathedral; a
// drive leaving the scene's ground (or the gate's studio) is refused, naming the key.
TEST(Simulate, DrivePresetCoversTheDriveAndStaysOnTheScene) {
  SimulateOptions o;
  o.scene = "cathedral";
  ASSERT_TRUE(o.ApplyPreset("drive"));
  EXPECT_EQ(o.rig.frames, 200);
  EXPECT_DOUBLE_EQ(o.mobile_drive_m, 100.0);
  EXPECT_GE(o.mobile_revolutions / o.mobile_scan.rotation_hz, o.mobile_drive_m / o.mobile_speed_mps);
  EXPECT_LT(o.mobile_revolutions / o.mobile_scan.rotation_hz, o.mobile_drive_m / o.mobile_speed_mps + 0.2);
  // Rays per second of drive × duration: the head's share that returns is ~70 % on the
  // cathedral (measured: 53.7 M points), so the rays must be well above 50 M.
  const double rays = 360.0 / o.mobile_scan.azimuth_step_deg * o.mobile_scan.beams * o.mobile_revolutions;
  EXPECT_GT(rays, 50e6 / 0.7);
  std::string error;
  EXPECT_TRUE(o.Check(&error)) << error;
  o.scene = "gate";
  EXPECT_FALSE(o.Check(&error));
  EXPECT_NE(error.find("lidar.mobile_drive_m"), std::string::npos) << error;
  const fs::path dir = OutDir("drive");
  fs::create_directories(dir);
  std::ofstream(dir / "drive.yaml") << "scene: cathedral\npreset: drive\nlidar:\n  mobile_drive_m: 40\n";
  SimulateOptions from_file;
  ReadSceneFile((dir / "drive.yaml").string(), &from_file);
  EXPECT_EQ(from_file.rig.frames, 200);
  EXPECT_DOUBLE_EQ(from_file.mobile_drive_m, 40.0);
  std::ofstream(dir / "off.yaml") << "scene: cathedral\nlidar:\n  mobile_drive_m: 500\n";
  SimulateOptions off;
  try {
    ReadSceneFile((dir / "off.yaml").string(), &off);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mobile_drive_m 500"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mmba::sim
