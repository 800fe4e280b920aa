// The adjustment's GIS outputs on a small simulated gate (photos, two static scans, total
// station, GNSS; origin in Franconia): every output cloud has a LAS 1.4 beside its PLY,
// read back with its CRS by mmba's ReadLas and by the independent reader
// tests/io_cloud/las14_dump.py, the error map's signed distance as the extra field
// distance_m; points.geojson and cameras.geojson are RFC 7946 feature collections whose
// positions are points.csv's and poses.csv's latitude and longitude. The same project with
// `crs: EPSG:25832` (its network given in the CRS) writes the LAS in ETRS89 / UTM 32N, equal to
// points.csv's CRS columns' conversion, and (checked by pyproj) to PROJ's own pipeline.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/adjust/adjust.h"
#include "mmba/core/logging.h"
#include "mmba/geodesy/crs.h"
#include "mmba/geodesy/crs_frame.h"
#include "mmba/geodesy/geodesy.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/sim/simulate.h"
#include "test_support.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing_support::ReadText;

fs::path Root() { return testing_support::ScratchRoot("mmba_gis_outputs"); }

const geodesy::Geodetic kOrigin{49.7, 9.3, 180.0};

/// A CSV file's rows by their first column (the header, its first line, names the columns).
std::map<std::string, std::map<std::string, std::string>> CsvRows(const fs::path& path) {
  std::vector<std::string> names;
  const auto rows = testing_support::ReadCsvRows(path, &names);
  std::map<std::string, std::map<std::string, std::string>> by_first;
  for (const auto& row : rows) by_first[row.at(names.at(0))] = row;
  return by_first;
}

double Cell(const std::map<std::string, std::string>& row, const std::string& name) { return std::stod(row.at(name)); }

/// The shell's output and exit status of `command`.
std::string Shell(const std::string& command, int* status) {
  std::string text;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return text;
  char buf[4096];
  for (size_t got; (got = std::fread(buf, 1, sizeof(buf), pipe)) > 0;) text.append(buf, got);
  *status = ::pclose(pipe);
  return text;
}

