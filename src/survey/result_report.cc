// The text outputs of a survey adjustment (result_report.h).
#include "mmba/survey/result_report.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>
#include <vector>

#include "mmba/stats/statistics.h"
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

// sqrt(χ²_{2;0.95}) and the two-sided 95 % normal quantile: the factors from σ to the 95 %
// confidence ellipse and to the 95 % interval of a height (Ghilani 2017, ch. 19).
double K95Ellipse() { return std::sqrt(stats::ChiSquareQuantile(0.95, 2)); }
constexpr double kK95Height = 1.959964;

// Cov(east, north, up of p; east, north, up of q), scaled by the σ0 used; zero for fixed
// coordinates.
Eigen::Matrix3d CrossCovarianceEnu(const stats::NetworkStatistics& st, const SurveyPoint& p, const SurveyPoint& q) {
  double* pb = const_cast<double*>(p.coords.data());
  double* qb = const_cast<double*>(q.coords.data());
  const std::pair<double*, int> ps[3] = {{pb, 0}, {pb, 1}, {pb + 2, 0}};
  const std::pair<double*, int> qs[3] = {{qb, 0}, {qb, 1}, {qb + 2, 0}};
  Eigen::Matrix3d c;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) c(a, b) = st.Covariance(ps[a].first, ps[a].second, qs[b].first, qs[b].second);
  }
  return c;
}

// The adjusted points with σ, the 95 % confidence ellipse and the 95 % interval of the height.
std::string PointsTable(const SurveyNetwork& net, const SurveyAdjustment& adj) {
  const AngleUnit unit{net.output_gons};
  std::ostringstream md;
  md << "| point | x [m] | y [m] | z [m] | σx [mm] | σy [mm] | σz [mm] | 95 % a [mm] | 95 % b [mm] | azimuth of a ["
     << unit.name() << "] | 95 % z [mm] |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  const double k = K95Ellipse();
  for (const SurveyPoint& p : net.points) {
    if (!p.xy_free() && !p.z_free()) continue;
    const Eigen::Matrix3d cov = PointCovariance(adj, net, p);
    const Eigen::Vector2d xy = net.axes.XyFromEn(p.coords.head<2>());
    md << "| `" << p.id << "` | " << (p.has_xy ? Fixed(xy.x(), 4) : "") << " | " << (p.has_xy ? Fixed(xy.y(), 4) : "")
       << " | " << (p.has_z ? Fixed(p.coords.z(), 4) : "") << " | ";
    if (p.xy_free()) {
      const stats::ErrorEllipse e = stats::StandardEllipse(cov.topLeftCorner<2, 2>());
      md << Fixed(1e3 * std::sqrt(cov(0, 0)), 2) << " | " << Fixed(1e3 * std::sqrt(cov(1, 1)), 2) << " | ";
      md << (p.z_free() ? Fixed(1e3 * std::sqrt(cov(2, 2)), 2) : "") << " | " << Fixed(1e3 * k * e.a, 2) << " | "
         << Fixed(1e3 * k * e.b, 2) << " | " << Fixed(unit.FromRad(e.angle_rad), 4) << " | ";
    } else {
      md << " |  | " << Fixed(1e3 * std::sqrt(cov(2, 2)), 2) << " |  |  |  | ";
    }
    md << (p.z_free() ? Fixed(1e3 * kK95Height * std::sqrt(cov(2, 2)), 2) : "") << " |\n";
  }
  return md.str();
}

