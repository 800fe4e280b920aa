// A photo_measurements block controlled by an OpenDroneMap gcp_list.txt in UTM (EPSG:32632):
// the projection becomes the project's crs, the origin the GCPs' mean, the GCPs fixed control
// with their image measurements (pixels as OpenSfM counts them, centre of the first pixel 0)
// beside a measurement file of tie points. A simulated convergent block with exact truth; a
// GCP withheld as a check point; a gcp_list naming an image the block does not have, and one
// in another projection than the project's crs, are input errors naming the file and line.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/geodesy/crs_frame.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io/odm_gcp_list.h"
#include "test_support.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using testing_support::ReadText;
using testing_support::RunProject;
using testing_support::ScratchRoot;

/// 8 images on a circle 6 m from the axis, 10 m above 60 points in an 8 x 6 x 2 m box, a
/// PINHOLE camera of 1000 px, σ 0.3 px noise. Points g0..g5 are GCPs (in gcp_list.txt, in
/// EPSG:32632), the others tie points (marks.txt).
struct Block {
  fs::path dir;
  std::map<std::string, Eigen::Vector3d> truth;  ///< world (tangent plane at the GCPs' mean)
};

std::string Image(int k) { return "DJI_000" + std::to_string(k + 1) + ".JPG"; }

Block Simulate(const fs::path& dir) {
  Block b;
  b.dir = dir;
  fs::create_directories(dir);
  std::ofstream(dir / "camera.yaml") << "model: PINHOLE\nwidth: 1200\nheight: 900\nparams: [1000, 1000, 600, 450]\n";
  const sensors::Camera camera = io::ReadCameraFile((dir / "camera.yaml").string()).camera;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (int i = 0; i < 60; ++i) b.truth[(i < 6 ? "g" : "t") + std::to_string(i)] = {4.0 * u(rng), 3.0 * u(rng), 1.0 + u(rng)};
  // The GCPs' CRS coordinates: a UTM 32N site at 48.137 N, 11.575 E; the world origin is the
  // mean of the GCP lines' coordinates (the project's rule), found by iterating once.
  auto crs = std::make_shared<const geodesy::Crs>("EPSG:32632", "test");
  geodesy::CrsFrame frame(crs, geodesy::Geodetic{48.137, 11.575, 520.0});
  std::vector<std::pair<std::string, Eigen::Vector2d>> gcp_rows[8];
  std::ofstream marks(dir / "marks.txt");
  marks << std::setprecision(12);
  for (int k = 0; k < 8; ++k) {
    const double a = 2.0 * M_PI * k / 8.0;
    const Eigen::Vector3d centre(6.0 * std::cos(a), 6.0 * std::sin(a), 10.0);
    const Eigen::Vector3d z = (Eigen::Vector3d(0, 0, 1) - centre).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY()).normalized();
    Eigen::Matrix3d r;
    r << x.transpose(), z.cross(x).transpose(), z.transpose();
    const Rigid3d pose(Eigen::Quaterniond(r), -r * centre);
    for (const auto& [id, p] : b.truth) {
      const auto xy = camera.ImgFromCam(pose * p);
      if (!xy) continue;
      const Eigen::Vector2d m = *xy + Eigen::Vector2d(noise(rng), noise(rng));
      if (id[0] == 'g') gcp_rows[k].push_back({id, m});
      else marks << Image(k) << " " << id << " " << m.x() << " " << m.y() << "\n";
    }
  }
  std::vector<Eigen::Vector3d> geo;
  for (int k = 0; k < 8; ++k) {
    for (const auto& row : gcp_rows[k]) geo.push_back(frame.CrsFromWorld(b.truth.at(row.first)));
  }
  const geodesy::CrsFrame site(crs, geodesy::OriginOfCrsPoints(*crs, geo));
  std::ofstream gcp(dir / "gcp_list.txt");
  gcp << std::fixed << std::setprecision(4) << "EPSG:32632\n";
  for (int k = 0; k < 8; ++k) {
    for (const auto& [id, m] : gcp_rows[k]) {
      const Eigen::Vector3d g = frame.CrsFromWorld(b.truth.at(id));
      gcp << g.x() << " " << g.y() << " " << g.z() << " " << m.x() - 0.5 << " " << m.y() - 0.5 << " " << Image(k) << " " << id << "\n";
    }
  }
  for (auto& [id, p] : b.truth) p = site.WorldFromCrs(frame.CrsFromWorld(p));  // into the project's world
  return b;
}

void WriteProject(const fs::path& dir, const std::string& top, const std::string& gcp_file) {
  std::ofstream(dir / "project.yaml")
      << "mmba_project: 1\n" << top
      << "sensors:\n  - id: drone\n    type: photo_measurements\n    camera: camera.yaml\n"
         "    measurements: [{file: marks.txt, columns: [image, id, x, y], sigma_px: 0.3}]\n"
         "    gcp_list: {file: " << gcp_file << ", sigma_px: 0.3, sigma_m: 0}\n"
         "    refine: []\n    loss: none\nadjustment: {variance_components: false, outlier_sigma: 100}\n";
}

