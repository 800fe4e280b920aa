// mmba adjust: the joint adjustment of a project (every sensor one group of residual blocks
// of one Ceres problem), with the accuracy report.
#include <filesystem>
#include <iostream>

#include "command.h"
#include "mmba/adjust/adjust.h"
#include "mmba/core/error.h"

namespace mmba::app {
namespace {

namespace fs = std::filesystem;

struct AdjustArgs {
  std::string project;
  std::string output;
  int threads = 2;
};

int RunAdjust(const AdjustArgs& args, const CommonOptions& common) {
  if (args.threads < 1) throw InputError::Message("--threads", "found " + std::to_string(args.threads) + ", expected >= 1");
  const adjust::Project project = adjust::LoadProject(args.project);
  // RunAdjustment checks and locks the output folder (core/output_folder.h) before any work.
  adjust::AdjustOptions options;
  options.output_dir = args.output;
  options.num_threads = args.threads;
  options.log_progress = !common.quiet;
  const adjust::AdjustOutcome outcome = adjust::RunAdjustment(project, options);
  if (!outcome.ok) throw CommandFailed("adjustment " + outcome.status + ": " + outcome.reason);
  std::cout << outcome.summary << std::endl;
  return kExitOk;
}

std::function<int()> SetupAdjustCommand(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<AdjustArgs>();
  CLI::App* sub = app.add_subcommand(
      "adjust", "Joint adjustment of a project (photos, total station, GNSS, LiDAR) with report.html");
  sub->add_option("project,--input", args->project, "Project file (YAML; schema in docs/project-yaml.md), as --input or the first argument")->required();
  sub->add_option("--output", args->output, "Output folder: new, empty or written by mmba (replaced whole, only when the adjustment succeeds)")->required();
  sub->add_option("--threads", args->threads, "Solver threads")->capture_default_str();
  AddCommonOptions(sub, common);
  return [args, common]() { return RunAdjust(*args, *common); };
}

}  // namespace

MMBA_REGISTER_COMMAND(15, SetupAdjustCommand);

}  // namespace mmba::app