/// survey/network.xml with every point's x (north), y (east), z converted from the world
/// tangent plane to `crs` (as a surveyor's file in that CRS holds them).
void WriteNetworkInCrs(const fs::path& in, const fs::path& out, const geodesy::CrsFrame& frame) {
  const std::regex point(R"re(<point id="([^"]*)" x="([-0-9.]+)" y="([-0-9.]+)"( z="([-0-9.]+)")?)re");
  std::ifstream from(in);
  std::ofstream to(out);
  for (std::string line; std::getline(from, line);) {
    std::smatch m;
    if (std::regex_search(line, m, point)) {
      const bool has_z = m[4].matched;
      const Eigen::Vector3d world(std::stod(m[3]), std::stod(m[2]), has_z ? std::stod(m[5]) : 0.0);
      const Eigen::Vector3d crs = frame.CrsFromWorld(world);
      char buf[200];
      std::snprintf(buf, sizeof buf, "<point id=\"%s\" x=\"%.6f\" y=\"%.6f\"", m[1].str().c_str(), crs.y(), crs.x());
      std::string replacement = buf;
      if (has_z) {
        std::snprintf(buf, sizeof buf, " z=\"%.6f\"", crs.z());
        replacement += buf;
      }
      line = m.prefix().str() + replacement + m.suffix().str();
    }
    to << line << "\n";
  }
}

class GisOutputsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SetVerbosity(Verbosity::kQuiet);
    fs::remove_all(Root());
    sim::SimulateOptions o;
    o.scene = "gate";
    o.seed = 17;
    o.threads = 2;
    o.origin = kOrigin;
    o.photos.count = 16;
    o.photos.tie_points = 300;
    o.spheres.stations = 0;
    o.rig.frames = 0;
    o.static_scans = 2;
    o.mobile_revolutions = 0;
    o.clouds.surface_samples = 0;
    o.render.samples_per_axis = 1;
    sim::Simulate(o, (Root() / "sim").string());
  }
  static void TearDownTestSuite() {
    outcome_.reset();
    crs_outcomes_.clear();
    if (!std::getenv("MMBA_KEEP_TEST_OUTPUT")) fs::remove_all(Root());
  }
  static fs::path Out() { return Root() / "out"; }
  static fs::path CrsOut(const std::string& code) { return Root() / ("out_" + code.substr(5)); }

  /// The adjustment of the simulated project (run once, by the first test that needs it).
  static const AdjustOutcome& Adjusted() {
    if (!outcome_) {
      outcome_ = std::make_unique<AdjustOutcome>(
          testing_support::RunProject((Root() / "sim" / "project.yaml").string(), Out().string()));
    }
    return *outcome_;
  }

  /// The adjustment of the same project in `code` (a projected CRS; run once per code): the
  /// network's coordinates in the CRS, the origin (taken on the CRS's datum) and the GNSS
  /// latitudes and longitudes as they are.
  static const AdjustOutcome& AdjustedIn(const std::string& code) {
    if (crs_outcomes_.count(code)) return crs_outcomes_.at(code);
    const fs::path sim = Root() / "sim";
    const std::string tag = code.substr(5);
    const auto crs = std::make_shared<const geodesy::Crs>(code, "test");
    WriteNetworkInCrs(sim / "survey" / "network.xml", sim / "survey" / ("network_" + tag + ".xml"),
                      geodesy::CrsFrame(crs, kOrigin));
    std::string yaml = ReadText(sim / "project.yaml");
    yaml = std::regex_replace(yaml, std::regex("survey/network.xml"), "survey/network_" + tag + ".xml");
    yaml = std::regex_replace(yaml, std::regex("\norigin:"), "\ncrs: " + code + "\norigin:");
    std::ofstream(sim / ("project_" + tag + ".yaml")) << yaml;
    return crs_outcomes_[code] =
               testing_support::RunProject((sim / ("project_" + tag + ".yaml")).string(), CrsOut(code).string());
  }

  static std::unique_ptr<AdjustOutcome> outcome_;
  static std::map<std::string, AdjustOutcome> crs_outcomes_;
};

std::unique_ptr<AdjustOutcome> GisOutputsTest::outcome_;
std::map<std::string, AdjustOutcome> GisOutputsTest::crs_outcomes_;

/// Whether report.json `files` names `name`.
bool Listed(const json& report, const std::string& name) {
  for (const json& f : report["files"]) {
    if (f["name"] == name) return true;
  }
  return false;
}

TEST_F(GisOutputsTest, EveryCloudHasALasInUtmOfTheOriginZoneWithItsWkt) {
  ASSERT_TRUE(Adjusted().ok) << Adjusted().reason;
  const geodesy::LocalTangentPlane plane(kOrigin);
  for (const std::string stem : {"tie_points", "error_map_lidar", "lidar_coloured"}) {
    SCOPED_TRACE(stem);
    ASSERT_TRUE(fs::exists(Out() / (stem + ".ply")));
    ASSERT_TRUE(fs::exists(Out() / (stem + ".las")));
    EXPECT_TRUE(Listed(Adjusted().report, stem + ".las"));
    const io::PointCloud ply = io::ReadPly((Out() / (stem + ".ply")).string());
    io::LasInfo info;
    const io::PointCloud las = io::ReadLas((Out() / (stem + ".las")).string(), {}, nullptr, &info);
    ASSERT_EQ(las.size(), ply.size());
    EXPECT_NE(info.crs_wkt.find("WGS 84 / UTM zone 32N"), std::string::npos) << info.crs_wkt.substr(0, 200);
    EXPECT_NE(info.crs_wkt.find("32632"), std::string::npos);
    double worst = 0.0;
    for (size_t i = 0; i < ply.size(); ++i) {
      const geodesy::Geodetic g = plane.GeodeticFromEnu(ply.points[i]);
      const geodesy::Utm u = geodesy::UtmFromGeodetic(g, 32);
      worst = std::max(worst, (las.points[i] - Eigen::Vector3d(u.easting_m, u.northing_m, g.height_m)).cwiseAbs().maxCoeff());
    }
    EXPECT_LE(worst, 0.0005 + 1e-9);  // the 1 mm resolution's rounding
    if (!ply.colors.empty()) {
      ASSERT_EQ(las.colors.size(), ply.colors.size());
      EXPECT_EQ(las.colors[ply.size() / 2], ply.colors[ply.size() / 2]);
    }
  }
}

