// mmba ba: bundle adjustment of a COLMAP sparse model.
#include <filesystem>
#include <iostream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/logging.h"
#include "mmba/core/output_folder.h"
#include "mmba/core/progress.h"
#include "mmba/io/colmap_model.h"
#include "mmba/problem/colmap_scene.h"
#include "mmba/problem/solve.h"
#include "mmba/core/version.h"

namespace mmba::app {
namespace {
namespace fs = std::filesystem;

struct BaArgs {
  std::string input;
  std::string output;
  std::string loss = "none";
  double loss_scale_px = 1.0;
  double sigma_px = 1.0;
  bool refine_focal = false;
  bool refine_principal_point = false;
  bool refine_extra = false;
  int max_iterations = 100;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::string json;
  std::vector<uint64_t> fix_images;
  std::vector<uint64_t> gauge_images;
};

nlohmann::json GroupJson(const GroupEvaluation& e) {
  return {{"name", e.name},
          {"unit", e.unit},
          {"observations", e.num_observations},
          {"skipped", e.num_skipped},
          {"rms", e.rms_units},
          {"mean", e.mean_norm_units},
          {"outliers", e.num_outliers},
          {"outlier_threshold_sigma", e.outlier_threshold}};
}

/// The robust loss of --loss/--loss-scale in σ units (σ = --sigma-px); throws InputError
/// naming the flag.
LossOptions BaLoss(const BaArgs& args) {
  LossOptions loss;
  if (!ParseLossType(args.loss, &loss.type)) {
    throw InputError::Message("--loss", "found '" + args.loss +
                                            "', expected none, huber, cauchy or soft_l1");
  }
  // σ = sigma_px, so a loss scale in pixels is scale/σ in σ units.
  loss.scale = args.loss_scale_px / args.sigma_px;
  std::string error;
  if (!(args.sigma_px > 0)) {
    throw InputError::Message("--sigma-px", "found " + std::to_string(args.sigma_px) +
                                                ", expected a number > 0");
  }
  if (!loss.Check(&error)) throw InputError::Message("--loss-scale", error);
  return loss;
}

SolveOptions BaSolveOptions(const BaArgs& args) {
  SolveOptions solve_options;
  solve_options.max_iterations = args.max_iterations;
  solve_options.num_threads = args.threads;
  solve_options.log_progress = GetVerbosity() != Verbosity::kQuiet;
  std::string error;
  if (!solve_options.Check(&error)) throw InputError::Message("options", error);
  return solve_options;
}

/// The files of the model in --input (text and binary), which no output may overwrite.
std::vector<FileArg> BaModelFiles(const std::string& input) {
  std::vector<FileArg> model_files;
  for (const char* name : {"cameras", "images", "points3D"}) {
    for (const char* ext : {".txt", ".bin"}) {
      model_files.push_back({"--input", (fs::path(input) / (std::string(name) + ext)).string()});
    }
  }
  return model_files;
}

/// --fix-images, else two poses (--gauge-images or the two smallest image ids).
GaugeOptions BaGauge(const BaArgs& args) {
  GaugeOptions gauge;
  if (!args.fix_images.empty()) {
    gauge.kind = GaugeOptions::Kind::kFixedImages;
    for (uint64_t id : args.fix_images) gauge.fixed_images.push_back(ImageId(id));
  } else {
    gauge.kind = GaugeOptions::Kind::kTwoPoses;
    if (!args.gauge_images.empty()) {
      if (args.gauge_images.size() != 2) {
        throw InputError::Message("--gauge-images", "expected exactly two image ids");
      }
      gauge.first = ImageId(args.gauge_images[0]);
      gauge.second = ImageId(args.gauge_images[1]);
    }
  }
  return gauge;
}

/// The --json report; wall_seconds is 0 until the end of the run.
nlohmann::json BaReportJson(const BaArgs& args, const SolveResult& result,
                            const io::ColmapModel& model, io::ColmapFormat format,
                            const LossOptions& loss) {
  const GroupEvaluation& before = result.before.at(0);
  const GroupEvaluation& after = result.after.at(0);
  return {
      {"status", result.status},
      {"reason", result.reason},
      {"input", args.input},
      {"output", args.output},
      {"format", format == io::ColmapFormat::kText ? "text" : "binary"},
      {"num_cameras", model.cameras.size()},
      {"num_images", model.images.size()},
      {"num_points", model.points3D.size()},
      {"num_observations", after.num_observations},
      {"num_skipped_observations", after.num_skipped},
      {"initial_rms_px", before.rms_units},
      {"final_rms_px", after.rms_units},
      {"initial_mean_px", before.mean_norm_units},
      {"final_mean_px", after.mean_norm_units},
      {"initial_cost", result.initial_cost},
      {"final_cost", result.final_cost},
      {"iterations", result.iterations},
      {"solve_seconds", result.solve_seconds},
      {"wall_seconds", 0.0},
      {"gauge", result.gauge},
      {"loss", loss.ToString()},
      {"refine_focal", args.refine_focal},
      {"refine_principal_point", args.refine_principal_point},
      {"refine_extra", args.refine_extra},
      {"groups", {GroupJson(after)}},
  };
}

/// The summary on stdout: status, RMS before and after, gauge and the files written.
void PrintBaSummary(const BaArgs& args, const SolveResult& result, double wall_seconds,
                    bool written) {
  const GroupEvaluation& before = result.before.at(0);
  const GroupEvaluation& after = result.after.at(0);
  std::ostringstream summary;
  summary << "mmba ba: " << result.status << " after " << result.iterations
          << " iterations, " << wall_seconds << " s\n"
          << "  RMS reprojection error: " << before.rms_units << " px -> " << after.rms_units
          << " px (" << after.num_observations << " observations";
  if (after.num_skipped) summary << ", " << after.num_skipped << " skipped";
  summary << ")\n  gauge: " << result.gauge << "\n";
  if (written) summary << "  adjusted model: " << args.output << "\n";
  if (!args.json.empty()) summary << "  report: " << args.json << "\n";
  std::cout << summary.str();
}

int RunBa(const BaArgs& args) {
  Timer wall;
  const LossOptions loss = BaLoss(args);
  const SolveOptions solve_options = BaSolveOptions(args);
  RefuseToOverwriteInputs({{"--json", args.json}}, BaModelFiles(args.input));
  OutputFolder output(args.output, "--output", "mmba ba", {{"--input", args.input}});

  io::ColmapFormat format;
  io::ColmapModel model = io::ReadColmapModel(args.input, &format);
  spdlog::info("read {} ({}): {} cameras, {} images, {} points, {} observations", args.input,
               format == io::ColmapFormat::kText ? "text" : "binary", model.cameras.size(),
               model.images.size(), model.points3D.size(), model.NumObservations());

  Scene scene;
  std::vector<ReprojectionObservation> observations =
      SceneFromColmap(model, args.sigma_px, &scene);
  if (observations.empty()) {
    throw InputError::Message(args.input, "the model has no observations (no 3-D point with a "
                                          "track): nothing to adjust");
  }
  ProblemBuilder builder(&scene);
  const FactorGroup& group =
      builder.AddGroup(std::make_unique<ReprojectionGroup>(std::move(observations), loss));
  ParameterOptions parameters;
  parameters.refine_focal = args.refine_focal;
  parameters.refine_principal_point = args.refine_principal_point;
  parameters.refine_extra = args.refine_extra;
  builder.set_parameter_options(parameters);
  builder.set_gauge(BaGauge(args));
  builder.Build();
  if (group.residual_blocks().empty()) {
    throw CommandFailed("none of the " + std::to_string(group.num_skipped()) +
                        " observations can be used (points behind their cameras at the "
                        "start): no model written");
  }

  SolveResult result = Solve(builder, solve_options);
  nlohmann::json json = BaReportJson(args, result, model, format, loss);
  const bool written = result.converged;
  if (written) {
    UpdateColmapFromScene(scene, &model);
    io::WriteColmapModel(model, output.staging().string(), format);
    output.Commit();  // before --json, which may name a file inside the output folder
  }
  json["wall_seconds"] = wall.ElapsedSeconds();
  json["model_written"] = written;
  RecordBuild(&json);
  if (!args.json.empty()) {
    WriteFileAtomically(args.json, [&](std::ostream& out) { out << json.dump(2) << "\n"; });
  }
  PrintBaSummary(args, result, json["wall_seconds"].get<double>(), written);
  if (!written) {
    throw CommandFailed("adjustment " + result.status + ": " + result.reason +
                        " — no model written" +
                        (result.status == "no_convergence"
                             ? " (raise --max-iterations, or check the input)"
                             : ""));
  }
  return kExitOk;
}

std::function<int()> SetupBa(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<BaArgs>();
  CLI::App* sub = app.add_subcommand(
      "ba", "Bundle-adjust a COLMAP sparse model (text or binary, detected); writes the "
            "adjusted model in the same format");
  sub->add_option("input,--input", args->input, "COLMAP model folder (cameras/images/points3D), as --input or the first argument")
      ->required();
  sub->add_option("--output", args->output, "Folder for the adjusted model: new, empty or written by mmba (replaced whole)")
      ->required();
  sub->add_option("--loss", args->loss, "Robust loss: none|huber|cauchy|soft_l1")
      ->capture_default_str();
  sub->add_option("--loss-scale", args->loss_scale_px, "Robust loss scale in pixels")
      ->capture_default_str();
  sub->add_option("--sigma-px", args->sigma_px, "A-priori sigma of image coordinates, px")
      ->capture_default_str();
  sub->add_flag("--refine-focal", args->refine_focal, "Estimate focal length(s)");
  sub->add_flag("--refine-principal-point", args->refine_principal_point,
                "Estimate the principal point");
  sub->add_flag("--refine-extra", args->refine_extra,
                "Estimate the remaining (distortion) parameters");
  sub->add_option("--max-iterations", args->max_iterations, "Levenberg-Marquardt iterations")
      ->capture_default_str();
  sub->add_option("--threads", args->threads, "Threads")->capture_default_str();
  sub->add_option("--json", args->json, "Write a JSON report to this file");
  sub->add_option("--fix-images", args->fix_images,
                  "Gauge: hold the poses of these image ids fixed (instead of two-pose)")
      ->delimiter(',');
  sub->add_option("--gauge-images", args->gauge_images,
                  "Gauge: FIRST,SECOND — pose of FIRST fixed, distance FIRST-SECOND fixed "
                  "(default: the two smallest image ids)")
      ->delimiter(',');
  AddCommonOptions(sub, common);
  return [args] { return RunBa(*args); };
}

}  // namespace

MMBA_REGISTER_COMMAND(10, SetupBa);

}  // namespace mmba::app
