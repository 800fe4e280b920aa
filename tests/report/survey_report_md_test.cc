// report.md of `mmba survey` (survey/result_report.h) on GNU Gama's gama-local example: the
// adjusted points with σ and 95 % ellipses (2.4477 × the standard ellipse of adjusted.json),
// and the relative precision of neighbours, which for a pair with one fixed point equals the
// other point's own σ.
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/io_survey/gama_local.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/result_json.h"
#include "mmba/survey/result_report.h"

namespace mmba::survey {
namespace {

// The cells of the table rows of one "## title" section whose first cell is a `code` id.
std::vector<std::vector<std::string>> TableRows(const std::string& md, const std::string& title) {
  std::vector<std::vector<std::string>> rows;
  const size_t begin = md.find("## " + title + "\n");
  if (begin == std::string::npos) return rows;
  std::istringstream in(md.substr(begin, md.find("\n## ", begin + 3) - begin));
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    std::vector<std::string> cells;
    std::istringstream cells_in(line.substr(1));
    for (std::string cell; std::getline(cells_in, cell, '|');) {
      cell.erase(0, cell.find_first_not_of(" `"));
      cell.erase(cell.find_last_not_of(" `") + 1);
      cells.push_back(cell);
    }
    rows.push_back(cells);
  }
  return rows;
}

TEST(SurveyReportMarkdown, PointsAndRelativePrecisionOnGamaLocal) {
  SurveyNetwork net = io::ReadGamaLocal(std::string(MMBA_SOURCE_DIR) + "/data/gama/gama-local.gkf");
  const SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged) << adj.reason;
  const std::string md = ReportMarkdown("gama-local.gkf", net, adj, 5);
  const nlohmann::json json = ResultToJson("gama-local.gkf", net, adj);

  const auto points = TableRows(md, "Adjusted points");
  size_t free = 0;
  for (const SurveyPoint& p : net.points) free += p.xy_free() || p.z_free();
  ASSERT_EQ(points.size(), free);
  std::map<std::string, std::vector<std::string>> by_id;
  for (const auto& row : points) by_id[row[0]] = row;
  size_t compared = 0;
  for (const auto& jp : json["points"]) {
    if (!jp.contains("ellipse_a")) continue;
    const auto& row = by_id.at(jp["id"].get<std::string>());
    EXPECT_NEAR(std::stod(row[7]), 2.447747 * 1e3 * jp["ellipse_a"].get<double>(), 0.006) << jp["id"];
    EXPECT_NEAR(std::stod(row[8]), 2.447747 * 1e3 * jp["ellipse_b"].get<double>(), 0.006) << jp["id"];
    EXPECT_NEAR(std::stod(row[4]), 1e3 * jp["sigma_x"].get<double>(), 0.006) << jp["id"];
    ++compared;
  }
  EXPECT_GT(compared, 5u);

  const auto pairs = TableRows(md, "Relative precision between neighbouring points");
  ASSERT_FALSE(pairs.empty());
  std::map<std::string, const SurveyPoint*> point_of;
  for (const SurveyPoint& p : net.points) point_of[p.id] = &p;
  size_t with_fixed = 0;
  for (const auto& row : pairs) {
    const double distance = std::stod(row[2]), sd = std::stod(row[3]);
    EXPECT_NEAR(std::stod(row[4]), sd / distance * 1e3, 0.06) << row[0] << "-" << row[1];
    const double se = std::stod(row[5]), sn = std::stod(row[6]);
    EXPECT_LE(sd, std::hypot(se, sn) + 0.01);  // a projection of the 2-D difference
    const SurveyPoint* a = point_of.at(row[0]);
    const SurveyPoint* b = point_of.at(row[1]);
    const SurveyPoint* fixed = a->xy == CoordStatus::kFixed ? a : (b->xy == CoordStatus::kFixed ? b : nullptr);
    if (fixed == nullptr) continue;
    const auto& other = by_id.at((fixed == a ? b : a)->id);
    std::vector<double> own = {std::stod(other[4]), std::stod(other[5])}, rel = {se, sn};
    std::sort(own.begin(), own.end());
    std::sort(rel.begin(), rel.end());
    EXPECT_NEAR(rel[0], own[0], 0.006) << row[0] << "-" << row[1];
    EXPECT_NEAR(rel[1], own[1], 0.006) << row[0] << "-" << row[1];
    ++with_fixed;
  }
  EXPECT_GT(with_fixed, 0u);
}

}  // namespace
}  // namespace mmba::survey