TEST_F(GisOutputsTest, ErrorMapDistanceIsTheExtraFieldDistanceAndTheIndependentReaderAgrees) {
  ASSERT_TRUE(Adjusted().ok) << Adjusted().reason;
  const fs::path las_path = Out() / "error_map_lidar.las";
  const io::PointCloud ply = io::ReadPly((Out() / "error_map_lidar.ply").string());
  io::LasInfo info;
  const io::PointCloud las = io::ReadLas(las_path.string(), {}, nullptr, &info);
  const io::LasExtraField* distance = info.Field("distance_m");
  ASSERT_NE(distance, nullptr);
  ASSERT_EQ(distance->values.size(), ply.size());
  ASSERT_GT(ply.size(), 50u);
  for (size_t i = 0; i < ply.size(); ++i) ASSERT_EQ(distance->values[i], ply.intensity[i]) << i;
  for (float v : las.intensity) ASSERT_EQ(v, 0.0f);  // the distance is not in the intensity
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  int status = -1;
  const std::string dump = Shell("/usr/bin/python3 " MMBA_SOURCE_DIR "/tests/io_cloud/las14_dump.py '" + las_path.string() + "'", &status);
  ASSERT_EQ(status, 0) << dump.substr(0, 2000);
  std::string one_line_wkt;  // the dump writes line breaks as \n
  for (char c : info.crs_wkt) one_line_wkt += c == '\n' ? std::string("\\n") : std::string(1, c);
  EXPECT_NE(dump.find("\nwkt " + one_line_wkt + "\n"), std::string::npos);
  EXPECT_NE(dump.find("\nextra distance_m 9 "), std::string::npos) << dump.substr(0, 3000);
  // The point lines: x y z intensity return class time extra; x y z and the distance as ReadLas's.
  std::istringstream lines(dump);
  size_t n = 0;
  double worst_xyz = 0.0, worst_distance = 0.0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("point ", 0) != 0) continue;
    std::istringstream row(line.substr(6));
    std::vector<double> v;
    for (double x; row >> x;) v.push_back(x);
    ASSERT_GE(v.size(), 8u) << line;
    ASSERT_LT(n, las.size());
    worst_xyz = std::max(worst_xyz, (Eigen::Vector3d(v[0], v[1], v[2]) - las.points[n]).cwiseAbs().maxCoeff());
    worst_distance = std::max(worst_distance, std::abs(v.back() - distance->values[n]));
    ++n;
  }
  EXPECT_EQ(n, las.size());
  EXPECT_LT(worst_xyz, 1e-6);
  EXPECT_LT(worst_distance, 1e-6);
}

