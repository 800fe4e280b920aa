#include "mmba/report/adjust_report.h"

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "sample_report.h"

namespace mmba::report {
namespace {

using nlohmann::json;

size_t CountOf(const std::string& text, const std::string& needle) {
  size_t n = 0;
  for (size_t pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + 1)) ++n;
  return n;
}

json MinimalReport() {
  return {{"schema", "mmba-adjust-report-1"},
          {"project", "minimal"},
          {"status", "converged"},
          {"sigma0", {{"apriori", 1.0}, {"aposteriori", 0.99}, {"dof", 40}, {"confidence", 0.95},
                      {"chi2_lower", 0.79}, {"chi2_upper", 1.2}}},
          {"groups", json::array()}};
}

// The message of the std::invalid_argument RenderAdjustReportHtml throws ("" if none).
std::string ErrorOf(const json& report) {
  try {
    RenderAdjustReportHtml(report);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(AdjustReport, FullSampleHasEverySectionAndNoExternalAsset) {
  const std::string html = RenderAdjustReportHtml(testing::MakeSampleReport());
  for (const char* id : {"id=\"summary\"", "id=\"warnings\"", "id=\"groups\"", "id=\"control\"",
                         "id=\"blunders\"", "id=\"poses\"", "id=\"calibrations\"", "id=\"files\""}) {
    EXPECT_NE(html.find(id), std::string::npos) << id;
  }
  // 3 histograms, the plan view, the pose-correction plot.
  EXPECT_EQ(CountOf(html, "<svg "), 5u);
  EXPECT_EQ(CountOf(html, "<ellipse "), 11u);
  EXPECT_NE(html.find("N(0,1) density"), std::string::npos);
  EXPECT_NE(html.find("\xCF\x87 density, k = 2"), std::string::npos);  // reprojection norms
  EXPECT_NE(html.find("huber 3"), std::string::npos);
  // How the variance components treated each group: a factor, a reason, or "—" (a report
  // from before the field).
  EXPECT_NE(html.find("<td>\xCF\x83 \xC3\x97 0.985</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>prior: not re-weighted</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>\xE2\x80\x94</td><td class=\"num\">0</td><td>huber 3</td>"), std::string::npos);
  EXPECT_NE(html.find("direction M1-&gt;T3 (network.xml:45)"), std::string::npos);
  EXPECT_NE(html.find("photo camera"), std::string::npos);
  EXPECT_NE(html.find("UTM zone"), std::string::npos);
  EXPECT_NE(html.find("18N"), std::string::npos);
  EXPECT_NE(html.find("verdict pass\">PASSED"), std::string::npos);
  // Self-contained: no script, no fetched resource.
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("src="), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("@import"), std::string::npos);
  EXPECT_EQ(CountOf(html, "http"), CountOf(html, "http://www.w3.org/2000/svg"));
  // Check-point C10 (dU = 16 mm, σU = 4 mm) is highlighted, nothing else among the points.
  EXPECT_NE(html.find("<tr class=\"flag\"><td>C10</td>"), std::string::npos);
  EXPECT_NE(html.find("RMSE check (3)"), std::string::npos);
  EXPECT_NE(html.find("expected RMSE check"), std::string::npos);
  // The blunder that kept its weight is highlighted.
  EXPECT_NE(html.find("<b>no</b>"), std::string::npos);
}

TEST(AdjustReport, MissingOptionalSectionsAreOmitted) {
  const std::string html = RenderAdjustReportHtml(MinimalReport());
  EXPECT_NE(html.find("<h1>minimal</h1>"), std::string::npos);
  EXPECT_NE(html.find("id=\"summary\""), std::string::npos);
  EXPECT_NE(html.find("lists no observation groups"), std::string::npos);
  for (const char* id : {"id=\"warnings\"", "id=\"control\"", "id=\"blunders\"", "id=\"poses\"",
                         "id=\"calibrations\"", "id=\"files\"", "Origin (WGS84)", "UTM zone",
                         "Solver", "Check points", "<svg"}) {
    EXPECT_EQ(html.find(id), std::string::npos) << id;
  }
  // Bounds given, "passed" absent: the verdict is computed (0.79 <= 0.99 <= 1.2).
  EXPECT_NE(html.find("verdict pass\">PASSED"), std::string::npos);
  EXPECT_NE(html.find("</html>"), std::string::npos);
}

TEST(AdjustReport, EscapesEveryString) {
  json report = testing::MakeSampleReport();
  report["project"] = "<b>gate</b> & \"co\"";
  report["control_points"][0]["id"] = "<script>alert('id')</script>";
  report["groups"][0]["name"] = "<img src=x onerror=alert(1)>";
  report["warnings"] = json::array({"<iframe>"});
  report["files"][0]["name"] = "a\"><svg onload=alert(2)>";
  report["blunders"][0]["observation"] = "</td></tr></table><h1>x</h1>";
  report["pose_corrections"][0]["image"] = "<i>p</i>";
  report["calibrations"][0]["parameters"][0]["name"] = "<u>fx</u>";
  const std::string html = RenderAdjustReportHtml(report);
  for (const char* raw : {"<script", "<img", "<iframe", "onload=alert(2)>", "<b>gate", "<h1>x</h1>",
                          "<i>p</i>", "<u>fx</u>", "\"co\""}) {
    EXPECT_EQ(html.find(raw), std::string::npos) << raw;
  }
  EXPECT_NE(html.find("&lt;script&gt;alert(&#39;id&#39;)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(html.find("&lt;b&gt;gate&lt;/b&gt; &amp; &quot;co&quot;"), std::string::npos);
  EXPECT_NE(html.find("&lt;iframe&gt;"), std::string::npos);
  EXPECT_NE(html.find("&lt;i&gt;p&lt;/i&gt;"), std::string::npos);
}

TEST(AdjustReport, NamesTheVersionThatWroteIt) {
  json report = MinimalReport();
  EXPECT_EQ(RenderAdjustReportHtml(report).find("Written by"), std::string::npos);
  report["mmba"] = {{"version", "0.1.0"}, {"commit", "abc1234"}};
  EXPECT_NE(RenderAdjustReportHtml(report).find("<tr><th>Written by</th><td>mmba 0.1.0 (commit abc1234)</td></tr>"),
            std::string::npos);
}

TEST(AdjustReport, MissingRequiredFieldNamesTheField) {
  for (const char* field : {"schema", "project", "status", "sigma0", "groups"}) {
    json report = MinimalReport();
    report.erase(field);
    const std::string message = ErrorOf(report);
    EXPECT_NE(message.find(std::string("'") + field + "'"), std::string::npos)
        << field << ": " << message;
    EXPECT_NE(message.find("missing"), std::string::npos) << message;
  }
}

TEST(AdjustReport, MistypedFieldNamesThePathValueAndExpectation) {
  struct Case {
    std::function<void(json&)> edit;
    std::string field;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {[](json& r) { r["schema"] = "mmba-adjust-report-0"; }, "'schema'", "mmba-adjust-report-1"},
      {[](json& r) { r["status"] = "ok"; }, "'status'", "\"converged\""},
      {[](json& r) { r["groups"] = json::object(); }, "'groups'", "an array"},
      {[](json& r) { r["project"] = 7; }, "'project'", "a string"},
      {[](json& r) { r["sigma0"]["aposteriori"] = "1.0"; }, "'sigma0.aposteriori'", "a number"},
      {[](json& r) { r["sigma0"]["passed"] = 1; }, "'sigma0.passed'", "true or false"},
      {[](json& r) { r["groups"][1].erase("name"); }, "'groups[1].name'", "a string"},
      {[](json& r) { r["groups"][0]["whitened"][3] = "x"; }, "'groups[0].whitened[3]'", "a number"},
      {[](json& r) { r["groups"][0]["whitened_kind"] = "vectors"; }, "'groups[0].whitened_kind'", "norms"},
      {[](json& r) { r["control_points"][1]["d"] = {0.1, 0.2}; }, "'control_points[1].d'", "3 numbers"},
      {[](json& r) { r["control_points"][2]["role"] = "tie"; }, "'control_points[2].role'", "\"check\""},
      {[](json& r) { r["control_points"][3]["ellipse"]["a"] = true; }, "'control_points[3].ellipse.a'", "a number"},
      {[](json& r) { r["blunders"][1]["downweighted"] = "yes"; }, "'blunders[1].downweighted'", "true or false"},
      {[](json& r) { r["pose_corrections"][5].erase("image"); }, "'pose_corrections[5].image'", "a string"},
      {[](json& r) { r["calibrations"][0]["parameters"][2]["sigma"] = "0.1"; },
       "'calibrations[0].parameters[2].sigma'", "a number"},
      {[](json& r) { r["warnings"][1] = 3; }, "'warnings[1]'", "a string"},
      {[](json& r) { r["files"] = "x"; }, "'files'", "an array"},
      {[](json& r) { r["origin"]["height_m"] = "35"; }, "'origin.height_m'", "a number"},
  };
  for (const Case& c : cases) {
    json report = testing::MakeSampleReport();
    c.edit(report);
    const std::string message = ErrorOf(report);
    EXPECT_NE(message.find(c.field), std::string::npos) << c.field << ": " << message;
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.field << ": " << message;
  }
  EXPECT_NE(ErrorOf(json::array()).find("an object"), std::string::npos);
}

TEST(AdjustReport, Chi2VerdictInWordsAndColour) {
  json report = MinimalReport();
  report["sigma0"]["aposteriori"] = 1.5;  // outside [0.79, 1.2]
  std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("verdict fail\">FAILED"), std::string::npos);
  EXPECT_NE(html.find("do not agree"), std::string::npos);

  report["sigma0"]["passed"] = true;  // disagrees with the bounds: shown, not hidden
  html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("verdict pass\">PASSED"), std::string::npos);
  EXPECT_NE(html.find("Inconsistent"), std::string::npos);

  report["sigma0"] = {{"apriori", 1.0}, {"aposteriori", nullptr}, {"dof", 0}};
  html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("NOT TESTED"), std::string::npos);
  EXPECT_EQ(html.find("PASSED"), std::string::npos);
}

TEST(AdjustReport, FailedRunShowsABanner) {
  json report = MinimalReport();
  report["status"] = "no_convergence";
  report["reason"] = "iteration limit 100";
  std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("did NOT CONVERGE"), std::string::npos);
  EXPECT_NE(html.find("iteration limit 100"), std::string::npos);
  report["status"] = "failed";
  html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("The adjustment FAILED"), std::string::npos);
  EXPECT_NE(html.find("badge bad"), std::string::npos);
}

