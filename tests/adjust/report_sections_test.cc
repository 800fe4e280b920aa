// report.json of `mmba adjust` holds what report.html renders for a client (docs/report.md):
// the project folder and file, every adjusted point with σ and ellipse, the relative precision
// of neighbouring points, the observations with redundancy and studentized residual, and the
// settings in force; the page renders them without an error. On DBAT's camcaldemo (a
// photo_measurements block whose points the adjustment eliminates) and on a total-station
// network in EPSG:25832.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include <Eigen/Core>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/report/adjust_report.h"
#include "test_support.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing_support::ReadText;
using testing_support::RunProject;
using testing_support::ScratchRoot;

const fs::path kCamcal = fs::path(MMBA_SOURCE_DIR) / "data/dbat/camcaldemo";

void ExpectVec3(const json& v, const std::string& what) {
  ASSERT_TRUE(v.is_array()) << what << ": " << v.dump();
  ASSERT_EQ(v.size(), 3u) << what;
  for (const json& x : v) EXPECT_TRUE(x.is_number()) << what << ": " << v.dump();
}

/// The `points` entries: {id, role, adjusted[3], sigma[3], ellipse {a >= b >= 0, azimuth_deg}}.
void ExpectPointShapes(const json& points) {
  ASSERT_TRUE(points.is_array());
  for (const json& p : points) {
    ASSERT_TRUE(p["id"].is_string()) << p.dump();
    ASSERT_TRUE(p["role"].is_string()) << p.dump();
    ExpectVec3(p["adjusted"], "adjusted");
    ExpectVec3(p["sigma"], "sigma");
    const json& e = p["ellipse"];
    ASSERT_TRUE(e.is_object()) << p.dump();
    EXPECT_GE(e["a"].get<double>(), e["b"].get<double>()) << p.dump();
    EXPECT_GE(e["b"].get<double>(), 0.0) << p.dump();
    EXPECT_GT(p["sigma"][0].get<double>() + p["sigma"][1].get<double>() + p["sigma"][2].get<double>(), 0.0) << p.dump();
  }
}

/// Data rows of a CSV (the lines after its header).
size_t DataRows(const fs::path& csv) { return testing_support::ReadCsvRows(csv).size(); }

/// The page renders and holds the sections of the keys written.
void ExpectSections(const json& report, const std::vector<std::string>& ids) {
  std::string html;
  ASSERT_NO_THROW(html = report::RenderAdjustReportHtml(report));
  for (const std::string& id : ids) EXPECT_NE(html.find("<section id=\"" + id + "\">"), std::string::npos) << id;
}

TEST(AdjustReportSections, CamcaldemoWritesThePointsObservationsAndSettings) {
  const fs::path out = ScratchRoot("report_sections") / "camcal";
  fs::remove_all(out);
  const AdjustOutcome outcome = RunProject((kCamcal / "project.yaml").string(), out.string());
  ASSERT_TRUE(outcome.ok) << outcome.status << ": " << outcome.reason;
  const json report = json::parse(ReadText(out / "report.json"));
  EXPECT_EQ(fs::path(report["project_dir"].get<std::string>()), fs::canonical(kCamcal));
  EXPECT_EQ(fs::path(report["project_file"].get<std::string>()), fs::canonical(kCamcal / "project.yaml"));
  // 96 object points adjusted; the 4 corners are held (σ 0) and left out.
  const json& points = report["points"];
  EXPECT_EQ(points.size(), 96u);
  ExpectPointShapes(points);
  EXPECT_EQ(points[0]["role"], "tie");
  EXPECT_EQ(report["points_file"], "c4040z_points.csv");
  // Relative precision of the points the adjustment eliminated (Schur complement): their
  // covariance through the back-substitution gain. |Cov(x_i, x_j)| <= σ_i σ_j (Cauchy–Schwarz),
  // so σ of a difference lies within |σ_i − σ_j| and σ_i + σ_j per axis.
  std::map<std::string, json> by_id;
  for (const json& p : points) by_id[p["id"].get<std::string>()] = p["sigma"];
  const json& relative = report["relative_precision"];
  ASSERT_GE(relative.size(), 96u) << relative.size();
  for (const json& r : relative) {
    const json& si = by_id.at(r["from"].get<std::string>());
    const json& sj = by_id.at(r["to"].get<std::string>());
    for (int k = 0; k < 3; ++k) {
      const double a = si[k].get<double>(), b = sj[k].get<double>(), d = r["sigma"][k].get<double>();
      EXPECT_LE(d, (a + b) * (1 + 1e-9)) << r.dump();
      EXPECT_GE(d, std::abs(a - b) * (1 - 1e-9)) << r.dump();
    }
  }
  // Every row of observations.csv counted; 300 listed, by decreasing |w|.
  const json& obs = report["observations"];
  EXPECT_EQ(obs["file"], "observations.csv");
  EXPECT_EQ(obs["total"].get<size_t>(), DataRows(out / "observations.csv"));
  EXPECT_EQ(obs["rows"].size(), std::min<size_t>(300, obs["total"].get<size_t>()));
  EXPECT_GE(std::abs(obs["rows"][0]["studentized"].get<double>()), std::abs(obs["rows"][1]["studentized"].get<double>()));
  EXPECT_EQ(obs["rows"][0]["unit"], "px");
  const json& settings = report["settings"];
  EXPECT_EQ(settings["variance_components"], false);
  EXPECT_EQ(settings["max_iterations"], 100);
  EXPECT_DOUBLE_EQ(settings["confidence"].get<double>(), 0.95);
  ExpectSections(report, {"points", "relative", "observations", "settings", "images"});
  // The project file is shown relative to the project folder.
  const std::string html = ReadText(out / "report.html");
  EXPECT_NE(html.find("<tr><th>Project file</th><td><code>project.yaml</code></td></tr>"), std::string::npos);
}

