#include "mmba/report/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace mmba::report {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr const char* kFont = "font-family=\"DejaVu Sans, Arial, Helvetica, sans-serif\"";
constexpr const char* kPalette[] = {"#4e79a7", "#f28e2b", "#59a14f", "#b07aa1",
                                    "#76b7b2", "#edc948", "#9c755f", "#e15759"};

// Pixel coordinate with two decimals.
std::string Px(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f", std::isfinite(v) ? v : 0.0);
  return buffer;
}

// Shortest readable tick label ("0.5", "10", "-2", "1e+06").
std::string Tick(double v) {
  if (std::abs(v) < 1e-12) v = 0.0;
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.6g", v);
  return buffer;
}

// Largest 1/2/5 × 10^k not above raw > 0 (scale-bar lengths).
double NiceFloor(double raw) {
  if (!(raw > 0.0) || !std::isfinite(raw)) return 0.0;
  const double base = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / base;
  const double nice = f >= 5.0 ? 5.0 : (f >= 2.0 ? 2.0 : 1.0);
  return nice * base;
}

// A length in metres as "2 m", "5 cm" or "2 mm".
std::string LengthLabel(double metres) {
  char buffer[48];
  if (metres >= 1.0) {
    std::snprintf(buffer, sizeof(buffer), "%g m", metres);
  } else if (metres >= 0.01) {
    std::snprintf(buffer, sizeof(buffer), "%g cm", std::round(metres * 1e4) / 100.0);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%g mm", std::round(metres * 1e6) / 1000.0);
  }
  return buffer;
}

std::string Text(double x, double y, const std::string& escaped, const std::string& extra = "") {
  return "<text x=\"" + Px(x) + "\" y=\"" + Px(y) + "\" " + extra + ">" + escaped + "</text>\n";
}

std::string Line(double x1, double y1, double x2, double y2, const std::string& style) {
  return "<line x1=\"" + Px(x1) + "\" y1=\"" + Px(y1) + "\" x2=\"" + Px(x2) + "\" y2=\"" +
         Px(y2) + "\" " + style + "/>\n";
}

std::string SvgOpen(int width, int height, const std::string& label) {
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" width=\"" +
         std::to_string(width) + "\" height=\"" + std::to_string(height) + "\" viewBox=\"0 0 " +
         std::to_string(width) + " " + std::to_string(height) + "\" role=\"img\" aria-label=\"" +
         HtmlEscape(label) + "\" " + kFont + " font-size=\"11\">\n<title>" + HtmlEscape(label) +
         "</title>\n<rect x=\"0\" y=\"0\" width=\"" + std::to_string(width) + "\" height=\"" +
         std::to_string(height) + "\" fill=\"#ffffff\"/>\n";
}