TEST(AdjustReport, CheckRmseFromTheTableWhenNoSummary) {
  json report = MinimalReport();
  // Check points d = (3, 4, 0) mm and (0, 0, 11.9) mm: RMSE E = sqrt(9/2) = 2.1 mm,
  // N = sqrt(16/2) = 2.8 mm, U = sqrt(141.61/2) = 8.4 mm, 3-D = sqrt((25 + 141.61)/2) = 9.1 mm.
  report["control_points"] = json::array(
      {{{"id", "A"}, {"role", "check"}, {"surveyed", {0, 0, 0}}, {"d", {0.003, 0.004, 0.0}},
        {"sigma", {0.002, 0.002, 0.004}}},
       {{"id", "B"}, {"role", "check"}, {"surveyed", {10, 0, 0}}, {"d", {0.0, 0.0, 0.0119}},
        {"sigma", {0.002, 0.002, 0.004}}},
       {{"id", "K"}, {"role", "control"}, {"surveyed", {0, 10, 0}}, {"adjusted", {0.001, 10.0, 0.0}}}});
  const std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("RMSE check (2), from this table</td><td class=\"num\">2.1</td><td "
                      "class=\"num\">2.8</td><td class=\"num\">8.4</td><td class=\"num\">9.1</td>"),
            std::string::npos);
  EXPECT_NE(html.find("RMSE 3-D <b>9.1 mm</b> over 2 points"), std::string::npos);
  // d of K from adjusted − surveyed: dE = 1.0 mm.
  EXPECT_NE(html.find("<td>K</td><td>control</td><td class=\"num\">0.000</td><td "
                      "class=\"num\">10.000</td><td class=\"num\">0.000</td><td "
                      "class=\"num\">1.0</td>"),
            std::string::npos);
  // B: |dU| 11.9 mm < 3 · 4 mm and A: |dN| 4 mm = 2σ → not flagged; 12.1 mm > 12 mm is.
  EXPECT_EQ(CountOf(html, "<tr class=\"flag\">"), 0u);
  report["control_points"][1]["d"][2] = 0.0121;
  EXPECT_EQ(CountOf(RenderAdjustReportHtml(report), "<tr class=\"flag\">"), 1u);
}

