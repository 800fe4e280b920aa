// The survey's outputs built by the library (result_json.h, result_report.h) on GNU Gama's
// gama-local example: the JSON's entries are the adjustment's, the CSV has one row per
// observation, the report holds the summary and as many residual rows as asked.
#include "mmba/survey/result_json.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "mmba/io_survey/gama_local.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/result_report.h"

namespace mmba::survey {
namespace {

const std::string kInput = std::string(MMBA_SOURCE_DIR) + "/data/gama/gama-local.gkf";

class SurveyResult : public ::testing::Test {
 protected:
  void SetUp() override {
    net_ = io::ReadGamaLocal(kInput);
    adj_ = AdjustNetwork(&net_, SurveyAdjustOptions());
    ASSERT_TRUE(adj_.converged) << adj_.reason;
  }
  SurveyNetwork net_;
  SurveyAdjustment adj_;
};

size_t CountLines(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  size_t count = 0;
  for (std::string line; std::getline(in, line);) count += line.rfind(prefix, 0) == 0;
  return count;
}

TEST_F(SurveyResult, JsonHoldsTheAdjustmentAndNoBuildFields) {
  const nlohmann::json j = ResultToJson("net.gkf", net_, adj_);
  EXPECT_EQ(j["input"], "net.gkf");
  EXPECT_EQ(j["degrees_of_freedom"], adj_.statistics.degrees_of_freedom);
  EXPECT_EQ(j["equations"], 69);
  EXPECT_DOUBLE_EQ(j["sigma0_aposteriori"].get<double>(), net_.sigma0_apriori * adj_.statistics.sigma0_ratio);
  EXPECT_EQ(j["angle_unit"], "gon");
  EXPECT_EQ(j["frame"], "input plane (gama-local)");
  EXPECT_EQ(j["variance_components"].size(), adj_.statistics.groups.size());
  EXPECT_FALSE(j["points"].empty());
  EXPECT_FALSE(j.contains("build"));
}

TEST_F(SurveyResult, CsvHasOneRowPerObservationAndOneMaximum) {
  const std::string csv = ObservationsCsv(net_, adj_);
  EXPECT_EQ(csv.rfind("index,line,kind,from,to,observed,adjusted,residual,", 0), 0u);
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  size_t rows = 0, maxima = 0;
  while (std::getline(in, line)) {
    ++rows;
    maxima += line.find(",max") != std::string::npos;
  }
  EXPECT_EQ(rows, adj_.rows.size());
  EXPECT_EQ(maxima, 1u);
}

TEST_F(SurveyResult, ReportHoldsTheSummaryAndTheLargestResiduals) {
  const std::string summary = ResultSummary("net.gkf", net_, adj_);
  EXPECT_EQ(summary.rfind("survey net.gkf: 69 observations, 32 unknowns, defect 0, dof 37\n", 0), 0u) << summary;
  for (const size_t rows : {size_t{3}, size_t{10}}) {
    const std::string md = ReportMarkdown("net.gkf", net_, adj_, rows);
    EXPECT_EQ(md.rfind("# Survey adjustment\n\nInput: `net.gkf`", 0), 0u);
    EXPECT_NE(md.find("```\n" + summary + "```\n"), std::string::npos);
    // Table rows start with "| <index> |"; the group table's rows with "| <group name> |".
    size_t residual_rows = 0;
    for (int digit = 1; digit <= 9; ++digit) residual_rows += CountLines(md, "| " + std::to_string(digit));
    EXPECT_EQ(residual_rows, rows);
  }
}

}  // namespace
}  // namespace mmba::survey