TEST_F(GisOutputsTest, GeoJsonPointsWithClosedEllipsesAndCamerasAtTheCsvPositions) {
  ASSERT_TRUE(Adjusted().ok) << Adjusted().reason;
  EXPECT_TRUE(Listed(Adjusted().report, "points.geojson"));
  EXPECT_TRUE(Listed(Adjusted().report, "cameras.geojson"));
  const json points = json::parse(ReadText(Out() / "points.geojson"));
  EXPECT_EQ(points["type"], "FeatureCollection");
  EXPECT_FALSE(points.contains("crs"));  // RFC 7946 §4
  const auto csv = CsvRows(Out() / "points.csv");
  size_t matched = 0, ellipses = 0;
  for (const json& f : points["features"]) {
    EXPECT_EQ(f["type"], "Feature");
    const std::string id = f["properties"]["id"];
    const json& g = f["geometry"];
    const auto in_range = [](const json& p) {
      return p.size() >= 2 && std::abs(p[0].get<double>()) <= 180 && std::abs(p[1].get<double>()) <= 90;
    };
    if (g["type"] == "Point") {
      ASSERT_TRUE(in_range(g["coordinates"])) << g.dump();
      ASSERT_TRUE(csv.count(id)) << id;
      EXPECT_NEAR(g["coordinates"][0].get<double>(), Cell(csv.at(id), "longitude_deg"), 1e-8) << id;
      EXPECT_NEAR(g["coordinates"][1].get<double>(), Cell(csv.at(id), "latitude_deg"), 1e-8) << id;
      EXPECT_NEAR(g["coordinates"][2].get<double>(), Cell(csv.at(id), "height_m"), 1e-4) << id;
      EXPECT_NEAR(f["properties"]["sigma_east_m"].get<double>(), Cell(csv.at(id), "sigma_east_m"), 1e-6) << id;
      // The 95 % ellipse is the 1-sigma one of points.csv scaled by 2.4477.
      EXPECT_NEAR(f["properties"]["ellipse95_a_m"].get<double>(), 2.4477 * Cell(csv.at(id), "ellipse_a_m"),
                  1e-5 + 1e-4 * Cell(csv.at(id), "ellipse_a_m")) << id;
      ++matched;
    } else {
      ASSERT_EQ(g["type"], "Polygon");
      const json& ring = g["coordinates"][0];
      ASSERT_GE(ring.size(), 4u);
      EXPECT_EQ(ring.front(), ring.back()) << id;  // closed
      for (const json& p : ring) ASSERT_TRUE(in_range(p));
      // Counter-clockwise (RFC 7946's right-hand rule): positive shoelace area, in degrees
      // from the first vertex (an ellipse of 0.1 mm is still 1e-9 deg across).
      double area = 0.0;
      const double lon0 = ring[0][0].get<double>(), lat0 = ring[0][1].get<double>();
      for (size_t k = 0; k + 1 < ring.size(); ++k) {
        const double x0 = ring[k][0].get<double>() - lon0, y0 = ring[k][1].get<double>() - lat0;
        const double x1 = ring[k + 1][0].get<double>() - lon0, y1 = ring[k + 1][1].get<double>() - lat0;
        area += x0 * y1 - x1 * y0;
      }
      if (f["properties"]["ellipse95_b_m"].get<double>() > 1e-4) EXPECT_GT(area, 0.0) << id;
      ++ellipses;
    }
  }
  EXPECT_EQ(matched, csv.size());
  EXPECT_EQ(ellipses, csv.size());
  const json cameras = json::parse(ReadText(Out() / "cameras.geojson"));
  EXPECT_EQ(cameras["type"], "FeatureCollection");
  const auto poses = CsvRows(Out() / "poses.csv");
  ASSERT_EQ(cameras["features"].size(), poses.size());
  for (const json& f : cameras["features"]) {
    const std::string id = f["properties"]["id"];
    ASSERT_TRUE(poses.count(id)) << id;
    EXPECT_NEAR(f["geometry"]["coordinates"][0].get<double>(), Cell(poses.at(id), "longitude_deg"), 1e-8) << id;
    EXPECT_NEAR(f["geometry"]["coordinates"][1].get<double>(), Cell(poses.at(id), "latitude_deg"), 1e-8) << id;
    EXPECT_NEAR(f["properties"]["sigma_up_m"].get<double>(), Cell(poses.at(id), "sigma_up_m"), 1e-6) << id;
  }
}

