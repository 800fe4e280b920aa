// report.html: control and check points against their surveyed coordinates, with the plan view.
#include <cmath>
#include <string>
#include <vector>

#include "report/html_internal.h"

namespace mmba::report::internal {

double EllipseFactorTo95(double confidence, const std::string& path) {
  if (!std::isfinite(confidence)) return k95Ellipse2d;
  if (!(confidence > 0.0 && confidence < 1.0)) Fail(Join(path, "confidence"), Sig(confidence), "a probability in (0, 1)");
  return k95Ellipse2d / std::sqrt(-2.0 * std::log(1.0 - confidence));
}

std::vector<ControlPoint> ReadControlPoints(const json& report) {
  std::vector<ControlPoint> points;
  const json* array = OptArray(report, "control_points", "");
  if (array == nullptr) return points;
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("control_points", i);
    const json& o = ElementObject(*array, i, "control_points");
    ControlPoint p;
    p.id = ReqString(o, "id", path);
    const std::string role = ReqString(o, "role", path);
    if (role != "control" && role != "check") {
      Fail(Join(path, "role"), "\"" + role + "\"", "\"control\" or \"check\"");
    }
    p.check = role == "check";
    if (auto v = OptVec3(o, "surveyed", path)) p.surveyed = *v;
    if (auto v = OptVec3(o, "adjusted", path)) p.adjusted = *v;
    if (auto v = OptVec3(o, "sigma", path)) p.sigma = *v;
    if (auto v = OptVec3(o, "d", path)) {
      p.d = *v;
    } else {
      for (int k = 0; k < 3; ++k) p.d[k] = p.adjusted[k] - p.surveyed[k];
    }
    if (const json* e = OptObject(o, "ellipse", path)) {
      const std::string epath = Join(path, "ellipse");
      p.ellipse_a = Num(*e, "a", epath);
      p.ellipse_b = Num(*e, "b", epath);
      p.ellipse_azimuth_deg = Num(*e, "azimuth_deg", epath);
      const double to95 = EllipseFactorTo95(Num(*e, "confidence", epath), epath);
      p.ellipse_a *= to95;
      p.ellipse_b *= to95;
    }
    static const char* kAxis[3] = {"E", "N", "U"};
    for (int k = 0; k < 3; ++k) {
      if (std::isfinite(p.d[k]) && std::isfinite(p.sigma[k]) && p.sigma[k] > 0.0 &&
          std::abs(p.d[k]) > 3.0 * p.sigma[k]) {
        p.flagged_axes += (p.flagged_axes.empty() ? "" : ", ") + std::string(kAxis[k]);
      }
    }
    points.push_back(p);
  }
  return points;
}

