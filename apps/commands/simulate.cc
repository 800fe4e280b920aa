// mmba simulate: a whole survey of a scene with exact ground truth (mmba/sim/simulate.h).
#include <filesystem>
#include <iostream>

#include "command.h"
#include "mmba/core/logging.h"
#include "mmba/core/output_folder.h"
#include "mmba/sim/simulate.h"

namespace mmba::app {
namespace {
namespace fs = std::filesystem;

struct SimulateArgs {
  std::string scene = "gate";
  std::string out;
  int64_t seed = -1;
  std::string preset;
  int threads = 2;
  int photos = -1;
};

int RunSimulate(const SimulateArgs& args) {
  sim::SimulateOptions options;
  const std::string lower = [&] {
    std::string s = args.scene;
    for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
  }();
  const auto ends_with = [&](const std::string& suffix) {
    return lower.size() >= suffix.size() && lower.compare(lower.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (!args.preset.empty() && !options.ApplyPreset(args.preset)) {
    throw InputError::Message("--preset", "found '" + args.preset + "', expected small, full or drive");
  }
  if (args.scene == "gate" || args.scene == "cathedral") {
    options.scene = args.scene;
  } else if (ends_with(".yaml") || ends_with(".yml")) {
    sim::ReadSceneFile(args.scene, &options);
  } else if (ends_with(".obj") || ends_with(".ply")) {
    if (!fs::exists(args.scene)) throw InputError::Message(args.scene, "mesh file not found");
    options.scene = args.scene;
    options.mesh_path = args.scene;
  } else {
    throw InputError::Message("--scene", "found '" + args.scene +
                                             "', expected gate, cathedral, a .yaml scene file or a .obj/.ply mesh");
  }
  // Command-line values override the scene file.
  if (!args.preset.empty() && options.preset != args.preset) options.ApplyPreset(args.preset);
  if (args.seed >= 0) options.seed = static_cast<uint64_t>(args.seed);
  options.threads = args.threads;
  if (args.photos >= 0) options.photos.count = args.photos;
  const bool scene_is_a_file = args.scene != "gate" && args.scene != "cathedral";
  OutputFolder output(args.out, "--output", "mmba simulate",
                      {{"--scene", scene_is_a_file ? args.scene : std::string()}, {"the scene's mesh", options.mesh_path}});
  sim::SimulateResult result = sim::Simulate(options, output.staging().string());
  output.Commit();
  result.out_dir = args.out;
  if (GetVerbosity() != Verbosity::kQuiet) spdlog::info("{}", result.BriefReport());
  std::cout << result.BriefReport() << "\n";
  return kExitOk;
}

std::function<int()> SetupSimulate(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* sub = app.add_subcommand(
      "simulate",
      "Simulate a survey with exact ground truth: photos, spherical stereo pairs, a Ladybug-style rig, "
      "static and mobile LiDAR, a total-station network and GNSS, reconstruction-like clouds");
  sub->add_option("--scene", args->scene, "gate | cathedral | FILE.yaml (scene file) | FILE.obj/.ply (mesh)")
      ->capture_default_str();
  sub->add_option("--output,--out", args->out, "Output folder: new, empty or written by mmba (replaced whole)")->required();
  sub->add_option("--seed", args->seed, "Random seed (same seed, same bytes); default 1 or the scene file's");
  sub->add_option("--preset", args->preset, "small (default, < 1 min on 2 cores) | full (paper-sized) | drive (100 m, 200 rig frames, >= 50 M mobile LiDAR points)");
  sub->add_option("--threads", args->threads, "Worker threads")->capture_default_str();
  sub->add_option("--photos", args->photos, "Number of photos (default 30)");
  AddCommonOptions(sub, common);
  return [args] { return RunSimulate(*args); };
}

}  // namespace

MMBA_REGISTER_COMMAND(80, SetupSimulate);

}  // namespace mmba::app
