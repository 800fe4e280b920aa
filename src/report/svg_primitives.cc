// Drawing primitives of the SVG plots (svg_internal.h).
#include <cmath>
#include <cstdio>

#include "mmba/report/svg_plot.h"
#include "report/svg_internal.h"

namespace mmba::report::svg {

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

std::string Text(double x, double y, const std::string& escaped, const std::string& extra) {
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

}  // namespace mmba::report::svg
