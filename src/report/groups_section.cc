// report.html: the observation groups with their variance components and whitened-residual histograms.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "report/html_internal.h"

namespace mmba::report::internal {
namespace {

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


}  // namespace

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

}  // namespace mmba::report::internal