/// A trilateration network in EPSG:25832: A, B held, P1..P4 adjusted from distances and height
/// differences (σ 2 mm and 1 mm), observed with normal errors of those σ.
void WriteNetwork(const fs::path& dir) {
  fs::create_directories(dir);
  const std::map<std::string, Eigen::Vector3d> truth = {
      {"A", {690000.0, 5334000.0, 500.0}},  {"B", {690100.0, 5334000.0, 500.5}},
      {"P1", {690050.0, 5334080.0, 502.0}}, {"P2", {690020.0, 5333950.0, 498.0}},
      {"P3", {690120.0, 5334060.0, 501.0}}, {"P4", {689960.0, 5334040.0, 499.0}}};
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::ofstream net(dir / "network.csv");
  net << std::fixed << std::setprecision(4) << "param,axes-xy,en\n";
  for (const auto& [id, x] : truth) {
    const bool held = id.size() == 1;
    const Eigen::Vector3d start = held ? x : Eigen::Vector3d(x + Eigen::Vector3d(0.3, -0.2, 0.1));
    net << "point," << id << "," << start.x() << "," << start.y() << "," << start.z() << "," << (held ? "xyz," : ",xyz") << "\n";
  }
  for (auto i = truth.begin(); i != truth.end(); ++i) {
    for (auto j = std::next(i); j != truth.end(); ++j) {
      const Eigen::Vector3d d = j->second - i->second;
      net << "distance," << i->first << "," << j->first << "," << std::hypot(d.x(), d.y()) + 0.002 * noise(rng) << ",2\n"
          << "dh," << i->first << "," << j->first << "," << d.z() + 0.001 * noise(rng) << ",1\n";
    }
  }
  std::ofstream(dir / "project.yaml") << "mmba_project: 1\nname: net\ncrs: EPSG:25832\n"
                                         "sensors:\n  - {id: ts, type: total_station, file: network.csv}\n"
                                         "adjustment: {variance_components: false}\n";
}

TEST(AdjustReportSections, ANetworkWritesItsPointsAndTheirRelativePrecision) {
  const fs::path dir = ScratchRoot("report_sections") / "net";
  fs::remove_all(dir);
  WriteNetwork(dir);
  const AdjustOutcome outcome = RunProject((dir / "project.yaml").string(), (dir / "out").string());
  ASSERT_TRUE(outcome.ok) << outcome.status << ": " << outcome.reason;
  const json report = json::parse(ReadText(dir / "out/report.json"));
  const json& points = report["points"];
  ASSERT_EQ(points.size(), 4u) << points.dump(1);
  ExpectPointShapes(points);
  for (const json& p : points) EXPECT_EQ(p["role"], "adjusted");
  EXPECT_EQ(report["points_file"], "points.csv");
  // Each of the 4 points with its 2 nearest neighbours in plan: at least 4 unique pairs.
  const json& relative = report["relative_precision"];
  ASSERT_GE(relative.size(), 4u) << relative.dump(1);
  for (const json& r : relative) {
    EXPECT_GT(r["distance_m"].get<double>(), 20.0) << r.dump();
    // Each pair's distance is observed (σ 2 mm); the others' add to it: σ at most 2 mm.
    EXPECT_GT(r["sigma_distance_m"].get<double>(), 0.0) << r.dump();
    EXPECT_LT(r["sigma_distance_m"].get<double>(), 0.002) << r.dump();
    EXPECT_DOUBLE_EQ(r["ellipse"]["confidence"].get<double>(), 0.95);
  }
  EXPECT_EQ(report["observations"]["total"].get<size_t>(), 30u);  // 15 distances, 15 dh
  ExpectSections(report, {"points", "relative", "observations", "settings", "crs"});
}

}  // namespace
}  // namespace mmba::adjust