std::string InputErrorOf(const fs::path& dir) {
  try {
    RunProject((dir / "project.yaml").string(), (dir / "out_bad").string());
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(PhotoMeasurementsGcp, GcpListControlsTheBlockInItsProjection) {
  const fs::path dir = ScratchRoot("pm_gcp") / "block";
  fs::remove_all(dir.parent_path());
  const Block block = Simulate(dir);
  WriteProject(dir, "check_points: [g5]\n", "gcp_list.txt");
  const AdjustOutcome outcome = RunProject((dir / "project.yaml").string(), (dir / "out").string());
  ASSERT_TRUE(outcome.ok) << outcome.status << ": " << outcome.reason;
  const nlohmann::json report = nlohmann::json::parse(ReadText(dir / "out/report.json"));
  const nlohmann::json& pm = report["photo_measurements"];
  EXPECT_NE(pm["datum"].get<std::string>().find("5 fixed"), std::string::npos) << pm["datum"];
  EXPECT_EQ(report["crs"]["identifier"], "EPSG:32632") << report["crs"].dump();
  EXPECT_NEAR(report["sigma0"]["aposteriori"].get<double>(), 1.0, 0.15);
  // Every tie point within 2 cm of the truth (noise 0.3 px ≈ 3 mm at 10 m).
  std::istringstream points(ReadText(dir / "out/drone_points.csv"));
  std::string line;
  std::getline(points, line);
  int compared = 0;
  while (std::getline(points, line)) {
    std::istringstream row(line);
    std::string id, kind, x, y, z;
    std::getline(row, id, ',');
    std::getline(row, kind, ',');
    std::getline(row, x, ',');
    std::getline(row, y, ',');
    std::getline(row, z, ',');
    if (id[0] != 't') continue;
    EXPECT_LT((Eigen::Vector3d(std::stod(x), std::stod(y), std::stod(z)) - block.truth.at(id)).norm(), 0.02) << id;
    ++compared;
  }
  EXPECT_EQ(compared, 54);
  // The CSV files carry the project CRS's columns: the held GCPs at their gcp_list coordinates.
  std::map<std::string, Eigen::Vector3d> gcp;
  std::istringstream gcp_list(ReadText(dir / "gcp_list.txt"));
  std::getline(gcp_list, line);
  while (std::getline(gcp_list, line)) {
    std::istringstream row(line);
    Eigen::Vector3d g;
    double x, y;
    std::string image, id;
    row >> g.x() >> g.y() >> g.z() >> x >> y >> image >> id;
    gcp[id] = g;
  }
  const std::string columns = ",easting_epsg32632_m,northing_epsg32632_m,height_epsg32632_m";
  EXPECT_NE(ReadText(dir / "out/drone_images.csv").find("rms_px" + columns + "\n"), std::string::npos);
  std::istringstream crs_points(ReadText(dir / "out/drone_points.csv"));
  std::getline(crs_points, line);  // the header is the first line
  EXPECT_EQ(line.substr(line.size() - columns.size()), columns);
  int held = 0;
  while (std::getline(crs_points, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 15u) << line;
    if (cells[1] != "control (fixed)") continue;
    const Eigen::Vector3d e(std::stod(cells[12]), std::stod(cells[13]), std::stod(cells[14]));
    EXPECT_LT((e - gcp.at(cells[0])).norm(), 0.001) << line;
    ++held;
  }
  EXPECT_EQ(held, 5);
  // The check point against its gcp_list coordinates.
  const nlohmann::json& check = pm["check_points"];
  ASSERT_FALSE(check.is_null()) << pm.dump(1);
  EXPECT_NE(check.dump().find("g5"), std::string::npos) << check.dump();
}

TEST(PhotoMeasurementsGcp, UnknownImageAndOtherProjectionAreInputErrors) {
  const fs::path dir = ScratchRoot("pm_gcp") / "bad";
  fs::remove_all(dir);
  Simulate(dir);
  std::ofstream(dir / "gcp_unknown.txt") << ReadText(dir / "gcp_list.txt") << "691000 5334000 520 10 10 DJI_0099.JPG g9\n";
  std::ifstream count(dir / "gcp_list.txt");
  const int lines = static_cast<int>(std::count(std::istreambuf_iterator<char>(count), {}, '\n'));
  WriteProject(dir, "", "gcp_unknown.txt");
  const std::string unknown = InputErrorOf(dir);
  EXPECT_NE(unknown.find("gcp_unknown.txt:" + std::to_string(lines + 1) + ": field 'image_name': found 'DJI_0099.JPG'"),
            std::string::npos) << unknown;
  WriteProject(dir, "crs: EPSG:25832\norigin: {latitude_deg: 48.137, longitude_deg: 11.575, height_m: 520}\n", "gcp_list.txt");
  const std::string other = InputErrorOf(dir);
  EXPECT_NE(other.find("gcp_list.txt:1: field 'projection': found 'EPSG:32632'"), std::string::npos) << other;
  EXPECT_NE(other.find("EPSG:25832"), std::string::npos) << other;
  EXPECT_FALSE(fs::exists(dir / "out_bad" / "report.json"));
}

}  // namespace
}  // namespace mmba::adjust
