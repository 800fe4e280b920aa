// The client sections of report.html (both χ² tests, adjusted points with 95 % ellipses,
// relative precision, observations, check-point accuracy, photo images, CRS, settings,
// relative paths) from the fixture report, and the figures behind them.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "mmba/report/accuracy.h"
#include "mmba/report/adjust_report.h"
#include "mmba/report/relative_precision.h"
#include "mmba/report/report_entries.h"
#include "sample_report.h"

namespace mmba::report {
namespace {

size_t Occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The part of the page between an element's id and the end of its section.
std::string Section(const std::string& html, const std::string& id) {
  const size_t begin = html.find("id=\"" + id + "\"");
  if (begin == std::string::npos) return "";
  return html.substr(begin, html.find("</section>", begin) - begin);
}

TEST(ReportSections, BothChiSquareTests) {
  const std::string html = RenderAdjustReportHtml(testing::MakeClientReport());
  const std::string summary = html.substr(html.find("id=\"summary\""), html.find("</div>", html.find("id=\"summary\"")) - html.find("id=\"summary\""));
  const size_t given = summary.find("test, project's");
  const size_t after = summary.find("test, after variance components");
  ASSERT_NE(given, std::string::npos);
  ASSERT_NE(after, std::string::npos);
  // The project's σ: 1.84 outside [0.9876, 1.0125] -> FAILED; after re-weighting 1.006 -> PASSED.
  EXPECT_NE(summary.substr(given, after - given).find("FAILED"), std::string::npos);
  EXPECT_NE(summary.substr(given, after - given).find("1.840"), std::string::npos);
  EXPECT_NE(summary.substr(after).find("PASSED"), std::string::npos);
  // Variance components that changed nothing: the second test is named, not repeated.
  nlohmann::json same = testing::MakeClientReport();
  same["sigma0_given_weights"]["aposteriori"] = 1.006;
  same["sigma0_given_weights"]["passed"] = true;
  const std::string once = RenderAdjustReportHtml(same);
  EXPECT_NE(once.find("the same: the variance components re-weighted no group"), std::string::npos);
  EXPECT_EQ(Occurrences(once, "verdict pass\">PASSED"), 1u);
  // Without sigma0_given_weights: one test.
  const std::string single = RenderAdjustReportHtml(testing::MakeSampleReport());
  EXPECT_EQ(single.find("test, project's"), std::string::npos);
  EXPECT_NE(single.find("test (two-sided)"), std::string::npos);
}

TEST(ReportSections, PointsWith95PercentEllipses) {
  const std::string html = RenderAdjustReportHtml(testing::MakeClientReport());
  const std::string points = Section(html, "points");
  ASSERT_FALSE(points.empty());
  // 1σ a = 3.0 mm, b = 2.0 mm -> 95 %: 7.3 and 4.9 mm; 95 % height 1.96 × 5 mm = 9.8 mm.
  EXPECT_NE(points.find(">7.3<"), std::string::npos);
  EXPECT_NE(points.find(">4.9<"), std::string::npos);
  EXPECT_NE(points.find(">9.8<"), std::string::npos);
  EXPECT_NE(points.find("<details>"), std::string::npos) << "70 rows are folded";
  EXPECT_EQ(Occurrences(points, "<tr><td>P"), 70u);
  // The control table shows 95 % too: sample a = 2.6 mm (1σ) -> 6.4 mm.
  EXPECT_NE(Section(html, "control").find(">6.4<"), std::string::npos);
  // An ellipse already at 95 % is not scaled again.
  nlohmann::json report = testing::MakeClientReport();
  report["points"][0]["ellipse"]["confidence"] = 0.95;
  const std::string again = Section(RenderAdjustReportHtml(report), "points");
  EXPECT_NE(again.find("<tr><td>P1</td><td>control</td><td class=\"num\">0.0000</td><td class=\"num\">0.0000</td>"
                       "<td class=\"num\">10.0000</td><td class=\"num\">2.0</td><td class=\"num\">3.0</td>"
                       "<td class=\"num\">5.0</td><td class=\"num\">3.0</td><td class=\"num\">2.0</td>"),
            std::string::npos);
  report["points"][0]["ellipse"]["confidence"] = 1.5;
  EXPECT_THROW(RenderAdjustReportHtml(report), std::invalid_argument);
}

TEST(ReportSections, RelativePrecisionTable) {
  const std::string rel = Section(RenderAdjustReportHtml(testing::MakeClientReport()), "relative");
  ASSERT_FALSE(rel.empty());
  EXPECT_NE(rel.find("<td>T1</td><td>T5</td>"), std::string::npos);
  EXPECT_NE(rel.find(">39.5<"), std::string::npos) << "1.2 mm over 30.414 m = 39.5 ppm";
  EXPECT_NE(rel.find(">3.43<"), std::string::npos) << "1σ a 1.4 mm -> 95 % 3.43 mm";
}

TEST(RelativePrecision, CorrelationShrinksTheDifference) {
  const std::array<double, 9> cii = {4e-6, 0, 0, 0, 4e-6, 0, 0, 0, 9e-6};
  const std::array<double, 9> cij = {3e-6, 0, 0, 0, 3e-6, 0, 0, 0, 8e-6};
  const RelativePrecision r = RelativePrecisionOf({0, 0, 0}, {30, 40, 0}, cii, cii, cij);
  EXPECT_NEAR(r.distance_m, 50.0, 1e-12);
  EXPECT_NEAR(r.sigma[0], std::sqrt(2e-6), 1e-12);  // 2·(4 − 3)e-6
  EXPECT_NEAR(r.sigma[2], std::sqrt(2e-6), 1e-12);  // 2·(9 − 8)e-6
  EXPECT_NEAR(r.sigma_distance_m, std::sqrt(2e-6), 1e-12);  // isotropic
  EXPECT_NEAR(r.ellipse95.a, 2.447747 * std::sqrt(2e-6), 1e-9);
  // Uncorrelated and anisotropic: σ_d² = uᵀ C u with u = (0.6, 0.8).
  const std::array<double, 9> ca = {1e-6, 0, 0, 0, 4e-6, 0, 0, 0, 1e-6};
  const RelativePrecision s = RelativePrecisionOf({0, 0, 0}, {30, 40, 0}, ca, ca, {});
  EXPECT_NEAR(s.sigma_distance_m, std::sqrt(0.36 * 2e-6 + 0.64 * 8e-6), 1e-12);
}

TEST(RelativePrecision, EllipseAzimuthAndNeighbours) {
  EXPECT_NEAR(EllipseOf(1.0, 0.0, 4.0, 1.0).azimuth_deg, 0.0, 1e-9);   // long axis north
  EXPECT_NEAR(EllipseOf(4.0, 0.0, 1.0, 1.0).azimuth_deg, 90.0, 1e-9);  // long axis east
  EXPECT_NEAR(EllipseOf(2.0, 1.0, 2.0, 1.0).azimuth_deg, 45.0, 1e-9);  // north-east
  EXPECT_NEAR(EllipseOf(2.0, 1.0, 2.0, 1.0).a, std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(EllipseOf(2.0, 1.0, 2.0, 1.0).b, 1.0, 1e-12);
  // A 2 × 2 grid 10 m apart and one far point: k = 1 joins each to its nearest.
  const std::vector<std::array<double, 3>> xyz = {{0, 0, 0}, {10, 0, 0}, {0, 11, 0}, {10, 11, 0}, {100, 100, 0}};
  const auto pairs = NeighbourPairs(xyz, 1);
  const std::vector<std::pair<size_t, size_t>> expected = {{0, 1}, {2, 3}, {3, 4}};
  EXPECT_EQ(pairs, expected);
  EXPECT_EQ(NeighbourPairs(xyz, 4).size(), 10u);
}

TEST(CheckAccuracy, NssdaAndAsprsFigures) {
  // RMSE_x = RMSE_y = 3 mm, RMSE_z = 5 mm, mean x 0.
  const std::vector<std::array<double, 3>> d = {{0.003, 0.003, 0.005}, {-0.003, -0.003, -0.005},
                                                {0.003, -0.003, 0.005}, {-0.003, 0.003, -0.005}};
  const CheckAccuracy a = ComputeCheckAccuracy(d);
  EXPECT_EQ(a.count, 4);
  EXPECT_NEAR(a.rmse_h, std::sqrt(18e-6), 1e-12);
  EXPECT_NEAR(a.accuracy_h95, 1.7308 * std::sqrt(18e-6), 1e-12);
  EXPECT_NEAR(a.accuracy_v95, 1.96 * 0.005, 1e-12);
  EXPECT_NEAR(a.mean[0], 0.0, 1e-15);
  EXPECT_NEAR(a.stdev[2], std::sqrt(4 * 25e-6 / 3), 1e-12);
  ASSERT_EQ(a.warnings.size(), 1u);
  EXPECT_NE(a.warnings[0].find("at least 20"), std::string::npos);
  // RMSE_x = 4, RMSE_y = 3 mm: ratio 0.75 -> 2.4477·0.5·(x + y).
  std::vector<std::array<double, 3>> e(30, {0.004, 0.003, 0.0});
  const CheckAccuracy b = ComputeCheckAccuracy(e);
  EXPECT_NEAR(b.accuracy_h95, 2.4477 * 0.5 * 0.007, 1e-12);
  EXPECT_TRUE(b.warnings.empty());
  std::vector<std::array<double, 3>> f(25, {0.004, 0.001, 0.0});  // ratio 0.25: not defined
  const CheckAccuracy c = ComputeCheckAccuracy(f);
  EXPECT_TRUE(std::isnan(c.accuracy_h95));
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("30"), std::string::npos);
  f.push_back({NAN, 0.0, 0.0});
  EXPECT_EQ(ComputeCheckAccuracy(f).count, 25);
}

TEST(ReportSections, AccuracyBlockWarnsOnFewPoints) {
  const std::string acc = Section(RenderAdjustReportHtml(testing::MakeClientReport()), "accuracy");
  ASSERT_FALSE(acc.empty());
  EXPECT_NE(acc.find("Too few check points"), std::string::npos);
  // 3 check points of the control table + 2 of the photo block.
  EXPECT_NE(acc.find("5 check points withheld"), std::string::npos);
  EXPECT_NE(acc.find("<td>CP2</td>"), std::string::npos);
  EXPECT_NE(acc.find("FGDC-STD-007.3-1998"), std::string::npos);
  EXPECT_NE(acc.find("NSSDA vertical, 95&nbsp;%"), std::string::npos);
}

TEST(ReportSections, ObservationTableIsLimitedAndPointsToTheCsv) {
  const std::string obs = Section(RenderAdjustReportHtml(testing::MakeClientReport()), "observations");
  ASSERT_FALSE(obs.empty());
  EXPECT_EQ(Occurrences(obs, "<td>total station</td>"), 300u);
  EXPECT_NE(obs.find("300 of 401 rows shown; all of them in <code>observations.csv</code>"), std::string::npos);
  EXPECT_NE(obs.find("<details>"), std::string::npos);
  EXPECT_EQ(Occurrences(obs, "<b>blunder?</b>"), 1u);  // w = 5.2 > 3.29
  EXPECT_NE(obs.find("redundancy r<sub>i</sub>"), std::string::npos);
}

TEST(ReportSections, PhotoImagesCrsSettingsAndRelativePaths) {
  const std::string html = RenderAdjustReportHtml(testing::MakeClientReport());
  const std::string images = Section(html, "images");
  ASSERT_FALSE(images.empty());
  EXPECT_EQ(Occurrences(images, "<tr class=\"flag\">"), 2u);  // 4 image points; RMS 0.9 > 2 × 0.3
  EXPECT_NE(images.find("<code>images/IMG_100.JPG</code>"), std::string::npos);
  EXPECT_NE(html.find("ETRS89 / UTM zone 33N (EPSG:25833)"), std::string::npos);
  EXPECT_NE(Section(html, "crs").find("ellipsoidal (GRS80)"), std::string::npos);
  const std::string settings = Section(html, "settings");
  EXPECT_NE(settings.find("loss.photos"), std::string::npos);
  EXPECT_NE(settings.find("version 0.9.0"), std::string::npos);
  EXPECT_NE(html.find("control file control/points.csv line 7"), std::string::npos);
  EXPECT_NE(html.find("<code>project.yaml</code>"), std::string::npos);
  EXPECT_EQ(html.find("/home/surveyor"), std::string::npos) << "an absolute path left in the page";
}

TEST(ReportSections, PhotoBlockImagesWhenTheyAreAnArray) {
  nlohmann::json report = testing::MakeClientReport();
  report["photo_block"] = {{"id", "colmap"}, {"images", 12}};  // a count: no table
  EXPECT_EQ(RenderAdjustReportHtml(report).find("id=\"images-photo_block\""), std::string::npos);
  report["photo_block"]["images"] = report["photo_measurements"]["images"];
  const std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("id=\"images-photo_block\""), std::string::npos);
  EXPECT_NE(html.find("Images of the photo block colmap"), std::string::npos);
}

TEST(ReportSections, CrsAsMmbaAdjustWritesIt) {
  nlohmann::json report = testing::MakeClientReport();
  const std::string wkt(400, 'W');
  report["crs"] = {{"definition", "EPSG:25833"}, {"identifier", "EPSG:25833"}, {"epsg", 25833},
                   {"name", "ETRS89 / UTM zone 33N"}, {"wkt", wkt}, {"axes", "easting_m, northing_m, height_m"},
                   {"height_kind", "ellipsoidal"}, {"geoid_grid", nullptr}, {"columns", "easting_m,northing_m"}};
  const std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("<td>ETRS89 / UTM zone 33N (EPSG:25833) <a href"), std::string::npos);
  const std::string crs = Section(html, "crs");
  EXPECT_NE(crs.find("<summary>400 characters</summary><pre class=\"wrap\">" + wkt), std::string::npos);
  EXPECT_NE(crs.find("<th>geoid_grid</th><td><code>\xE2\x80\x94</code>"), std::string::npos);
  report["crs"]["epsg"] = nullptr;
  report["crs"]["identifier"] = "+proj=tmerc +lat_0=0";
  EXPECT_NE(RenderAdjustReportHtml(report).find("ETRS89 / UTM zone 33N (+proj=tmerc +lat_0=0)"), std::string::npos);
}

