#include "mmba/report/adjust_report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mmba/report/svg_plot.h"

namespace mmba::report {
namespace {

using nlohmann::json;

constexpr const char* kDash = "\xE2\x80\x94";
constexpr const char* kSigma = "\xCF\x83";

// ---------------------------------------------------------------------------------------
// Typed access to the report JSON; every error names the field by its path.

std::string Describe(const json& value) {
  std::string text = value.dump(-1, ' ', false, json::error_handler_t::replace);
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return std::string(value.type_name()) + " " + text;
}

[[noreturn]] void Fail(const std::string& path, const std::string& found,
                       const std::string& expected) {
  throw std::invalid_argument("report JSON: field '" + path + "': found " + found + ", expected " +
                              expected);
}

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string Index(const std::string& path, size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

// A present, non-null member (nullptr when absent or null).
const json* Member(const json& object, const std::string& key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return nullptr;
  return &*it;
}

std::optional<std::string> OptString(const json& object, const std::string& key,
                                     const std::string& path) {
  const json* v = Member(object, key);
  if (v == nullptr) return std::nullopt;
  if (!v->is_string()) Fail(Join(path, key), Describe(*v), "a string");
  return v->get<std::string>();
}

std::string ReqString(const json& object, const std::string& key, const std::string& path) {
  const auto value = OptString(object, key, path);
  if (!value) Fail(Join(path, key), "nothing (missing)", "a string");
  return *value;
}

// A number; NaN when absent or null (JSON has no NaN: writers emit null).
double Num(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v == nullptr) return NAN;
  if (!v->is_number()) Fail(Join(path, key), Describe(*v), "a number or null");
  return v->get<double>();
}

std::optional<bool> OptBool(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v == nullptr) return std::nullopt;
  if (!v->is_boolean()) Fail(Join(path, key), Describe(*v), "true or false");
  return v->get<bool>();
}

const json* OptObject(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v != nullptr && !v->is_object()) Fail(Join(path, key), Describe(*v), "an object");
  return v;
}

const json* OptArray(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v != nullptr && !v->is_array()) Fail(Join(path, key), Describe(*v), "an array");
  return v;
}

const json& ElementObject(const json& array, size_t i, const std::string& path) {
  const json& v = array[i];
  if (!v.is_object()) Fail(Index(path, i), Describe(v), "an object");
  return v;
}

// An array of 3 numbers (null = NaN); nullopt when absent.
std::optional<std::array<double, 3>> OptVec3(const json& object, const std::string& key,
                                             const std::string& path) {
  const json* v = OptArray(object, key, path);
  if (v == nullptr) return std::nullopt;
  const std::string field = Join(path, key);
  if (v->size() != 3) Fail(field, Describe(*v), "an array of 3 numbers [E, N, U]");
  std::array<double, 3> out{};
  for (size_t i = 0; i < 3; ++i) {
    const json& e = (*v)[i];
    if (e.is_null()) {
      out[i] = NAN;
    } else if (e.is_number()) {
      out[i] = e.get<double>();
    } else {
      Fail(Index(field, i), Describe(e), "a number or null");
    }
  }
  return out;
}

std::vector<double> NumberArray(const json& object, const std::string& key, const std::string& path) {
  std::vector<double> out;
  const json* v = OptArray(object, key, path);
  if (v == nullptr) return out;
  out.reserve(v->size());
  for (size_t i = 0; i < v->size(); ++i) {
    const json& e = (*v)[i];
    if (e.is_null()) {
      out.push_back(NAN);
    } else if (e.is_number()) {
      out.push_back(e.get<double>());
    } else {
      Fail(Index(Join(path, key), i), Describe(e), "a number or null");
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Formatting.

std::string Esc(const std::string& s) { return HtmlEscape(s); }

// A count with thin spaces between thousands ("35 966"); "—" when not finite.
std::string Count(double value) {
  if (!std::isfinite(value)) return kDash;
  if (std::abs(value - std::round(value)) > 1e-9) return FormatFixed(value, 1);
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.0f", std::abs(value));
  std::string digits = buffer, out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += "\xE2\x80\xAF";  // narrow no-break space
    out += digits[i];
  }
  return (value < 0 ? "-" : "") + out;
}

// Significant digits ("%.Ng"), "—" when not finite.
std::string Sig(double value, int digits = 6) {
  if (!std::isfinite(value)) return kDash;
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, value);
  return buffer;
}

std::string Mm(double metres, int decimals = 1) { return FormatFixed(metres * 1000.0, decimals); }

std::string Td(const std::string& content) { return "<td class=\"num\">" + content + "</td>"; }
std::string TdText(const std::string& escaped) { return "<td>" + escaped + "</td>"; }

// How the variance components treated a group (`reweighting`, `sigma_factor`): "σ × f" for a
// re-weighted group, the reason for one that is not (a prior, a constraint, …); "—" when the
// report predates the field.
std::string Reweighting(const json& group, const std::string& path) {
  const std::optional<std::string> how = OptString(group, "reweighting", path);
  if (!how) return kDash;
  if (*how != "variance components") return *how;
  const double factor = Num(group, "sigma_factor", path);
  return std::isfinite(factor) ? "\xCF\x83 \xC3\x97 " + FormatFixed(factor, 3) : *how;
}

// ---------------------------------------------------------------------------------------
// Statistics helpers.

// Regularised lower incomplete gamma P(a, x) by its series (Abramowitz & Stegun 6.5.29);
// used for the χ tail P(|w| > t) = 1 − P(k/2, t²/2) at t = 3 with small k.
double LowerRegularizedGamma(double a, double x) {
  if (x <= 0.0) return 0.0;
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 500; ++n) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * 1e-15) break;
  }
  return std::min(1.0, sum * std::exp(-x + a * std::log(x) - std::lgamma(a)));
}

