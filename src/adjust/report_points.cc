// report.json entries of `mmba adjust` that report.html renders from the adjustment's
// covariance and statistics (docs/report.md): `points` (every adjusted point with σ and its
// standard ellipse), `relative_precision` (neighbouring points, report_entries.h),
// `observations` (the rows of observations.csv with redundancy and studentized residual) and
// `settings` (the adjustment settings in force).
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "blocks/photo_measurements.h"
#include "internal.h"
#include "mmba/report/report_entries.h"
#include "output_support.h"

namespace mmba::adjust::internal {

namespace {

using json = nlohmann::json;

/// One adjusted point: where it is, its covariance (ENU, m², scaled as every σ of the report)
/// and how its coordinates follow from columns of the statistics, x = G·(those parameters) +
/// a part of its own: G a selection of its own columns when the statistics hold the point,
/// the back-substitution gain L when they eliminated it (MeasurementBlock::point_gain). Without
/// `related` its covariance with the other points is not known.
struct AdjustedPoint {
  std::string id, role;
  Eigen::Vector3d x;
  Eigen::Matrix3d cov;
  bool related = false;
  std::vector<int> columns;
  Eigen::MatrixXd gain;  ///< 3 × columns
};

/// Relates `a` to the statistics' columns of its three coordinate scalars (a held scalar has
/// none: a zero row).
void HeldBy(const stats::NetworkStatistics& st, const std::array<std::pair<const double*, int>, 3>& scalars,
            AdjustedPoint* a) {
  std::vector<std::pair<int, int>> rows;  // (coordinate, column)
  for (int k = 0; k < 3; ++k) {
    const auto it = st.column.find(scalars[k].first);
    if (it != st.column.end()) rows.push_back({k, it->second + scalars[k].second});
  }
  a->gain = Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(rows.size()));
  for (size_t c = 0; c < rows.size(); ++c) {
    a->gain(rows[c].first, static_cast<Eigen::Index>(c)) = 1.0;
    a->columns.push_back(rows[c].second);
  }
  a->related = true;
}

bool HasCovariance(const Eigen::Matrix3d& cov) { return cov.diagonal().maxCoeff() > 0.0; }

/// The survey network's points with a covariance, with points.csv's roles ("adjusted",
/// "check (photos only)"); held points (σ 0) are left out.
void NetworkPoints(const JointState& s, std::vector<AdjustedPoint>* out) {
  const Project& project = *s.project;
  const stats::NetworkStatistics& st = s.statistics;
  for (const survey::SurveyPoint& p : s.joint->points) {
    const bool check = std::count(project.check_points.begin(), project.check_points.end(), p.id) > 0;
    if (check && !(s.photos && s.photos->check_ids.count(p.id))) continue;
    AdjustedPoint a;
    a.id = p.id;
    if (check) {
      const double* x = s.scene.Point(s.photos->check_ids.at(p.id)).data();
      a.role = "check (photos only)";
      a.x = s.scene.Point(s.photos->check_ids.at(p.id));
      a.cov = PointCovariance3(st, x);
      HeldBy(st, {{{x, 0}, {x, 1}, {x, 2}}}, &a);
    } else {
      const double* xy = p.coords.data();
      a.role = "adjusted";
      a.x = WorldFromSurvey(*s.joint, p);
      a.cov = SurveyPointCovariance(st, *s.joint, p);
      HeldBy(st, {{{xy, 0}, {xy, 1}, {xy + 2, 0}}}, &a);
    }
    if (HasCovariance(a.cov)) out->push_back(a);
  }
}

/// The photo_measurements block's points with a covariance, with <id>_points.csv's kinds
/// ("control (weighted)", "check", "tie"); held control is left out.
void MeasuredPoints(const JointState& s, std::vector<AdjustedPoint>* out) {
  const MeasurementBlock& b = *s.measured;
  std::set<Point3DId> weighted;
  for (const ControlCoordinate& c : b.control) weighted.insert(c.point);
  for (const auto& [name, id] : b.point_of) {
    if (b.fixed_points.count(id)) continue;
    const double* x = s.scene.Point(id).data();
    AdjustedPoint a;
    a.id = name;
    a.role = weighted.count(id) ? "control (weighted)" : b.check_reference.count(name) ? "check" : "tie";
    a.x = s.scene.Point(id);
    const auto folded = b.point_covariance.find(id);
    const auto gain = b.point_gain.find(id);
    if (folded == b.point_covariance.end()) {
      a.cov = PointCovariance3(s.statistics, x);
      if (s.statistics.IsFree(x)) HeldBy(s.statistics, {{{x, 0}, {x, 1}, {x, 2}}}, &a);
    } else {
      a.cov = folded->second;
      if (gain != b.point_gain.end()) {
        a.columns = gain->second.first;
        a.gain = gain->second.second;
        a.related = true;
      }
    }
    if (HasCovariance(a.cov)) out->push_back(a);
  }
}

/// Cov(x_i, x_j) = σ0² G_i Q(cols_i, cols_j) G_jᵀ, row-major 3×3; the point's own
/// covariance when i = j. The columns of x_j outermost, so that a cofactor held as a factor
/// solves once per column.
std::array<double, 9> CrossCovariance(const stats::NetworkStatistics& st, const AdjustedPoint& i,
                                      const AdjustedPoint& j) {
  std::array<double, 9> c{};
  if (&i == &j) {
    for (int k = 0; k < 9; ++k) c[k] = i.cov(k / 3, k % 3);
    return c;
  }
  Eigen::MatrixXd q(i.columns.size(), j.columns.size());
  for (size_t b = 0; b < j.columns.size(); ++b) {
    for (size_t a = 0; a < i.columns.size(); ++a) q(a, b) = st.cofactor(i.columns[a], j.columns[b]);
  }
  const Eigen::Matrix3d cov = st.scale_used * st.scale_used * i.gain * q * j.gain.transpose();
  for (int k = 0; k < 9; ++k) c[k] = cov(k / 3, k % 3);
  return c;
}

}  // namespace

