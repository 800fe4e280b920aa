// mmba survey: adjustment of a total-station / levelling / GNSS-vector network (GNU Gama
// gama-local XML or the survey CSV), with survey statistics.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/output_folder.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/survey_csv.h"
#include "mmba/geodesy/geodesy.h"
#include "mmba/survey/adjust.h"
#include "mmba/core/version.h"

namespace mmba::app {
namespace {
namespace fs = std::filesystem;
using survey::CoordStatus;

struct SurveyArgs {
  std::string input;
  std::string output;
  double confidence = 0.0;
  int max_iterations = 100;
  size_t report_rows = 10;
};

/// Input angle unit: gon (default) or degrees (parameters angles="360").
struct AngleUnit {
  bool gons = true;
  double FromRad(double rad) const { return rad * (gons ? 200.0 : 180.0) / M_PI; }
  /// Small angles (residuals, σ): cc or arc seconds.
  double SmallFromRad(double rad) const { return rad * (gons ? 2.0e6 : 648000.0) / M_PI; }
  const char* name() const { return gons ? "gon" : "deg"; }
  const char* small_name() const { return gons ? "cc" : "arcsec"; }
};

double Full(double value, double full) {
  value = std::fmod(value, full);
  return value < 0 ? value + full : value;
}

std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

// The network's header entries of adjusted.json: input, frame, σ0, dimensions, χ² test.
nlohmann::json NetworkJson(const std::string& input, const survey::SurveyNetwork& net,
                           const survey::SurveyAdjustment& adj, const AngleUnit& unit) {
  const stats::NetworkStatistics& st = adj.statistics;
  const double m0_apr = net.sigma0_apriori;
  nlohmann::json json;
  json["input"] = input;
  json["description"] = net.description;
  json["axes_xy"] = net.axes.code;
  json["angles"] = net.angles_left_handed ? "left-handed" : "right-handed";
  json["angle_unit"] = unit.name();
  if (net.geodetic) {
    json["origin"] = {{"latitude_deg", net.origin.latitude_deg},
                      {"longitude_deg", net.origin.longitude_deg},
                      {"height_m", net.origin.height_m}};
    json["frame"] = "local tangent plane (ENU) at the origin, station verticals";
  } else {
    json["frame"] = "input plane (gama-local)";
  }
  json["sigma0_apriori"] = m0_apr;
  json["sigma0_aposteriori"] = m0_apr * st.sigma0_ratio;
  json["sigma0_ratio"] = st.sigma0_ratio;
  json["sigma0_used"] = net.sigma_act_apriori ? "apriori" : "aposteriori";
  json["degrees_of_freedom"] = st.degrees_of_freedom;
  json["equations"] = st.num_equations;
  json["unknowns"] = st.num_unknowns;
  json["defect"] = st.defect;
  json["datum"] = adj.datum;
  json["confidence"] = st.confidence;
  json["chi2_lower"] = st.chi2_lower;
  json["chi2_upper"] = st.chi2_upper;
  json["chi2_test_passed"] = st.chi2_passed;
  json["critical_value"] = st.critical_value;
  json["iterations"] = adj.iterations;
  json["removed_observations"] = adj.removed;
  return json;
}

// WGS84 geodetic and UTM coordinates of an adjusted point of a georeferenced network.
void AddGeoreferencedCoordinates(const survey::SurveyNetwork& net, const survey::SurveyPoint& p,
                                 nlohmann::json* jp) {
  const geodesy::LocalTangentPlane plane(net.origin);
  const Eigen::Vector3d enu(p.coords.x(), p.coords.y(), p.has_z ? p.coords.z() : 0.0);
  const geodesy::Geodetic g = plane.GeodeticFromEnu(enu);
  (*jp)["latitude_deg"] = g.latitude_deg;
  (*jp)["longitude_deg"] = g.longitude_deg;
  if (p.has_z) (*jp)["ellipsoidal_height_m"] = g.height_m;
  const geodesy::Utm utm = geodesy::UtmFromGeodetic(g);
  (*jp)["utm"] = {{"zone", utm.zone}, {"north", utm.northp}, {"easting", utm.easting_m},
                  {"northing", utm.northing_m}};
}

// One adjusted point: coordinates in the input axes, status, σ, standard and confidence
// ellipses (major axis angle from +x towards +y, Gama's convention, input unit), geodetic
// coordinates when georeferenced, and the standard ellipsoid's axes.
nlohmann::json PointJson(const survey::SurveyNetwork& net, const survey::SurveyAdjustment& adj,
                         const survey::SurveyPoint& p, const AngleUnit& unit) {
  nlohmann::json jp;
  jp["id"] = p.id;
  const Eigen::Vector2d xy = net.axes.XyFromEn(p.coords.head<2>());
  const Eigen::Matrix3d cov = survey::PointCovariance(adj, net, p);
  if (p.xy != CoordStatus::kUnused && p.has_xy) {
    jp["x"] = xy.x();
    jp["y"] = xy.y();
    jp["status_x"] = jp["status_y"] = survey::CoordStatusName(p.xy);
    if (p.xy_free()) {
      jp["sigma_x"] = std::sqrt(cov(0, 0));
      jp["sigma_y"] = std::sqrt(cov(1, 1));
      const stats::ErrorEllipse e = stats::StandardEllipse(cov.topLeftCorner<2, 2>());
      jp["ellipse_a"] = e.a;
      jp["ellipse_b"] = e.b;
      jp["ellipse_azimuth"] = unit.FromRad(e.angle_rad);
      const double k = std::sqrt(stats::ChiSquareQuantile(adj.statistics.confidence, 2));
      jp["confidence_ellipse_a"] = k * e.a;
      jp["confidence_ellipse_b"] = k * e.b;
    }
  }
  if (p.z != CoordStatus::kUnused && p.has_z) {
    jp["z"] = p.coords.z();
    jp["status_z"] = survey::CoordStatusName(p.z);
    if (p.z_free()) jp["sigma_z"] = std::sqrt(cov(2, 2));
  }
  if (net.geodetic && p.has_xy) AddGeoreferencedCoordinates(net, p, &jp);
  if (p.xy_free() && p.z_free()) {
    Eigen::Vector3d axes_m;
    Eigen::Matrix3d dirs;
    stats::StandardEllipsoid(cov, &axes_m, &dirs);
    jp["ellipsoid_axes"] = {axes_m(0), axes_m(1), axes_m(2)};
  }
  return jp;
}

// adjusted.json: the network's entries, the used points, the stations' orientations and the
// variance components per group.
nlohmann::json AdjustedJson(const std::string& input, const survey::SurveyNetwork& net,
                            const survey::SurveyAdjustment& adj, const AngleUnit& unit) {
  nlohmann::json json = NetworkJson(input, net, adj, unit);
  nlohmann::json points = nlohmann::json::array();
  for (const survey::SurveyPoint& p : net.points) {
    if (p.xy == CoordStatus::kUnused && p.z == CoordStatus::kUnused) continue;
    points.push_back(PointJson(net, adj, p, unit));
  }
  json["points"] = points;
  nlohmann::json orientations = nlohmann::json::array();
  for (const survey::Cluster& c : net.clusters) {
    if (c.type != survey::Cluster::Type::kStandpoint || !c.has_orientation) continue;
    const double o = net.angles_left_handed ? c.orientation : -c.orientation;
    orientations.push_back({{"station", c.station}, {"line", c.line},
                            {"orientation", Full(unit.FromRad(o), unit.gons ? 400.0 : 360.0)}});
  }
  json["orientations"] = orientations;
  nlohmann::json groups = nlohmann::json::array();
  for (const stats::GroupStatistic& g : adj.statistics.groups) {
    groups.push_back({{"name", g.name}, {"observations", g.rows},
                      {"redundancy", g.redundancy},
                      {"variance_component", g.variance_component},
                      {"sigma0_ratio", std::sqrt(g.variance_component)}});
  }
  json["variance_components"] = groups;
  return json;
}

// A row of the report's table of largest studentized residuals, with its |t|.
struct Line {
  double abs_t;
  std::string text;
};

// observations.csv: the observations in input order with their statistics (angles in the
// input unit, residuals and σ in cc/arc seconds or mm; residual = adjusted − observed, Gama's
// v). `largest` gets each one's report row, sorted by decreasing |studentized residual|.
std::string ObservationsCsv(const survey::SurveyNetwork& net, const survey::SurveyAdjustment& adj,
                            const AngleUnit& unit, std::vector<Line>* largest) {
  const stats::NetworkStatistics& st = adj.statistics;
  std::vector<int> order(adj.rows.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return std::make_pair(adj.rows[a].cluster, adj.rows[a].observation) <
           std::make_pair(adj.rows[b].cluster, adj.rows[b].observation);
  });
  std::ostringstream csv;
  csv << "index,line,kind,from,to,observed,adjusted,residual,residual_unit,sigma,redundancy,"
         "studentized,flag\n";
  for (size_t k = 0; k < order.size(); ++k) {
    const int r = order[k];
    const stats::RowStatistic& row = st.rows[r];
    const survey::Observation& o =
        net.clusters[adj.rows[r].cluster].observations[adj.rows[r].observation];
    const bool angle = survey::ObsKindIsAngle(o.kind);
    const double sign = angle && !net.angles_left_handed ? -1.0 : 1.0;
    double observed = o.value, adjusted = o.value + row.residual;
    double residual = row.residual, sigma = row.sigma;
    std::string runit = "mm";
    if (angle) {
      const bool zenith = o.kind == survey::ObsKind::kZenithAngle;
      observed = zenith ? unit.FromRad(o.value) : Full(unit.FromRad(sign * o.value), unit.gons ? 400 : 360);
      adjusted = zenith ? unit.FromRad(o.value + row.residual)
                        : Full(unit.FromRad(sign * (o.value + row.residual)), unit.gons ? 400 : 360);
      residual = unit.SmallFromRad(sign * row.residual);
      sigma = unit.SmallFromRad(row.sigma);
      runit = unit.small_name();
    } else {
      residual *= 1000.0;
      sigma *= 1000.0;
    }
    std::string flag;
    if (r == st.max_row) flag = row.critical ? "max-critical" : "max";
    else if (row.critical) flag = "critical";
    const std::string to = o.fs.empty() ? o.to : o.to + "/" + o.fs;
    csv << k + 1 << "," << o.line << "," << survey::ObsKindName(o.kind) << "," << o.from << ","
        << to << "," << Fixed(observed, 7) << "," << Fixed(adjusted, 7) << ","
        << Fixed(residual, 3) << "," << runit << "," << Fixed(sigma, 3) << ","
        << Fixed(row.redundancy, 4) << "," << Fixed(row.studentized, 3) << "," << flag << "\n";
    largest->push_back({std::abs(row.studentized),
                        "| " + std::to_string(k + 1) + " | " + std::to_string(o.line) + " | " +
                            survey::ObsKindName(o.kind) + " | " + o.from + " | " + to + " | " +
                            Fixed(residual, 2) + " " + runit + " | " + Fixed(row.redundancy, 3) +
                            " | " + Fixed(row.studentized, 2) + " | " + flag + " |"});
  }
  std::sort(largest->begin(), largest->end(),
            [](const Line& a, const Line& b) { return a.abs_t > b.abs_t; });
  return csv.str();
}

// The summary printed on stdout and heading the report: dimensions, datum, σ0, χ² test, the
// largest studentized residual and the removed observations.
std::string Summary(const std::string& input, const survey::SurveyNetwork& net,
                    const survey::SurveyAdjustment& adj) {
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
    const survey::Observation& o =
        net.clusters[adj.rows[st.max_row].cluster].observations[adj.rows[st.max_row].observation];
    summary << "  data snooping: largest studentized residual " << Fixed(row.studentized, 2)
            << " (critical " << Fixed(st.critical_value, 3) << ") at " << net.source << ":"
            << o.line << " " << survey::ObsKindName(o.kind) << " " << o.from << " -> " << o.to
            << (row.critical ? "  <- likely blunder" : "") << "\n";
  }
  if (!adj.removed.empty()) summary << "  removed observations: " << adj.removed.size() << "\n";
  return summary.str();
}

