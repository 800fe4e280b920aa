// mmba survey: adjustment of a total-station / levelling / GNSS-vector network (GNU Gama
// gama-local XML, the survey CSV, or a Leica GSI field file reduced by io_survey/field_job.h),
// with survey statistics. The outputs are the survey
// library's (survey/result_json.h, survey/result_report.h); this file reads the arguments and
// writes the files.
#include <filesystem>
#include <iostream>
#include <optional>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/output_folder.h"
#include "mmba/core/version.h"
#include "mmba/geodesy/crs_frame.h"
#include "mmba/io_survey/field_job.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/gama_local_writer.h"
#include "mmba/io_survey/survey_csv.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/face_reduction.h"
#include "mmba/survey/result_json.h"
#include "mmba/survey/result_report.h"

namespace mmba::app {
namespace {

/// The options of `mmba survey`; report_rows: the largest studentized residuals in report.md.
struct SurveyArgs {
  std::string input;
  std::string output;
  double confidence = 0.0;
  int max_iterations = 100;
  size_t report_rows = 10;
  std::vector<std::string> known;     ///< --known: coordinates for a field file
  std::string export_gama_local;      ///< --export-gama-local FILE
  std::vector<std::string> settings;  ///< --set NAME=VALUE (survey/face_reduction.h)
  std::string crs;                    ///< --crs: the CRS of the network's coordinates
  std::string geoid_grid;             ///< --geoid-grid: with --crs, orthometric heights
};

/// --crs: the network's coordinates in the CRS moved into the tangent plane at the mean of its
/// points (crs_frame.h); std::nullopt without --crs.
std::optional<geodesy::CrsFrame> NetworkCrs(const SurveyArgs& args, std::shared_ptr<const geodesy::Crs> crs,
                                            survey::SurveyNetwork* net) {
  if (!crs) return std::nullopt;
  std::vector<Eigen::Vector3d> points;
  for (const survey::SurveyPoint& p : net->points) {
    if (p.has_xy) points.emplace_back(p.coords.x(), p.coords.y(), p.has_z ? p.coords.z() : 0.0);
  }
  if (points.empty()) {
    throw InputError::Message("--crs", args.input + " has no point with plane coordinates to place the origin at");
  }
  geodesy::CrsFrame frame(crs, geodesy::OriginOfCrsPoints(*crs, points));
  survey::NetworkFromCrs(frame, "--crs " + args.crs, net);
  return frame;
}

/// A field file's job, or writes its gama-local export; the options that only field files
/// take are refused for other inputs.
std::optional<io::FieldJob> ReadFieldInput(const SurveyArgs& args) {
  if (!io::IsFieldFile(args.input)) {
    for (const auto& [given, name] : {std::pair{!args.known.empty(), "--known"},
                                      std::pair{!args.export_gama_local.empty(), "--export-gama-local"},
                                      std::pair{!args.settings.empty(), "--set"}}) {
      if (given) {
        throw InputError::Message(name, std::string("applies to a field file (.gsi) input, found ") + args.input);
      }
    }
    return std::nullopt;
  }
  survey::FaceReductionOptions options;
  std::string problem;
  if (!survey::FaceReductionSettingsTable().Apply(args.settings, &options, &problem)) {
    throw InputError::Message("--set", problem);
  }
  return io::ReadFieldJob(args.input, args.known, options);
}

/// --export-gama-local: the reduced observations as gama-local XML, nothing adjusted.
int ExportGamaLocal(const SurveyArgs& args, const io::FieldJob& job) {
  const std::string text = io::GamaLocalText(job.network);
  WriteFileAtomically(args.export_gama_local, [&](std::ostream& out) { out << text; });
  std::cout << "survey " << args.input << ": exported " << job.network.clusters.size()
            << " observation set(s) of " << job.network.points.size() << " point(s) to "
            << args.export_gama_local << " (not adjusted)\n"
            << survey::FaceReductionSummary(job.reduction);
  return kExitOk;
}

int RunSurvey(const SurveyArgs& args) {
  if (args.confidence != 0.0 && !(args.confidence > 0 && args.confidence < 1)) {
    throw InputError::Message("--confidence", "found " + std::to_string(args.confidence) +
                                                  ", expected 0 < p < 1");
  }
  std::optional<io::FieldJob> field = ReadFieldInput(args);
  if (field && !args.export_gama_local.empty()) return ExportGamaLocal(args, *field);
  if (args.output.empty()) {
    throw InputError::Message("--output", "needed (a folder for the results) unless --export-gama-local is given");
  }
  if (args.crs.empty() && !args.geoid_grid.empty()) throw InputError::Message("--geoid-grid", "applies with --crs only");
  const auto crs_given = args.crs.empty() ? nullptr
                                          : std::make_shared<const geodesy::Crs>(args.crs, "--crs", args.geoid_grid);
  OutputFolder output(args.output, "--output", "mmba survey", {{"--input", args.input}});
  const std::string ext = std::filesystem::path(args.input).extension().string();
  survey::SurveyNetwork net = field ? std::move(field->network)
                              : (ext == ".csv") ? io::ReadSurveyCsv(args.input)
                                                : io::ReadGamaLocal(args.input);
  const std::optional<geodesy::CrsFrame> crs = NetworkCrs(args, crs_given, &net);
  survey::SurveyAdjustOptions options;
  options.confidence = args.confidence;
  options.max_iterations = args.max_iterations;
  const survey::SurveyAdjustment adj = survey::AdjustNetwork(&net, options);
  if (!adj.converged) {
    throw CommandFailed("survey adjustment " + adj.status + ": " + adj.reason);
  }
  nlohmann::json json = survey::ResultToJson(args.input, net, adj, crs ? &*crs : nullptr);
  const std::string csv_text = survey::ObservationsCsv(net, adj);
  std::string summary = survey::ResultSummary(args.input, net, adj);
  if (crs) {
    summary += "  crs: " + crs->crs().name() + (crs->crs().identifier().empty() ? "" : " (" + crs->crs().identifier() + ")") +
               ", heights " + geodesy::HeightKindName(crs->crs().height_kind()) +
               "; adjusted in the tangent plane at the mean of the points (report.md, adjusted.json origin)\n";
  }
  if (field) {
    json["face_reduction"] = survey::FaceReductionToJson(field->reduction);
    summary += survey::FaceReductionSummary(field->reduction);
  }
  std::string md_text = survey::ReportMarkdown(args.input, net, adj, args.report_rows);
  if (crs) md_text += survey::CrsPointsMarkdown(net, *crs);
  if (field) {
    md_text += "\n## Field book: rounds and face differences\n\n```\n" +
               survey::FaceReductionSummary(field->reduction) + "```\n";
  }

  RecordBuild(&json);
  AtomicFileSet files;
  const std::string json_text = json.dump(2);
  files.Add(output.staging() / "adjusted.json", [&](std::ostream& out) { out << json_text << "\n"; });
  files.Add(output.staging() / "observations.csv", [&](std::ostream& out) { out << csv_text; });
  files.Add(output.staging() / "report.md", [&](std::ostream& out) { out << md_text; });
  const std::string faces_csv = field ? survey::FaceDifferencesCsv(field->reduction) : std::string();
  if (field) {
    files.Add(output.staging() / "face_differences.csv", [&](std::ostream& out) { out << faces_csv; });
  }
  files.Commit();
  output.Commit();
  std::cout << summary;
  return kExitOk;
}

std::function<int()> SetupSurveyCommand(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<SurveyArgs>();
  CLI::App* sub = app.add_subcommand(
      "survey", "Adjust a survey network (gama-local XML, survey CSV or Leica GSI field file) with statistics");
  sub->add_option("input,--input", args->input,
                  "Network: gama-local .xml/.gkf, survey .csv or Leica GSI field file .gsi, as --input or the first argument")
      ->required();
  sub->add_option("--output", args->output,
                  "Folder for adjusted.json, observations.csv, report.md (+ face_differences.csv for .gsi): new, empty or written by mmba (replaced whole); required unless --export-gama-local");
  sub->add_option("--known", args->known,
                  "Field file only: known (fixed) coordinates, .gsi (WI 81-83) or .csv (id,east,north[,height]); repeatable. Without: a free network");
  sub->add_option("--export-gama-local", args->export_gama_local,
                  "Field file only: write the reduced observations as gama-local XML to FILE and exit without adjusting");
  sub->add_option("--set", args->settings, "Field file only: NAME=VALUE, face tolerances and a-priori sigmas (listed below)");
  sub->footer(survey::FaceReductionSettingsTable().Footer("Settings for --set NAME=VALUE (default; accepted values):"));
  sub->add_option("--crs", args->crs,
                  "Coordinate reference system of the network's coordinates (EPSG:25832, EPSG:2154+5720, a PROJ string or WKT): adjusted in the tangent plane at their mean, written back in the CRS with latitude, longitude, height and the grid scale");
  sub->add_option("--geoid-grid", args->geoid_grid,
                  "With --crs: a geoid grid (GTX, GeoTIFF) for the CRS's orthometric heights (h = H + N)");
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
