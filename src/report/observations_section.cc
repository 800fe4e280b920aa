// report.html: the observation table — residual, redundancy number, studentized residual and
// the data-snooping verdict per observation, as GNU Gama's HTML output lists them.
#include <cmath>
#include <string>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

constexpr size_t kShownRows = 300;   ///< rows in the page; the rest in the CSV
constexpr size_t kFoldAbove = 40;    ///< longer tables are folded (<details>)

std::string Verdict(const json& row, const std::string& path, double critical) {
  if (auto v = OptString(row, "verdict", path)) return *v;
  const auto flagged = OptBool(row, "critical", path);
  if (flagged.has_value()) return *flagged ? "blunder?" : "";
  const double w = Num(row, "studentized", path);
  if (std::isfinite(w) && std::isfinite(critical)) return std::abs(w) > critical ? "blunder?" : "";
  return "";
}

void RenderObservationRow(const json& row, const std::string& path, double critical, const PageContext& context,
                          std::ostringstream& html) {
  const std::string verdict = Verdict(row, path, critical);
  const double r = Num(row, "redundancy", path);
  html << "<tr" << (verdict.empty() ? "" : " class=\"flag\"") << ">"
       << TdText(Esc(OptString(row, "group", path).value_or("")))
       << TdText(Esc(context.Text(OptString(row, "observation", path).value_or(""))))
       << Td(Sig(Num(row, "residual", path), 4)) << TdText(Esc(OptString(row, "unit", path).value_or("")))
       << Td(Sig(Num(row, "sigma", path), 4)) << Td(FormatFixed(r, 3))
       << Td(FormatFixed(Num(row, "studentized", path), 2)) << TdText(verdict.empty() ? "" : "<b>" + Esc(verdict) + "</b>")
       << "</tr>\n";
}

}  // namespace

void RenderObservations(const json& report, const PageContext& context, std::ostringstream& html) {
  const json* obs = OptObject(report, "observations", "");
  if (obs == nullptr) return;
  const json* rows = OptArray(*obs, "rows", "observations");
  if (rows == nullptr) Fail("observations.rows", "nothing (missing)", "an array of observations");
  const std::string file = OptString(*obs, "file", "observations").value_or("observations.csv");
  const double total = Num(*obs, "total", "observations");
  const double critical = Num(*obs, "critical_value", "observations");
  const std::string order = OptString(*obs, "order", "observations").value_or("as in the input");
  html << "<section id=\"observations\">\n<h2>Observations</h2>\n<p>" << Count(std::isfinite(total) ? total : rows->size())
       << " observations; listed " << Esc(order);
  if (std::isfinite(critical)) html << "; critical value of the studentized residual " << FormatFixed(critical, 2);
  html << ". Every row is in <code>" << Esc(context.Path(file)) << "</code>.</p>\n";
  const size_t shown = std::min(rows->size(), kShownRows);
  if (rows->size() > kFoldAbove) html << "<details><summary>" << shown << " observations</summary>\n";
  html << "<table>\n<tr><th>group</th><th>observation</th><th>residual v</th><th>unit</th><th>" << kSigma
       << "</th><th>redundancy r<sub>i</sub></th><th>studentized w<sub>i</sub></th><th>verdict</th></tr>\n";
  for (size_t i = 0; i < shown; ++i) {
    RenderObservationRow(ElementObject(*rows, i, "observations.rows"), Index("observations.rows", i), critical, context, html);
  }
  html << "</table>\n";
  if (rows->size() > kFoldAbove) html << "</details>\n";
  const double all = std::isfinite(total) ? total : static_cast<double>(rows->size());
  if (all > shown) {
    html << "<p class=\"note\">" << Count(static_cast<double>(shown)) << " of " << Count(all) << " rows shown; all of them in <code>"
         << Esc(context.Path(file)) << "</code>.</p>\n";
  }
  html << "<p class=\"note\">v = adjusted &minus; observed; r<sub>i</sub> = (Q<sub>vv</sub>P)<sub>ii</sub>, the share "
          "of an error that shows in its own residual (0: uncontrolled, 1: fully controlled); w<sub>i</sub> = "
          "v<sub>i</sub>/(" << kSigma << "<sub>i</sub>&radic;r<sub>i</sub>), Baarda's data snooping (Baarda 1968) "
          "with the a-priori " << kSigma << "<sub>0</sub>, or Pope's &tau; with the a-posteriori one; rows in red "
          "exceed the critical value.</p>\n</section>\n";
}

}  // namespace mmba::report::internal
