// mmba survey: adjustment of a total-station / levelling / GNSS-vector network (GNU Gama
// gama-local XML or the survey CSV), with survey statistics. The outputs are the survey
// library's (survey/result_json.h, survey/result_report.h); this file reads the arguments and
// writes the files.
#include <filesystem>
#include <iostream>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/output_folder.h"
#include "mmba/core/version.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/survey_csv.h"
#include "mmba/survey/adjust.h"
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
};

int RunSurvey(const SurveyArgs& args) {
  OutputFolder output(args.output, "--output", "mmba survey", {{"--input", args.input}});
  if (args.confidence != 0.0 && !(args.confidence > 0 && args.confidence < 1)) {
    throw InputError::Message("--confidence", "found " + std::to_string(args.confidence) +
                                                  ", expected 0 < p < 1");
  }
  const std::string ext = std::filesystem::path(args.input).extension().string();
  survey::SurveyNetwork net = (ext == ".csv") ? io::ReadSurveyCsv(args.input)
                                              : io::ReadGamaLocal(args.input);
  survey::SurveyAdjustOptions options;
  options.confidence = args.confidence;
  options.max_iterations = args.max_iterations;
  const survey::SurveyAdjustment adj = survey::AdjustNetwork(&net, options);
  if (!adj.converged) {
    throw CommandFailed("survey adjustment " + adj.status + ": " + adj.reason);
  }
  nlohmann::json json = survey::ResultToJson(args.input, net, adj);
  const std::string csv_text = survey::ObservationsCsv(net, adj);
  const std::string summary = survey::ResultSummary(args.input, net, adj);
  const std::string md_text = survey::ReportMarkdown(args.input, net, adj, args.report_rows);

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
