// Shared by the joint-adjustment tests: scratch folders, file reading, one adjustment run.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/adjust/adjust.h"

namespace mmba::adjust::testing_support {

/// A scratch folder of this test process: `<TempDir>/<name>_<pid>`.
inline std::filesystem::path ScratchRoot(const std::string& name) {
  return std::filesystem::path(::testing::TempDir()) / (name + "_" + std::to_string(::getpid()));
}

inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Pearson's correlation of the pairs (the colour tests' measure of agreement).
inline double Pearson(const std::vector<std::pair<double, double>>& pairs) {
  double ma = 0, mb = 0;
  for (const auto& [a, b] : pairs) ma += a, mb += b;
  ma /= pairs.size();
  mb /= pairs.size();
  double sab = 0, saa = 0, sbb = 0;
  for (const auto& [a, b] : pairs) sab += (a - ma) * (b - mb), saa += (a - ma) * (a - ma), sbb += (b - mb) * (b - mb);
  return sab / std::sqrt(saa * sbb);
}

/// Loads `project_path` and adjusts it into `out` (no progress output).
inline AdjustOutcome RunProject(const std::string& project_path, const std::string& out) {
  const Project project = LoadProject(project_path);
  AdjustOptions options;
  options.output_dir = out;
  options.log_progress = false;
  return RunAdjustment(project, options);
}

}  // namespace mmba::adjust::testing_support
