// report.html: the observations flagged by data snooping.
#include <string>

#include "report/html_internal.h"

namespace mmba::report::internal {

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

}  // namespace mmba::report::internal
