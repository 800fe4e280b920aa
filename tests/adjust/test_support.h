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
#include "mmba/stats/correlation.h"

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

using stats::Pearson;  ///< the colour tests' measure of agreement

/// Loads `project_path` and adjusts it into `out` (no progress output).
inline AdjustOutcome RunProject(const std::string& project_path, const std::string& out) {
  const Project project = LoadProject(project_path);
  AdjustOptions options;
  options.output_dir = out;
  options.log_progress = false;
  return RunAdjustment(project, options);
}

}  // namespace mmba::adjust::testing_support