void PointsReport(const JointState& s, json* report) {
  std::vector<AdjustedPoint> points;
  if (s.joint) NetworkPoints(s, &points);
  if (s.measured) MeasuredPoints(s, &points);
  if (points.empty()) return;
  json entries = json::array();
  for (const AdjustedPoint& p : points) {
    entries.push_back({{"id", p.id}, {"role", p.role}, {"adjusted", Vec(p.x)},
                       {"sigma", Vec(p.cov.diagonal().cwiseMax(0.0).cwiseSqrt())}, {"ellipse", Ellipse(p.cov)}});
  }
  (*report)["points"] = entries;
  std::string file = s.joint ? "points.csv" : "";
  if (s.measured) file += (file.empty() ? "" : " and ") + s.measured->config->id + "_points.csv";
  (*report)["points_file"] = file;
  // Relative precision needs Cov(x_i, x_j): the points related to the statistics' columns.
  std::vector<const AdjustedPoint*> held;
  for (const AdjustedPoint& p : points) {
    if (p.related) held.push_back(&p);
  }
  std::vector<std::string> ids;
  std::vector<std::array<double, 3>> xyz;
  for (const AdjustedPoint* p : held) {
    ids.push_back(p->id);
    xyz.push_back({p->x.x(), p->x.y(), p->x.z()});
  }
  const stats::NetworkStatistics& st = s.statistics;
  (*report)["relative_precision"] = report::RelativePrecisionEntries(
      ids, xyz, [&](size_t i, size_t j) { return CrossCovariance(st, *held[i], *held[j]); });
}

json ObservationsReport(const JointState& s) {
  std::vector<report::GroupLabel> labels;
  for (const auto& group : s.builder->groups()) {
    // Angles in mgon, as the report's groups show them (the groups work in radians).
    const bool angle = group->unit() == "rad";
    labels.push_back({group->name(), angle ? "mgon" : group->unit(), angle ? 200000.0 / M_PI : 1.0});
  }
  return report::ObservationsEntry(s.statistics, labels, "observations.csv");
}

json SettingsReport(const JointState& s, const AdjustOptions& options) {
  const AdjustSettings& a = s.project->settings;
  // The σ of each group is in the groups table (groups[].sigma, sigma_factor).
  return {{"max_iterations", a.max_iterations},   {"outer_iterations", a.outer_iterations},
          {"confidence", a.confidence},           {"outlier_sigma", a.outlier_sigma},
          {"variance_components", a.variance_components}, {"threads", options.num_threads}};
}

}  // namespace mmba::adjust::internal
