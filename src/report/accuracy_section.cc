// Check-point accuracy (accuracy.h) and its report.html section.
#include "mmba/report/accuracy.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "report/html_internal.h"

namespace mmba::report {

CheckAccuracy ComputeCheckAccuracy(const std::vector<std::array<double, 3>>& differences) {
  CheckAccuracy a;
  std::array<double, 3> sum{0, 0, 0}, sum2{0, 0, 0};
  for (const auto& d : differences) {
    if (!(std::isfinite(d[0]) && std::isfinite(d[1]) && std::isfinite(d[2]))) continue;
    ++a.count;
    for (int k = 0; k < 3; ++k) {
      sum[k] += d[k];
      sum2[k] += d[k] * d[k];
    }
  }
  const double n = a.count;
  for (int k = 0; k < 3; ++k) {
    a.mean[k] = n > 0 ? sum[k] / n : NAN;
    a.rmse[k] = n > 0 ? std::sqrt(sum2[k] / n) : NAN;
    a.stdev[k] = n > 1 ? std::sqrt(std::max(0.0, (sum2[k] - n * a.mean[k] * a.mean[k]) / (n - 1))) : NAN;
  }
  a.rmse_h = std::hypot(a.rmse[0], a.rmse[1]);
  a.rmse_v = a.rmse[2];
  a.rmse_3d = std::hypot(a.rmse_h, a.rmse_v);
  a.accuracy_v95 = 1.9600 * a.rmse_v;
  const double lo = std::min(a.rmse[0], a.rmse[1]), hi = std::max(a.rmse[0], a.rmse[1]);
  const double ratio = hi > 0.0 ? lo / hi : 1.0;
  if (n == 0) {
    a.accuracy_h95 = NAN;
    a.horizontal_formula = "no check points";
  } else if (ratio >= 0.999) {
    a.accuracy_h95 = 1.7308 * a.rmse_h;
    a.horizontal_formula = "1.7308 RMSE_r (RMSE_x = RMSE_y)";
  } else if (ratio > 0.6) {
    a.accuracy_h95 = 2.4477 * 0.5 * (a.rmse[0] + a.rmse[1]);
    a.horizontal_formula = "2.4477 * 0.5 (RMSE_x + RMSE_y) (0.6 < RMSE_min/RMSE_max < 1)";
  } else {
    a.accuracy_h95 = NAN;
    a.horizontal_formula = "not defined: RMSE_min/RMSE_max = " + FormatFixed(ratio, 2) + " <= 0.6";
  }
  if (a.count < kNssdaMinCheckPoints) {
    a.warnings.push_back(std::to_string(a.count) + " check point" + (a.count == 1 ? "" : "s") +
                         ": NSSDA (FGDC-STD-007.3-1998) and ASPRS 2014 need at least 20 to state an accuracy; "
                         "the figures describe these points only, not the product");
  } else if (a.count < kAsprs2023MinCheckPoints) {
    a.warnings.push_back(std::to_string(a.count) + " check points: enough for NSSDA and ASPRS 2014 (20), fewer "
                         "than the 30 ASPRS Edition 2 (2023) requires");
  }
  return a;
}

namespace internal {
namespace {

/// A check point's difference adjusted − reference and its σ, from either source.
struct CheckRow {
  std::string id, source;
  std::array<double, 3> d{NAN, NAN, NAN}, sigma{NAN, NAN, NAN};
};

/// Check points of `control_points` (role "check") and of `photo_measurements.check_points`.
std::vector<CheckRow> ReadCheckRows(const json& report) {
  std::vector<CheckRow> rows;
  for (const ControlPoint& p : ReadControlPoints(report)) {
    if (p.check) rows.push_back({p.id, "control_points", p.d, p.sigma});
  }
  const json* pm = OptObject(report, "photo_measurements", "");
  const json* cp = pm != nullptr ? OptObject(*pm, "check_points", "photo_measurements") : nullptr;
  const json* points = cp != nullptr ? OptArray(*cp, "points", "photo_measurements.check_points") : nullptr;
  if (points == nullptr) return rows;
  const std::string base = "photo_measurements.check_points.points";
  for (size_t i = 0; i < points->size(); ++i) {
    const json& o = ElementObject(*points, i, base);
    const std::string path = Index(base, i);
    CheckRow r;
    r.id = ReqString(o, "point", path);
    r.source = OptString(o, "status", path).value_or("photo_measurements");
    if (auto v = OptVec3(o, "d_m", path)) r.d = *v;
    if (auto v = OptVec3(o, "sigma_m", path)) r.sigma = *v;
    rows.push_back(r);
  }
  return rows;
}

void RenderAccuracyTable(const CheckAccuracy& a, std::ostringstream& html) {
  static const char* kAxis[3] = {"E (x)", "N (y)", "U (z)"};
  html << "<table>\n<tr><th>axis</th><th>mean error [mm]</th><th>std. dev. [mm]</th><th>RMSE [mm]</th></tr>\n";
  for (int k = 0; k < 3; ++k) {
    html << "<tr>" << TdText(kAxis[k]) << Td(Mm(a.mean[k])) << Td(Mm(a.stdev[k])) << Td(Mm(a.rmse[k])) << "</tr>\n";
  }
  html << "</table>\n<table class=\"meta\">\n"
       << "<tr><th>RMSE<sub>H</sub> = RMSE<sub>r</sub></th><td><b>" << Mm(a.rmse_h) << " mm</b></td></tr>\n"
       << "<tr><th>RMSE<sub>V</sub></th><td><b>" << Mm(a.rmse_v) << " mm</b></td></tr>\n"
       << "<tr><th>RMSE<sub>3D</sub></th><td>" << Mm(a.rmse_3d) << " mm</td></tr>\n"
       << "<tr><th>NSSDA horizontal, 95&nbsp;%</th><td><b>" << Mm(a.accuracy_h95) << " mm</b> ("
       << Esc(a.horizontal_formula) << ")</td></tr>\n"
       << "<tr><th>NSSDA vertical, 95&nbsp;%</th><td><b>" << Mm(a.accuracy_v95) << " mm</b> (1.9600 RMSE<sub>z</sub>)</td></tr>\n"
       << "</table>\n";
}

}  // namespace

void RenderAccuracy(const json& report, std::ostringstream& html) {
  const std::vector<CheckRow> rows = ReadCheckRows(report);
  if (rows.empty()) return;
  std::vector<std::array<double, 3>> d;
  for (const CheckRow& r : rows) d.push_back(r.d);
  const CheckAccuracy a = ComputeCheckAccuracy(d);
  html << "<section id=\"accuracy\">\n<h2>Accuracy from check points</h2>\n";
  if (!a.warnings.empty()) {
    html << "<div class=\"caution\"><b>Too few check points to support an accuracy claim.</b><ul>\n";
    for (const std::string& w : a.warnings) html << "<li>" << Esc(w) << "</li>\n";
    html << "</ul></div>\n";
  }
  html << "<p>" << a.count << " check point" << (a.count == 1 ? "" : "s")
       << " withheld from the adjustment; differences adjusted &minus; reference.</p>\n";
  RenderAccuracyTable(a, html);
  html << "<details><summary>The " << rows.size() << " check points</summary>\n<table>\n<tr><th>point</th><th>source</th>"
          "<th>dE [mm]</th><th>dN [mm]</th><th>dU [mm]</th><th>" << kSigma << " E</th><th>" << kSigma << " N</th><th>"
       << kSigma << " U [mm]</th></tr>\n";
  for (const CheckRow& r : rows) {
    html << "<tr>" << TdText(Esc(r.id)) << TdText(Esc(r.source));
    for (int k = 0; k < 3; ++k) html << Td(Mm(r.d[k]));
    for (int k = 0; k < 3; ++k) html << Td(Mm(r.sigma[k]));
    html << "</tr>\n";
  }
  html << "</table>\n</details>\n<p class=\"note\">NSSDA: FGDC-STD-007.3-1998, Appendix 3-A "
          "(Accuracy<sub>r</sub> = 1.7308 RMSE<sub>r</sub> when RMSE<sub>x</sub> = RMSE<sub>y</sub>, "
          "&asymp; 2.4477&middot;0.5&middot;(RMSE<sub>x</sub> + RMSE<sub>y</sub>) when 0.6 &lt; "
          "RMSE<sub>min</sub>/RMSE<sub>max</sub> &lt; 1; Accuracy<sub>z</sub> = 1.9600 RMSE<sub>z</sub>), at least 20 "
          "check points; ASPRS Positional Accuracy Standards, Edition 1 (2014): the same figures and count; "
          "Edition 2 (2023): RMSE<sub>H</sub>, RMSE<sub>V</sub> and RMSE<sub>3D</sub> without 95&nbsp;% figures, at least "
          "30 check points. A mean error well beyond std. dev./&radic;n is a bias (datum, scale or height "
          "reference), not noise.</p>\n</section>\n";
}

}  // namespace internal
}  // namespace mmba::report