// P(norm of k whitened components > t); k = 1 is the two-sided normal tail.
double ChiTail(double t, int k) { return 1.0 - LowerRegularizedGamma(0.5 * k, 0.5 * t * t); }

// ---------------------------------------------------------------------------------------
// Sections.

struct Sigma0 {
  double apriori = NAN, aposteriori = NAN, dof = NAN, confidence = NAN, lower = NAN, upper = NAN;
  std::optional<bool> passed;
};

Sigma0 ReadSigma0(const json& report) {
  const json* s = OptObject(report, "sigma0", "");
  if (s == nullptr) Fail("sigma0", "nothing (missing)", "an object {apriori, aposteriori, dof, ...}");
  Sigma0 out;
  out.apriori = Num(*s, "apriori", "sigma0");
  out.aposteriori = Num(*s, "aposteriori", "sigma0");
  out.dof = Num(*s, "dof", "sigma0");
  out.confidence = Num(*s, "confidence", "sigma0");
  out.lower = Num(*s, "chi2_lower", "sigma0");
  out.upper = Num(*s, "chi2_upper", "sigma0");
  out.passed = OptBool(*s, "passed", "sigma0");
  return out;
}

std::string StatusBadge(const std::string& status) {
  if (status == "converged") return "<span class=\"badge ok\">converged</span>";
  if (status == "no_convergence") return "<span class=\"badge warn\">no convergence</span>";
  return "<span class=\"badge bad\">failed</span>";
}

struct ControlPoint {
  std::string id;
  bool check = false;
  std::array<double, 3> surveyed{NAN, NAN, NAN}, adjusted{NAN, NAN, NAN}, d{NAN, NAN, NAN},
      sigma{NAN, NAN, NAN};
  double ellipse_a = NAN, ellipse_b = NAN, ellipse_azimuth_deg = NAN, ellipse_confidence = NAN;
  std::string flagged_axes;  // "E, U" when |d| > 3σ in those axes
};

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
      p.ellipse_confidence = Num(*e, "confidence", epath);
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

