// Photo positions from the photos' EXIF GPS tags (a gnss sensor's `photos`) as camera-position
// priors: a simulated block in a COLMAP frame of its own, its photos tagged with their true
// antenna positions plus 2 cm noise (altitudes written as heights above a geoid 47.3 m above
// the ellipsoid), is placed in the world by them alone, as the same positions in a GNSS CSV
// place it. A folder without any GPS tag and a sensor with both a file and photos are input
// errors naming them.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <exiv2/exiv2.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/adjust/adjust.h"
#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/geodesy/geodesy.h"
#include "mmba/geometry/sim3d.h"
#include "mmba/io/colmap_model.h"
#include "mmba/sim/simulate.h"
#include "test_support.h"

namespace mmba::adjust {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

fs::path Root() { return testing_support::ScratchRoot("mmba_exif_gnss"); }

constexpr double kUndulationM = 47.3;

/// "d/1 m/1 s/1000000" of |degrees|, as EXIF stores a latitude or longitude.
std::string Dms(double degrees) {
  degrees = std::abs(degrees);
  const int d = static_cast<int>(std::floor(degrees));
  const double minutes = (degrees - d) * 60;
  const int m = static_cast<int>(std::floor(minutes));
  const long long micro_seconds = std::llround((minutes - m) * 60 * 1e6);
  return std::to_string(d) + "/1 " + std::to_string(m) + "/1 " + std::to_string(micro_seconds) + "/1000000";
}

void TagGps(const fs::path& image, const geodesy::Geodetic& g) {
  auto file = Exiv2::ImageFactory::open(image.string());
  file->readMetadata();
  Exiv2::ExifData exif = file->exifData();
  exif["Exif.GPSInfo.GPSLatitudeRef"] = std::string(g.latitude_deg >= 0 ? "N" : "S");
  exif["Exif.GPSInfo.GPSLatitude"] = Dms(g.latitude_deg);
  exif["Exif.GPSInfo.GPSLongitudeRef"] = std::string(g.longitude_deg >= 0 ? "E" : "W");
  exif["Exif.GPSInfo.GPSLongitude"] = Dms(g.longitude_deg);
  const double altitude = g.height_m - kUndulationM;
  exif["Exif.GPSInfo.GPSAltitudeRef"] = std::string(altitude >= 0 ? "0" : "1");
  exif["Exif.GPSInfo.GPSAltitude"] = std::to_string(std::llround(std::abs(altitude) * 1000)) + "/1000";
  file->setExifData(exif);
  file->writeMetadata();
}

class ExifGnssTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SetVerbosity(Verbosity::kQuiet);
    fs::remove_all(Root());
    sim::SimulateOptions o;
    o.scene = "gate";
    o.seed = 11;
    o.threads = 2;
    o.photos.count = 20;
    o.photos.tie_points = 400;
    o.spheres.stations = 2;
    o.spheres.width = 512;
    o.rig.frames = 2;
    o.static_scans = 2;
    o.mobile_revolutions = 0;
    o.clouds.surface_samples = 0;
    o.render.samples_per_axis = 1;
    sim::Simulate(o, (Root() / "sim").string());
  }
  static void TearDownTestSuite() {
    if (!std::getenv("MMBA_KEEP_TEST_OUTPUT")) fs::remove_all(Root());
  }

  /// The block moved into a frame of its own (a COLMAP model knows nothing of the world), the
  /// photos copied with GPS tags of their true centres plus 2 cm noise.
  static void MakeBlock(const fs::path& dir) {
    const fs::path sim = Root() / "sim";
    fs::create_directories(dir / "colmap");
    io::ColmapModel model = io::ReadColmapModel((sim / "colmap" / "photos").string());
    const Sim3d block_from_world(2.5, Eigen::Quaterniond(Eigen::AngleAxisd(-2.0, Eigen::Vector3d(0.1, -0.4, 1).normalized())),
                                 Eigen::Vector3d(-3, 40, 7));
    for (auto& [id, image] : model.images) image.cam_from_world = block_from_world.TransformCamFromSource(image.cam_from_world);
    for (auto& [id, point] : model.points3D) point.xyz = block_from_world * point.xyz;
    io::WriteColmapModel(model, (dir / "colmap").string(), io::ColmapFormat::kText);
    fs::copy(sim / "images" / "photos", dir / "photos");
    const io::ColmapModel truth = io::ReadColmapModel((sim / "truth" / "colmap_photos").string());
    const geodesy::LocalTangentPlane plane(geodesy::Geodetic{45.5048, -73.5772, 60});
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.02);
    for (const auto& [id, image] : truth.images) {
      const Eigen::Vector3d enu = image.cam_from_world.Inverse().translation + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      TagGps(dir / "photos" / image.name, plane.GeodeticFromEnu(enu));
    }
  }

  static void WriteProject(const fs::path& dir, const std::string& gnss) {
    const fs::path sim = Root() / "sim";
    std::ofstream(dir / "project.yaml")
        << "mmba_project: 1\norigin: {latitude_deg: 45.5048, longitude_deg: -73.5772, height_m: 60}\n"
        << "simulated: {seed: 11, preset: small, truth: " << (sim / "truth/truth.json").string() << "}\nsensors:\n"
        << "  - {id: photos, type: photo_collection, images: " << (dir / "photos").string()
        << ", calibration: " << (sim / "calib/photo_camera.yaml").string() << ", colmap_model: " << (dir / "colmap").string()
        << ", sigma_px: 0.5}\n"
        << "  - {id: ts, type: total_station, file: " << (sim / "survey/network.xml").string() << "}\n"
        << "  - {id: gnss, type: gnss, " << gnss << "}\n"
        << "  - {id: tls, type: lidar_static, reference_cloud: " << (sim / "clouds/lidar.ply").string() << "}\n";
  }
};