TEST(ReportSections, AbsolutePathsWithoutAProjectFolderShowTheirFileName) {
  nlohmann::json report = testing::MakeClientReport();
  report.erase("project_dir");
  const std::string images = Section(RenderAdjustReportHtml(report), "images");
  EXPECT_NE(images.find("<code>IMG_101.JPG</code>"), std::string::npos);
  EXPECT_EQ(images.find("/home/surveyor"), std::string::npos);
}

TEST(ReportEntries, ObservationsFromTheStatisticsRenderAsTheTable) {
  stats::NetworkStatistics st;
  st.critical_value = 3.29;
  const double w[3] = {0.5, -4.1, 2.0};
  for (int i = 0; i < 3; ++i) {
    stats::RowStatistic r;
    r.group = i == 2 ? 1 : 0;
    r.block = i;
    r.residual = 1e-5 * w[i];
    r.sigma = 1e-5;
    r.redundancy = 0.5;
    r.studentized = w[i];
    r.critical = std::abs(w[i]) > 3.29;
    st.rows.push_back(r);
  }
  const std::vector<GroupLabel> groups = {{"directions", "mgon", 200000.0 / M_PI}, {"distances", "mm", 1000.0}};
  const nlohmann::json all = ObservationsEntry(st, groups, "observations.csv");
  ASSERT_EQ(all["rows"].size(), 3u);
  EXPECT_EQ(all["rows"][2]["group"], "distances");
  EXPECT_NEAR(all["rows"][2]["residual"].get<double>(), 0.02, 1e-12);
  EXPECT_NEAR(all["rows"][0]["sigma"].get<double>(), 1e-5 * 200000.0 / M_PI, 1e-12);
  const nlohmann::json two = ObservationsEntry(st, groups, "observations.csv", 2);
  ASSERT_EQ(two["rows"].size(), 2u);
  EXPECT_EQ(two["rows"][0]["studentized"].get<double>(), -4.1);  // the largest |w| first
  EXPECT_EQ(two["rows"][1]["studentized"].get<double>(), 2.0);
  EXPECT_EQ(two["total"].get<size_t>(), 3u);
  st.rows[0].group = 5;
  EXPECT_THROW(ObservationsEntry(st, groups, "x.csv"), std::out_of_range);

  nlohmann::json report = testing::MakeSampleReport();
  report["observations"] = two;
  const std::string obs = Section(RenderAdjustReportHtml(report), "observations");
  EXPECT_NE(obs.find("2 of 3 rows shown"), std::string::npos);
  EXPECT_EQ(Occurrences(obs, "<b>blunder?</b>"), 1u);
}

