#include "mi_bench_common.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace mmba::bench {

using registration::mi::RegistrationOptions;

double PeakRssMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + 1e-6 * usage.ru_utime.tv_usec + usage.ru_stime.tv_sec +
         1e-6 * usage.ru_stime.tv_usec;
}

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream list(text);
  for (std::string item; std::getline(list, item, ',');) items.push_back(item);
  return items;
}

void ApplyEvaluatorEnv(RegistrationOptions* options) {
  if (const char* v = std::getenv("MI_POINT_SAMPLES")) options->point_samples = std::atoi(v) != 0;
  if (const char* v = std::getenv("MI_PER_POINT_FROM_LEVEL")) {
    options->per_point_samples_from_level = std::atoi(v);
  }
  if (const char* v = std::getenv("MI_SAMPLE_BLOCK")) options->sample_block_px = std::atoi(v);
  if (const char* v = std::getenv("MI_SAMPLES_IN_CHECKS")) {
    options->point_samples_in_checks = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_COV_PER_POINT")) {
    options->covariance_per_point_samples = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_PYRAMID_PATHS")) options->pyramid_paths = std::atoi(v);
  if (const char* v = std::getenv("MI_PATHS_ADAPTIVE")) {
    options->pyramid_paths_adaptive = std::atoi(v) != 0;
  }
  if (const char* v = std::getenv("MI_THREADS")) options->threads = std::atoi(v);
  if (const char* v = std::getenv("MI_ALL_CHECKS")) options->measure_all_checks = std::atoi(v) != 0;
}

void ApplySearchEnv(RegistrationOptions* options) {
  if (const char* v = std::getenv("MI_LEVELS")) options->pyramid_levels = std::atoi(v);
  if (const char* v = std::getenv("MI_RESTART_LEVEL")) options->restart_level = std::atoi(v);
  if (const char* v = std::getenv("MI_SPLIT_LEVEL")) options->split_level = std::atoi(v);
  if (const char* v = std::getenv("MI_COARSE_STARTS")) options->coarse_starts = std::atoi(v);
  if (const char* v = std::getenv("MI_POLISH")) options->polish_rounds = std::atoi(v);
}

void PrintProbeArgmax(const std::vector<registration::mi::ProbeSample>& probe) {
  for (int axis = 0; axis < 6; ++axis) {
    const registration::mi::ProbeSample* best = nullptr;
    for (const registration::mi::ProbeSample& s : probe) {
      if (s.axis == axis && (best == nullptr || s.metric.value > best->metric.value)) best = &s;
    }
    std::printf(" %s %+.2f", registration::mi::ParameterName(axis), best->offset);
  }
}

void PrintDigest(const char* indent, const registration::mi::RegistrationResult& result) {
  std::printf("%sdigest %016llx  metric %a  iterations %d  evaluations %d\n", indent,
              static_cast<unsigned long long>(result.Digest()), result.metric_after.value,
              result.iterations, result.evaluations);
}

// Histogram with the paper's presentation: counts per bin of width `width` px up to `max`,
// the last bin holding everything beyond.
std::vector<double> Histogram(const std::vector<double>& values, double width, int bins,
                              bool normalise) {
  std::vector<double> counts(bins, 0.0);
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    counts[std::min(bins - 1, static_cast<int>(v / width))] += 1;
  }
  if (normalise && !values.empty()) {
    for (double& c : counts) c /= values.size();
  }
  return counts;
}

void WriteHistogram(const std::string& csv, const std::string& svg, const std::string& title,
                    const std::string& unit, const std::vector<double>& before,
                    const std::vector<double>& after, double width, int bins, bool normalise) {
  const std::vector<double> hb = Histogram(before, width, bins, normalise);
  const std::vector<double> ha = Histogram(after, width, bins, normalise);
  {
    std::ofstream out(csv);
    out << "bin_from_px,bin_to_px," << unit << "_before," << unit << "_after\n";
    for (int b = 0; b < bins; ++b) {
      out << b * width << "," << (b + 1 == bins ? INFINITY : (b + 1) * width) << "," << hb[b]
          << "," << ha[b] << "\n";
    }
  }
  const double top = std::max(*std::max_element(hb.begin(), hb.end()),
                              *std::max_element(ha.begin(), ha.end()));
  constexpr double kW = 720, kH = 360, kLeft = 60, kBottom = 50, kTop = 40, kRight = 20;
  const double plot_w = kW - kLeft - kRight, plot_h = kH - kTop - kBottom;
  const double bar = plot_w / bins;
  std::ofstream out(svg);
  out << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kW << "\" height=\"" << kH
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << kLeft << "\" y=\"20\" font-size=\"14\">" << title << "</text>\n";
  for (int b = 0; b < bins; ++b) {
    const double x = kLeft + b * bar;
    const double h1 = top > 0 ? hb[b] / top * plot_h : 0;
    const double h2 = top > 0 ? ha[b] / top * plot_h : 0;
    out << "<rect x=\"" << x + 1 << "\" y=\"" << kTop + plot_h - h1 << "\" width=\""
        << bar / 2 - 1 << "\" height=\"" << h1 << "\" fill=\"#d62728\"/>\n";
    out << "<rect x=\"" << x + bar / 2 << "\" y=\"" << kTop + plot_h - h2 << "\" width=\""
        << bar / 2 - 1 << "\" height=\"" << h2 << "\" fill=\"#1f77b4\"/>\n";
    if (b % std::max(1, bins / 10) == 0) {
      out << "<text x=\"" << x << "\" y=\"" << kTop + plot_h + 15 << "\">" << b * width
          << "</text>\n";
    }
  }
  out << "<line x1=\"" << kLeft << "\" y1=\"" << kTop + plot_h << "\" x2=\"" << kLeft + plot_w
      << "\" y2=\"" << kTop + plot_h << "\" stroke=\"black\"/>\n"
      << "<line x1=\"" << kLeft << "\" y1=\"" << kTop << "\" x2=\"" << kLeft << "\" y2=\""
      << kTop + plot_h << "\" stroke=\"black\"/>\n"
      << "<text x=\"" << kLeft - 55 << "\" y=\"" << kTop + 10 << "\">" << top << "</text>\n"
      << "<text x=\"" << kLeft + plot_w / 2 - 120 << "\" y=\"" << kH - 12
      << "\">pixel offset (px; last bin: ≥ " << (bins - 1) * width << ")</text>\n"
      << "<rect x=\"" << kW - 200 << "\" y=\"30\" width=\"12\" height=\"12\" fill=\"#d62728\"/>"
      << "<text x=\"" << kW - 182 << "\" y=\"41\">before (start)</text>\n"
      << "<rect x=\"" << kW - 200 << "\" y=\"48\" width=\"12\" height=\"12\" fill=\"#1f77b4\"/>"
      << "<text x=\"" << kW - 182 << "\" y=\"59\">after (registered)</text>\n</svg>\n";
}

}  // namespace mmba::bench
