// A Leica GSI field file adjusted as a network: data/gsi/network.GSI read, reduced and
// adjusted as a free network, and its gama-local export read back gives the same adjustment
// (library and `mmba survey`); known points from a CSV; exit codes of the command.
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/io_survey/field_job.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/gama_local_writer.h"
#include "mmba/survey/adjust.h"

namespace mmba::survey {
namespace {
namespace fs = std::filesystem;

std::string Source(const std::string& path) { return std::string(MMBA_SOURCE_DIR) + "/" + path; }

int RunMmba(const std::string& args) {
  const std::string command = std::string(MMBA_BINARY_DIR) + "/apps/mmba survey " + args + " > /dev/null 2>&1";
  return WEXITSTATUS(std::system(command.c_str()));
}

TEST(GsiNetwork, FreeNetworkAndItsGamaLocalExportAdjustAlike) {
  io::FieldJob job = io::ReadFieldJob(Source("data/gsi/network.GSI"), {}, FaceReductionOptions());
  const std::string xml = io::GamaLocalText(job.network);
  SurveyNetwork from_gsi = std::move(job.network);
  const SurveyAdjustment a = AdjustNetwork(&from_gsi, SurveyAdjustOptions());
  ASSERT_TRUE(a.converged) << a.reason;
  EXPECT_EQ(a.statistics.degrees_of_freedom, 1884);  // 2100 observations - 220 unknowns + defect 4
  EXPECT_GT(a.statistics.sigma0_ratio, 0.85);
  EXPECT_LT(a.statistics.sigma0_ratio, 1.0);
  EXPECT_NE(a.datum.find("free network"), std::string::npos) << a.datum;

  SurveyNetwork from_xml = io::ParseGamaLocal(xml, "export.xml");
  ASSERT_EQ(from_xml.clusters.size(), 154u);
  const SurveyAdjustment b = AdjustNetwork(&from_xml, SurveyAdjustOptions());
  ASSERT_TRUE(b.converged) << b.reason;
  EXPECT_EQ(b.statistics.degrees_of_freedom, a.statistics.degrees_of_freedom);
  EXPECT_NEAR(b.statistics.sigma0_ratio, a.statistics.sigma0_ratio, 1e-6);
  ASSERT_EQ(from_xml.points.size(), from_gsi.points.size());
  for (const SurveyPoint& p : from_gsi.points) {
    const SurveyPoint* q = from_xml.Find(p.id);
    ASSERT_NE(q, nullptr) << p.id;
    EXPECT_LT((p.coords - q->coords).cwiseAbs().maxCoeff(), 1e-6) << p.id;
    const Eigen::Matrix3d ca = PointCovariance(a, from_gsi, p);
    const Eigen::Matrix3d cb = PointCovariance(b, from_xml, *q);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(std::sqrt(cb(k, k)), std::sqrt(ca(k, k)), 1e-4 * std::sqrt(ca(k, k))) << p.id;
    }
  }
}

TEST(GsiNetwork, KnownPointsFromCsvFixTheNetwork) {
  io::FieldJob free_job = io::ReadFieldJob(Source("data/gsi/network.GSI"), {}, FaceReductionOptions());
  ASSERT_TRUE(AdjustNetwork(&free_job.network, SurveyAdjustOptions()).converged);
  const Eigen::Vector3d offset(650000.0, 250000.0, 100.0);
  const fs::path csv = fs::temp_directory_path() / "mmba_gsi_known.csv";
  {
    std::ofstream out(csv);
    out << "id,east,north,height\n";
    for (const char* id : {"BP04", "P4"}) {
      const Eigen::Vector3d c = free_job.network.Find(id)->coords + offset;
      out.precision(12);
      out << id << "," << c.x() << "," << c.y() << "," << c.z() << "\n";
    }
  }
  io::FieldJob job = io::ReadFieldJob(Source("data/gsi/network.GSI"), {csv.string()}, FaceReductionOptions());
  EXPECT_EQ(job.network.Find("BP04")->xy, CoordStatus::kFixed);
  EXPECT_EQ(job.network.Find("BP07")->xy, CoordStatus::kAdjusted);
  const SurveyAdjustment adj = AdjustNetwork(&job.network, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged) << adj.reason;
  EXPECT_EQ(adj.statistics.degrees_of_freedom, 2100 - (220 - 6));  // 6 fixed coordinates, no defect
  // Fixed on the free network's own coordinates: every point within 2 mm of them.
  for (const SurveyPoint& p : job.network.points) {
    const Eigen::Vector3d expected = free_job.network.Find(p.id)->coords + offset;
    EXPECT_LT((p.coords - expected).cwiseAbs().maxCoeff(), 2e-3) << p.id;
  }
  fs::remove(csv);
  // Known points of another job: none in the network.
  try {
    io::ReadFieldJob(Source("data/gsi/network.GSI"), {Source("data/gsi/coords.gsi")}, FaceReductionOptions());
    ADD_FAILURE() << "coords.gsi accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("coords.gsi"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("none of its 40 point(s)"), std::string::npos) << e.what();
  }
}

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(GsiNetwork, CommandExportsAndAdjustsAlike) {
  const fs::path dir = fs::temp_directory_path() / "mmba_gsi_command_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string gsi = Source("data/gsi/network.GSI");
  const fs::path xml = dir / "network.xml";
  ASSERT_EQ(RunMmba("--input " + gsi + " --export-gama-local " + xml.string()), 0);
  ASSERT_TRUE(fs::exists(xml));
  ASSERT_EQ(RunMmba("--input " + gsi + " --output " + (dir / "gsi").string()), 0);
  ASSERT_EQ(RunMmba(xml.string() + " --output " + (dir / "xml").string()), 0);
  const nlohmann::json a = ReadJson(dir / "gsi" / "adjusted.json");
  const nlohmann::json b = ReadJson(dir / "xml" / "adjusted.json");
  EXPECT_EQ(a["degrees_of_freedom"], b["degrees_of_freedom"]);
  EXPECT_NEAR(a["sigma0_aposteriori"].get<double>(), b["sigma0_aposteriori"].get<double>(), 1e-6);
  ASSERT_EQ(a["points"].size(), 22u);
  ASSERT_EQ(b["points"].size(), 22u);
  for (size_t k = 0; k < a["points"].size(); ++k) {
    const auto& p = a["points"][k];
    const auto& q = b["points"][k];
    ASSERT_EQ(p["id"], q["id"]);
    for (const char* c : {"x", "y", "z"}) {
      EXPECT_NEAR(p[c].get<double>(), q[c].get<double>(), 1e-6) << p["id"] << " " << c;
    }
  }
  ASSERT_TRUE(a.contains("face_reduction"));
  EXPECT_EQ(a["face_reduction"]["pairs"], 700);
  EXPECT_EQ(a["face_reduction"]["setups"].size(), 22u);
  std::ifstream faces(dir / "gsi" / "face_differences.csv");
  std::string line;
  int rows = -1;
  while (std::getline(faces, line)) ++rows;
  EXPECT_EQ(rows, 700);
  // Bad input: exit 2, nothing written.
  EXPECT_EQ(RunMmba(Source("tests/data/gsi/bad_word_index.gsi") + " --output " + (dir / "bad").string()), 2);
  EXPECT_FALSE(fs::exists(dir / "bad"));
  EXPECT_EQ(RunMmba(Source("tests/data/gsi/truncated.gsi") + " --export-gama-local " + (dir / "t.xml").string()), 2);
  EXPECT_FALSE(fs::exists(dir / "t.xml"));
  EXPECT_EQ(RunMmba(xml.string() + " --known " + gsi + " --output " + (dir / "k").string()), 2);
  EXPECT_EQ(RunMmba(gsi + " --set no_such_setting=1 --output " + (dir / "s").string()), 2);
  EXPECT_EQ(RunMmba(gsi), 2);  // neither --output nor --export-gama-local
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mmba::survey
