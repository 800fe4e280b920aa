// End-to-end: the mmba binary's `survey` command, its outputs and exit codes; the CSV form
// against the same network in gama-local XML.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/survey_csv.h"
#include "mmba/survey/adjust.h"

namespace mmba::survey {
namespace {
namespace fs = std::filesystem;

std::string Source(const std::string& path) { return std::string(MMBA_SOURCE_DIR) + "/" + path; }

int RunMmba(const std::string& args) {
  const std::string command =
      std::string(MMBA_BINARY_DIR) + "/apps/mmba survey " + args + " > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WEXITSTATUS(status);
}

TEST(SurveyCommand, WritesResultsAndExitCodes) {
  const fs::path out = fs::temp_directory_path() / "mmba_survey_command_test";
  fs::remove_all(out);
  ASSERT_EQ(RunMmba("--input " + Source("data/gama/gama-local.gkf") + " --output " + out.string()), 0);
  std::ifstream in(out / "adjusted.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_NEAR(j["sigma0_aposteriori"].get<double>(), 9.636082, 1e-4);
  EXPECT_EQ(j["sigma0_used"], "aposteriori");
  EXPECT_EQ(j["degrees_of_freedom"], 37);
  EXPECT_TRUE(j["chi2_test_passed"].get<bool>());
  bool found = false;
  for (const auto& p : j["points"]) {
    if (p["id"] == "403") {
      found = true;
      EXPECT_NEAR(p["x"].get<double>(), 1054612.5952166, 1e-4);
      EXPECT_EQ(p["status_x"], "adjusted");
      EXPECT_GT(p["sigma_x"].get<double>(), 0.0);
      EXPECT_GE(p["ellipse_a"].get<double>(), p["ellipse_b"].get<double>());
    }
    if (p["id"] == "1") {
      EXPECT_EQ(p["status_y"], "fixed");
    }
  }
  EXPECT_TRUE(found);
  std::ifstream csv(out / "observations.csv");
  std::string header, line;
  std::getline(csv, header);
  EXPECT_NE(header.find("redundancy,studentized,flag"), std::string::npos);
  int rows = 0, max_flags = 0;
  while (std::getline(csv, line)) {
    ++rows;
    max_flags += line.find(",max") != std::string::npos;
  }
  EXPECT_EQ(rows, 69);
  EXPECT_EQ(max_flags, 1);
  EXPECT_TRUE(fs::exists(out / "report.md"));

  // Bad input: exit 2, nothing written.
  const fs::path bad = out / "bad";
  EXPECT_EQ(RunMmba("--input " + Source("tests/data/gama/unknown-point.gkf") + " --output " +
                bad.string()),
            2);
  EXPECT_FALSE(fs::exists(bad / "adjusted.json"));
  EXPECT_EQ(RunMmba("--input " + Source("tests/data/gama/datum-defect.gkf") + " --output " +
                bad.string()),
            2);
  EXPECT_EQ(RunMmba("--input " + Source("tests/data/gama/zero-sigma.csv") + " --output " +
                bad.string()),
            2);
  EXPECT_EQ(RunMmba("--input " + Source("data/gama/gama-local.gkf") + " --output " + bad.string() +
                " --confidence 1.5"),
            2);
  EXPECT_FALSE(fs::exists(bad / "adjusted.json"));
  fs::remove_all(out);
}

// Inputs that crashed (deep nesting: stack overflow, exit 139), failed late (an invalid
// character reference: exit 1 when the JSON was written) or were "adjusted" (an empty CSV)
// end with exit 2 and no result.
TEST(SurveyCommand, BrokenInputsExitWith2) {
  const fs::path dir = fs::temp_directory_path() / ("mmba_survey_broken_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string deep = "<gama-local>\n";
  for (int i = 0; i < 50000; ++i) deep += "<network>";
  std::ofstream(dir / "deep.gkf") << deep;
  std::ifstream in(Source("tests/data/gama/gama-local-subset.gkf"));
  std::stringstream text;
  text << in.rdbuf();
  std::string reference = text.str();
  const size_t at = reference.find("<parameters");
  ASSERT_NE(at, std::string::npos);
  reference.insert(at, "<description>&#xFFFFFFFF;</description>\n");
  std::ofstream(dir / "reference.gkf") << reference;
  std::ofstream(dir / "empty.csv") << "# nothing but a comment\n";
  for (const std::string name : {"deep.gkf", "reference.gkf", "empty.csv"}) {
    const fs::path out = dir / ("out-" + name);
    EXPECT_EQ(RunMmba("--input " + (dir / name).string() + " --output " + out.string()), 2) << name;
    EXPECT_FALSE(fs::exists(out / "adjusted.json")) << name;
  }
  fs::remove_all(dir);
}

TEST(SurveyCsv, SameResultAsGamaLocalXml) {
  SurveyNetwork from_csv = io::ReadSurveyCsv(Source("tests/data/gama/gama-local-subset.csv"));
  SurveyNetwork from_xml = io::ReadGamaLocal(Source("tests/data/gama/gama-local-subset.gkf"));
  const SurveyAdjustment a = AdjustNetwork(&from_csv, SurveyAdjustOptions());
  const SurveyAdjustment b = AdjustNetwork(&from_xml, SurveyAdjustOptions());
  ASSERT_TRUE(a.converged && b.converged);
  EXPECT_EQ(a.statistics.degrees_of_freedom, b.statistics.degrees_of_freedom);
  EXPECT_NEAR(a.statistics.sigma0_ratio, b.statistics.sigma0_ratio, 1e-9);
  for (const std::string id : {"403", "407", "422", "424"}) {
    EXPECT_LT((from_csv.Find(id)->coords - from_xml.Find(id)->coords).norm(), 1e-7) << id;
  }
}

TEST(SurveyCsv, BadRecordNamesLine) {
  try {
    io::ReadSurveyCsv(Source("tests/data/gama/zero-sigma.csv"));
    FAIL();
  } catch (const mmba::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("zero-sigma.csv:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sigma"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mmba::survey
