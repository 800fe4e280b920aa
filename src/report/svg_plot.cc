#include "mmba/report/svg_plot.h"

#include "mmba/core/xml_escape.h"
#include "mmba/report/label_layout.h"
#include "report/svg_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace mmba::report {
namespace {

using namespace svg;  // NOLINT: the drawing primitives

double ReferenceValue(ReferenceDensity density, int chi_dof, double x) {
  switch (density) {
    case ReferenceDensity::kStandardNormal:
      return StandardNormalDensity(x);
    case ReferenceDensity::kChi:
      return ChiDensity(x, chi_dof);
    case ReferenceDensity::kNone:
      break;
  }
  return 0.0;
}

}  // namespace

std::string HtmlEscape(const std::string& text) { return XmlEscape(text); }

std::string FormatFixed(double value, int decimals) {
  if (!std::isfinite(value)) return "\xE2\x80\x94";  // em dash
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", std::clamp(decimals, 0, 12), value);
  // "-0.000" reads as a sign where there is none.
  std::string s = buffer;
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

double NiceStep(double raw) {
  if (!(raw > 0.0) || !std::isfinite(raw)) return 0.0;
  const double base = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / base;
  const double nice = f <= 1.0 + 1e-12 ? 1.0 : (f <= 2.0 + 1e-12 ? 2.0 : (f <= 5.0 + 1e-12 ? 5.0 : 10.0));
  return nice * base;
}

size_t Histogram::total() const {
  size_t sum = 0;
  for (size_t c : counts) sum += c;
  return sum;
}

Histogram ComputeHistogram(const std::vector<double>& values, double lower, double upper,
                           int bins) {
  if (bins < 1) {
    throw std::invalid_argument("ComputeHistogram: bins = " + std::to_string(bins) +
                                ", expected >= 1");
  }
  if (!(lower < upper) || !std::isfinite(lower) || !std::isfinite(upper)) {
    throw std::invalid_argument("ComputeHistogram: range [" + Tick(lower) + ", " + Tick(upper) +
                                ") is empty, expected finite lower < upper");
  }
  Histogram h;
  h.lower = lower;
  h.upper = upper;
  h.counts.assign(static_cast<size_t>(bins), 0);
  const double width = (upper - lower) / bins;
  for (double v : values) {
    if (!std::isfinite(v)) {
      ++h.non_finite;
      continue;
    }
    long index;
    if (v < lower) {
      ++h.below;
      index = 0;
    } else if (v >= upper) {
      ++h.above;
      index = bins - 1;
    } else {
      index = std::clamp(static_cast<long>(std::floor((v - lower) / width)), 0L,
                         static_cast<long>(bins - 1));
    }
    ++h.counts[static_cast<size_t>(index)];
  }
  return h;
}

double StandardNormalDensity(double x) { return std::exp(-0.5 * x * x) / std::sqrt(2.0 * kPi); }

double ChiDensity(double x, int k) {
  if (k < 1) throw std::invalid_argument("ChiDensity: k = " + std::to_string(k) + ", expected >= 1");
  if (x < 0.0) return 0.0;
  if (x == 0.0) return k == 1 ? 2.0 / std::sqrt(2.0 * kPi) : 0.0;
  // log form: (k−1)·ln x − x²/2 − ((k/2)−1)·ln 2 − lnΓ(k/2)
  const double half_k = 0.5 * k;
  return std::exp((k - 1) * std::log(x) - 0.5 * x * x - (half_k - 1.0) * std::log(2.0) -
                  std::lgamma(half_k));
}

Histogram ResolveHistogram(const std::vector<double>& values, const HistogramOptions& options) {
  double lower = options.lower;
  double upper = options.upper;
  std::vector<double> magnitudes;
  magnitudes.reserve(values.size());
  for (double v : values) {
    if (std::isfinite(v)) magnitudes.push_back(std::abs(v));
  }
  if (!(lower < upper) || !std::isfinite(lower) || !std::isfinite(upper)) {
    double range = 4.0;
    if (!magnitudes.empty()) {
      const size_t q = static_cast<size_t>(std::floor(0.999 * (magnitudes.size() - 1)));
      std::nth_element(magnitudes.begin(), magnitudes.begin() + q, magnitudes.end());
      range = std::clamp(std::ceil(magnitudes[q]), 4.0, 10.0);
    }
    const bool norms = options.density == ReferenceDensity::kChi;
    lower = norms ? 0.0 : -range;
    upper = range;
  }
  int bins = options.bins;
  if (bins < 1) {
    const double n = static_cast<double>(magnitudes.size());
    bins = std::clamp(static_cast<int>(std::ceil(2.0 * std::cbrt(n))), 6, 48);
    if (lower < 0.0 && upper > 0.0 && bins % 2 == 1) ++bins;  // zero on a bin edge
  }
  return ComputeHistogram(values, lower, upper, bins);
}

namespace {

/// Plot area of a histogram: x over [lower, upper], y over counts [0, y_top].
struct HistogramFrame {
  double left, top, plot_w, plot_h;
  double lower, upper, y_top;
  double X(double v) const { return left + (v - lower) / (upper - lower) * plot_w; }
  double Y(double c) const { return top + plot_h - c / y_top * plot_h; }
};

/// The reference density scaled to counts, n · bin width · f(x), at `samples` abscissae.
struct DensityCurve {
  static constexpr int samples = 241;
  std::vector<double> dx, dy;
};

DensityCurve ScaledDensity(const Histogram& h, ReferenceDensity density, int chi_dof) {
  DensityCurve d;
  d.dx.resize(DensityCurve::samples);
  d.dy.resize(DensityCurve::samples);
  const size_t n = h.total();
  const double bin_w = h.bin_width();
  for (int i = 0; i < DensityCurve::samples; ++i) {
    d.dx[i] = h.lower + (h.upper - h.lower) * i / (DensityCurve::samples - 1);
    d.dy[i] = n * bin_w * ReferenceValue(density, chi_dof, d.dx[i]);
  }
  return d;
}

/// "n = …", the values drawn in the end bins and the non-finite ones left out.
std::string HistogramNote(const Histogram& h) {
  std::string note = "n = " + std::to_string(h.total());
  if (h.below + h.above > 0) {
    note += "; " + std::to_string(h.below + h.above) + " beyond [" + Tick(h.lower) + ", " +
            Tick(h.upper) + ") counted in the end bins";
  }
  if (h.non_finite > 0) note += "; " + std::to_string(h.non_finite) + " NaN/Inf left out";
  return note;
}

/// One bar per non-empty bin; the end bins holding values beyond the range in red.
void DrawHistogramBars(const Histogram& h, const HistogramFrame& f, std::ostringstream& svg) {
  const double bin_w = h.bin_width();
  svg << "<g fill=\"#4a78b5\" stroke=\"#ffffff\" stroke-width=\"0.5\">\n";
  for (size_t i = 0; i < h.counts.size(); ++i) {
    if (h.counts[i] == 0) continue;
    const double x0 = f.X(h.lower + i * bin_w);
    const double x1 = f.X(h.lower + (i + 1) * bin_w);
    const bool end_bin = (i == 0 && h.below > 0) || (i + 1 == h.counts.size() && h.above > 0);
    svg << "<rect x=\"" << Px(x0) << "\" y=\"" << Px(f.Y(h.counts[i])) << "\" width=\""
        << Px(std::max(x1 - x0, 0.5)) << "\" height=\"" << Px(f.Y(0) - f.Y(h.counts[i])) << "\""
        << (end_bin ? " fill=\"#c0504d\"" : "") << "><title>[" << Tick(h.lower + i * bin_w)
        << ", " << Tick(h.lower + (i + 1) * bin_w) << "): " << h.counts[i] << "</title></rect>\n";
  }
  svg << "</g>\n";
}

/// The density curve, clipped at the top of the plot, and its legend entry.
void DrawReferenceDensity(const DensityCurve& d, ReferenceDensity density, int chi_dof,
                          const HistogramFrame& f, std::ostringstream& svg) {
  svg << "<polyline fill=\"none\" stroke=\"#d62728\" stroke-width=\"1.6\" points=\"";
  for (int i = 0; i < DensityCurve::samples; ++i) {
    if (!std::isfinite(d.dy[i])) continue;
    svg << Px(f.X(d.dx[i])) << "," << Px(f.Y(std::min(d.dy[i], f.y_top))) << " ";
  }
  svg << "\"/>\n";
  const std::string label = density == ReferenceDensity::kStandardNormal
                                ? "N(0,1) density"
                                : "\xCF\x87 density, k = " + std::to_string(chi_dof);
  svg << Line(f.left + f.plot_w - 118, f.top + 6, f.left + f.plot_w - 98, f.top + 6,
              "stroke=\"#d62728\" stroke-width=\"1.6\"");
  svg << Text(f.left + f.plot_w - 94, f.top + 9.5, HtmlEscape(label), "font-size=\"10\"");
}

/// Both axis lines, the x ticks and the axis labels.
void DrawHistogramAxes(const HistogramFrame& f, int height, const HistogramOptions& options,
                       std::ostringstream& svg) {
  svg << Line(f.left, f.Y(0), f.left + f.plot_w, f.Y(0), "stroke=\"#333\" stroke-width=\"1\"");
  svg << Line(f.left, f.top, f.left, f.Y(0), "stroke=\"#333\" stroke-width=\"1\"");
  const double x_step = NiceStep((f.upper - f.lower) / 10.0);
  for (double t : Ticks(f.lower, f.upper, x_step)) {
    svg << Line(f.X(t), f.Y(0), f.X(t), f.Y(0) + 4, "stroke=\"#333\"");
    svg << Text(f.X(t), f.Y(0) + 15, Tick(t), "text-anchor=\"middle\"");
  }
  svg << Text(f.left + f.plot_w / 2, height - 6, HtmlEscape(options.x_label),
              "text-anchor=\"middle\"");
  svg << "<text transform=\"translate(13," << Px(f.top + f.plot_h / 2)
      << ") rotate(-90)\" text-anchor=\"middle\">" << HtmlEscape(options.y_label) << "</text>\n";
}

}  // namespace

std::string SvgHistogram(const std::vector<double>& values, const HistogramOptions& options) {
  const int width = std::max(options.width_px, 200);
  const int height = std::max(options.height_px, 140);
  const double left = 54, right = 12, top = 38, bottom = 40;
  const double plot_w = width - left - right;
  const double plot_h = height - top - bottom;
  std::ostringstream svg;
  svg << SvgOpen(width, height,
                 options.title.empty() ? "histogram of " + options.x_label : options.title);
  svg << Text(4, 14, HtmlEscape(options.title), "font-weight=\"bold\" font-size=\"12\"");

  const Histogram h = ResolveHistogram(values, options);
  const size_t n = h.total();
  if (n == 0) {
    svg << Text(left + plot_w / 2, top + plot_h / 2,
                h.non_finite > 0 ? "no finite values (" + std::to_string(h.non_finite) + " NaN/Inf)"
                                 : std::string("no values"),
                "text-anchor=\"middle\" fill=\"#666\"");
    svg << "</svg>\n";
    return svg.str();
  }
  const int chi_dof = std::max(options.chi_dof, 1);
  const DensityCurve density = ScaledDensity(h, options.density, chi_dof);
  double y_max = 0.0;
  for (size_t c : h.counts) y_max = std::max(y_max, static_cast<double>(c));
  for (double y : density.dy) {
    if (std::isfinite(y)) y_max = std::max(y_max, y);
  }
  const double y_step = NiceStep(y_max / 5.0);
  const double y_top = std::max(y_step, std::ceil(y_max * 1.05 / y_step) * y_step);
  const HistogramFrame f{left, top, plot_w, plot_h, h.lower, h.upper, y_top};
  svg << Text(4, 29, HtmlEscape(HistogramNote(h)), "fill=\"#444\" font-size=\"10\"");
  // Grid and y axis.
  for (double t : Ticks(0.0, y_top, y_step)) {
    svg << Line(left, f.Y(t), left + plot_w, f.Y(t), "stroke=\"#e4e4e4\" stroke-width=\"1\"");
    svg << Text(left - 4, f.Y(t) + 3.5, Tick(t), "text-anchor=\"end\"");
  }
  DrawHistogramBars(h, f, svg);
  if (options.density != ReferenceDensity::kNone) {
    DrawReferenceDensity(density, options.density, chi_dof, f, svg);
  }
  DrawHistogramAxes(f, height, options, svg);
  svg << "</svg>\n";
  return svg.str();
}

namespace {

std::string PlanMarkerId(const std::string& colour) { return "plan-arrow-" + colour.substr(1); }

/// One point of the plan view: its ellipse, displacement arrow, marker and placed label.
void DrawPlanPoint(const PlanPoint& p, double x, double y, double error_scale, const LabelPlacement& label,
                   std::ostringstream& svg) {
  const std::string colour = p.flagged ? "#d62728" : (p.check ? "#e07b00" : "#1f5fa8");
  std::string tip = p.id + (p.check ? " (check)" : " (control)");
  if (std::isfinite(p.d_east) && std::isfinite(p.d_north)) {
    tip += ": dE " + FormatFixed(p.d_east * 1000, 1) + " mm, dN " +
           FormatFixed(p.d_north * 1000, 1) + " mm";
  }
  svg << "<g><title>" << HtmlEscape(tip) << "</title>\n";
  if (error_scale > 0.0 && std::isfinite(p.ellipse_a) && p.ellipse_a > 0.0) {
    const double b = std::isfinite(p.ellipse_b) && p.ellipse_b > 0.0 ? p.ellipse_b : 0.0;
    const double az = std::isfinite(p.ellipse_azimuth_deg) ? p.ellipse_azimuth_deg : 0.0;
    svg << "<ellipse cx=\"" << Px(x) << "\" cy=\"" << Px(y) << "\" rx=\""
        << Px(std::max(p.ellipse_a * error_scale, 0.5)) << "\" ry=\""
        << Px(std::max(b * error_scale, 0.5)) << "\" transform=\"rotate("
        << Px(SvgRotationFromAzimuth(az)) << " " << Px(x) << " " << Px(y)
        << ")\" fill=\"" << colour << "\" fill-opacity=\"0.12\" stroke=\"" << colour
        << "\" stroke-width=\"1.2\"/>\n";
  }
  if (error_scale > 0.0 && std::isfinite(p.d_east) && std::isfinite(p.d_north) &&
      std::hypot(p.d_east, p.d_north) * error_scale >= 1.0) {
    svg << Line(x, y, x + p.d_east * error_scale, y - p.d_north * error_scale,
                "stroke=\"" + colour + "\" stroke-width=\"1.6\" marker-end=\"url(#" + PlanMarkerId(colour) + ")\"");
  }
  if (p.check) {
    svg << "<circle cx=\"" << Px(x) << "\" cy=\"" << Px(y) << "\" r=\"4\" fill=\"#ffffff\" stroke=\""
        << colour << "\" stroke-width=\"2\"/>\n";
  } else {
    svg << "<path d=\"M" << Px(x) << "," << Px(y - 5.5) << " L" << Px(x + 5) << "," << Px(y + 3.5)
        << " L" << Px(x - 5) << "," << Px(y + 3.5) << " z\" fill=\"" << colour << "\"/>\n";
  }
  if (label.shown) {
    svg << Text(label.x, label.y, HtmlEscape(p.id), "font-size=\"10\" fill=\"#222\" text-anchor=\"" + label.anchor + "\"");
  }
  svg << "</g>\n";
}

/// Scale bars and legend below the plan's frame.
void DrawPlanLegend(double margin, double plot_w, double plot_h, const PlanScales& s, double map_scale,
                    double error_scale, const std::string& ellipse_label, size_t hidden, std::ostringstream& svg) {
  // Scale bars and legend below the frame.
  const double bar_y = margin + plot_h + 22;
  auto Bar = [&](double x0, double length_px, const std::string& label) {
    svg << Line(x0, bar_y, x0 + length_px, bar_y, "stroke=\"#222\" stroke-width=\"2\"");
    svg << Line(x0, bar_y - 4, x0, bar_y + 4, "stroke=\"#222\" stroke-width=\"1.5\"");
    svg << Line(x0 + length_px, bar_y - 4, x0 + length_px, bar_y + 4, "stroke=\"#222\" stroke-width=\"1.5\"");
    svg << Text(x0 + length_px / 2, bar_y - 6, HtmlEscape(label), "text-anchor=\"middle\"");
  };
  Bar(margin, s.map_bar_m * map_scale, "map: " + LengthLabel(s.map_bar_m));
  if (s.error_bar_m > 0.0) {
    Bar(margin + plot_w / 2, s.error_bar_m * error_scale,
        "ellipses and vectors: " + LengthLabel(s.error_bar_m));
  }
  const double ly = bar_y + 26;
  svg << "<path d=\"M" << Px(margin + 5) << "," << Px(ly - 5.5) << " L" << Px(margin + 10) << ","
      << Px(ly + 3.5) << " L" << Px(margin) << "," << Px(ly + 3.5) << " z\" fill=\"#1f5fa8\"/>\n";
  svg << Text(margin + 14, ly + 3.5, "control");
  svg << "<circle cx=\"" << Px(margin + 72) << "\" cy=\"" << Px(ly) << "\" r=\"4\" fill=\"#fff\" "
         "stroke=\"#e07b00\" stroke-width=\"2\"/>\n";
  svg << Text(margin + 80, ly + 3.5, "check");
  svg << "<circle cx=\"" << Px(margin + 128) << "\" cy=\"" << Px(ly) << "\" r=\"4\" fill=\"#d62728\"/>\n";
  svg << Text(margin + 136, ly + 3.5, "|d| &gt; 3\xCF\x83");
  svg << Text(margin + 196, ly + 3.5,
              HtmlEscape(ellipse_label + "; arrow: adjusted \xE2\x88\x92 surveyed"),
              "fill=\"#444\"");
  if (hidden > 0) {
    svg << Text(margin, ly + 18, std::to_string(hidden) + " label" + (hidden == 1 ? "" : "s") +
                " left out where they would overprint (the id is in the point's tooltip and the table)", "fill=\"#444\"");
  }
}

}  // namespace

double SvgRotationFromAzimuth(double azimuth_deg) { return azimuth_deg - 90.0; }

std::string SvgPlanView(const std::vector<PlanPoint>& points, const PlanViewOptions& options,
                        PlanScales* scales) {
  const int width = std::max(options.width_px, 240);
  const int height = std::max(options.height_px, 240);
  const double margin = 24, legend_h = 64;
  const double plot_w = width - 2 * margin;
  const double plot_h = height - margin - legend_h - 10;
  std::ostringstream svg;
  svg << SvgOpen(width, height, "plan view of control and check points");

  std::vector<const PlanPoint*> drawn;
  double e_min = INFINITY, e_max = -INFINITY, n_min = INFINITY, n_max = -INFINITY;
  double max_error = 0.0;
  for (const PlanPoint& p : points) {
    if (!std::isfinite(p.east) || !std::isfinite(p.north)) continue;
    drawn.push_back(&p);
    e_min = std::min(e_min, p.east);
    e_max = std::max(e_max, p.east);
    n_min = std::min(n_min, p.north);
    n_max = std::max(n_max, p.north);
    if (std::isfinite(p.ellipse_a) && p.ellipse_a > 0.0) max_error = std::max(max_error, p.ellipse_a);
    const double d = std::hypot(p.d_east, p.d_north);
    if (std::isfinite(d)) max_error = std::max(max_error, d);
  }
  if (drawn.empty()) {
    svg << Text(width / 2.0, height / 2.0, "no points with coordinates",
                "text-anchor=\"middle\" fill=\"#666\"");
    svg << "</svg>\n";
    return svg.str();
  }
  const double span_e = std::max(e_max - e_min, 1.0);
  const double span_n = std::max(n_max - n_min, 1.0);
  // 15 % of the frame left around the points for ellipses and labels.
  const double map_scale = 0.85 * std::min(plot_w / span_e, plot_h / span_n);
  const double centre_e = 0.5 * (e_min + e_max), centre_n = 0.5 * (n_min + n_max);
  const double cx = margin + plot_w / 2, cy = margin + plot_h / 2;
  auto X = [&](double e) { return cx + (e - centre_e) * map_scale; };
  auto Y = [&](double n) { return cy - (n - centre_n) * map_scale; };
  // The largest error (ellipse semi-axis or displacement) drawn 8 % of the frame long.
  const double error_scale = max_error > 0.0 ? 0.08 * std::min(plot_w, plot_h) / max_error : 0.0;
  PlanScales s;
  s.map_px_per_m = map_scale;
  s.error_px_per_m = error_scale;
  s.map_bar_m = NiceFloor(0.3 * plot_w / map_scale);
  s.error_bar_m = error_scale > 0.0 ? NiceFloor(90.0 / error_scale) : 0.0;
  if (scales != nullptr) *scales = s;

  // One arrow head per colour (markers cannot take the line's colour in every browser).
  svg << "<defs>";
  for (const std::string colour : {"#333333", "#1f5fa8", "#e07b00", "#d62728"}) {
    svg << "<marker id=\"" << PlanMarkerId(colour) << "\" viewBox=\"0 0 10 10\" refX=\"9\" "
        << "refY=\"5\" markerWidth=\"6\" markerHeight=\"6\" orient=\"auto\"><path "
        << "d=\"M0,0 L10,5 L0,10 z\" fill=\"" << colour << "\"/></marker>";
  }
  svg << "</defs>\n";
  svg << "<rect x=\"" << Px(margin) << "\" y=\"" << Px(margin) << "\" width=\"" << Px(plot_w)
      << "\" height=\"" << Px(plot_h) << "\" fill=\"none\" stroke=\"#bbb\"/>\n";
  // North arrow.
  const double na_x = margin + plot_w - 16, na_y = margin + 8;
  svg << Line(na_x, na_y + 26, na_x, na_y + 2, "stroke=\"#333333\" stroke-width=\"1.5\" marker-end=\"url(#" + PlanMarkerId("#333333") + ")\"");
  svg << Text(na_x, na_y + 38, "N", "text-anchor=\"middle\" font-weight=\"bold\"");

  std::vector<LabelRequest> requests;
  for (const PlanPoint* p : drawn) {
    requests.push_back({X(p->east), Y(p->north), EstimateTextWidth(p->id, 10.0), 12.0, 5.5});
  }
  const std::vector<LabelPlacement> labels = PlaceLabels(requests, margin, margin, margin + plot_w, margin + plot_h);
  size_t hidden = 0;
  for (size_t i = 0; i < drawn.size(); ++i) {
    DrawPlanPoint(*drawn[i], X(drawn[i]->east), Y(drawn[i]->north), error_scale, labels[i], svg);
    if (!labels[i].shown) ++hidden;
  }

  DrawPlanLegend(margin, plot_w, plot_h, s, map_scale, error_scale, options.ellipse_label, hidden, svg);
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace mmba::report