double Norm3(const std::array<double, 3>& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

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

struct CheckSummary {
  bool given = false;  // from check_summary (else computed from the table)
  double count = NAN;
  std::array<double, 3> rmse{NAN, NAN, NAN};
  double rmse_3d = NAN, expected_3d = NAN;
};

CheckSummary ReadCheckSummary(const json& report, const std::vector<ControlPoint>& points) {
  CheckSummary s;
  if (const json* o = OptObject(report, "check_summary", "")) {
    s.given = true;
    s.count = Num(*o, "count", "check_summary");
    if (auto v = OptVec3(*o, "rmse", "check_summary")) s.rmse = *v;
    s.rmse_3d = Num(*o, "rmse_3d", "check_summary");
    s.expected_3d = Num(*o, "expected_rmse_3d", "check_summary");
    return s;
  }
  const Rms r = RmsOf(points, true);
  if (r.count == 0) return s;
  s.count = r.count;
  s.rmse = r.axis;
  s.rmse_3d = r.d3;
  return s;
}

const char* kCss = R"CSS(
@page { size: A4; margin: 14mm 12mm; }
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", Arial, Helvetica, sans-serif; font-size: 10pt; color: #1d1d1d;
       background: #ffffff; max-width: 190mm; margin: 0 auto; padding: 14px 10px 30px; line-height: 1.35; }
.kicker { color: #555; font-size: 9pt; letter-spacing: 0.04em; text-transform: uppercase; }
h1 { font-size: 18pt; margin: 2px 0 8px; }
h2 { font-size: 13pt; border-bottom: 2px solid #1f5fa8; padding-bottom: 2px; margin: 22px 0 8px;
     break-after: avoid; page-break-after: avoid; }
h3 { font-size: 11pt; margin: 12px 0 4px; break-after: avoid; }
table { border-collapse: collapse; margin: 4px 0 10px; font-size: 8.5pt; }
th, td { border: 1px solid #c8c8c8; padding: 2px 5px; vertical-align: top; }
th { background: #eef2f7; text-align: center; font-weight: 600; }
td.num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
tr { break-inside: avoid; page-break-inside: avoid; }
tr.flag td { background: #fde2e1; }
tr.rms td { font-weight: bold; background: #f3f3f3; }
table.meta th { text-align: left; background: #f6f6f6; width: 40mm; white-space: nowrap; }
table.meta { font-size: 9.5pt; }
.badge { display: inline-block; padding: 1px 9px; border-radius: 3px; color: #fff; font-weight: bold; }
.ok { background: #1a7f37; } .bad { background: #c62828; } .warn { background: #b26a00; }
.banner { border: 2px solid #c62828; background: #fdecea; padding: 6px 10px; margin: 8px 0; font-weight: bold; }
.summary { border: 2px solid #1f5fa8; border-radius: 4px; padding: 8px 12px; margin: 10px 0;
           break-inside: avoid; page-break-inside: avoid; }
.summary table { border: none; margin: 0; font-size: 10pt; }
.summary th, .summary td { border: none; padding: 2px 8px 2px 0; text-align: left; }
.summary th { background: none; font-weight: normal; color: #444; white-space: nowrap; }
.verdict { font-weight: bold; padding: 1px 8px; border-radius: 3px; color: #fff; }
.verdict.pass { background: #1a7f37; } .verdict.fail { background: #c62828; } .verdict.none { background: #777; }
.note { color: #555; font-size: 8.5pt; }
.plots { display: flex; flex-wrap: wrap; gap: 6px 14px; }
.plots figure { flex: 0 0 335px; width: 335px; }
figure { margin: 4px 0; break-inside: avoid; page-break-inside: avoid; }
figcaption { font-size: 8.5pt; color: #333; max-width: 100%; }
svg.plot { max-width: 100%; height: auto; display: block; }
ul.warnings li { margin: 2px 0; }
section.warnings { border-left: 4px solid #b26a00; background: #fff7e6; padding: 2px 10px 4px; margin: 10px 0; }
section.warnings h2 { border: none; margin-top: 6px; }
code { font-family: "DejaVu Sans Mono", monospace; font-size: 8.5pt; }
footer { margin-top: 24px; color: #777; font-size: 8pt; border-top: 1px solid #ccc; padding-top: 4px; }
@media print { body { max-width: none; padding: 0; } details { display: none; } }
)CSS";

void RenderHeader(const json& report, const std::string& project, const std::string& status,
                  std::ostringstream& html) {
  html << "<header>\n<div class=\"kicker\">mmba adjust &middot; joint adjustment report</div>\n";
  html << "<h1>" << Esc(project) << "</h1>\n<table class=\"meta\">\n";
  if (auto t = OptString(report, "generated_utc", "")) {
    html << "<tr><th>Generated (UTC)</th><td>" << Esc(*t) << "</td></tr>\n";
  }
  html << "<tr><th>Status</th><td>" << StatusBadge(status) << "</td></tr>\n";
  if (const json* m = OptObject(report, "mmba", "")) {
    html << "<tr><th>Written by</th><td>mmba " << Esc(ReqString(*m, "version", "mmba")) << " (commit "
         << Esc(ReqString(*m, "commit", "mmba")) << ")</td></tr>\n";
  }
  if (auto r = OptString(report, "reason", "")) {
    html << "<tr><th>Reason</th><td>" << Esc(*r) << "</td></tr>\n";
  }
  if (const json* o = OptObject(report, "origin", "")) {
    const double lat = Num(*o, "latitude_deg", "origin");
    const double lon = Num(*o, "longitude_deg", "origin");
    const double h = Num(*o, "height_m", "origin");
    html << "<tr><th>Origin (WGS84)</th><td>latitude " << FormatFixed(lat, 9)
         << "&deg;, longitude " << FormatFixed(lon, 9) << "&deg;, height " << FormatFixed(h, 3)
         << " m</td></tr>\n";
  }
  if (auto f = OptString(report, "frame", "")) {
    html << "<tr><th>Frame</th><td>" << Esc(*f) << "</td></tr>\n";
  }
  if (auto z = OptString(report, "utm_zone", "")) {
    html << "<tr><th>UTM zone</th><td>" << Esc(*z) << "</td></tr>\n";
  }
  html << "</table>\n</header>\n";
}

void RenderSummary(const json& report, const std::string& status, const Sigma0& s0,
                   const CheckSummary& check, size_t num_groups, double num_observations,
                   size_t num_blunders, size_t num_downweighted, size_t num_warnings,
                   std::ostringstream& html) {
  if (status != "converged") {
    html << "<div class=\"banner\">"
         << (status == "failed" ? "The adjustment FAILED."
                                : "The adjustment did NOT CONVERGE within its iteration limit.")
         << " The figures below describe the last iterate and are not a valid result.";
    if (auto r = OptString(report, "reason", "")) html << " Reason: " << Esc(*r);
    html << "</div>\n";
  }
  html << "<div class=\"summary\" id=\"summary\">\n<table>\n";
  const double ratio = s0.aposteriori / s0.apriori;
  html << "<tr><th>" << kSigma << "<sub>0</sub> a-posteriori</th><td><b>" << Sig(s0.aposteriori, 4)
       << "</b> (a-priori " << Sig(s0.apriori, 4) << ", ratio " << FormatFixed(ratio, 3)
       << ")</td></tr>\n";
  html << "<tr><th>Degrees of freedom</th><td>" << Count(s0.dof) << "</td></tr>\n";
  // Global test of the adjustment: f·σ̂0²/σ0² ~ χ²_f, so the two-sided acceptance interval of
  // the ratio σ̂0/σ0 is [sqrt(χ²_{α/2,f}/f), sqrt(χ²_{1−α/2,f}/f)] (mmba_stats computes it as
  // chi2_lower/chi2_upper; the same test as GNU Gama's). Recomputed here only when "passed"
  // is absent, and a disagreement with "passed" is shown.
  std::optional<bool> passed = s0.passed;
  const bool bounds = std::isfinite(s0.lower) && std::isfinite(s0.upper) && std::isfinite(ratio);
  const bool inside = bounds && ratio >= s0.lower && ratio <= s0.upper;
  if (!passed && bounds) passed = inside;
  std::string level = "the stated level";
  if (std::isfinite(s0.confidence)) {
    const double percent = s0.confidence * 100.0;
    level = FormatFixed(percent, percent == std::round(percent) ? 0 : 1) + "&nbsp;% confidence";
  }
  html << "<tr><th>&chi;<sup>2</sup> test (two-sided)</th><td>";
  if (passed.has_value()) {
    html << "<span class=\"verdict " << (*passed ? "pass\">PASSED" : "fail\">FAILED") << "</span> ";
  } else {
    html << "<span class=\"verdict none\">NOT TESTED</span> ";
  }
  html << "at " << level << ": ratio " << FormatFixed(ratio, 3) << ", accepted interval ["
       << FormatFixed(s0.lower, 3) << ", " << FormatFixed(s0.upper, 3) << "]";
  if (passed.has_value()) {
    html << (*passed ? " &mdash; the a-priori " + std::string(kSigma) + " agree with the residuals"
                     : " &mdash; the a-priori " + std::string(kSigma) +
                           " do not agree with the residuals (weights or model to revise)");
  }
  if (s0.passed.has_value() && bounds && s0.passed.value() != inside) {
    html << "<br><span class=\"note\"><b>Inconsistent:</b> the report says "
         << (s0.passed.value() ? "passed" : "failed") << " but the ratio lies "
         << (inside ? "inside" : "outside") << " the interval.</span>";
  }
  html << "</td></tr>\n";
  if (const json* solver = OptObject(report, "solver", "")) {
    const double iterations = Num(*solver, "iterations", "solver");
    const double outer = Num(*solver, "outer_iterations", "solver");
    const double c0 = Num(*solver, "initial_cost", "solver");
    const double c1 = Num(*solver, "final_cost", "solver");
    const double seconds = Num(*solver, "seconds", "solver");
    html << "<tr><th>Solver</th><td>" << Count(iterations) << " iterations";
    if (std::isfinite(outer)) html << " in " << Count(outer) << " outer (re-association) loops";
    html << "; cost " << Sig(c0, 6) << " &rarr; " << Sig(c1, 6);
    if (std::isfinite(seconds)) html << "; " << FormatFixed(seconds, 1) << " s";
    html << "</td></tr>\n";
  }
  if (std::isfinite(check.rmse_3d)) {
    html << "<tr><th>Check points</th><td>RMSE 3-D <b>" << Mm(check.rmse_3d) << " mm</b> over "
         << Count(check.count) << " points";
    if (std::isfinite(check.expected_3d) && check.expected_3d > 0.0) {
      html << " (expected " << Mm(check.expected_3d) << " mm; ratio "
           << FormatFixed(check.rmse_3d / check.expected_3d, 2) << ")";
    }
    html << "</td></tr>\n";
  }
  html << "<tr><th>Observations</th><td>" << Count(num_observations) << " in " << num_groups
       << " group" << (num_groups == 1 ? "" : "s") << "; " << num_blunders
       << " flagged as blunder" << (num_blunders == 1 ? "" : "s") << " (" << num_downweighted
       << " down-weighted)";
  if (num_warnings > 0) html << "; <b>" << num_warnings << " warning" << (num_warnings == 1 ? "" : "s") << "</b>";
  html << "</td></tr>\n</table>\n</div>\n";
}

void RenderWarnings(const json& report, std::ostringstream& html) {
  const json* warnings = OptArray(report, "warnings", "");
  if (warnings == nullptr || warnings->empty()) return;
  html << "<section class=\"warnings\" id=\"warnings\">\n<h2>Warnings</h2>\n<ul class=\"warnings\">\n";
  for (size_t i = 0; i < warnings->size(); ++i) {
    const json& w = (*warnings)[i];
    if (!w.is_string()) Fail(Index("warnings", i), Describe(w), "a string");
    html << "<li>" << Esc(w.get<std::string>()) << "</li>\n";
  }
  html << "</ul>\n</section>\n";
}

/// A group's whitened residuals and how to plot them: components against N(0,1), or norms
/// of `dof` components against χ_dof.
struct GroupPlot {
  std::string name, unit;
  std::vector<double> whitened;
  bool norms = false;
  int dof = 1;
};

/// Whether the whitened values are norms: "whitened_kind", else all values >= 0.
bool WhitenedAreNorms(const json& g, const std::string& path,
                      const std::vector<double>& whitened) {
  const auto kind = OptString(g, "whitened_kind", path);
  if (kind && *kind != "components" && *kind != "norms") {
    Fail(Join(path, "whitened_kind"), "\"" + *kind + "\"", "\"components\" or \"norms\"");
  }
  if (kind) return *kind == "norms";
  return !whitened.empty() &&
         std::none_of(whitened.begin(), whitened.end(), [](double v) { return v < 0.0; });
}

/// Components per norm: "whitened_dof", else residuals per observation when whole, else 1.
int WhitenedDof(const json& g, const std::string& path, double observations, double residuals) {
  const double dof = Num(g, "whitened_dof", path);
  if (std::isfinite(dof)) {
    if (dof < 1.0 || dof != std::floor(dof) || dof > 1000.0) {
      Fail(Join(path, "whitened_dof"), Sig(dof), "a whole number in [1, 1000]");
    }
    return static_cast<int>(dof);
  }
  if (std::isfinite(observations) && std::isfinite(residuals) && observations > 0.0) {
    const double per = residuals / observations;
    if (per >= 1.0 && per == std::floor(per) && per <= 1000.0) return static_cast<int>(per);
  }
  return 1;
}

/// One row of the groups table; returns the group's plot.
GroupPlot RenderGroupRow(const json& g, const std::string& path, std::ostringstream& html) {
  GroupPlot plot;
  plot.name = ReqString(g, "name", path);
  plot.unit = OptString(g, "unit", path).value_or("");
  const double observations = Num(g, "observations", path);
  const double residuals = Num(g, "residuals", path);
  const std::string loss = OptString(g, "loss", path).value_or("");
  html << "<tr>" << TdText(Esc(plot.name)) << TdText(Esc(plot.unit)) << Td(Count(observations))
       << Td(Count(residuals)) << Td(Sig(Num(g, "redundancy", path), 6))
       << Td(Sig(Num(g, "sigma", path), 4)) << Td(Sig(Num(g, "rms", path), 4))
       << Td(Sig(Num(g, "mean", path), 4)) << Td(Sig(Num(g, "max", path), 4))
       << Td(FormatFixed(Num(g, "variance_component", path), 3))
       << TdText(Esc(Reweighting(g, path))) << Td(Count(Num(g, "outliers", path))) << TdText(loss.empty() ? "none" : Esc(loss))
       << "</tr>\n";
  plot.whitened = NumberArray(g, "whitened", path);
  plot.norms = WhitenedAreNorms(g, path, plot.whitened);
  plot.dof = WhitenedDof(g, path, observations, residuals);
  return plot;
}

/// A group's histogram of whitened residuals with the share beyond 3σ and its expectation.
void RenderGroupHistogram(const GroupPlot& plot, std::ostringstream& html) {
  HistogramOptions options;
  options.title = plot.name;
  options.width_px = 335;
  options.height_px = 215;
  if (plot.norms) {
    options.density = ReferenceDensity::kChi;
    options.chi_dof = plot.dof;
    options.x_label = "|r|/" + std::string(kSigma) + " (norm of " + std::to_string(plot.dof) +
                      " whitened component" + (plot.dof == 1 ? "" : "s") + ")";
  } else {
    options.density = ReferenceDensity::kStandardNormal;
    options.x_label = "whitened residual r/" + std::string(kSigma);
  }
  options.y_label = "count";
  size_t finite = 0, beyond3 = 0;
  for (double v : plot.whitened) {
    if (!std::isfinite(v)) continue;
    ++finite;
    if (std::abs(v) > 3.0) ++beyond3;
  }
  html << "<figure>\n" << SvgHistogram(plot.whitened, options) << "<figcaption>";
  if (finite > 0) {
    const int k = plot.norms ? plot.dof : 1;
    html << (plot.norms ? "|r|/" : "|r/") << kSigma << (plot.norms ? "" : "|") << " &gt; 3: "
         << FormatFixed(100.0 * beyond3 / finite, 2) << "&nbsp;% of " << Count(static_cast<double>(finite))
         << " (expected " << FormatFixed(100.0 * ChiTail(3.0, k), 2) << "&nbsp;% under "
         << (plot.norms ? "&chi;<sub>" + std::to_string(k) + "</sub>" : std::string("N(0,1)"))
         << ")";
  } else {
    html << "no whitened residuals in the report";
  }
  html << "</figcaption>\n</figure>\n";
}

void RenderGroups(const json& groups, std::ostringstream& html) {
  html << "<section id=\"groups\">\n<h2>Observation groups</h2>\n";
  if (groups.empty()) {
    html << "<p class=\"note\">The report lists no observation groups.</p>\n</section>\n";
    return;
  }
  html << "<table>\n<tr><th>group</th><th>unit</th><th>obser&shy;vations</th><th>resi&shy;duals</th>"
          "<th>redun&shy;dancy &Sigma;r</th><th>"
       << kSigma << " a-priori</th><th>RMS</th><th>mean</th><th>max</th><th>"
       << kSigma << "&#770;<sup>2</sup><sub>k</sub></th><th>re-weighting</th><th>out&shy;liers</th>"
          "<th>robust loss</th></tr>\n";
  std::vector<GroupPlot> plots;
  for (size_t i = 0; i < groups.size(); ++i) {
    const std::string path = Index("groups", i);
    plots.push_back(RenderGroupRow(ElementObject(groups, i, "groups"), path, html));
  }
  html << "</table>\n<p class=\"note\">RMS, mean, max and " << kSigma
       << " in the group's unit; variance component " << kSigma
       << "&#770;<sup>2</sup><sub>k</sub> = &Sigma;e<sup>2</sup>/&Sigma;r<sub>i</sub> (F&ouml;rstner "
          "1979), near 1 when the group's a-priori "
       << kSigma << " is right.</p>\n";

  html << "<h3>Whitened residuals</h3>\n<div class=\"plots\">\n";
  for (const GroupPlot& plot : plots) RenderGroupHistogram(plot, html);
  html << "</div>\n</section>\n";
}

void RenderControlPoints(const std::vector<ControlPoint>& points, const CheckSummary& check,
                         std::ostringstream& html) {
  if (points.empty()) return;
  html << "<section id=\"control\">\n<h2>Control and check points</h2>\n";
  html << "<table>\n<tr><th rowspan=\"2\">point</th><th rowspan=\"2\">role</th>"
          "<th colspan=\"3\">surveyed [m]</th><th colspan=\"4\">adjusted &minus; surveyed [mm]</th>"
          "<th colspan=\"3\">"
       << kSigma << " [mm]</th><th colspan=\"3\">error ellipse</th><th rowspan=\"2\">|d| &gt; 3"
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
  if (control.count > 0) {
    RmsRow("RMS control (" + std::to_string(control.count) + ")", control.axis, control.d3);
  }
  if (std::isfinite(check.rmse_3d) || std::isfinite(Norm3(check.rmse))) {
    RmsRow("RMSE check (" + Count(check.count) + ")" + (check.given ? "" : ", from this table"),
           check.rmse, check.rmse_3d);
  }
  if (std::isfinite(check.expected_3d)) {
    html << "<tr class=\"rms\"><td colspan=\"5\">expected RMSE check (from the a-priori "
         << kSigma << ")</td><td colspan=\"3\"></td>" << Td(Mm(check.expected_3d))
         << "<td colspan=\"7\"></td></tr>\n";
  }
  html << "</table>\n<p class=\"note\">Control points take part in the adjustment; check points "
          "are withheld from it and measure its accuracy. Rows in red: |d| &gt; 3"
       << kSigma << " in the axes named. Ellipse azimuth of the semi-major axis a from north towards east.</p>\n";

  std::vector<PlanPoint> plan;
  double confidence = NAN;
  bool mixed_confidence = false;
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
    if (std::isfinite(p.ellipse_a)) {
      if (std::isfinite(confidence) && std::isfinite(p.ellipse_confidence) &&
          confidence != p.ellipse_confidence) {
        mixed_confidence = true;
      }
      if (!std::isfinite(confidence)) confidence = p.ellipse_confidence;
    }
    plan.push_back(q);
  }
  PlanViewOptions options;
  if (mixed_confidence) {
    options.ellipse_label = "error ellipses (confidence levels differ, see the JSON)";
  } else if (std::isfinite(confidence)) {
    options.ellipse_label = FormatFixed(confidence * 100.0, 0) + " % confidence ellipse";
  }
  PlanScales scales;
  const std::string svg = SvgPlanView(plan, options, &scales);
  html << "<figure>\n" << svg << "<figcaption>Plan view, east to the right, north up. Error ellipses "
          "and displacement vectors (adjusted &minus; surveyed, horizontal) are magnified ";
  if (scales.error_px_per_m > 0.0 && scales.map_px_per_m > 0.0) {
    html << "&times;" << Sig(scales.error_px_per_m / scales.map_px_per_m, 3) << " relative to the map";
  }
  html << "; both scale bars are drawn below the plan.</figcaption>\n</figure>\n</section>\n";
}

void RenderBlunders(const json& report, std::ostringstream& html) {
  const json* blunders = OptArray(report, "blunders", "");
  if (blunders == nullptr) return;
  html << "<section id=\"blunders\">\n<h2>Flagged blunders</h2>\n";
  if (blunders->empty()) {
    html << "<p>Data snooping flagged no observation.</p>\n</section>\n";
    return;
  }
  html << "<table>\n<tr><th>#</th><th>group</th><th>observation</th><th>studentized</th>"
          "<th>whitened</th><th>down-weighted</th></tr>\n";
  for (size_t i = 0; i < blunders->size(); ++i) {
    const std::string path = Index("blunders", i);
    const json& b = ElementObject(*blunders, i, "blunders");
    const auto down = OptBool(b, "downweighted", path);
    html << "<tr" << (down.has_value() && !*down ? " class=\"flag\"" : "") << ">"
         << Td(std::to_string(i + 1)) << TdText(Esc(OptString(b, "group", path).value_or("")))
         << TdText(Esc(OptString(b, "observation", path).value_or("")))
         << Td(FormatFixed(Num(b, "studentized", path), 2)) << Td(FormatFixed(Num(b, "whitened", path), 2))
         << TdText(down.has_value() ? (*down ? "yes" : "<b>no</b>") : kDash) << "</tr>\n";
  }
  html << "</table>\n<p class=\"note\">Studentized residual: Baarda's w (a-priori " << kSigma
       << "<sub>0</sub>) or Pope's &tau; (a-posteriori), as the statistics state; whitened: r/"
       << kSigma << ". Rows in red were flagged but keep their full weight.</p>\n</section>\n";
}

std::vector<PoseCorrectionPoint> ReadPoseCorrections(const json& array) {
  std::vector<PoseCorrectionPoint> poses;
  for (size_t i = 0; i < array.size(); ++i) {
    const std::string path = Index("pose_corrections", i);
    const json& o = ElementObject(array, i, "pose_corrections");
    PoseCorrectionPoint p;
    p.image = ReqString(o, "image", path);
    p.sensor = OptString(o, "sensor", path).value_or("");
    p.dx = p.dy = p.dz = NAN;
    if (auto d = OptVec3(o, "d", path)) {
      p.dx = (*d)[0];
      p.dy = (*d)[1];
      p.dz = (*d)[2];
    }
    p.position_m = Num(o, "d_position_m", path);
    if (!std::isfinite(p.position_m)) p.position_m = Norm3({p.dx, p.dy, p.dz});
    p.rotation_deg = Num(o, "d_rotation_deg", path);
    poses.push_back(p);
  }
  return poses;
}

/// Per sensor: count, RMS and max of the position and rotation corrections.
void RenderPoseCorrectionStats(const std::vector<PoseCorrectionPoint>& poses,
                               std::ostringstream& html) {
  struct Stat {
    size_t n = 0, n_pos = 0, n_rot = 0;
    double sum_pos2 = 0, max_pos = 0, sum_rot2 = 0, max_rot = 0;
    std::string max_pos_image, max_rot_image;
  };
  std::vector<std::string> order;
  std::map<std::string, Stat> stats;
  for (const auto& p : poses) {
    if (!stats.count(p.sensor)) order.push_back(p.sensor);
    Stat& s = stats[p.sensor];
    ++s.n;
    if (std::isfinite(p.position_m)) {
      ++s.n_pos;
      s.sum_pos2 += p.position_m * p.position_m;
      if (std::abs(p.position_m) >= s.max_pos) {
        s.max_pos = std::abs(p.position_m);
        s.max_pos_image = p.image;
      }
    }
    if (std::isfinite(p.rotation_deg)) {
      ++s.n_rot;
      s.sum_rot2 += p.rotation_deg * p.rotation_deg;
      if (std::abs(p.rotation_deg) >= s.max_rot) {
        s.max_rot = std::abs(p.rotation_deg);
        s.max_rot_image = p.image;
      }
    }
  }
  html << "<table>\n<tr><th>sensor</th><th>images</th><th>RMS |&Delta;position| [mm]</th>"
          "<th>max [mm]</th><th>at image</th><th>RMS |&Delta;rotation| [&deg;]</th><th>max [&deg;]</th>"
          "<th>at image</th></tr>\n";
  for (const std::string& sensor : order) {
    const Stat& s = stats[sensor];
    const double rms_pos = s.n_pos > 0 ? std::sqrt(s.sum_pos2 / s.n_pos) : NAN;
    const double rms_rot = s.n_rot > 0 ? std::sqrt(s.sum_rot2 / s.n_rot) : NAN;
    html << "<tr>" << TdText(Esc(sensor)) << Td(Count(static_cast<double>(s.n))) << Td(Mm(rms_pos))
         << Td(s.n_pos ? Mm(s.max_pos) : kDash) << TdText(Esc(s.max_pos_image)) << Td(FormatFixed(rms_rot, 4))
         << Td(s.n_rot ? FormatFixed(s.max_rot, 4) : kDash) << TdText(Esc(s.max_rot_image)) << "</tr>\n";
  }
  html << "</table>\n";
}

void RenderPoseCorrections(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "pose_corrections", "");
  if (array == nullptr || array->empty()) return;
  const std::vector<PoseCorrectionPoint> poses = ReadPoseCorrections(*array);
  html << "<section id=\"poses\">\n<h2>Camera pose corrections</h2>\n";
  if (report.contains("photo_block") && report["photo_block"].is_object() &&
      report["photo_block"].contains("georeference") && report["photo_block"]["georeference"].is_string()) {
    html << "<p>Initial georeference of the photo block: " << Esc(report["photo_block"]["georeference"].get<std::string>())
         << ". The corrections below are from that initial pose.</p>\n";
  }
  RenderPoseCorrectionStats(poses, html);
  html << "<figure>\n" << SvgPoseCorrections(poses, 700)
       << "<figcaption>Change of each image's pose by the adjustment (cf. Fig. 13 of Wang, Ferrie "
          "&amp; Macfarlane 2012): bars |&Delta;position| and |&Delta;rotation|, markers the position "
          "components dx, dy, dz.</figcaption>\n</figure>\n";
  if (poses.size() <= 5000) {
    html << "<details><summary>All " << poses.size() << " images</summary>\n<table>\n<tr><th>image</th>"
            "<th>sensor</th><th>dx [mm]</th><th>dy [mm]</th><th>dz [mm]</th><th>|&Delta;position| [mm]</th>"
            "<th>|&Delta;rotation| [&deg;]</th></tr>\n";
    for (const auto& p : poses) {
      html << "<tr>" << TdText(Esc(p.image)) << TdText(Esc(p.sensor)) << Td(Mm(p.dx)) << Td(Mm(p.dy))
           << Td(Mm(p.dz)) << Td(Mm(p.position_m)) << Td(FormatFixed(p.rotation_deg, 4)) << "</tr>\n";
    }
    html << "</table>\n</details>\n";
  }
  html << "</section>\n";
}

void RenderCalibrations(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "calibrations", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"calibrations\">\n<h2>Calibrations</h2>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("calibrations", i);
    const json& c = ElementObject(*array, i, "calibrations");
    html << "<h3>" << Esc(ReqString(c, "name", path)) << "</h3>\n";
    const json* parameters = OptArray(c, "parameters", path);
    if (parameters == nullptr || parameters->empty()) {
      html << "<p class=\"note\">No parameters listed.</p>\n";
      continue;
    }
    html << "<table>\n<tr><th>parameter</th><th>initial</th><th>adjusted</th><th>change</th><th>"
         << kSigma << "</th><th>|change|/" << kSigma << "</th></tr>\n";
    const std::string ppath = Join(path, "parameters");
    for (size_t j = 0; j < parameters->size(); ++j) {
      const json& p = ElementObject(*parameters, j, ppath);
      const std::string epath = Index(ppath, j);
      const double initial = Num(p, "initial", epath);
      const double adjusted = Num(p, "adjusted", epath);
      const double sigma = Num(p, "sigma", epath);
      const double change = adjusted - initial;
      html << "<tr>" << TdText(Esc(ReqString(p, "name", epath))) << Td(Sig(initial, 8))
           << Td(Sig(adjusted, 8)) << Td(Sig(change, 4)) << Td(Sig(sigma, 3))
           << Td(sigma > 0.0 ? FormatFixed(std::abs(change) / sigma, 1) : kDash) << "</tr>\n";
    }
    html << "</table>\n";
  }
  html << "</section>\n";
}

void RenderDenseClouds(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "spherical_dense", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"dense\">\n<h2>Dense clouds of the spherical stations</h2>\n"
       << "<p class=\"note\">Vertical-baseline stereo of each adjusted pair; " << kSigma
       << " of a point's range from 0.5 px of disparity. The distance to the LiDAR surface is taken "
          "where the two overlap.</p>\n<table>\n<tr><th>station</th><th>points</th><th>median range (m)</th><th>median "
       << kSigma << " range (m)</th><th>on the LiDAR surface</th><th>median |distance| (m)</th><th>median |distance|/"
       << kSigma << "</th></tr>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("spherical_dense", i);
    const json& d = ElementObject(*array, i, "spherical_dense");
    const std::string station = Esc(ReqString(d, "station", path));
    const std::string status = ReqString(d, "status", path);
    if (status != "ok") {
      html << "<tr>" << TdText(station) << "<td colspan=\"6\">" << Esc(status) << "</td></tr>\n";
      continue;
    }
    const double compared = Num(d, "lidar_compared", path);
    html << "<tr>" << TdText(station) << Td(FormatFixed(Num(d, "points", path), 0))
         << Td(FormatFixed(Num(d, "median_range_m", path), 2)) << Td(FormatFixed(Num(d, "median_range_sigma_m", path), 3))
         << Td(std::isnan(compared) ? kDash : FormatFixed(compared, 0))
         << Td(FormatFixed(Num(d, "median_abs_distance_to_lidar_m", path), 3))
         << Td(FormatFixed(Num(d, "median_abs_distance_over_sigma", path), 2)) << "</tr>\n";
  }
  html << "</table>\n</section>\n";
}

void RenderMiRegistrations(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "mi_registration", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"mi\">\n<h2>MI registration of the images to the LiDAR</h2>\n"
       << "<p class=\"note\">Each image registered to the LiDAR by mutual information (Wang, Ferrie "
          "&amp; Macfarlane 2012) from its initial pose: the correction found, the pixel "
       << kSigma << " of its calibrated covariance, and for an &ldquo;ok&rdquo; (used as a weighted pose "
          "prior) how far the adjustment ended from it. Against the mobile LiDAR the rig's panoramas are registered "
          "jointly (the rig calibration: one rig_from_lidar for all frames, each frame &ldquo;used&rdquo; or "
          "&ldquo;rejected&rdquo; by its own screening registration).</p>\n<table>\n<tr><th>image</th><th>kind</th><th>LiDAR</th><th>status</th>"
          "<th>|t| [mm]</th><th>roll [&deg;]</th><th>pitch [&deg;]</th><th>yaw [&deg;]</th><th>"
       << kSigma << " [px]</th><th>adjusted &minus; MI [mm]</th><th>[&deg;]</th><th>time [s]</th><th>reason</th></tr>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("mi_registration", i);
    const json& m = ElementObject(*array, i, "mi_registration");
    const std::string status = ReqString(m, "status", path);
    double t = NAN, roll = NAN, pitch = NAN, yaw = NAN;
    if (m.contains("correction") && m["correction"].is_object()) {
      const json& c = m["correction"];
      const std::string cp = Join(path, "correction");
      t = Norm3({Num(c, "tx", cp), Num(c, "ty", cp), Num(c, "tz", cp)});
      roll = Num(c, "roll", cp);
      pitch = Num(c, "pitch", cp);
      yaw = Num(c, "yaw", cp);
    }
    const double dm = Num(m, "adjusted_minus_registered_m", path), dd = Num(m, "adjusted_minus_registered_deg", path);
    html << "<tr" << (status == "ok" || status == "used" ? "" : " class=\"flag\"") << ">" << TdText(Esc(ReqString(m, "image", path)))
         << TdText(Esc(OptString(m, "kind", path).value_or(""))) << TdText(Esc(OptString(m, "lidar", path).value_or("static")))
         << TdText(Esc(status)) << Td(Mm(t))
         << Td(FormatFixed(roll, 3)) << Td(FormatFixed(pitch, 3)) << Td(FormatFixed(yaw, 3))
         << Td(FormatFixed(Num(m, "sigma_px", path), 2)) << Td(std::isnan(dm) ? kDash : Mm(dm))
         << Td(std::isnan(dd) ? kDash : FormatFixed(dd, 3)) << Td(FormatFixed(Num(m, "runtime_seconds", path), 1))
         << TdText(Esc(OptString(m, "reason", path).value_or(""))) << "</tr>\n";
  }
  html << "</table>\n</section>\n";
}

void RenderFiles(const json& report, std::ostringstream& html) {
  const json* array = OptArray(report, "files", "");
  if (array == nullptr || array->empty()) return;
  html << "<section id=\"files\">\n<h2>Files</h2>\n<table>\n<tr><th>file</th><th>content</th></tr>\n";
  for (size_t i = 0; i < array->size(); ++i) {
    const std::string path = Index("files", i);
    const json& f = ElementObject(*array, i, "files");
    html << "<tr><td><code>" << Esc(ReqString(f, "name", path)) << "</code></td>"
         << TdText(Esc(OptString(f, "description", path).value_or(""))) << "</tr>\n";
  }
  html << "</table>\n</section>\n";
}

}  // namespace

std::string RenderAdjustReportHtml(const json& report) {
  if (!report.is_object()) Fail("(root)", Describe(report), "an object");
  const std::string schema = ReqString(report, "schema", "");
  if (schema != kAdjustReportSchema) {
    Fail("schema", "\"" + schema + "\"", "\"" + std::string(kAdjustReportSchema) + "\"");
  }
  const std::string project = ReqString(report, "project", "");
  const std::string status = ReqString(report, "status", "");
  if (status != "converged" && status != "failed" && status != "no_convergence") {
    Fail("status", "\"" + status + "\"", "\"converged\", \"failed\" or \"no_convergence\"");
  }
  const Sigma0 sigma0 = ReadSigma0(report);
  const json* groups = OptArray(report, "groups", "");
  if (groups == nullptr) Fail("groups", "nothing (missing)", "an array (may be empty)");
  const std::vector<ControlPoint> points = ReadControlPoints(report);
  const CheckSummary check = ReadCheckSummary(report, points);

  double observations = 0.0;
  for (size_t i = 0; i < groups->size(); ++i) {
    const double n = Num(ElementObject(*groups, i, "groups"), "observations", Index("groups", i));
    if (std::isfinite(n)) observations += n;
  }
  size_t num_blunders = 0, num_down = 0, num_warnings = 0;
  if (const json* b = OptArray(report, "blunders", "")) {
    num_blunders = b->size();
    for (size_t i = 0; i < b->size(); ++i) {
      const auto down = OptBool(ElementObject(*b, i, "blunders"), "downweighted", Index("blunders", i));
      if (down.value_or(false)) ++num_down;
    }
  }
  if (const json* w = OptArray(report, "warnings", "")) num_warnings = w->size();

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
       << "<title>" << Esc(project) << " &middot; adjustment report</title>\n<style>" << kCss
       << "</style>\n</head>\n<body>\n";
  RenderHeader(report, project, status, html);
  RenderSummary(report, status, sigma0, check, groups->size(), observations, num_blunders, num_down,
                num_warnings, html);
  RenderWarnings(report, html);
  RenderGroups(*groups, html);
  RenderControlPoints(points, check, html);
  RenderBlunders(report, html);
  RenderPoseCorrections(report, html);
  RenderMiRegistrations(report, html);
  RenderCalibrations(report, html);
  RenderDenseClouds(report, html);
  RenderFiles(report, html);
  html << "<footer>mmba adjust &middot; report schema " << kAdjustReportSchema;
  if (auto t = OptString(report, "generated_utc", "")) html << " &middot; " << Esc(*t) << " UTC";
  html << "</footer>\n</body>\n</html>\n";
  return html.str();
}

}  // namespace mmba::report