// Pairs (i < j) of horizontally placed points, each joined to its `k` nearest neighbours,
// at least one of the two adjusted.
std::vector<std::pair<size_t, size_t>> NeighbourPairs(const SurveyNetwork& net, int k) {
  std::vector<std::pair<size_t, size_t>> pairs;
  const auto& pts = net.points;
  for (size_t i = 0; i < pts.size(); ++i) {
    if (!pts[i].has_xy || pts[i].xy == CoordStatus::kUnused || pts[i].xy == CoordStatus::kRemoved) continue;
    std::vector<std::pair<double, size_t>> near;
    for (size_t j = 0; j < pts.size(); ++j) {
      if (j == i || !pts[j].has_xy || pts[j].xy == CoordStatus::kUnused || pts[j].xy == CoordStatus::kRemoved) continue;
      if (!pts[i].xy_free() && !pts[j].xy_free()) continue;
      near.push_back({(pts[j].coords.head<2>() - pts[i].coords.head<2>()).norm(), j});
    }
    std::sort(near.begin(), near.end());
    for (size_t m = 0; m < near.size() && m < static_cast<size_t>(k); ++m) {
      pairs.push_back({std::min(i, near[m].second), std::max(i, near[m].second)});
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

// σ of the coordinate difference of neighbouring points from the joint covariance,
// C_Δ = C_ii + C_jj − C_ij − C_ijᵀ (Ghilani 2017, ch. 19), its 95 % relative ellipse and the
// σ of the horizontal distance uᵀ C_Δ u.
std::string RelativePrecisionTable(const SurveyNetwork& net, const SurveyAdjustment& adj) {
  const stats::NetworkStatistics& st = adj.statistics;
  const double k = K95Ellipse();
  std::ostringstream md;
  md << "| from | to | distance [m] | σ distance [mm] | σ/distance [ppm] | σΔe [mm] | σΔn [mm] | σΔz [mm] | 95 % a [mm] | "
        "95 % b [mm] |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& [i, j] : NeighbourPairs(net, 2)) {
    const SurveyPoint& p = net.points[i];
    const SurveyPoint& q = net.points[j];
    const Eigen::Matrix3d cij = CrossCovarianceEnu(st, p, q);
    const Eigen::Matrix3d c = CrossCovarianceEnu(st, p, p) + CrossCovarianceEnu(st, q, q) - cij - cij.transpose();
    const Eigen::Vector2d d = q.coords.head<2>() - p.coords.head<2>();
    const double distance = d.norm();
    const Eigen::Vector2d u = distance > 0.0 ? Eigen::Vector2d(d / distance) : Eigen::Vector2d::Zero();
    const double sd = std::sqrt(std::max(0.0, u.dot(c.topLeftCorner<2, 2>() * u)));
    const stats::ErrorEllipse e = stats::StandardEllipse(c.topLeftCorner<2, 2>());
    const bool z = p.has_z && q.has_z && (p.z_free() || q.z_free());
    md << "| `" << p.id << "` | `" << q.id << "` | " << Fixed(distance, 3) << " | " << Fixed(1e3 * sd, 2) << " | "
       << (distance > 0.0 ? Fixed(1e6 * sd / distance, 1) : "") << " | " << Fixed(1e3 * std::sqrt(std::max(0.0, c(0, 0))), 2)
       << " | " << Fixed(1e3 * std::sqrt(std::max(0.0, c(1, 1))), 2) << " | "
       << (z ? Fixed(1e3 * std::sqrt(std::max(0.0, c(2, 2))), 2) : "") << " | " << Fixed(1e3 * k * e.a, 2) << " | "
       << Fixed(1e3 * k * e.b, 2) << " |\n";
  }
  return md.str();
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
  md << "\n## Adjusted points\n\nσ from the covariance of the adjustment (σ0 "
     << (net.sigma_act_apriori ? "a-priori" : "a-posteriori") << "); 95 % confidence ellipse = standard ellipse × "
     << Fixed(K95Ellipse(), 4) << " = sqrt(χ²(2; 0.95)); 95 % z = " << Fixed(kK95Height, 2)
     << " σz; azimuth of a from the x axis towards y.\n\n" << PointsTable(net, adj);
  md << "\n## Relative precision between neighbouring points\n\nEach point with its two nearest neighbours in "
        "plan (Δ in east, north, up); differences do not depend on the datum, so the figures hold for a free "
        "network too.\n\n" << RelativePrecisionTable(net, adj);
  md << "\n## Largest studentized residuals\n\nResidual v = adjusted − observed; redundancy r_i = (Q_vv P)_ii; "
        "studentized w_i = v_i / (σ_i √r_i) against the critical value " << Fixed(adj.statistics.critical_value, 3)
     << " (Baarda's data snooping with the a-priori σ0, Pope's τ with the a-posteriori one). All " << adj.rows.size() << " observations with these columns are in "
        "observations.csv.\n\n" << LargestResidualsTable(ObservationRows(net, adj), largest_rows);
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