TEST(ReportEntries, RelativePrecisionEntriesRenderAsTheTable) {
  const std::vector<std::string> ids = {"A", "B", "C"};
  const std::vector<std::array<double, 3>> xyz = {{0, 0, 0}, {100, 0, 0}, {0, 50, 0}};
  // Independent points, σ 2 mm per axis: σ of any difference 2.83 mm.
  const auto cov = [](size_t i, size_t j) {
    std::array<double, 9> c{};
    if (i == j) c[0] = c[4] = c[8] = 4e-6;
    return c;
  };
  const nlohmann::json entries = RelativePrecisionEntries(ids, xyz, cov, 1);
  ASSERT_EQ(entries.size(), 2u);  // A-B (B's nearest), A-C
  EXPECT_EQ(entries[0]["from"], "A");
  EXPECT_NEAR(entries[0]["sigma"][0].get<double>(), std::sqrt(8e-6), 1e-12);
  nlohmann::json report = testing::MakeSampleReport();
  report["relative_precision"] = entries;
  const std::string rel = Section(RenderAdjustReportHtml(report), "relative");
  EXPECT_NE(rel.find("<td>A</td><td>C</td><td class=\"num\">50.000</td><td class=\"num\">2.83</td>"
                     "<td class=\"num\">56.6</td>"),
            std::string::npos);
  // Already at 95 %: a = 2.4477 × 2.83 mm = 6.92 mm, not scaled twice.
  EXPECT_NE(rel.find(">6.92<"), std::string::npos);
}

}  // namespace
}  // namespace mmba::report
