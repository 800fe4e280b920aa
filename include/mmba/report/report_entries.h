#pragma once

// Builders of report.json entries that report.html renders (adjust_report.h, docs/report.md)
// from the adjustment's statistics, for the command that writes report.json:
//   report["observations"]       = ObservationsEntry(statistics, groups, "observations.csv");
//   report["relative_precision"] = RelativePrecisionEntries(ids, xyz, covariance);

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mmba/stats/statistics.h"

namespace mmba::report {

/// How one factor group's rows are shown: its name, the unit of its residuals in the report
/// and the factor from the statistics' unit to it (e.g. 200000/π for rad -> mgon).
struct GroupLabel {
  std::string name;
  std::string unit;
  double scale = 1.0;
};

/// `observations` {file, total, critical_value, order, rows[]}: every row of `statistics`
/// when there are at most `max_rows`, in their order; else the `max_rows` with the largest
/// |studentized| in decreasing order (`order` says which). A row: {group, observation
/// ("block b, row r", or `describe(row)` when given), residual, unit, sigma, redundancy,
/// studentized, critical}. Throws std::out_of_range when a row names a group beyond `groups`.
nlohmann::json ObservationsEntry(const stats::NetworkStatistics& statistics, const std::vector<GroupLabel>& groups,
                                 const std::string& file, size_t max_rows = 300,
                                 const std::function<std::string(const stats::RowStatistic&)>& describe = nullptr);

/// `relative_precision` entries for each point and its `neighbours` nearest in plan
/// (NeighbourPairs): {from, to, distance_m, sigma_distance_m, sigma[3], ellipse {a, b,
/// azimuth_deg, confidence 0.95}}. `covariance(i, j)` returns Cov(x_i, x_j), row-major 3×3 in
/// m² (east, north, up).
nlohmann::json RelativePrecisionEntries(const std::vector<std::string>& ids,
                                        const std::vector<std::array<double, 3>>& xyz,
                                        const std::function<std::array<double, 9>(size_t, size_t)>& covariance,
                                        int neighbours = 2);

}  // namespace mmba::report
