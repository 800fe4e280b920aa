// report.html: the title block, the summary with both σ0/χ² tests, the warnings.
#include <cmath>
#include <optional>
#include <string>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

/// One global test of the adjustment (report.json `sigma0` or `sigma0_given_weights`).
struct Sigma0 {
  double apriori = 1.0, aposteriori = NAN, dof = NAN, confidence = NAN, lower = NAN, upper = NAN;
  std::optional<bool> passed;
};

Sigma0 ReadSigma0(const json& s, const std::string& path, double confidence) {
  Sigma0 out;
  const double apriori = Num(s, "apriori", path);
  if (std::isfinite(apriori)) out.apriori = apriori;
  out.aposteriori = Num(s, "aposteriori", path);
  out.dof = Num(s, "dof", path);
  out.confidence = Num(s, "confidence", path);
  if (!std::isfinite(out.confidence)) out.confidence = confidence;
  out.lower = Num(s, "chi2_lower", path);
  out.upper = Num(s, "chi2_upper", path);
  out.passed = OptBool(s, "passed", path);
  return out;
}

std::string StatusBadge(const std::string& status) {
  if (status == "converged") return "<span class=\"badge ok\">converged</span>";
  if (status == "no_convergence") return "<span class=\"badge warn\">no convergence</span>";
  return "<span class=\"badge bad\">failed</span>";
}

/// One table row of a χ² test. Global test of the adjustment: f·σ̂0²/σ0² ~ χ²_f, so the
/// two-sided acceptance interval of the ratio σ̂0/σ0 is [sqrt(χ²_{α/2,f}/f), sqrt(χ²_{1−α/2,f}/f)]
/// (Koch 1999, ch. 4, test of the variance factor; mmba_stats computes it as chi2_lower/chi2_upper, the test of GNU Gama).
/// Recomputed here only when "passed" is absent; a disagreement with "passed" is shown.
void RenderChi2Row(const std::string& label, const Sigma0& s0, const std::string& meaning,
                   std::ostringstream& html) {
  const double ratio = s0.aposteriori / s0.apriori;
  std::optional<bool> passed = s0.passed;
  const bool bounds = std::isfinite(s0.lower) && std::isfinite(s0.upper) && std::isfinite(ratio);
  const bool inside = bounds && ratio >= s0.lower && ratio <= s0.upper;
  if (!passed && bounds) passed = inside;
  std::string level = "the stated level";
  if (std::isfinite(s0.confidence)) {
    const double percent = s0.confidence * 100.0;
    level = FormatFixed(percent, percent == std::round(percent) ? 0 : 1) + "&nbsp;% confidence";
  }
  html << "<tr><th>" << label << "</th><td>";
  if (passed.has_value()) {
    html << "<span class=\"verdict " << (*passed ? "pass\">PASSED" : "fail\">FAILED") << "</span> ";
  } else {
    html << "<span class=\"verdict none\">NOT TESTED</span> ";
  }
  html << "at " << level << ": " << kSigma << "&#770;<sub>0</sub>/" << kSigma << "<sub>0</sub> = "
       << FormatFixed(ratio, 3) << ", accepted interval [" << FormatFixed(s0.lower, 3) << ", "
       << FormatFixed(s0.upper, 3) << "], " << Count(s0.dof) << " degrees of freedom";
  if (passed.has_value()) {
    html << " &mdash; " << meaning << (*passed ? " agree with the residuals" : " do not agree with the residuals (weights or model to revise)");
  }
  if (s0.passed.has_value() && bounds && s0.passed.value() != inside) {
    html << "<br><span class=\"note\"><b>Inconsistent:</b> the report says "
         << (s0.passed.value() ? "passed" : "failed") << " but the ratio lies "
         << (inside ? "inside" : "outside") << " the interval.</span>";
  }
  html << "</td></tr>\n";
}