TEST(AdjustReport, NullsAndEmptyArraysRenderGracefully) {
  json report = MinimalReport();
  report["groups"] = json::array(
      {{{"name", "gnss"}, {"unit", "m"}, {"observations", nullptr}, {"rms", nullptr},
        {"whitened", {nullptr, nullptr}}},
       {{"name", "empty"}, {"whitened", json::array()}}});
  report["control_points"] = json::array(
      {{{"id", "P"}, {"role", "control"}, {"surveyed", {nullptr, nullptr, nullptr}},
        {"sigma", {nullptr, 0.0, nullptr}}}});
  // A report filled from C++ holds NaN/Inf doubles (not nulls) where a figure is undefined.
  report["sigma0"]["aposteriori"] = NAN;
  report["groups"][0]["sigma"] = INFINITY;
  report["groups"][0]["whitened"].push_back(NAN);
  report["blunders"] = json::array();
  report["pose_corrections"] = json::array();
  report["warnings"] = json::array();
  const std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("no finite values (3 NaN/Inf)"), std::string::npos);
  EXPECT_NE(html.find("NOT TESTED"), std::string::npos);
  EXPECT_NE(html.find("no values"), std::string::npos);
  EXPECT_NE(html.find("no points with coordinates"), std::string::npos);
  EXPECT_NE(html.find("\xE2\x80\x94"), std::string::npos);  // "—" for the missing numbers
  EXPECT_NE(html.find("Data snooping flagged no observation"), std::string::npos);
  EXPECT_EQ(html.find("id=\"poses\""), std::string::npos);
  EXPECT_EQ(html.find("id=\"warnings\""), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);
  EXPECT_EQ(html.find("inf<"), std::string::npos);
}