TEST_F(ExifGnssTest, PhotosArePlacedByTheirExifPositions) {
  const fs::path dir = Root() / "exif";
  MakeBlock(dir);
  WriteProject(dir, "photos: {folder: " + (dir / "photos").string() +
                        ", sigma_horizontal_m: 0.02, sigma_vertical_m: 0.02, geoid_undulation_m: 47.3}");
  const AdjustOutcome outcome = testing_support::RunProject((dir / "project.yaml").string(), (dir / "out").string());
  ASSERT_TRUE(outcome.ok) << outcome.reason;
  const std::string georeference = outcome.report["photo_block"]["georeference"];
  EXPECT_NE(georeference.find("GNSS positions of"), std::string::npos) << georeference;
  const json& photos = outcome.report["truth_evaluation"]["photo_positions"];
  EXPECT_LT(photos["max_m"].get<double>(), 0.03) << photos.dump();
  bool group = false;
  for (const json& g : outcome.report["groups"]) {
    if (g["name"] == "photos: GNSS camera positions") {
      group = true;
      EXPECT_EQ(g["observations"].get<size_t>(), 3u * 20u) << g.dump();
    }
  }
  EXPECT_TRUE(group) << outcome.report["groups"].dump(1);
}

TEST_F(ExifGnssTest, UntaggedPhotosAndTwoSourcesAreInputErrors) {
  const fs::path dir = Root() / "untagged";
  fs::create_directories(dir);
  fs::copy(Root() / "sim" / "images" / "photos", dir / "photos");
  fs::copy(Root() / "sim" / "colmap" / "photos", dir / "colmap");
  const auto error = [&](const std::string& gnss) -> std::string {
    WriteProject(dir, gnss);
    try {
      testing_support::RunProject((dir / "project.yaml").string(), (dir / "out").string());
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string photos = "photos: {folder: " + (dir / "photos").string() +
                             ", sigma_horizontal_m: 3, sigma_vertical_m: 5, geoid_undulation_m: 0}";
  const std::string untagged = error(photos);
  EXPECT_NE(untagged.find((dir / "photos").string()), std::string::npos) << untagged;
  EXPECT_NE(untagged.find("no JPEG, TIFF or PNG photo with an EXIF GPS position"), std::string::npos) << untagged;
  const std::string both = error("file: " + (Root() / "sim" / "project.yaml").string() + ", " + photos);
  EXPECT_NE(both.find("one of file (a GNSS CSV) or photos"), std::string::npos) << both;
  EXPECT_FALSE(fs::exists(dir / "out" / "report.json"));
}

}  // namespace
}  // namespace mmba::adjust
