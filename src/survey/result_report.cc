// The text outputs of a survey adjustment (result_report.h).
#include "mmba/survey/result_report.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "survey/output_units_internal.h"

namespace mmba::survey {
namespace {

using internal::AngleUnit;
using internal::Fixed;
using internal::Full;

// One observation as the outputs show it.
struct ObservationRow {
  size_t index = 0;  ///< 1-based, in input order
  const Observation* observation = nullptr;
  std::string to;    ///< "to" or "to/fs"
  double observed = 0.0, adjusted = 0.0, residual = 0.0, sigma = 0.0;
  std::string residual_unit;
  double redundancy = 0.0, studentized = 0.0;
  std::string flag;
};

// The observations in input order: angles in the input unit, residuals and σ in cc/arc
// seconds or mm.
std::vector<ObservationRow> ObservationRows(const SurveyNetwork& net, const SurveyAdjustment& adj) {
  const stats::NetworkStatistics& st = adj.statistics;
  const AngleUnit unit{net.output_gons};
  std::vector<int> order(adj.rows.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return std::make_pair(adj.rows[a].cluster, adj.rows[a].observation) <
           std::make_pair(adj.rows[b].cluster, adj.rows[b].observation);
  });
  std::vector<ObservationRow> rows;
  for (size_t k = 0; k < order.size(); ++k) {
    const int r = order[k];
    const stats::RowStatistic& row = st.rows[r];
    const Observation& o = net.clusters[adj.rows[r].cluster].observations[adj.rows[r].observation];
    ObservationRow out;
    out.index = k + 1;
    out.observation = &o;
    out.to = o.fs.empty() ? o.to : o.to + "/" + o.fs;
    out.observed = o.value;
    out.adjusted = o.value + row.residual;
    out.residual = row.residual * 1000.0;
    out.sigma = row.sigma * 1000.0;
    out.residual_unit = "mm";
    if (ObsKindIsAngle(o.kind)) {
      const double sign = !net.angles_left_handed ? -1.0 : 1.0;
      const bool zenith = o.kind == ObsKind::kZenithAngle;
      out.observed = zenith ? unit.FromRad(o.value) : Full(unit.FromRad(sign * o.value), unit.FullTurn());
      out.adjusted = zenith ? unit.FromRad(o.value + row.residual)
                            : Full(unit.FromRad(sign * (o.value + row.residual)), unit.FullTurn());
      out.residual = unit.SmallFromRad(sign * row.residual);
      out.sigma = unit.SmallFromRad(row.sigma);
      out.residual_unit = unit.small_name();
    }
    out.redundancy = row.redundancy;
    out.studentized = row.studentized;
    if (r == st.max_row) out.flag = row.critical ? "max-critical" : "max";
    else if (row.critical) out.flag = "critical";
    rows.push_back(std::move(out));
  }
  return rows;
}

// The report's table of the `count` largest studentized residuals, by decreasing |t|.
std::string LargestResidualsTable(const std::vector<ObservationRow>& rows, size_t count) {
  struct Line {
    double abs_t;
    std::string text;
  };
  std::vector<Line> largest;
  for (const ObservationRow& row : rows) {
    const Observation& o = *row.observation;
    largest.push_back({std::abs(row.studentized),
                       "| " + std::to_string(row.index) + " | " + std::to_string(o.line) + " | " +
                           ObsKindName(o.kind) + " | " + o.from + " | " + row.to + " | " +
                           Fixed(row.residual, 2) + " " + row.residual_unit + " | " +
                           Fixed(row.redundancy, 3) + " | " + Fixed(row.studentized, 2) + " | " +
                           row.flag + " |"});
  }
  std::sort(largest.begin(), largest.end(),
            [](const Line& a, const Line& b) { return a.abs_t > b.abs_t; });
  std::string table =
      "| # | line | kind | from | to | residual | redundancy | studentized | flag |\n"
      "|---|---|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < std::min(count, largest.size()); ++i) table += largest[i].text + "\n";
  return table;
}

}  // namespace

