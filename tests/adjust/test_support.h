// Shared by the joint-adjustment tests: scratch folders, file reading, one adjustment run.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
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

/// The rows of a CSV that mmba writes (its header on the first line, comma-separated, no
/// quoted fields) as column name → cell; `header` receives the column names.
inline std::vector<std::map<std::string, std::string>> ReadCsvRows(const std::filesystem::path& path,
                                                                   std::vector<std::string>* header = nullptr) {
  std::istringstream in(ReadText(path));
  std::vector<std::string> names;
  std::vector<std::map<std::string, std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (names.empty()) {
      names = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < names.size() && i < cells.size(); ++i) row[names[i]] = cells[i];
    rows.push_back(std::move(row));
  }
  if (header) *header = names;
  return rows;
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