// report.md: the summary, the variance components, the `report_rows` largest studentized
// residuals and the removed observations.
std::string ReportMarkdown(const SurveyArgs& args, const survey::SurveyNetwork& net,
                           const survey::SurveyAdjustment& adj, const std::string& summary,
                           const std::vector<Line>& largest) {
  std::ostringstream md;
  md << "# Survey adjustment\n\n" << "Input: `" << args.input << "`";
  if (!net.description.empty()) md << " — " << net.description;
  md << "\n\n```\n" << summary << "```\n\n## Variance components (per group)\n\n"
     << "| group | observations | redundancy | σ0 ratio |\n|---|---|---|---|\n";
  for (const stats::GroupStatistic& g : adj.statistics.groups) {
    md << "| " << g.name << " | " << g.rows << " | " << Fixed(g.redundancy, 2) << " | "
       << Fixed(std::sqrt(g.variance_component), 3) << " |\n";
  }
  md << "\n## Largest studentized residuals\n\n"
     << "| # | line | kind | from | to | residual | redundancy | studentized | flag |\n"
     << "|---|---|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < std::min(args.report_rows, largest.size()); ++i) {
    md << largest[i].text << "\n";
  }
  if (!adj.removed.empty()) {
    md << "\n## Removed observations\n\n";
    for (const std::string& r : adj.removed) md << "- " << r << "\n";
  }
  return md.str();
}

