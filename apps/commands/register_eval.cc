// mmba register-eval: the two experiments of Kim & Hilton (3DV 2013) on a scene folder.
#include <filesystem>
#include <iostream>

#include "command.h"
#include "mmba/core/logging.h"
#include "mmba/core/output_folder.h"
#include "mmba/registration/cloud/registration_settings.h"
#include "mmba/registration/cloud/scene_evaluation.h"

namespace mmba::app {
namespace {

struct RegisterEvalArgs {
  std::string scene, output;
  std::vector<std::string> methods = registration::SceneEvalOptions().methods;
  std::vector<double> truth_window;
  double success_fraction = 0.1;
  double accurate_m = 0.05;
  bool no_cross_modal = false;
  bool gravity_aligned = false;
  bool no_local_search = false;
  bool no_viewpoints = false;
  std::vector<std::string> cells;
  std::vector<std::string> settings;
  double min_fitness = registration::CloudRegistrationOptions().min_fitness;
};

int RunRegisterEval(const RegisterEvalArgs& args) {
  std::error_code ec;
  if (!std::filesystem::is_directory(args.scene, ec)) {
    throw InputError::Message("--scene", "found '" + args.scene +
                                             "', expected a scene folder (as written by mmba simulate)");
  }
  registration::SceneEvalOptions options;
  options.methods = args.methods;
  options.success_fraction = args.success_fraction;
  options.accurate_m = args.accurate_m;
  options.cross_modal = !args.no_cross_modal;
  options.base.gravity_aligned = args.gravity_aligned;
  options.base.local_search = !args.no_local_search;
  options.base.min_fitness = args.min_fitness;
  options.use_viewpoints = !args.no_viewpoints;
  options.cells = args.cells;
  if (!args.truth_window.empty()) {
    if (args.truth_window.size() != 2 || !(args.truth_window[0] > 0) ||
        !(args.truth_window[1] > 0) || args.truth_window[1] > 180) {
      throw InputError::Message("--truth-window",
                                "expected two positive numbers: metres and degrees (<= 180)");
    }
    options.truth_window_m = args.truth_window[0];
    options.truth_window_deg = args.truth_window[1];
  }
  std::string error;
  if (!options.base.Check(&error)) throw InputError::Message("--min-fitness", error);
  if (!registration::ApplyRegistrationSettings(args.settings, &options.base, &error) ||
      !options.base.Check(&error)) {
    throw InputError::Message("--set", error);
  }
  if (!(args.success_fraction > 0)) {
    throw InputError::Message("--success-fraction", "expected a number > 0");
  }
  const std::string output = args.output.empty() ? args.scene + "/registration_eval" : args.output;
  OutputFolder folder(output, "--output", "mmba register-eval", {{"--scene", args.scene}});
  const registration::SceneEvaluation eval = registration::EvaluateScene(args.scene, options);
  registration::WriteSceneEvaluation(eval, folder.staging().string());
  folder.Commit();
  // The paper's success is the RMS alone (its methods report no failure); a pose the method
  // refused is counted apart, so that "within" never reads as "registered".
  size_t ok = 0, ok_within = 0, refused_within = 0;
  for (const auto& r : eval.rows) {
    ok += r.status == "ok" ? 1 : 0;
    ok_within += r.status == "ok" && r.success ? 1 : 0;
    refused_within += r.status != "ok" && r.success ? 1 : 0;
  }
  std::cout << "register-eval: " << eval.rows.size() << " registrations: " << ok << " ok ("
            << ok_within << " of them within " << eval.success_threshold_m
            << " m of the ground truth), " << eval.rows.size() - ok << " failed ("
            << refused_within << " of them within it all the same); tables in " << output
            << "/tables.md\n";
  return kExitOk;
}

std::function<int()> SetupRegisterEval(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<RegisterEvalArgs>();
  CLI::App* sub = app.add_subcommand(
      "register-eval",
      "Kim & Hilton's experiments on a scene folder (clouds/lidar.ply, clouds/<m>.ply, "
      "clouds/<m>_part.ply, ground_truth.json): every modality to the LiDAR model and the "
      "cross-modal matrix, per method; writes results.csv and tables.md");
  sub->add_option("--scene", args->scene, "scene folder (e.g. written by mmba simulate)")
      ->required();
  sub->add_option("--output", args->output, "output folder (default SCENE/registration_eval): new, empty or written by mmba (replaced whole)");
  sub->add_option("--methods", args->methods,
                  "any of fpfh shot si sc3d mmba mmba-g (robust + --gravity-aligned) from-truth "
                  "(a reference: robust, started at the true pose and searched only near it — "
                  "what the data allow; never a cell's best method)")
      ->capture_default_str();
  sub->add_option("--truth-window", args->truth_window,
                  "from-truth: search window around the truth, metres and degrees (default 0.5 5)")
      ->expected(2);
  sub->add_option("--success-fraction", args->success_fraction,
                  "success: RMS < this × scene extent (paper: 3 m / 30 m)")
      ->capture_default_str();
  sub->add_option("--accurate", args->accurate_m, "accurate: RMS below this (m)")
      ->capture_default_str();
  sub->add_flag("--no-cross-modal", args->no_cross_modal, "experiment I only");
  sub->add_flag("--gravity-aligned", args->gravity_aligned, "clouds are levelled (z up)");
  sub->add_flag("--no-local-search", args->no_local_search,
                "robust pipeline: do not move an unresolved best pose along the directions it "
                "slides in");
  sub->add_option("--min-fitness", args->min_fitness,
                  "robust pipeline: fraction of the source that must fit the target (0..1]")
      ->capture_default_str();
  sub->add_option("--cells", args->cells,
                  "run only these cells, each SOURCE:TARGET (e.g. spherical_stereo_part:lidar)");
  sub->add_option("--set", args->settings,
                  "NAME=VALUE ...: a setting of the registration pipeline for every method, as "
                  "register-cloud --set (mmba register-cloud --help lists them)");
  sub->add_flag("--no-viewpoints", args->no_viewpoints,
                "ignore clouds/<m>.viewpoints.txt (no free-space test)");
  AddCommonOptions(sub, common);
  return [args] { return RunRegisterEval(*args); };
}

}  // namespace

MMBA_REGISTER_COMMAND(51, SetupRegisterEval);

}  // namespace mmba::app
