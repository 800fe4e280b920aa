// Coordinates in a national CRS through `mmba adjust` and `mmba survey --crs`: a simulated
// total-station network whose control is given in the CRS (computed by pyproj from the truth)
// is adjusted once in the CRS and once in the local tangent plane; the adjusted coordinates in
// the CRS agree with the local adjustment converted by PROJ's own transformation (pyproj,
// tests/apps/adjust_crs_reference.py) within 1 mm. An unknown EPSG code is exit 2 naming the
// file and line (or the option) and the value, with nothing written.
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <vector>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "shell.h"

namespace mmba::test {
namespace {

namespace fs = std::filesystem;

const std::string kMmba = MMBA_EXECUTABLE;
const std::string kReference = "/usr/bin/python3 " MMBA_SOURCE_DIR "/tests/apps/adjust_crs_reference.py";

bool HavePyproj() { return RunShell("/usr/bin/python3 -c 'import pyproj'").exit_code == 0; }

/// The figure after `key` in the reference script's output, or -1.
double Figure(const std::string& output, const std::string& key) {
  const size_t at = output.find(key + " ");
  return at == std::string::npos ? -1.0 : std::stod(output.substr(at + key.size() + 1));
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class AdjustCrsTest : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    if (!HavePyproj()) GTEST_SKIP() << "no pyproj for /usr/bin/python3 (Debian python3-pyproj)";
    dir_ = fs::path(::testing::TempDir()) / ("mmba_adjust_crs_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// Runs `command`, expecting exit 0.
  std::string Run(const std::string& command) {
    const RunResult run = RunShell(command);
    EXPECT_EQ(run.exit_code, 0) << command << "\n" << run.output;
    return run.output;
  }

  fs::path dir_;
};

struct Place {
  const char* code;
  const char* lat;
  const char* lon;
};

// ETRS89 / UTM 32N near Würzburg; RGF93 / Lambert-93 in the Massif Central.
const Place kPlaces[] = {{"EPSG:25832", "49.7", "9.3"}, {"EPSG:2154", "45.6", "3.4"}};

Place PlaceOf(const std::string& code) {
  for (const Place& p : kPlaces) {
    if (code == p.code) return p;
  }
  return kPlaces[0];
}

TEST_P(AdjustCrsTest, AdjustInTheCrsEqualsTheLocalFrameAdjustmentConvertedByPyproj) {
  const Place place = PlaceOf(GetParam());
  const std::string d = dir_.string();
  Run(kReference + " make " + d + " " + place.code + " " + place.lat + " " + place.lon);
  Run(kMmba + " adjust " + d + "/project_crs.yaml --output " + d + "/out_crs");
  Run(kReference + " local " + d + " " + place.code + " " + d + "/out_crs/report.json");
  Run(kMmba + " adjust " + d + "/project_local.yaml --output " + d + "/out_local");
  const std::string compared =
      Run(kReference + " compare-adjust " + d + " " + place.code + " " + d + "/out_crs " + d + "/out_local");
  EXPECT_EQ(Figure(compared, "points"), 7) << compared;
  const double max_difference = Figure(compared, "max_difference_m");
  EXPECT_GE(max_difference, 0.0) << compared;
  EXPECT_LT(max_difference, 0.001) << compared;
  std::cout << place.code << " adjust: " << compared;
  // The CRS named in the outputs: the CSV header and report.json.
  const std::string tag = std::string("epsg") + (place.code + 5);
  const std::string points = ReadFile(dir_ / "out_crs" / "points.csv");
  EXPECT_NE(points.find(",easting_" + tag + "_m,northing_" + tag + "_m,height_" + tag + "_m,ellipse_azimuth_grid_deg\n"),
            std::string::npos)
      << points.substr(0, 600);
  const std::string report = ReadFile(dir_ / "out_crs" / "report.json");
  EXPECT_NE(report.find("\"epsg\": " + std::string(place.code + 5)), std::string::npos);
  EXPECT_NE(report.find("\"height_kind\": \"as given\""), std::string::npos);
  EXPECT_NE(report.find("mean of 7 point(s) of network_crs.csv"), std::string::npos);
}

TEST_P(AdjustCrsTest, SurveyWithCrsEqualsTheLocalFrameSurveyConvertedByPyproj) {
  const Place place = PlaceOf(GetParam());
  const std::string d = dir_.string();
  Run(kReference + " make " + d + " " + place.code + " " + place.lat + " " + place.lon);
  Run(kMmba + " survey " + d + "/network_crs.csv --crs " + place.code + " --output " + d + "/survey_crs");
  Run(kReference + " local " + d + " " + place.code + " " + d + "/survey_crs/adjusted.json");
  Run(kMmba + " survey " + d + "/network_local.csv --output " + d + "/survey_local");
  const std::string compared =
      Run(kReference + " compare-survey " + d + " " + place.code + " " + d + "/survey_crs " + d + "/survey_local");
  EXPECT_EQ(Figure(compared, "points"), 7) << compared;
  const double max_difference = Figure(compared, "max_difference_m");
  EXPECT_GE(max_difference, 0.0) << compared;
  EXPECT_LT(max_difference, 0.001) << compared;
  std::cout << place.code << " survey: " << compared;
  const std::string adjusted = ReadFile(dir_ / "survey_crs" / "adjusted.json");
  EXPECT_NE(adjusted.find("\"identifier\": \"" + std::string(place.code) + "\""), std::string::npos);
  EXPECT_NE(adjusted.find("\"combined_scale\""), std::string::npos);
  EXPECT_NE(adjusted.find("\"latitude_deg\""), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Crs, AdjustCrsTest, ::testing::Values("EPSG:25832", "EPSG:2154"));

/// A CSV file's rows by their first column (the header names the columns), the # line skipped.
std::map<std::string, std::map<std::string, std::string>> CsvRows(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> names;
  std::map<std::string, std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (names.empty()) {
      names = cells;
      continue;
    }
    for (size_t i = 0; i < cells.size() && i < names.size(); ++i) rows[cells[0]][names[i]] = cells[i];
  }
  return rows;
}

// GNSS control in the project's crs (easting_m, northing_m, height_m): a mark 3 mm east of
// where the network alone puts it (σ of the point there ≈ 1 mm), with σ 1 mm, pulls the
// adjusted point about half-way east, not north.
TEST_F(AdjustCrsTest, GnssRowsInTheCrsPullTheirPointInTheGrid) {
  const std::string d = dir_.string();
  Run(kReference + " make " + d + " EPSG:25832 49.7 9.3");
  Run(kMmba + " adjust " + d + "/project_crs.yaml --output " + d + "/out_alone");
  const auto alone = CsvRows(dir_ / "out_alone" / "points.csv").at("D");
  const double east = std::stod(alone.at("easting_epsg25832_m")), north = std::stod(alone.at("northing_epsg25832_m"));
  std::ofstream(dir_ / "gnss.csv") << "id,kind,easting_m,northing_m,height_m,sigma_east_m,sigma_north_m,sigma_up_m\n"
                                   << "D,control," << std::to_string(east + 0.003) << "," << std::to_string(north) << ","
                                   << alone.at("height_epsg25832_m") << ",0.001,0.001,0.001\n";
  std::ofstream(dir_ / "project_gnss.yaml") << "mmba_project: 1\nname: g\ncrs: EPSG:25832\nsensors:\n"
                                            << "  - {id: ts, type: total_station, file: network_crs.csv}\n"
                                            << "  - {id: g, type: gnss, file: gnss.csv}\n";
  Run(kMmba + " adjust " + d + "/project_gnss.yaml --output " + d + "/out_gnss");
  const auto pulled = CsvRows(dir_ / "out_gnss" / "points.csv").at("D");
  const double d_east = std::stod(pulled.at("easting_epsg25832_m")) - east;
  const double d_north = std::stod(pulled.at("northing_epsg25832_m")) - north;
  EXPECT_GT(d_east, 0.0008) << d_east;
  EXPECT_LT(d_east, 0.0025) << d_east;
  EXPECT_LT(std::abs(d_north), 0.0005) << d_north;
  // Without a crs, easting/northing columns are refused naming the file.
  std::ofstream(dir_ / "project_nocrs.yaml") << "mmba_project: 1\nname: n\n"
                                             << "origin: {latitude_deg: 49.7, longitude_deg: 9.3, height_m: 150}\nsensors:\n"
                                             << "  - {id: ts, type: total_station, file: network_crs.csv}\n"
                                             << "  - {id: g, type: gnss, file: gnss.csv}\n";
  const RunResult refused = RunShell(kMmba + " adjust " + d + "/project_nocrs.yaml --output " + d + "/out_nocrs");
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("gnss.csv:1"), std::string::npos) << refused.output;
}

// The same network with orthometric heights H = h − N in EPSG:25832+7837 (ETRS89 / UTM 32N +
// DHHN2016) and a geoid grid of constant N = 47.25 m: the same ellipsoidal heights and plane
// coordinates as with ellipsoidal heights in EPSG:25832, the CRS heights 47.25 m lower.
TEST_F(AdjustCrsTest, CompoundCrsWithAGeoidGridGivesOrthometricHeights) {
  const std::string d = dir_.string();
  Run(kReference + " make " + d + " EPSG:25832 49.7 9.3");
  std::ofstream grid(dir_ / "geoid.gtx", std::ios::binary);  // NOAA GTX: big-endian header, float32 rows
  const auto put = [&grid](const void* value, int size) {
    for (int i = size - 1; i >= 0; --i) grid.put(static_cast<const char*>(value)[i]);
  };
  for (double v : {40.0, 0.0, 1.0, 1.0}) put(&v, 8);
  for (int32_t v : {21, 21}) put(&v, 4);
  const float undulation = 47.25f;
  for (int i = 0; i < 21 * 21; ++i) put(&undulation, 4);
  grid.close();
  std::ifstream in(dir_ / "network_crs.csv");
  std::ofstream out(dir_ / "network_h.csv");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("point,", 0) == 0) {  // point,id,x,y,z,fix,adj
      std::vector<std::string> c;
      std::stringstream ss(line);
      for (std::string cell; std::getline(ss, cell, ',');) c.push_back(cell);
      c[4] = std::to_string(std::stod(c[4]) - 47.25);
      line = c[0];
      for (size_t i = 1; i < 7; ++i) line += "," + (i < c.size() ? c[i] : "");
    }
    out << line << "\n";
  }
  out.close();
  std::ofstream(dir_ / "project_h.yaml") << "mmba_project: 1\nname: h\ncrs: EPSG:25832+7837\ngeoid_grid: geoid.gtx\n"
                                         << "sensors:\n  - {id: ts, type: total_station, file: network_h.csv}\n";
  Run(kMmba + " adjust " + d + "/project_h.yaml --output " + d + "/out_h");
  Run(kMmba + " adjust " + d + "/project_crs.yaml --output " + d + "/out_e");
  const auto h = CsvRows(dir_ / "out_h" / "points.csv");
  const auto e = CsvRows(dir_ / "out_e" / "points.csv");
  ASSERT_EQ(h.size(), 7u);
  for (const auto& [id, row] : h) {
    const auto& other = e.at(id);
    EXPECT_NEAR(std::stod(row.at("easting_epsg25832_7837_m")), std::stod(other.at("easting_epsg25832_m")), 2e-4) << id;
    EXPECT_NEAR(std::stod(row.at("height_epsg25832_7837_m")), std::stod(other.at("height_epsg25832_m")) - 47.25, 2e-4) << id;
    EXPECT_NEAR(std::stod(row.at("height_m")), std::stod(other.at("height_m")), 2e-4) << id;  // ellipsoidal
  }
  const std::string report = ReadFile(dir_ / "out_h" / "report.json");
  EXPECT_NE(report.find("\"height_kind\": \"orthometric\""), std::string::npos);
  EXPECT_NE(report.find("\"geoid_grid\": \"geoid.gtx\""), std::string::npos);
  // mmba survey --crs --geoid-grid: the same.
  Run(kMmba + " survey " + d + "/network_h.csv --crs EPSG:25832+7837 --geoid-grid " + d + "/geoid.gtx --output " + d +
      "/survey_h");
  Run(kMmba + " survey " + d + "/network_crs.csv --crs EPSG:25832 --output " + d + "/survey_e");
  const auto points = [](const fs::path& path) {
    std::map<std::string, nlohmann::json> out;
    const nlohmann::json adjusted = nlohmann::json::parse(ReadFile(path));
    for (const nlohmann::json& p : adjusted["points"]) out[p["id"].get<std::string>()] = p;
    return out;
  };
  const auto sh = points(dir_ / "survey_h" / "adjusted.json"), se = points(dir_ / "survey_e" / "adjusted.json");
  ASSERT_EQ(sh.size(), 7u);
  for (const auto& [id, p] : sh) {
    EXPECT_NEAR(p["x"].get<double>(), se.at(id)["x"].get<double>(), 1e-6) << id;
    EXPECT_NEAR(p["z"].get<double>(), se.at(id)["z"].get<double>() - 47.25, 1e-6) << id;
    EXPECT_NEAR(p["ellipsoidal_height_m"].get<double>(), se.at(id)["ellipsoidal_height_m"].get<double>(), 1e-6) << id;
  }
}

class UnknownCrsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("mmba_unknown_crs_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "network.csv") << "param,axes-xy,en\n"
                                        << "point,M1,500000,5500000,100,xyz,\n"
                                        << "point,M2,500100,5500000,100,xyz,\n"
                                        << "point,M3,500000,5500100,100,,xyz\n"
                                        << "distance,M1,M3,100.001,2\n"
                                        << "distance,M2,M3,141.422,2\n"
                                        << "dh,M1,M3,0.001,2\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(UnknownCrsTest, InTheProjectFileIsExit2NamingFileLineAndValue) {
  std::ofstream(dir_ / "project.yaml") << "mmba_project: 1\nname: t\n"
                                       << "crs: EPSG:999999\n"
                                       << "sensors:\n  - {id: ts, type: total_station, file: network.csv}\n";
  const RunResult run = RunShell(kMmba + " adjust " + (dir_ / "project.yaml").string() + " --output " +
                                 (dir_ / "out").string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("project.yaml:3"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("'EPSG:999999'"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(UnknownCrsTest, ForSurveyIsExit2NamingTheOptionAndValue) {
  const RunResult run = RunShell(kMmba + " survey " + (dir_ / "network.csv").string() +
                                 " --crs EPSG:999999 --output " + (dir_ / "out").string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("--crs"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("'EPSG:999999'"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  // A known CRS adjusts the same file.
  const RunResult ok = RunShell(kMmba + " survey " + (dir_ / "network.csv").string() +
                                " --crs EPSG:25832 --output " + (dir_ / "out").string());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
}

}  // namespace
}  // namespace mmba::test
