// report.html: every adjusted point with σ and its 95 % confidence ellipse, and the relative
// precision between neighbouring points.
#include <array>
#include <cmath>
#include <string>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

/// Rows shown in a table before the rest is left to the CSV the report names.
constexpr size_t kMaxTableRows = 500;

/// Opens a table that is folded away (<details>) when it has more than `fold_above` rows.
void OpenLongTable(size_t rows, size_t fold_above, const std::string& what, std::ostringstream& html) {
  if (rows > fold_above) html << "<details><summary>" << what << " (" << rows << " rows)</summary>\n";
}

void CloseLongTable(size_t rows, size_t fold_above, const std::string& csv, std::ostringstream& html) {
  if (rows > kMaxTableRows) {
    html << "<p class=\"note\">The first " << kMaxTableRows << " of " << rows << " rows; all of them in <code>"
         << Esc(csv) << "</code>.</p>\n";
  }
  if (rows > fold_above) html << "</details>\n";
}

/// An entry's optional `ellipse` at 95 %: semi-axes a, b and the azimuth of a (degrees from
/// north); NaN without one.
std::array<double, 3> Ellipse95(const json& p, const std::string& path) {
  const json* e = OptObject(p, "ellipse", path);
  if (e == nullptr) return {NAN, NAN, NAN};
  const std::string epath = Join(path, "ellipse");
  const double to95 = EllipseFactorTo95(Num(*e, "confidence", epath), epath);
  return {Num(*e, "a", epath) * to95, Num(*e, "b", epath) * to95, Num(*e, "azimuth_deg", epath)};
}

void RenderPointRow(const json& p, const std::string& path, std::ostringstream& html) {
  std::array<double, 3> xyz{NAN, NAN, NAN}, sigma{NAN, NAN, NAN};
  if (auto v = OptVec3(p, "adjusted", path)) xyz = *v;
  if (auto v = OptVec3(p, "sigma", path)) sigma = *v;
  const auto [a, b, azimuth] = Ellipse95(p, path);
  html << "<tr>" << TdText(Esc(ReqString(p, "id", path))) << TdText(Esc(OptString(p, "role", path).value_or("")));
  for (int k = 0; k < 3; ++k) html << Td(FormatFixed(xyz[k], 4));
  for (int k = 0; k < 3; ++k) html << Td(Mm(sigma[k]));
  html << Td(Mm(a)) << Td(Mm(b)) << Td(FormatFixed(azimuth, 1)) << Td(Mm(k95Normal * sigma[2])) << "</tr>\n";
}

}  // namespace

void RenderAdjustedPoints(const json& report, std::ostringstream& html) {
  const json* points = OptArray(report, "points", "");
  if (points == nullptr || points->empty()) return;
  const std::string csv = OptString(report, "points_file", "").value_or("points.csv");
  html << "<section id=\"points\">\n<h2>Adjusted points</h2>\n";
  OpenLongTable(points->size(), 60, "All adjusted points", html);
  html << "<table>\n<tr><th rowspan=\"2\">point</th><th rowspan=\"2\">kind</th><th colspan=\"3\">adjusted [m]</th>"
          "<th colspan=\"3\">" << kSigma << " [mm]</th><th colspan=\"3\">95&nbsp;% ellipse</th><th>95&nbsp;%</th></tr>\n"
          "<tr><th>E</th><th>N</th><th>U</th><th>E</th><th>N</th><th>U</th><th>a [mm]</th><th>b [mm]</th>"
          "<th>az [&deg;]</th><th>U [mm]</th></tr>\n";
  for (size_t i = 0; i < points->size() && i < kMaxTableRows; ++i) {
    RenderPointRow(ElementObject(*points, i, "points"), Index("points", i), html);
  }
  html << "</table>\n";
  CloseLongTable(points->size(), 60, csv, html);
  html << "<p class=\"note\">" << kSigma << " from the covariance of the adjustment (scaled by " << kSigma
       << "&#770;<sub>0</sub><sup>2</sup> where the project says so). 95&nbsp;% confidence ellipse: the standard "
          "ellipse &times; " << FormatFixed(k95Ellipse2d, 4) << " = sqrt(&chi;<sup>2</sup><sub>2;0.95</sub>) "
          "(Ghilani 2017, ch. 19, error ellipses); 95&nbsp;% of the height: " << FormatFixed(k95Normal, 2) << " " << kSigma
       << "<sub>U</sub>; a 3-D 95&nbsp;% ellipsoid would take &times; " << FormatFixed(k95Ellipsoid3d, 4)
       << " = sqrt(&chi;<sup>2</sup><sub>3;0.95</sub>).</p>\n</section>\n";
}

void RenderRelativePrecision(const json& report, std::ostringstream& html) {
  const json* pairs = OptArray(report, "relative_precision", "");
  if (pairs == nullptr || pairs->empty()) return;
  html << "<section id=\"relative\">\n<h2>Relative precision between neighbouring points</h2>\n";
  OpenLongTable(pairs->size(), 60, "All pairs", html);
  html << "<table>\n<tr><th>from</th><th>to</th><th>distance [m]</th><th>" << kSigma << " distance [mm]</th><th>"
       << kSigma << "/distance [ppm]</th><th>" << kSigma << " &Delta;E</th><th>" << kSigma << " &Delta;N</th><th>"
       << kSigma << " &Delta;U [mm]</th><th>95&nbsp;% a [mm]</th><th>b [mm]</th><th>az [&deg;]</th></tr>\n";
  for (size_t i = 0; i < pairs->size() && i < kMaxTableRows; ++i) {
    const std::string path = Index("relative_precision", i);
    const json& p = ElementObject(*pairs, i, "relative_precision");
    const double d = Num(p, "distance_m", path), sd = Num(p, "sigma_distance_m", path);
    std::array<double, 3> sigma{NAN, NAN, NAN};
    if (auto v = OptVec3(p, "sigma", path)) sigma = *v;
    const auto [a, b, azimuth] = Ellipse95(p, path);
    html << "<tr>" << TdText(Esc(ReqString(p, "from", path))) << TdText(Esc(ReqString(p, "to", path)))
         << Td(FormatFixed(d, 3)) << Td(Mm(sd, 2)) << Td(d > 0.0 ? FormatFixed(sd / d * 1e6, 1) : kDash);
    for (int k = 0; k < 3; ++k) html << Td(Mm(sigma[k], 2));
    html << Td(Mm(a, 2)) << Td(Mm(b, 2)) << Td(FormatFixed(azimuth, 1)) << "</tr>\n";
  }
  html << "</table>\n";
  CloseLongTable(pairs->size(), 60, "report.json", html);
  html << "<p class=\"note\">Each point with its nearest neighbours in plan. " << kSigma
       << " of the coordinate difference from the joint covariance, C<sub>&Delta;</sub> = C<sub>ii</sub> + "
          "C<sub>jj</sub> &minus; C<sub>ij</sub> &minus; C<sub>ij</sub><sup>T</sup> (Ghilani 2017, ch. 19, relative "
          "error ellipses); it is smaller than either point's own " << kSigma
       << " where the two are correlated, as neighbours measured together are.</p>\n</section>\n";
}

}  // namespace mmba::report::internal