// Ticks at multiples of step inside [lo, hi].
std::vector<double> Ticks(double lo, double hi, double step) {
  std::vector<double> ticks;
  if (!(step > 0.0) || !(hi > lo)) return ticks;
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + 1e-9 * step; t += step) {
    ticks.push_back(t);
    if (ticks.size() > 200) break;
  }
  return ticks;
}

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

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size() + 16);
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

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
  auto MarkerId = [](const std::string& colour) { return "plan-arrow-" + colour.substr(1); };
  svg << "<defs>";
  for (const std::string colour : {"#333333", "#1f5fa8", "#e07b00", "#d62728"}) {
    svg << "<marker id=\"" << MarkerId(colour) << "\" viewBox=\"0 0 10 10\" refX=\"9\" "
        << "refY=\"5\" markerWidth=\"6\" markerHeight=\"6\" orient=\"auto\"><path "
        << "d=\"M0,0 L10,5 L0,10 z\" fill=\"" << colour << "\"/></marker>";
  }
  svg << "</defs>\n";
  svg << "<rect x=\"" << Px(margin) << "\" y=\"" << Px(margin) << "\" width=\"" << Px(plot_w)
      << "\" height=\"" << Px(plot_h) << "\" fill=\"none\" stroke=\"#bbb\"/>\n";
  // North arrow.
  const double na_x = margin + plot_w - 16, na_y = margin + 8;
  svg << Line(na_x, na_y + 26, na_x, na_y + 2, "stroke=\"#333333\" stroke-width=\"1.5\" marker-end=\"url(#" + MarkerId("#333333") + ")\"");
  svg << Text(na_x, na_y + 38, "N", "text-anchor=\"middle\" font-weight=\"bold\"");

  for (const PlanPoint* p : drawn) {
    const double x = X(p->east), y = Y(p->north);
    const std::string colour = p->flagged ? "#d62728" : (p->check ? "#e07b00" : "#1f5fa8");
    std::string tip = p->id + (p->check ? " (check)" : " (control)");
    if (std::isfinite(p->d_east) && std::isfinite(p->d_north)) {
      tip += ": dE " + FormatFixed(p->d_east * 1000, 1) + " mm, dN " +
             FormatFixed(p->d_north * 1000, 1) + " mm";
    }
    svg << "<g><title>" << HtmlEscape(tip) << "</title>\n";
    if (error_scale > 0.0 && std::isfinite(p->ellipse_a) && p->ellipse_a > 0.0) {
      const double b = std::isfinite(p->ellipse_b) && p->ellipse_b > 0.0 ? p->ellipse_b : 0.0;
      const double az = std::isfinite(p->ellipse_azimuth_deg) ? p->ellipse_azimuth_deg : 0.0;
      svg << "<ellipse cx=\"" << Px(x) << "\" cy=\"" << Px(y) << "\" rx=\""
          << Px(std::max(p->ellipse_a * error_scale, 0.5)) << "\" ry=\""
          << Px(std::max(b * error_scale, 0.5)) << "\" transform=\"rotate("
          << Px(SvgRotationFromAzimuth(az)) << " " << Px(x) << " " << Px(y)
          << ")\" fill=\"" << colour << "\" fill-opacity=\"0.12\" stroke=\"" << colour
          << "\" stroke-width=\"1.2\"/>\n";
    }
    if (error_scale > 0.0 && std::isfinite(p->d_east) && std::isfinite(p->d_north) &&
        std::hypot(p->d_east, p->d_north) * error_scale >= 1.0) {
      svg << Line(x, y, x + p->d_east * error_scale, y - p->d_north * error_scale,
                  "stroke=\"" + colour + "\" stroke-width=\"1.6\" marker-end=\"url(#" + MarkerId(colour) + ")\"");
    }
    if (p->check) {
      svg << "<circle cx=\"" << Px(x) << "\" cy=\"" << Px(y) << "\" r=\"4\" fill=\"#ffffff\" stroke=\""
          << colour << "\" stroke-width=\"2\"/>\n";
    } else {
      svg << "<path d=\"M" << Px(x) << "," << Px(y - 5.5) << " L" << Px(x + 5) << "," << Px(y + 3.5)
          << " L" << Px(x - 5) << "," << Px(y + 3.5) << " z\" fill=\"" << colour << "\"/>\n";
    }
    svg << Text(x + 7, y - 6, HtmlEscape(p->id), "font-size=\"10\" fill=\"#222\"");
    svg << "</g>\n";
  }

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
              HtmlEscape(options.ellipse_label + "; arrow: adjusted \xE2\x88\x92 surveyed"),
              "fill=\"#444\"");
  svg << "</svg>\n";
  return svg.str();
}