TEST(AdjustReport, DenseStationCloudsAreTabulatedAndAStationWithoutPanoramasSaysWhy) {
  json report = MinimalReport();
  report["spherical_dense"] = json::array(
      {json{{"station", "S1"}, {"status", "ok"}, {"points", 568646}, {"median_range_m", 4.8566},
            {"median_range_sigma_m", 0.068}, {"lidar_compared", 1631}, {"median_abs_distance_to_lidar_m", 0.342},
            {"median_abs_distance_over_sigma", 0.166}},
       json{{"station", "S2"}, {"status", "ok"}, {"points", 1000}, {"median_range_m", 3.0}, {"median_range_sigma_m", 0.05}},
       json{{"station", "S<3>"}, {"status", "no panoramas S3_lower/_upper in images"}}});
  const std::string html = RenderAdjustReportHtml(report);
  EXPECT_NE(html.find("id=\"dense\""), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">568646</td><td class=\"num\">4.86</td>"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">0.342</td><td class=\"num\">0.17</td>"), std::string::npos);
  EXPECT_NE(html.find("S&lt;3&gt;"), std::string::npos);  // escaped
  EXPECT_NE(html.find("no panoramas S3_lower/_upper in images"), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);  // S2 has no LiDAR comparison: dashes
  report["spherical_dense"][0]["points"] = "many";
  EXPECT_NE(ErrorOf(report).find("spherical_dense[0].points"), std::string::npos) << ErrorOf(report);
  EXPECT_EQ(RenderAdjustReportHtml(MinimalReport()).find("id=\"dense\""), std::string::npos);
}

TEST(AdjustReport, MiRegistrationsAreTabulatedWithTheirOutcome) {
  json report = MinimalReport();
  report["mi_registration"] = json::array(
      {json{{"image", "frame_001"}, {"kind", "panorama"}, {"status", "ok"},
            {"correction", {{"tx", -0.0215}, {"ty", 0.0306}, {"tz", 0.0979}, {"roll", -0.0019}, {"pitch", 0.1378}, {"yaw", 0.3118}}},
            {"sigma_px", 0.587}, {"adjusted_minus_registered_m", 0.0512}, {"adjusted_minus_registered_deg", 0.313},
            {"runtime_seconds", 45.0}, {"prior", true}},
       json{{"image", "photo<0>.png"}, {"kind", "photo"}, {"status", "failed"}, {"reason", "restarts disagree"}, {"prior", false}},
       json{{"image", "frame_004"}, {"kind", "panorama"}, {"lidar", "mobile"}, {"status", "used"}, {"prior", false}}});
  const std::string html = RenderAdjustReportHtml(report);
  // The cloud each was registered to; a frame used by the rig calibration is not a failure.
  EXPECT_NE(html.find("<tr><td>frame_004</td><td>panorama</td><td>mobile</td><td>used</td>"), std::string::npos) << html;
  EXPECT_NE(html.find("<td>frame_001</td><td>panorama</td><td>static</td>"), std::string::npos);
  EXPECT_NE(html.find("id=\"mi\""), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">104.8</td>"), std::string::npos) << html;  // |t| in mm
  EXPECT_NE(html.find("<td class=\"num\">51.2</td><td class=\"num\">0.313</td>"), std::string::npos);
  EXPECT_NE(html.find("photo&lt;0&gt;.png"), std::string::npos);  // escaped
  EXPECT_NE(html.find("<tr class=\"flag\"><td>photo&lt;0&gt;.png"), std::string::npos);  // the failure marked
  EXPECT_NE(html.find("restarts disagree"), std::string::npos);
  EXPECT_EQ(html.find("nan"), std::string::npos);
  report["mi_registration"][0]["sigma_px"] = "small";
  EXPECT_NE(ErrorOf(report).find("mi_registration[0].sigma_px"), std::string::npos) << ErrorOf(report);
  EXPECT_EQ(RenderAdjustReportHtml(MinimalReport()).find("id=\"mi\""), std::string::npos);
}

}  // namespace
}  // namespace mmba::report