namespace {

// RMS per axis and 3-D over the points of one role with finite d.
struct Rms {
  int count = 0;
  std::array<double, 3> axis{NAN, NAN, NAN};
  double d3 = NAN;
};

Rms RmsOf(const std::vector<ControlPoint>& points, bool check) {
  Rms r;
  std::array<double, 3> sum{0, 0, 0};
  for (const auto& p : points) {
    if (p.check != check || !std::isfinite(Norm3(p.d))) continue;
    ++r.count;
    for (int k = 0; k < 3; ++k) sum[k] += p.d[k] * p.d[k];
  }
  if (r.count == 0) return r;
  for (int k = 0; k < 3; ++k) r.axis[k] = std::sqrt(sum[k] / r.count);
  r.d3 = std::sqrt((sum[0] + sum[1] + sum[2]) / r.count);
  return r;
}

void RenderControlTable(const std::vector<ControlPoint>& points, const CheckSummary& check, std::ostringstream& html) {
  html << "<table>\n<tr><th rowspan=\"2\">point</th><th rowspan=\"2\">role</th>"
          "<th colspan=\"3\">surveyed [m]</th><th colspan=\"4\">adjusted &minus; surveyed [mm]</th>"
          "<th colspan=\"3\">"
       << kSigma << " [mm]</th><th colspan=\"3\">95&nbsp;% ellipse</th><th rowspan=\"2\">|d| &gt; 3"
       << kSigma << "</th></tr>\n<tr><th>E</th><th>N</th><th>U</th><th>dE</th><th>dN</th>"
          "<th>dU</th><th>3-D</th><th>E</th><th>N</th><th>U</th><th>a [mm]</th><th>b [mm]</th>"
          "<th>az [&deg;]</th></tr>\n";
  auto Row = [&](const ControlPoint& p) {
    const auto& xyz = std::isfinite(Norm3(p.surveyed)) ? p.surveyed : p.adjusted;
    html << "<tr" << (p.flagged_axes.empty() ? "" : " class=\"flag\"") << ">" << TdText(Esc(p.id))
         << TdText(p.check ? "check" : "control");
    for (int k = 0; k < 3; ++k) html << Td(FormatFixed(xyz[k], 3));
    for (int k = 0; k < 3; ++k) html << Td(Mm(p.d[k]));
    html << Td(Mm(Norm3(p.d)));
    for (int k = 0; k < 3; ++k) html << Td(Mm(p.sigma[k]));
    html << Td(Mm(p.ellipse_a)) << Td(Mm(p.ellipse_b)) << Td(FormatFixed(p.ellipse_azimuth_deg, 1))
         << TdText(p.flagged_axes.empty() ? "" : "<b>" + p.flagged_axes + "</b>") << "</tr>\n";
  };
  auto RmsRow = [&](const std::string& label, const std::array<double, 3>& axis, double d3) {
    html << "<tr class=\"rms\"><td colspan=\"5\">" << label << "</td>";
    for (int k = 0; k < 3; ++k) html << Td(Mm(axis[k]));
    html << Td(Mm(d3)) << "<td colspan=\"7\"></td></tr>\n";
  };
  for (bool role_check : {false, true}) {
    for (const auto& p : points) {
      if (p.check == role_check) Row(p);
    }
  }
  const Rms control = RmsOf(points, false);
  if (control.count > 0) RmsRow("RMS control (" + std::to_string(control.count) + ")", control.axis, control.d3);
  if (std::isfinite(check.rmse_3d) || std::isfinite(Norm3(check.rmse))) {
    RmsRow("RMSE check (" + Count(check.count) + ")" + (check.given ? "" : ", from this table"), check.rmse, check.rmse_3d);
  }
  if (std::isfinite(check.expected_3d)) {
    html << "<tr class=\"rms\"><td colspan=\"5\">expected RMSE check (from the a-priori " << kSigma
         << ")</td><td colspan=\"3\"></td>" << Td(Mm(check.expected_3d)) << "<td colspan=\"7\"></td></tr>\n";
  }
  html << "</table>\n<p class=\"note\">Control points take part in the adjustment; check points "
          "are withheld from it and measure its accuracy. Rows in red: |d| &gt; 3"
       << kSigma << " in the axes named. 95&nbsp;% confidence ellipse: the standard ellipse &times; "
       << FormatFixed(k95Ellipse2d, 4) << " = sqrt(&chi;<sup>2</sup><sub>2;0.95</sub>); azimuth of the semi-major "
          "axis a from north towards east.</p>\n";
}

void RenderControlPlan(const std::vector<ControlPoint>& points, std::ostringstream& html) {
  std::vector<PlanPoint> plan;
  for (const auto& p : points) {
    PlanPoint q;
    q.id = p.id;
    q.check = p.check;
    const auto& xyz = std::isfinite(p.surveyed[0] + p.surveyed[1]) ? p.surveyed : p.adjusted;
    q.east = xyz[0];
    q.north = xyz[1];
    q.d_east = p.d[0];
    q.d_north = p.d[1];
    q.ellipse_a = p.ellipse_a;
    q.ellipse_b = p.ellipse_b;
    q.ellipse_azimuth_deg = p.ellipse_azimuth_deg;
    q.flagged = !p.flagged_axes.empty();
    plan.push_back(q);
  }
  PlanViewOptions options;
  options.ellipse_label = "95 % confidence ellipse";
  PlanScales scales;
  const std::string svg = SvgPlanView(plan, options, &scales);
  html << "<figure>\n" << svg << "<figcaption>Plan view, east to the right, north up. 95&nbsp;% confidence ellipses "
          "and displacement vectors (adjusted &minus; surveyed, horizontal) are magnified ";
  if (scales.error_px_per_m > 0.0 && scales.map_px_per_m > 0.0) {
    html << "&times;" << Sig(scales.error_px_per_m / scales.map_px_per_m, 3) << " relative to the map";
  }
  html << "; both scale bars are drawn below the plan.</figcaption>\n</figure>\n";
}

}  // namespace

CheckSummary ReadCheckSummary(const json& report) {
  CheckSummary s;
  if (const json* o = OptObject(report, "check_summary", "")) {
    s.given = true;
    s.count = Num(*o, "count", "check_summary");
    if (auto v = OptVec3(*o, "rmse", "check_summary")) s.rmse = *v;
    s.rmse_3d = Num(*o, "rmse_3d", "check_summary");
    s.expected_3d = Num(*o, "expected_rmse_3d", "check_summary");
    return s;
  }
  const Rms r = RmsOf(ReadControlPoints(report), true);
  if (r.count == 0) return s;
  s.count = r.count;
  s.rmse = r.axis;
  s.rmse_3d = r.d3;
  return s;
}

void RenderControlPoints(const json& report, std::ostringstream& html) {
  const std::vector<ControlPoint> points = ReadControlPoints(report);
  if (points.empty()) return;
  html << "<section id=\"control\">\n<h2>Control and check points</h2>\n";
  RenderControlTable(points, ReadCheckSummary(report), html);
  RenderControlPlan(points, html);
  html << "</section>\n";
}

}  // namespace mmba::report::internal