/// σ0 and its tests: with the project's own σ (`sigma0_given_weights`) and after the
/// variance components re-weighted the groups (`sigma0`); one test when only `sigma0` is given.
void RenderSigma0Rows(const json& report, std::ostringstream& html) {
  const json* s = OptObject(report, "sigma0", "");
  if (s == nullptr) Fail("sigma0", "nothing (missing)", "an object {apriori, aposteriori, dof, ...}");
  const Sigma0 after = ReadSigma0(*s, "sigma0", NAN);
  const json* g = OptObject(report, "sigma0_given_weights", "");
  if (g == nullptr) {
    html << "<tr><th>" << kSigma << "<sub>0</sub> a-posteriori</th><td><b>" << Sig(after.aposteriori, 4)
         << "</b> (a-priori " << Sig(after.apriori, 4) << ")</td></tr>\n";
    RenderChi2Row("&chi;<sup>2</sup> test (two-sided)", after, "the a-priori " + std::string(kSigma), html);
    return;
  }
  const Sigma0 given = ReadSigma0(*g, "sigma0_given_weights", after.confidence);
  html << "<tr><th>" << kSigma << "<sub>0</sub> a-posteriori</th><td><b>" << Sig(given.aposteriori / given.apriori, 4)
       << "</b> with the project's " << kSigma << "; " << Sig(after.aposteriori / after.apriori, 4)
       << " after variance components (a-priori " << Sig(after.apriori, 4) << ")</td></tr>\n";
  RenderChi2Row("&chi;<sup>2</sup> test, project's " + std::string(kSigma), given,
                "the project's " + std::string(kSigma), html);
  if (given.aposteriori / given.apriori == after.aposteriori / after.apriori) {
    html << "<tr><th>&chi;<sup>2</sup> test, after variance components</th><td>the same: the variance components "
            "re-weighted no group</td></tr>\n";
    return;
  }
  RenderChi2Row("&chi;<sup>2</sup> test, after variance components", after,
                "the re-weighted " + std::string(kSigma), html);
}

void RenderSolverRow(const json& report, std::ostringstream& html) {
  const json* solver = OptObject(report, "solver", "");
  if (solver == nullptr) return;
  const double outer = Num(*solver, "outer_iterations", "solver");
  const double seconds = Num(*solver, "seconds", "solver");
  html << "<tr><th>Solver</th><td>" << Count(Num(*solver, "iterations", "solver")) << " iterations";
  if (std::isfinite(outer)) html << " in " << Count(outer) << " outer (re-association) loops";
  html << "; cost " << Sig(Num(*solver, "initial_cost", "solver"), 6) << " &rarr; "
       << Sig(Num(*solver, "final_cost", "solver"), 6);
  if (std::isfinite(seconds)) html << "; " << FormatFixed(seconds, 1) << " s";
  html << "</td></tr>\n";
}

void RenderObservationCountRow(const json& report, std::ostringstream& html) {
  const json* groups = OptArray(report, "groups", "");
  if (groups == nullptr) Fail("groups", "nothing (missing)", "an array (may be empty)");
  double observations = 0.0;
  for (size_t i = 0; i < groups->size(); ++i) {
    const double n = Num(ElementObject(*groups, i, "groups"), "observations", Index("groups", i));
    if (std::isfinite(n)) observations += n;
  }
  size_t num_blunders = 0, num_down = 0, num_warnings = 0;
  if (const json* b = OptArray(report, "blunders", "")) {
    num_blunders = b->size();
    for (size_t i = 0; i < b->size(); ++i) {
      if (OptBool(ElementObject(*b, i, "blunders"), "downweighted", Index("blunders", i)).value_or(false)) ++num_down;
    }
  }
  if (const json* w = OptArray(report, "warnings", "")) num_warnings = w->size();
  const size_t num_groups = groups->size();
  html << "<tr><th>Observations</th><td>" << Count(observations) << " in " << num_groups << " group"
       << (num_groups == 1 ? "" : "s") << "; " << num_blunders << " flagged as blunder"
       << (num_blunders == 1 ? "" : "s") << " (" << num_down << " down-weighted)";
  if (num_warnings > 0) html << "; <b>" << num_warnings << " warning" << (num_warnings == 1 ? "" : "s") << "</b>";
  html << "</td></tr>\n";
}