std::string ObservationsCsv(const SurveyNetwork& net, const SurveyAdjustment& adj) {
  std::ostringstream csv;
  csv << "index,line,kind,from,to,observed,adjusted,residual,residual_unit,sigma,redundancy,"
         "studentized,flag\n";
  for (const ObservationRow& row : ObservationRows(net, adj)) {
    const Observation& o = *row.observation;
    csv << row.index << "," << o.line << "," << ObsKindName(o.kind) << "," << o.from << ","
        << row.to << "," << Fixed(row.observed, 7) << "," << Fixed(row.adjusted, 7) << ","
        << Fixed(row.residual, 3) << "," << row.residual_unit << "," << Fixed(row.sigma, 3) << ","
        << Fixed(row.redundancy, 4) << "," << Fixed(row.studentized, 3) << "," << row.flag << "\n";
  }
  return csv.str();
}

std::string ResultSummary(const std::string& input, const SurveyNetwork& net,
                          const SurveyAdjustment& adj) {
  const stats::NetworkStatistics& st = adj.statistics;
  const double m0_apr = net.sigma0_apriori;
  const double m0_apost = m0_apr * st.sigma0_ratio;
  std::ostringstream summary;
  summary << "survey " << input << ": " << st.num_equations << " observations, "
          << st.num_unknowns << " unknowns, defect " << st.defect << ", dof "
          << st.degrees_of_freedom << "\n"
          << "  datum: " << adj.datum << "\n"
          << "  sigma0 a-priori " << m0_apr << ", a-posteriori " << Fixed(m0_apost, 4)
          << " (ratio " << Fixed(st.sigma0_ratio, 3) << "), used: "
          << (net.sigma_act_apriori ? "apriori" : "aposteriori") << "\n"
          << "  chi2 test at " << st.confidence << ": ratio in [" << Fixed(st.chi2_lower, 3)
          << ", " << Fixed(st.chi2_upper, 3) << "] -> "
          << (st.degrees_of_freedom > 0 ? (st.chi2_passed ? "passed" : "failed")
                                        : "failed (no redundancy)")
          << "\n";
  if (st.max_row >= 0) {
    const stats::RowStatistic& row = st.rows[st.max_row];
    const Observation& o =
        net.clusters[adj.rows[st.max_row].cluster].observations[adj.rows[st.max_row].observation];
    summary << "  data snooping: largest studentized residual " << Fixed(row.studentized, 2)
            << " (critical " << Fixed(st.critical_value, 3) << ") at " << net.source << ":"
            << o.line << " " << ObsKindName(o.kind) << " " << o.from << " -> " << o.to
            << (row.critical ? "  <- likely blunder" : "") << "\n";
  }
  if (!adj.removed.empty()) summary << "  removed observations: " << adj.removed.size() << "\n";
  for (const RemovedCoordinate& r : adj.removed_points) {
    summary << "  " << RemovedCoordinateWarning(net.source, r) << "\n";
  }
  return summary.str();
}

std::string ReportMarkdown(const std::string& input, const SurveyNetwork& net,
                           const SurveyAdjustment& adj, size_t largest_rows) {
  std::ostringstream md;
  md << "# Survey adjustment\n\n" << "Input: `" << input << "`";
  if (!net.description.empty()) md << " — " << net.description;
  md << "\n\n```\n" << ResultSummary(input, net, adj) << "```\n\n## Variance components (per group)\n\n"
     << "| group | observations | redundancy | σ0 ratio |\n|---|---|---|---|\n";
  for (const stats::GroupStatistic& g : adj.statistics.groups) {
    md << "| " << g.name << " | " << g.rows << " | " << Fixed(g.redundancy, 2) << " | "
       << Fixed(std::sqrt(g.variance_component), 3) << " |\n";
  }
  md << "\n## Largest studentized residuals\n\n" << LargestResidualsTable(ObservationRows(net, adj), largest_rows);
  if (!adj.removed_points.empty()) {
    md << "\n## Coordinates removed from the adjustment\n\n"
       << "The observations cannot determine these coordinates; they are not adjusted, and the "
          "observations that need them are passive.\n\n| point | line | coordinates | reason |\n|---|---|---|---|\n";
    for (const RemovedCoordinate& r : adj.removed_points) {
      md << "| " << r.point << " | " << r.line << " | " << r.coordinates << " | " << r.reason << " |\n";
    }
  }
  if (!adj.removed.empty()) {
    md << "\n## Removed observations\n\n";
    for (const std::string& r : adj.removed) md << "- " << r << "\n";
  }
  return md.str();
}

}  // namespace mmba::survey
