#include "mmba/report/svg_plot.h"

#include <cmath>
#include <random>
#include <regex>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace mmba::report {
namespace {

size_t CountOf(const std::string& text, const std::string& needle) {
  size_t n = 0;
  for (size_t pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + 1)) ++n;
  return n;
}

TEST(SvgPlot, HistogramBinsSumToTheNumberOfFiniteValues) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> values;
  for (int i = 0; i < 10000; ++i) values.push_back(normal(rng));
  values.insert(values.end(), {-50.0, -40.0, 50.0, 60.0, 1e300, NAN, INFINITY, -INFINITY});
  const Histogram h = ComputeHistogram(values, -5.0, 5.0, 40);
  EXPECT_EQ(h.counts.size(), 40u);
  EXPECT_EQ(h.total(), 10005u);
  EXPECT_EQ(h.non_finite, 3u);
  EXPECT_EQ(h.below, 2u);
  EXPECT_EQ(h.above, 3u);
  EXPECT_GE(h.counts.front(), 2u);
  EXPECT_GE(h.counts.back(), 3u);
  EXPECT_DOUBLE_EQ(h.bin_width(), 0.25);
  // About 34.1 % of N(0,1) in [0, 1): 4 bins.
  const size_t in_0_1 = h.counts[20] + h.counts[21] + h.counts[22] + h.counts[23];
  EXPECT_NEAR(in_0_1 / 10000.0, 0.3413, 0.015);

  // The auto-ranged histogram of SvgHistogram counts every finite value too.
  HistogramOptions options;
  const Histogram auto_h = ResolveHistogram(values, options);
  EXPECT_EQ(auto_h.total(), 10005u);
  EXPECT_DOUBLE_EQ(auto_h.lower, -4.0);
  EXPECT_DOUBLE_EQ(auto_h.upper, 4.0);
  EXPECT_EQ(auto_h.counts.size() % 2, 0u);
}

TEST(SvgPlot, HistogramBinEdgesByHand) {
  // Bins [-1,-0.5) [-0.5,0) [0,0.5) [0.5,1); 1.0 and 2 are at/above the upper edge.
  const Histogram h = ComputeHistogram({-1.0, -0.5, 0.0, 0.49, 0.5, 1.0, 2.0, -3.0}, -1.0, 1.0, 4);
  EXPECT_EQ(h.counts, (std::vector<size_t>{2, 1, 2, 3}));
  EXPECT_EQ(h.below, 1u);
  EXPECT_EQ(h.above, 2u);
  EXPECT_THROW(ComputeHistogram({1.0}, 0.0, 1.0, 0), std::invalid_argument);
  EXPECT_THROW(ComputeHistogram({1.0}, 1.0, 1.0, 4), std::invalid_argument);
  EXPECT_THROW(ComputeHistogram({1.0}, 0.0, NAN, 4), std::invalid_argument);
}

TEST(SvgPlot, AutoRangeOfNormsStartsAtZeroAndCoversTheBulk) {
  std::vector<double> norms;
  for (int i = 0; i < 2000; ++i) norms.push_back(0.004 * i);  // 0 … 8
  HistogramOptions options;
  options.density = ReferenceDensity::kChi;
  options.chi_dof = 2;
  const Histogram h = ResolveHistogram(norms, options);
  EXPECT_DOUBLE_EQ(h.lower, 0.0);
  EXPECT_DOUBLE_EQ(h.upper, 8.0);  // ⌈99.9 % quantile⌉
  EXPECT_EQ(h.total(), 2000u);
  EXPECT_EQ(h.counts.size(), 26u);  // ⌈2·2000^(1/3)⌉
}

TEST(SvgPlot, ReferenceDensities) {
  EXPECT_NEAR(StandardNormalDensity(0.0), 0.3989422804, 1e-9);
  double normal = 0.0, chi[6] = {0, 0, 0, 0, 0, 0};
  const double dx = 1e-3;
  for (double x = -10.0; x < 10.0; x += dx) normal += StandardNormalDensity(x + dx / 2) * dx;
  EXPECT_NEAR(normal, 1.0, 1e-6);
  for (int k = 1; k <= 5; ++k) {
    for (double x = 0.0; x < 12.0; x += dx) chi[k] += ChiDensity(x + dx / 2, k) * dx;
    EXPECT_NEAR(chi[k], 1.0, 1e-4) << k;
  }
  // k = 1: half-normal 2φ(x); k = 2: Rayleigh x·e^(−x²/2); k = 3: Maxwell.
  for (double x : {0.3, 1.0, 2.5}) {
    EXPECT_NEAR(ChiDensity(x, 1), 2.0 * StandardNormalDensity(x), 1e-12);
    EXPECT_NEAR(ChiDensity(x, 2), x * std::exp(-0.5 * x * x), 1e-12);
    EXPECT_NEAR(ChiDensity(x, 3), std::sqrt(2.0 / M_PI) * x * x * std::exp(-0.5 * x * x), 1e-12);
  }
  EXPECT_EQ(ChiDensity(-1.0, 2), 0.0);
  EXPECT_THROW(ChiDensity(1.0, 0), std::invalid_argument);
}