void RenderCheckRow(const json& report, std::ostringstream& html) {
  const CheckSummary check = ReadCheckSummary(report);
  if (!std::isfinite(check.rmse_3d)) return;
  html << "<tr><th>Check points</th><td>RMSE 3-D <b>" << Mm(check.rmse_3d) << " mm</b> over "
       << Count(check.count) << " points";
  if (std::isfinite(check.expected_3d) && check.expected_3d > 0.0) {
    html << " (expected " << Mm(check.expected_3d) << " mm; ratio " << FormatFixed(check.rmse_3d / check.expected_3d, 2) << ")";
  }
  html << "; <a href=\"#accuracy\">accuracy statement</a></td></tr>\n";
}

}  // namespace

void RenderHeader(const json& report, const std::string& project, const std::string& status,
                  const PageContext& context, std::ostringstream& html) {
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
  if (auto f = OptString(report, "project_file", "")) {
    html << "<tr><th>Project file</th><td><code>" << Esc(context.Path(*f)) << "</code></td></tr>\n";
  }
  if (auto r = OptString(report, "reason", "")) html << "<tr><th>Reason</th><td>" << Esc(context.Text(*r)) << "</td></tr>\n";
  if (const json* o = OptObject(report, "origin", "")) {
    html << "<tr><th>Origin (WGS84)</th><td>latitude " << FormatFixed(Num(*o, "latitude_deg", "origin"), 9)
         << "&deg;, longitude " << FormatFixed(Num(*o, "longitude_deg", "origin"), 9) << "&deg;, height "
         << FormatFixed(Num(*o, "height_m", "origin"), 3) << " m</td></tr>\n";
  }
  if (auto f = OptString(report, "frame", "")) html << "<tr><th>Frame</th><td>" << Esc(*f) << "</td></tr>\n";
  if (auto z = OptString(report, "utm_zone", "")) html << "<tr><th>UTM zone</th><td>" << Esc(*z) << "</td></tr>\n";
  RenderCrsRow(report, html);
  html << "</table>\n</header>\n";
}

void RenderSummary(const json& report, const std::string& status, const PageContext& context,
                   std::ostringstream& html) {
  if (status != "converged") {
    html << "<div class=\"banner\">"
         << (status == "failed" ? "The adjustment FAILED." : "The adjustment did NOT CONVERGE within its iteration limit.")
         << " The figures below describe the last iterate and are not a valid result.";
    if (auto r = OptString(report, "reason", "")) html << " Reason: " << Esc(context.Text(*r));
    html << "</div>\n";
  }
  html << "<div class=\"summary\" id=\"summary\">\n<table>\n";
  RenderSigma0Rows(report, html);
  RenderSolverRow(report, html);
  RenderCheckRow(report, html);
  RenderObservationCountRow(report, html);
  html << "</table>\n";
  if (OptObject(report, "sigma0_given_weights", "") != nullptr) {
    html << "<p class=\"note\">The first test judges the " << kSigma << " the project states; the second the "
         << kSigma << " after each re-weighted group's " << kSigma << " was multiplied by its factor from the "
         << "variance components (F&ouml;rstner 1979), which moves that ratio towards 1. A failed "
            "first test with a passed second one means the project's " << kSigma << " were off, not the model.</p>\n";
  }
  html << "</div>\n";
}

void RenderWarnings(const json& report, const PageContext& context, std::ostringstream& html) {
  const json* warnings = OptArray(report, "warnings", "");
  if (warnings == nullptr || warnings->empty()) return;
  html << "<section class=\"warnings\" id=\"warnings\">\n<h2>Warnings</h2>\n<ul class=\"warnings\">\n";
  for (size_t i = 0; i < warnings->size(); ++i) {
    const json& w = (*warnings)[i];
    if (!w.is_string()) Fail(Index("warnings", i), Describe(w), "a string");
    html << "<li>" << Esc(context.Text(w.get<std::string>())) << "</li>\n";
  }
  html << "</ul>\n</section>\n";
}

}  // namespace mmba::report::internal