int RunSurvey(const SurveyArgs& args) {
  OutputFolder output(args.output, "--output", "mmba survey", {{"--input", args.input}});
  if (args.confidence != 0.0 && !(args.confidence > 0 && args.confidence < 1)) {
    throw InputError::Message("--confidence", "found " + std::to_string(args.confidence) +
                                                  ", expected 0 < p < 1");
  }
  const std::string ext = fs::path(args.input).extension().string();
  survey::SurveyNetwork net = (ext == ".csv") ? io::ReadSurveyCsv(args.input)
                                              : io::ReadGamaLocal(args.input);
  survey::SurveyAdjustOptions options;
  options.confidence = args.confidence;
  options.max_iterations = args.max_iterations;
  const survey::SurveyAdjustment adj = survey::AdjustNetwork(&net, options);
  if (!adj.converged) {
    throw CommandFailed("survey adjustment " + adj.status + ": " + adj.reason);
  }
  const AngleUnit unit{net.output_gons};
  nlohmann::json json = AdjustedJson(args.input, net, adj, unit);
  std::vector<Line> largest;
  const std::string csv_text = ObservationsCsv(net, adj, unit, &largest);
  const std::string summary = Summary(args.input, net, adj);
  const std::string md_text = ReportMarkdown(args, net, adj, summary, largest);

  RecordBuild(&json);
  AtomicFileSet files;
  const std::string json_text = json.dump(2);
  files.Add(output.staging() / "adjusted.json", [&](std::ostream& out) { out << json_text << "\n"; });
  files.Add(output.staging() / "observations.csv", [&](std::ostream& out) { out << csv_text; });
  files.Add(output.staging() / "report.md", [&](std::ostream& out) { out << md_text; });
  files.Commit();
  output.Commit();
  std::cout << summary;
  return kExitOk;
}

std::function<int()> SetupSurveyCommand(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<SurveyArgs>();
  CLI::App* sub = app.add_subcommand(
      "survey", "Adjust a survey network (gama-local XML or survey CSV) with statistics");
  sub->add_option("input,--input", args->input, "Network: gama-local .xml/.gkf or survey .csv, as --input or the first argument")
      ->required();
  sub->add_option("--output", args->output,
                  "Folder for adjusted.json, observations.csv, report.md: new, empty or written by mmba (replaced whole)")
      ->required();
  sub->add_option("--confidence", args->confidence,
                  "Confidence level of the tests (default: the file's conf-pr, else 0.95)");
  sub->add_option("--max-iterations", args->max_iterations, "Levenberg-Marquardt iterations")
      ->capture_default_str();
  AddCommonOptions(sub, common);
  return [args]() { return RunSurvey(*args); };
}

}  // namespace

MMBA_REGISTER_COMMAND(40, SetupSurveyCommand);

}  // namespace mmba::app
