// report.json entries from the adjustment's statistics (report_entries.h).
#include "mmba/report/report_entries.h"

#include <algorithm>
#include <cmath>

#include "mmba/report/relative_precision.h"

namespace mmba::report {

nlohmann::json ObservationsEntry(const stats::NetworkStatistics& statistics, const std::vector<GroupLabel>& groups,
                                 const std::string& file, size_t max_rows,
                                 const std::function<std::string(const stats::RowStatistic&)>& describe) {
  const auto& rows = statistics.rows;
  std::vector<size_t> order(rows.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  const bool all = rows.size() <= max_rows;
  if (!all) {
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return std::abs(rows[a].studentized) > std::abs(rows[b].studentized);
    });
    order.resize(max_rows);
  }
  nlohmann::json out_rows = nlohmann::json::array();
  for (size_t i : order) {
    const stats::RowStatistic& r = rows[i];
    const GroupLabel& g = groups.at(r.group);
    const std::string what =
        describe ? describe(r) : "block " + std::to_string(r.block) + ", row " + std::to_string(r.row);
    out_rows.push_back({{"group", g.name}, {"observation", what}, {"residual", g.scale * r.residual}, {"unit", g.unit},
                        {"sigma", g.scale * r.sigma}, {"redundancy", r.redundancy}, {"studentized", r.studentized},
                        {"critical", r.critical}});
  }
  return {{"file", file},
          {"total", rows.size()},
          {"critical_value", statistics.critical_value},
          {"order", all ? "as in the adjustment" : "by decreasing |w|, the " + std::to_string(max_rows) + " largest"},
          {"rows", out_rows}};
}

nlohmann::json RelativePrecisionEntries(const std::vector<std::string>& ids,
                                        const std::vector<std::array<double, 3>>& xyz,
                                        const std::function<std::array<double, 9>(size_t, size_t)>& covariance,
                                        int neighbours) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [i, j] : NeighbourPairs(xyz, neighbours)) {
    const RelativePrecision r = RelativePrecisionOf(xyz[i], xyz[j], covariance(i, i), covariance(j, j), covariance(i, j));
    out.push_back({{"from", ids[i]},
                   {"to", ids[j]},
                   {"distance_m", r.distance_m},
                   {"sigma_distance_m", r.sigma_distance_m},
                   {"sigma", {r.sigma[0], r.sigma[1], r.sigma[2]}},
                   {"ellipse", {{"a", r.ellipse95.a}, {"b", r.ellipse95.b}, {"azimuth_deg", r.ellipse95.azimuth_deg},
                                {"confidence", 0.95}}}});
  }
  return out;
}

}  // namespace mmba::report