namespace {

/// Layout of the pose-correction plot: two panels of the same width, one slot per image.
struct PoseFrame {
  static constexpr double left = 62, right = 14, panel_h = 150, gap = 46, top = 44;
  double plot_w = 0.0;
  size_t n = 0;        // images
  double slot = 0.0;   // px per image
  double bar_w = 0.0;  // px
  double X(size_t i) const { return left + (i + 0.5) * slot; }
};

/// Panel y mapping: [lo, hi] onto [y0 + panel_h, y0].
struct PanelY {
  double y0, lo, hi;
  double operator()(double v) const {
    return y0 + PoseFrame::panel_h - (v - lo) / (hi - lo) * PoseFrame::panel_h;
  }
};

/// Sensors in order of appearance (one colour each) and the largest corrections.
struct PoseExtent {
  std::map<std::string, size_t> sensor_index;
  std::vector<std::string> sensors;
  double max_pos = 0.0;  // m, over |Δp| and the components
  double max_rot = 0.0;  // degrees
  bool any_component = false;
  std::string Colour(const std::string& sensor) const {
    return std::string(
        kPalette[sensor_index.at(sensor) % (sizeof(kPalette) / sizeof(kPalette[0]))]);
  }
};

constexpr const char* kComponentColour[3] = {"#d62728", "#2ca02c", "#1f3fbf"};
constexpr const char* kComponentName[3] = {"dx", "dy", "dz"};

PoseExtent ScanPoses(const std::vector<PoseCorrectionPoint>& poses) {
  PoseExtent e;
  for (const auto& p : poses) {
    if (e.sensor_index.emplace(p.sensor, e.sensors.size()).second) e.sensors.push_back(p.sensor);
  }
  for (const auto& p : poses) {
    if (std::isfinite(p.position_m)) e.max_pos = std::max(e.max_pos, std::abs(p.position_m));
    for (double c : {p.dx, p.dy, p.dz}) {
      if (std::isfinite(c)) {
        e.max_pos = std::max(e.max_pos, std::abs(c));
        e.any_component = true;
      }
    }
    if (std::isfinite(p.rotation_deg)) e.max_rot = std::max(e.max_rot, std::abs(p.rotation_deg));
  }
  return e;
}

/// Grid, y ticks, frame and y label of the panel at y0; returns its y mapping.
PanelY DrawPanelAxes(const PoseFrame& f, double y0, double lo, double hi, double step,
                     const std::string& label, std::ostringstream& svg) {
  const PanelY Y{y0, lo, hi};
  for (double t : Ticks(lo, hi, step)) {
    svg << Line(f.left, Y(t), f.left + f.plot_w, Y(t),
                std::abs(t) < 1e-12 ? "stroke=\"#555\"" : "stroke=\"#e4e4e4\"");
    svg << Text(f.left - 4, Y(t) + 3.5, Tick(t), "text-anchor=\"end\"");
  }
  svg << "<rect x=\"" << Px(f.left) << "\" y=\"" << Px(y0) << "\" width=\"" << Px(f.plot_w)
      << "\" height=\"" << Px(f.panel_h) << "\" fill=\"none\" stroke=\"#999\"/>\n";
  svg << "<text transform=\"translate(14," << Px(y0 + f.panel_h / 2)
      << ") rotate(-90)\" text-anchor=\"middle\">" << HtmlEscape(label) << "</text>\n";
  return Y;
}

/// Image-index ticks below a panel whose base is at y_base.
void DrawImageTicks(const PoseFrame& f, double y_base, std::ostringstream& svg) {
  const double x_step = std::max(1.0, NiceStep(f.n / 10.0));
  for (double t : Ticks(0, f.n - 1, x_step)) {
    const double x = f.X(static_cast<size_t>(t));
    svg << Line(x, y_base, x, y_base + 4, "stroke=\"#333\"");
    svg << Text(x, y_base + 15, Tick(t), "text-anchor=\"middle\"");
  }
}

/// Title and legend: sensors, then the components.
void DrawPoseLegend(const PoseExtent& e, std::ostringstream& svg) {
  svg << Text(4, 14, "Pose corrections per image (adjusted \xE2\x88\x92 initial)",
              "font-weight=\"bold\" font-size=\"12\"");
  double lx = 4;
  for (const std::string& sensor : e.sensors) {
    svg << "<rect x=\"" << Px(lx) << "\" y=\"22\" width=\"10\" height=\"10\" fill=\""
        << e.Colour(sensor) << "\"/>\n";
    svg << Text(lx + 14, 31, HtmlEscape(sensor.empty() ? "(no sensor)" : sensor));
    lx += 24 + 6.5 * std::min<size_t>(sensor.size(), 30);
  }
  if (e.any_component) {
    for (int c = 0; c < 3; ++c) {
      svg << "<circle cx=\"" << Px(lx + 4) << "\" cy=\"27\" r=\"3\" fill=\"" << kComponentColour[c]
          << "\"/>\n";
      svg << Text(lx + 10, 31, kComponentName[c]);
      lx += 36;
    }
  }
}

/// Panel 1: |Δposition| bars and signed components, in cm below 1 m, else m.
void DrawPositionPanel(const std::vector<PoseCorrectionPoint>& poses, const PoseExtent& e,
                       const PoseFrame& f, std::ostringstream& svg) {
  const bool centimetres = e.max_pos < 1.0;
  const double pos_factor = centimetres ? 100.0 : 1.0;
  const std::string pos_unit = centimetres ? "cm" : "m";
  const double y0 = f.top;
  const double extent = std::max(e.max_pos * pos_factor, 1e-9);
  const double step = NiceStep(extent / 3.0);
  const double hi = std::ceil(extent / step) * step;
  const double lo = e.any_component ? -hi : 0.0;
  const PanelY Y =
      DrawPanelAxes(f, y0, lo, hi, step, "\xCE\x94position [" + pos_unit + "]", svg);
  for (size_t i = 0; i < f.n; ++i) {
    const auto& p = poses[i];
    if (!std::isfinite(p.position_m)) continue;
    const double v = std::abs(p.position_m) * pos_factor;
    svg << "<rect x=\"" << Px(f.X(i) - f.bar_w / 2) << "\" y=\"" << Px(Y(v)) << "\" width=\""
        << Px(f.bar_w) << "\" height=\"" << Px(Y(0) - Y(v)) << "\" fill=\"" << e.Colour(p.sensor)
        << "\" fill-opacity=\"0.75\"><title>" << HtmlEscape(p.image) << ": |\xCE\x94p| = "
        << FormatFixed(v, 2) << " " << pos_unit << "</title></rect>\n";
  }
  if (e.any_component) {
    const double r = std::clamp(f.slot * 0.3, 1.0, 3.0);
    for (int c = 0; c < 3; ++c) {
      svg << "<g fill=\"" << kComponentColour[c] << "\">";
      for (size_t i = 0; i < f.n; ++i) {
        const double v = (c == 0 ? poses[i].dx : c == 1 ? poses[i].dy : poses[i].dz) * pos_factor;
        if (!std::isfinite(v)) continue;
        svg << "<circle cx=\"" << Px(f.X(i)) << "\" cy=\"" << Px(Y(v)) << "\" r=\"" << Px(r) << "\"/>";
      }
      svg << "</g>\n";
    }
  }
  DrawImageTicks(f, y0 + f.panel_h, svg);
}

/// Panel 2: |Δrotation| bars in degrees.
void DrawRotationPanel(const std::vector<PoseCorrectionPoint>& poses, const PoseExtent& e,
                       const PoseFrame& f, std::ostringstream& svg) {
  const double y0 = f.top + f.panel_h + f.gap;
  const double extent = std::max(e.max_rot, 1e-9);
  const double step = NiceStep(extent / 3.0);
  const double hi = std::ceil(extent / step) * step;
  const PanelY Y = DrawPanelAxes(f, y0, 0.0, hi, step, "\xCE\x94rotation [\xC2\xB0]", svg);
  for (size_t i = 0; i < f.n; ++i) {
    const auto& p = poses[i];
    if (!std::isfinite(p.rotation_deg)) continue;
    const double v = std::abs(p.rotation_deg);
    svg << "<rect x=\"" << Px(f.X(i) - f.bar_w / 2) << "\" y=\"" << Px(Y(v)) << "\" width=\""
        << Px(f.bar_w) << "\" height=\"" << Px(Y(0) - Y(v)) << "\" fill=\"" << e.Colour(p.sensor)
        << "\" fill-opacity=\"0.75\"><title>" << HtmlEscape(p.image) << ": |\xCE\x94R| = "
        << FormatFixed(v, 4) << "\xC2\xB0</title></rect>\n";
  }
  DrawImageTicks(f, y0 + f.panel_h, svg);
  svg << Text(f.left + f.plot_w / 2, y0 + f.panel_h + 32, "image index (order of the report)",
              "text-anchor=\"middle\"");
}

}  // namespace

std::string SvgPoseCorrections(const std::vector<PoseCorrectionPoint>& poses, int width_px) {
  const int width = std::max(width_px, 300);
  const int height = static_cast<int>(PoseFrame::top + 2 * PoseFrame::panel_h + PoseFrame::gap + 44);
  std::ostringstream svg;
  svg << SvgOpen(width, height, "pose corrections per image");
  if (poses.empty()) {
    svg << Text(width / 2.0, height / 2.0, "no pose corrections", "text-anchor=\"middle\" fill=\"#666\"");
    svg << "</svg>\n";
    return svg.str();
  }
  PoseFrame f;
  f.plot_w = width - f.left - f.right;
  f.n = poses.size();
  f.slot = f.plot_w / f.n;
  f.bar_w = std::max(f.slot * 0.8, 0.6);
  const PoseExtent e = ScanPoses(poses);
  DrawPoseLegend(e, svg);
  DrawPositionPanel(poses, e, f, svg);
  DrawRotationPanel(poses, e, f, svg);
  svg << "</svg>\n";
  return svg.str();
}

}  // namespace mmba::report
