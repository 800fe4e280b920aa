// The pose-correction plot of report.html (svg_plot.h: SvgPoseCorrections).
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "mmba/report/svg_plot.h"

#include "mmba/report/label_layout.h"
#include "report/svg_internal.h"

namespace mmba::report {

using namespace svg;  // NOLINT: the drawing primitives

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
    const std::string name = sensor.empty() ? "(no sensor)" : sensor;
    svg << Text(lx + 14, 31, HtmlEscape(name));
    lx += 24 + EstimateTextWidth(name, 11.0);  // the next entry starts after this one's text
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