TEST_F(GisOutputsTest, WithACrsTheLasIsInTheCrsAsPointsCsvAndAsPyprojConvertsIt) {
  const AdjustOutcome& outcome = AdjustedIn("EPSG:25832");
  ASSERT_TRUE(outcome.ok) << outcome.reason;
  const fs::path out_dir = CrsOut("EPSG:25832");
  const auto crs = std::make_shared<const geodesy::Crs>("EPSG:25832", "test");
  const geodesy::CrsFrame frame(crs, kOrigin);
  // points.csv's CRS columns are the world columns converted by this frame ...
  const auto csv = CsvRows(out_dir / "points.csv");
  ASSERT_FALSE(csv.empty());
  for (const auto& [id, row] : csv) {
    const Eigen::Vector3d expected =
        frame.CrsFromWorld(Eigen::Vector3d(Cell(row, "east_m"), Cell(row, "north_m"), Cell(row, "up_m")));
    EXPECT_NEAR(Cell(row, "easting_epsg25832_m"), expected.x(), 1e-4) << id;
    EXPECT_NEAR(Cell(row, "northing_epsg25832_m"), expected.y(), 1e-4) << id;
    EXPECT_NEAR(Cell(row, "height_epsg25832_m"), expected.z(), 1e-4) << id;
  }
  // So are scans.csv's scanner positions (the trajectory's corrected positions go through the
  // same CrsValues; this project has no mobile LiDAR); every CSV starts with its header, as a
  // GIS or a spreadsheet reads it.
  int scans = 0;
  for (const auto& entry : fs::directory_iterator(out_dir)) {
    if (entry.path().extension() != ".csv") continue;
    std::ifstream in(entry.path());
    std::string header;
    std::getline(in, header);
    EXPECT_FALSE(header.empty() || header[0] == '#') << entry.path() << ": " << header;
    const std::string name = entry.path().filename().string();
    if (name != "scans.csv") continue;
    for (const auto& [id, row] : CsvRows(entry.path())) {
      const Eigen::Vector3d expected =
          frame.CrsFromWorld(Eigen::Vector3d(Cell(row, "east_m"), Cell(row, "north_m"), Cell(row, "up_m")));
      EXPECT_NEAR(Cell(row, "easting_epsg25832_m"), expected.x(), 1e-4) << name << " " << id;
      EXPECT_NEAR(Cell(row, "northing_epsg25832_m"), expected.y(), 1e-4) << name << " " << id;
      EXPECT_NEAR(Cell(row, "height_epsg25832_m"), expected.z(), 1e-4) << name << " " << id;
      ++scans;
    }
  }
  EXPECT_GT(scans, 0);
  // points.csv's grid azimuth of the ellipse = its true azimuth + the grid bearing of true north
  // at the point, which pyproj gives from two points 1e-5 deg of latitude apart.
  {
    int status = -1;
    if (Shell("/usr/bin/python3 -c 'import pyproj'", &status), status == 0) {
      std::ofstream(Root() / "north.py")
          << "import pyproj,sys,math\n"
             "t=pyproj.Transformer.from_crs('EPSG:4258','EPSG:25832',always_xy=True)\n"
             "for l in sys.stdin:\n  lat,lon=map(float,l.split())\n"
             "  e0,n0=t.transform(lon,lat)\n  e1,n1=t.transform(lon,lat+1e-5)\n"
             "  print('%.8f'%math.degrees(math.atan2(e1-e0,n1-n0)))\n";
      std::ofstream geodetic(Root() / "north.txt");
      std::vector<std::string> ids;
      for (const auto& [id, row] : csv) {
        geodetic << row.at("latitude_deg") << " " << row.at("longitude_deg") << "\n";
        ids.push_back(id);
      }
      geodetic.close();
      const std::string out = Shell(
          "/usr/bin/python3 " + (Root() / "north.py").string() + " < " + (Root() / "north.txt").string(), &status);
      ASSERT_EQ(status, 0) << out;
      std::istringstream bearings(out);
      for (const std::string& id : ids) {
        double north = 0.0;
        ASSERT_TRUE(bearings >> north) << out;
        const double expected = std::fmod(Cell(csv.at(id), "ellipse_azimuth_deg") + north + 360.0, 180.0);
        const double got = Cell(csv.at(id), "ellipse_azimuth_grid_deg");
        const double d = std::fmod(std::abs(got - expected), 180.0);
        // Both azimuths are printed to 6 significant digits (0.001 deg above 100 deg); the
        // convergence here is about 0.23 deg, so a sign error would show.
        EXPECT_LT(std::min(d, 180.0 - d), 1.5e-3) << id << " grid bearing of north " << north;
        EXPECT_GT(std::abs(north), 0.1);
      }
    }
  }
  // ... and so are the LAS coordinates of the PLY's world points.
  const io::PointCloud ply = io::ReadPly((out_dir / "tie_points.ply").string());
  io::LasInfo info;
  const io::PointCloud las = io::ReadLas((out_dir / "tie_points.las").string(), {}, nullptr, &info);
  ASSERT_EQ(las.size(), ply.size());
  EXPECT_EQ(info.crs_wkt, crs->wkt1());
  EXPECT_NE(info.crs_wkt.find("ETRS89 / UTM zone 32N"), std::string::npos);
  double worst = 0.0;
  for (size_t i = 0; i < ply.size(); ++i) {
    worst = std::max(worst, (las.points[i] - frame.CrsFromWorld(ply.points[i])).cwiseAbs().maxCoeff());
  }
  EXPECT_LE(worst, 0.0005 + 1e-9);
  // PROJ's own pipeline (pyproj): world ENU on GRS80 at the origin → geocentric → UTM 32N.
  int status = -1;
  if (Shell("/usr/bin/python3 -c 'import pyproj'", &status), status != 0) GTEST_SKIP() << "no pyproj";
  std::ostringstream script;
  script << std::setprecision(12)
         << "import pyproj,sys\n"
            "t=pyproj.Transformer.from_pipeline('+proj=pipeline +step +inv +proj=topocentric +ellps=GRS80 +lat_0="
         << kOrigin.latitude_deg << " +lon_0=" << kOrigin.longitude_deg << " +h_0=" << kOrigin.height_m
         << " +step +inv +proj=cart +ellps=GRS80 +step +proj=utm +zone=32 +ellps=GRS80')\n"
            "for l in sys.stdin:\n  e,n,u=map(float,l.split())\n  print('%.4f %.4f %.4f'%t.transform(e,n,u))\n";
  std::ofstream(Root() / "reference.py") << script.str();
  std::ofstream points_in(Root() / "world.txt");
  points_in << std::setprecision(12);
  const size_t step = std::max<size_t>(1, ply.size() / 50);
  for (size_t i = 0; i < ply.size(); i += step) points_in << ply.points[i].transpose() << "\n";
  points_in.close();
  const std::string out =
      Shell("/usr/bin/python3 " + (Root() / "reference.py").string() + " < " + (Root() / "world.txt").string(), &status);
  ASSERT_EQ(status, 0) << out;
  std::istringstream rows(out);
  double worst_proj = 0.0;
  size_t compared = 0;
  for (size_t i = 0; i < ply.size(); i += step, ++compared) {
    Eigen::Vector3d reference;
    ASSERT_TRUE(rows >> reference.x() >> reference.y() >> reference.z()) << out.substr(0, 500);
    worst_proj = std::max(worst_proj, (las.points[i] - reference).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(compared, 20u);
  EXPECT_LT(worst_proj, 0.001) << "LAS vs pyproj, worst coordinate difference (m)";
  std::cout << "EPSG:25832 LAS vs pyproj: " << compared << " points, worst " << worst_proj << " m\n";
  // The GeoJSON in WGS84: ETRS89 to WGS 84 is PROJ's null transformation here, so the point
  // is at points.csv's latitude and longitude (on ETRS89).
  const json points = json::parse(ReadText(out_dir / "points.geojson"));
  ASSERT_FALSE(points["features"].empty());
  const json& first = points["features"][0];
  const auto& row = csv.at(first["properties"]["id"].get<std::string>());
  EXPECT_NEAR(first["geometry"]["coordinates"][0].get<double>(), Cell(row, "longitude_deg"), 1e-8);
  EXPECT_NEAR(first["geometry"]["coordinates"][1].get<double>(), Cell(row, "latitude_deg"), 1e-8);
}

// A CRS on another datum (DHDN / 3-degree Gauss-Kruger zone 3, Bessel 1841): the GeoJSON is
// in WGS84 through PROJ's DHDN → WGS 84 transformation, as pyproj transforms points.csv's
// latitude, longitude and height (on DHDN) from EPSG:4314 (3-D) to EPSG:4979; the shift is
// about 100 m, so the datum step is not skipped.
TEST_F(GisOutputsTest, OnAnotherDatumTheGeoJsonIsTransformedToWgs84AsPyprojDoes) {
  int status = -1;
  if (Shell("/usr/bin/python3 -c 'import pyproj'", &status), status != 0) GTEST_SKIP() << "no pyproj";
  const AdjustOutcome& outcome = AdjustedIn("EPSG:31467");
  ASSERT_TRUE(outcome.ok) << outcome.reason;
  const fs::path out_dir = CrsOut("EPSG:31467");
  io::LasInfo info;
  io::ReadLas((out_dir / "tie_points.las").string(), {}, nullptr, &info);
  EXPECT_NE(info.crs_wkt.find("DHDN / 3-degree Gauss-Kruger zone 3"), std::string::npos) << info.crs_wkt.substr(0, 200);
  const auto csv = CsvRows(out_dir / "points.csv");
  const json points = json::parse(ReadText(out_dir / "points.geojson"));
  std::ofstream(Root() / "datum.py")
      << "import pyproj,sys\n"
         "t=pyproj.Transformer.from_crs(pyproj.CRS('EPSG:4314').to_3d(),'EPSG:4979',always_xy=True)\n"
         "for l in sys.stdin:\n  lat,lon,h=map(float,l.split())\n  print('%.10f %.10f %.4f'%t.transform(lon,lat,h))\n";
  std::ofstream geodetic(Root() / "dhdn.txt");
  std::vector<json> features;
  for (const json& f : points["features"]) {
    if (f["geometry"]["type"] != "Point") continue;
    const auto& row = csv.at(f["properties"]["id"].get<std::string>());
    geodetic << row.at("latitude_deg") << " " << row.at("longitude_deg") << " " << row.at("height_m") << "\n";
    features.push_back(f);
  }
  geodetic.close();
  const std::string out =
      Shell("/usr/bin/python3 " + (Root() / "datum.py").string() + " < " + (Root() / "dhdn.txt").string(), &status);
  ASSERT_EQ(status, 0) << out;
  std::istringstream rows(out);
  double worst_deg = 0.0, worst_h = 0.0, shift_deg = 0.0;
  for (const json& f : features) {
    double lon, lat, h;
    ASSERT_TRUE(rows >> lon >> lat >> h) << out.substr(0, 500);
    const json& c = f["geometry"]["coordinates"];
    worst_deg = std::max({worst_deg, std::abs(c[0].get<double>() - lon), std::abs(c[1].get<double>() - lat)});
    worst_h = std::max(worst_h, std::abs(c[2].get<double>() - h));
    const auto& row = csv.at(f["properties"]["id"].get<std::string>());
    shift_deg = std::max(shift_deg, std::abs(c[0].get<double>() - Cell(row, "longitude_deg")));
  }
  ASSERT_FALSE(features.empty());
  EXPECT_LT(worst_deg, 1e-8);  // 1 mm; points.csv holds 10 significant digits (5e-9 deg here)
  EXPECT_LT(worst_h, 2e-4);
  EXPECT_GT(shift_deg, 5e-4);  // the datum shift, about 0.001 deg of longitude here
  std::cout << "DHDN -> WGS84 in points.geojson vs pyproj: " << features.size() << " points, worst " << worst_deg
            << " deg, " << worst_h << " m; datum shift " << shift_deg << " deg of longitude\n";
}

}  // namespace
}  // namespace mmba::adjust