TEST(SvgPlot, HistogramSvgHasOneBarPerNonEmptyBinAndLabelledAxes) {
  std::vector<double> values = {-0.1, 0.1, 0.2, 1.1, 1.2, 1.3, 9.0, NAN};
  HistogramOptions options;
  options.title = "group <1>";
  options.x_label = "r/\xCF\x83 & more";
  options.lower = -2.0;
  options.upper = 2.0;
  options.bins = 4;
  const std::string svg = SvgHistogram(values, options);
  const Histogram h = ResolveHistogram(values, options);
  EXPECT_EQ(h.counts, (std::vector<size_t>{0, 1, 2, 4}));
  EXPECT_EQ(CountOf(svg, "<rect x="), 3u + 1u);  // 3 bars + the background
  EXPECT_NE(svg.find("[1, 2): 4"), std::string::npos);
  EXPECT_NE(svg.find("group &lt;1&gt;"), std::string::npos);
  EXPECT_NE(svg.find("r/\xCF\x83 &amp; more"), std::string::npos);
  EXPECT_NE(svg.find(">count<"), std::string::npos);
  EXPECT_NE(svg.find("n = 7; 1 beyond [-2, 2) counted in the end bins; 1 NaN/Inf left out"),
            std::string::npos);
  EXPECT_NE(svg.find("N(0,1) density"), std::string::npos);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_EQ(svg.find("<script"), std::string::npos);
  EXPECT_NE(SvgHistogram({}, options).find("no values"), std::string::npos);
}

TEST(SvgPlot, PlanViewScalesEllipsesAndVectors) {
  EXPECT_DOUBLE_EQ(SvgRotationFromAzimuth(0.0), -90.0);   // major axis north: up on screen
  EXPECT_DOUBLE_EQ(SvgRotationFromAzimuth(90.0), 0.0);    // east: along +x
  std::vector<PlanPoint> points(3);
  points[0] = {"A", false, 0.0, 0.0, 0.0, 0.010, 0.004, 0.002, 30.0, false};
  points[1] = {"B<", true, 100.0, 50.0, NAN, NAN, NAN, NAN, NAN, true};
  points[2] = {"nowhere", false, NAN, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0, false};
  PlanViewOptions options;
  PlanScales scales;
  const std::string svg = SvgPlanView(points, options, &scales);
  // Plot frame 592 × 422 px; 100 m × 50 m site: map scale 0.85 · min(5.92, 8.44) px/m.
  EXPECT_NEAR(scales.map_px_per_m, 0.85 * 5.92, 1e-9);
  // Largest error: |d| = 10 mm drawn 8 % of 422 px.
  EXPECT_NEAR(scales.error_px_per_m * 0.010, 0.08 * 422, 1e-9);
  EXPECT_DOUBLE_EQ(scales.map_bar_m, 20.0);   // nice ≤ 0.3 · 592 / 5.032 = 35.3 m
  EXPECT_DOUBLE_EQ(scales.error_bar_m, 0.02); // nice ≤ 90 / 3376 = 0.0267 m
  EXPECT_EQ(CountOf(svg, "<ellipse "), 1u);
  EXPECT_NE(svg.find("rotate(-60.00 "), std::string::npos);
  EXPECT_NE(svg.find("B&lt;"), std::string::npos);
  EXPECT_EQ(svg.find("nowhere"), std::string::npos);
  EXPECT_NE(svg.find("map: 20 m"), std::string::npos);
  EXPECT_NE(svg.find("ellipses and vectors: 2 cm"), std::string::npos);
  // A's displacement is 10 mm north: an arrow going up the screen by 33.76 px.
  const std::regex arrow(
      "<line x1=\"([0-9.]+)\" y1=\"([0-9.]+)\" x2=\"([0-9.]+)\" y2=\"([0-9.]+)\" stroke=\"#1f5fa8\"");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, arrow));
  EXPECT_NEAR(std::stod(m[3]) - std::stod(m[1]), 0.0, 0.01);
  EXPECT_NEAR(std::stod(m[2]) - std::stod(m[4]), 33.76, 0.02);
  // The flagged check point is drawn red.
  EXPECT_NE(svg.find("stroke=\"#d62728\" stroke-width=\"2\""), std::string::npos);
}

TEST(SvgPlot, PoseCorrectionsOneBarPerImageAndPanel) {
  std::vector<PoseCorrectionPoint> poses;
  for (int i = 0; i < 25; ++i) {
    poses.push_back({"img" + std::to_string(i), i < 10 ? "pano<a>" : "photos", 0.01, -0.02, 0.005,
                     0.0229, 0.1 * i});
  }
  poses[3].rotation_deg = NAN;
  const std::string svg = SvgPoseCorrections(poses, 800);
  EXPECT_EQ(CountOf(svg, ": |\xCE\x94p| = "), 25u);
  EXPECT_EQ(CountOf(svg, ": |\xCE\x94R| = "), 24u);
  EXPECT_NE(svg.find("img7: |\xCE\x94p| = 2.29 cm"), std::string::npos);
  EXPECT_NE(svg.find("pano&lt;a&gt;"), std::string::npos);
  EXPECT_EQ(CountOf(svg, "<circle cx="), 3u + 75u);  // legend + dx, dy, dz per image
  EXPECT_NE(SvgPoseCorrections({}).find("no pose corrections"), std::string::npos);
}

TEST(SvgPlot, FormattingHelpers) {
  EXPECT_EQ(HtmlEscape("<a href=\"x\">'&'</a>"), "&lt;a href=&quot;x&quot;&gt;&#39;&amp;&#39;&lt;/a&gt;");
  EXPECT_EQ(FormatFixed(NAN, 2), "\xE2\x80\x94");
  EXPECT_EQ(FormatFixed(-0.0001, 2), "0.00");
  EXPECT_EQ(FormatFixed(-1.25, 1), "-1.2");
  EXPECT_DOUBLE_EQ(NiceStep(0.3), 0.5);
  EXPECT_DOUBLE_EQ(NiceStep(7.0), 10.0);
  EXPECT_DOUBLE_EQ(NiceStep(1.0), 1.0);
  EXPECT_DOUBLE_EQ(NiceStep(0.0012), 0.002);
  EXPECT_EQ(NiceStep(0.0), 0.0);
}

}  // namespace
}  // namespace mmba::report
