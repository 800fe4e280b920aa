#pragma once

// Drawing primitives shared by the SVG plots (svg_plot.h): pixel numbers, text, lines, the
// <svg> element, ticks and scale-bar lengths.

#include <string>
#include <vector>

namespace mmba::report::svg {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr const char* kFont = "font-family=\"DejaVu Sans, Arial, Helvetica, sans-serif\"";
inline constexpr const char* kPalette[] = {"#4e79a7", "#f28e2b", "#59a14f", "#b07aa1",
                                           "#76b7b2", "#edc948", "#9c755f", "#e15759"};

/// Pixel coordinate with two decimals.
std::string Px(double v);
/// Shortest readable tick label ("0.5", "10", "-2", "1e+06").
std::string Tick(double v);
/// Largest 1/2/5 × 10^k not above raw > 0 (scale-bar lengths).
double NiceFloor(double raw);
/// A length in metres as "2 m", "5 cm" or "2 mm".
std::string LengthLabel(double metres);
std::string Text(double x, double y, const std::string& escaped, const std::string& extra = "");
std::string Line(double x1, double y1, double x2, double y2, const std::string& style);
/// The opening <svg> with its title and a white background.
std::string SvgOpen(int width, int height, const std::string& label);
/// Ticks at multiples of step inside [lo, hi].
std::vector<double> Ticks(double lo, double hi, double step);

}  // namespace mmba::report::svg
