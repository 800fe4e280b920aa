// mmba register-cloud: feature-based rigid registration of two point clouds.
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/cloud/feature_registration.h"
#include "mmba/registration/cloud/registration_settings.h"
#include "mmba/registration/cloud/scale_trial_json.h"
#include "mmba/registration/cloud/scene_evaluation.h"
#include "mmba/core/version.h"
#include "registration_json.h"

namespace mmba::app {
namespace {

struct RegisterCloudArgs {
  std::string source, target, output, error_map;
  std::string source_viewpoints, target_viewpoints;
  std::string descriptor = "auto";
  double normal_radius_m = 0.0, support_radius_m = 0.0;
  std::string normal_orientation = "auto";
  bool gravity_aligned = false;
  std::vector<double> search_window;
  std::vector<double> up = {0.0, 0.0, 1.0};
  bool no_icp = false;
  bool no_intensity = false;
  bool no_local_search = false;
  bool keep_blunders = false;
  bool paper = false;
  bool skip_invalid = false;
  double error_map_max_m = std::numeric_limits<double>::quiet_NaN();  // NaN: not given
  bool error_map_max_given = false;  ///< --error-map-max on the command line (a NaN given is refused)
  uint64_t seed = 42;
  double min_fitness = registration::CloudRegistrationOptions().min_fitness;
  std::vector<double> scale_range;
  double scale_step = 1.05;
  std::vector<std::string> settings;  ///< --set NAME=VALUE (registration_settings.h)
};

// Writes the result JSON (--output) and, with --error-map, the error map of a registered
// result, as one AtomicFileSet with the JSON as its index: the JSON goes last and an error map
// of an earlier run is removed when this one has none (a failed registration), so a JSON is
// never beside an error map of another run (a run killed in between leaves no JSON).
void WriteResult(const RegisterCloudArgs& args, const nlohmann::ordered_json& json, const io::PointCloud& error_map,
                 double error_map_max_m) {
  nlohmann::ordered_json recorded = json;
  RecordBuild(&recorded);
  AtomicFileSet files;
  files.Add(args.output, [&](std::ostream& out) { out << recorded.dump(2) << "\n"; });
  if (!args.error_map.empty() && !error_map.empty()) {
    files.Add(
        args.error_map,
        [&](std::ostream& out) {
          io::WritePlyHeader(out, error_map.size(), error_map);
          io::AppendPlyRecords(out, error_map);
        },
        /*binary=*/true);
  } else if (!args.error_map.empty()) {
    files.Remove(args.error_map);
  }
  files.Commit();
  if (!error_map.empty()) spdlog::info("error map {} (blue 0 → red {:.4g} m)", args.error_map, error_map_max_m);
}

// --scale-range: the source in a scale of its own, registered at trial scales
// (RegisterCloudsOverScales); target_from_source is then a similarity [sR | t].
int RunScaleSearch(const RegisterCloudArgs& args, const registration::CloudRegistrationOptions& options,
                   const io::PointCloud& source, const io::PointCloud& target) {
  const registration::ScaleSearchResult result = registration::RegisterCloudsOverScales(
      source, target, options, args.scale_range[0], args.scale_range[1], args.scale_step, 0.0,
      [](size_t done, size_t total, const registration::ScaleTrial& t) {
        spdlog::info("scale {} of {} ({:.4g}): {}", done, total, t.scale, t.status.substr(0, 160));
      });
  nlohmann::ordered_json json;
  json["status"] = result.status;
  json["reason"] = result.reason;
  json["target_from_source"] = TransformIfOk(result.ok(), result.target_from_source);
  json["failed_attempt_target_from_source"] =
      FailedAttempt(result.ok(), !result.trials.empty(), result.target_from_source);
  json["scale"] = result.scale;
  json["fitness"] = result.fitness;
  json["inlier_rmse"] = result.inlier_rmse;
  json["tolerance_m"] = result.tolerance_m;
  json["runtime_seconds"] = {{"total", result.seconds}};
  nlohmann::ordered_json trials = nlohmann::ordered_json::array();
  for (const registration::ScaleTrial& t : result.trials) trials.push_back(registration::ScaleTrialJson(t));
  json["trials"] = trials;
  json["source"] = args.source;
  json["target"] = args.target;
  const double max_m = args.error_map_max_m > 0 ? args.error_map_max_m : 5.0 * result.tolerance_m;
  WriteResult(args, json,
              result.ok() && !args.error_map.empty()
                  ? registration::MakeErrorMap(source, target, result.target_from_source, max_m)
                  : io::PointCloud(),
              max_m);
  std::ostringstream brief;
  brief << result.status << ": scale " << result.scale << ", " << 100 * result.fitness << " % within "
        << result.tolerance_m << " m (RMS " << result.inlier_rmse << " m), " << result.trials.size() << " trial scales, "
        << result.seconds << " s";
  if (!result.ok()) throw CommandFailed("registration failed: " + result.reason);
  std::cout << brief.str() << "\n";
  return kExitOk;
}

// The registration's options from the flags, then --set (the last word); the checks a
// user's flags can fail are named by the flags (options.Check names the fields).
registration::CloudRegistrationOptions OptionsOf(const RegisterCloudArgs& args) {
  registration::CloudRegistrationOptions options;
  if (!registration::ParseDescriptor(args.descriptor, &options.descriptor)) {
    throw InputError::Message("--descriptor", "found '" + args.descriptor +
                                                  "', expected fpfh, shot, si, sc3d or auto");
  }
  if (!registration::ParseNormalOrientation(args.normal_orientation, &options.normal_orientation)) {
    throw InputError::Message("--normal-orientation",
                              "found '" + args.normal_orientation +
                                  "', expected auto, viewpoint, consistent or consistent-turned");
  }
  options.normal_radius_m = args.normal_radius_m;
  options.support_radius_m = args.support_radius_m;
  options.gravity_aligned = args.gravity_aligned;
  if (!args.search_window.empty()) {
    if (args.search_window.size() != 2 || !(args.search_window[0] > 0) || !(args.search_window[1] > 0) ||
        args.search_window[1] > 180) {
      throw InputError::Message("--search-window", "expected two positive numbers: metres and degrees (<= 180)");
    }
    options.search_window_m = args.search_window[0];
    options.search_window_deg = args.search_window[1];
  }
  if (args.up.size() != 3) throw InputError::Message("--up", "expected three numbers x y z");
  Eigen::Vector3d up(args.up[0], args.up[1], args.up[2]);
  if (!(up.norm() > 0)) throw InputError::Message("--up", "expected a non-zero vector");
  options.up = up.normalized();
  options.icp = !args.no_icp;
  options.intensity_test = !args.no_intensity;
  options.local_search = !args.no_local_search;
  options.paper_only = args.paper;
  options.remove_blunders = !args.keep_blunders;
  options.seed = args.seed;
  options.min_fitness = args.min_fitness;
  if (!args.source_viewpoints.empty()) {
    options.source_viewpoints = registration::ReadViewpoints(args.source_viewpoints);
  }
  if (!args.target_viewpoints.empty()) {
    options.target_viewpoints = registration::ReadViewpoints(args.target_viewpoints);
  }
  // The checks a user's flags can fail, named by the flags (options.Check names the fields).
  if (args.normal_radius_m > 0 && args.support_radius_m > 0 &&
      args.support_radius_m < args.normal_radius_m) {
    std::ostringstream what;
    what << "found " << args.support_radius_m << ", expected >= --normal-radius "
         << args.normal_radius_m << " (descriptors are computed over at least the normals' "
         << "neighbourhood)";
    throw InputError::Message("--support-radius", what.str());
  }
  const auto found = [](double v) {
    std::ostringstream s;
    s << "found " << v;
    return s.str();
  };
  if (!(args.min_fitness > 0 && args.min_fitness <= 1)) {
    throw InputError::Message("--min-fitness", found(args.min_fitness) + ", expected a fraction in (0, 1]");
  }
  if (args.error_map_max_given && !(args.error_map_max_m > 0 && std::isfinite(args.error_map_max_m))) {
    throw InputError::Message("--error-map-max", found(args.error_map_max_m) + ", expected metres > 0");
  }
  // --set NAME=VALUE: any other setting of the pipeline (after the flags, so it has the last
  // word).
  std::string problem;
  if (!registration::ApplyRegistrationSettings(args.settings, &options, &problem)) {
    throw InputError::Message("--set", problem);
  }
  std::string error;
  if (!options.Check(&error)) throw InputError::Message("options", error);
  if (!args.scale_range.empty() &&
      (args.scale_range.size() != 2 || !(args.scale_range[0] > 0) || !(args.scale_range[1] >= args.scale_range[0]) ||
       !(args.scale_range[1] <= 1e6))) {
    throw InputError::Message("--scale-range", "expected MIN MAX with 0 < MIN <= MAX <= 1e6 (target units per source unit)");
  }
  if (!(args.scale_step > 1.0) || !(args.scale_step <= 2.0)) {
    throw InputError::Message("--scale-step", "expected a factor in (1, 2]");
  }

  return options;
}

// The cloud `path` given as `option`; a cloud without points (none in the file, or none left
// by --skip-invalid) is bad input.
io::PointCloud ReadCloud(const std::string& option, const std::string& path, const io::ReadOptions& options,
                         io::ReadStats* stats) {
  io::PointCloud cloud = io::ReadPointCloud(path, options, stats);
  if (cloud.empty()) {
    const std::string skipped =
        stats->num_skipped > 0 ? " left (" + std::to_string(stats->num_skipped) + " not finite, skipped)" : "";
    throw InputError::Message(path, "the " + option + " cloud has no points" + skipped +
                                        "; expected a cloud of at least one point");
  }
  return cloud;
}

int RunRegisterCloud(const RegisterCloudArgs& args) {
  RefuseToOverwriteInputs({{"--output", args.output}, {"--error-map", args.error_map}},
                          {{"--source", args.source},
                           {"--target", args.target},
                           {"--source-viewpoints", args.source_viewpoints},
                           {"--target-viewpoints", args.target_viewpoints}});
  const registration::CloudRegistrationOptions options = OptionsOf(args);
  Timer read_timer;
  const std::clock_t read_cpu = std::clock();
  io::ReadOptions read_options;
  read_options.skip_invalid_points = args.skip_invalid;
  io::ReadStats source_stats, target_stats;
  io::PointCloud source, target;
  // A readable cloud with a NaN/Inf point is a failed registration (exit 3, the JSON written
  // with the reason), not unreadable input.
  std::string not_finite;
  try {
    source = ReadCloud("--source", args.source, read_options, &source_stats);
    target = ReadCloud("--target", args.target, read_options, &target_stats);
  } catch (const NonFiniteInput& e) {
    not_finite = e.what();
  }
  const double read_seconds = read_timer.ElapsedSeconds();
  const std::clock_t read_cpu_end = std::clock();
  registration::CloudRegistrationResult result;
  if (!not_finite.empty()) {
    result.status = "failed";
    result.reason = "a point is not finite: " + not_finite;
  } else {
    spdlog::info("read {} ({}, {} points, {} skipped) and {} ({}, {} points, {} skipped)",
                 args.source, source_stats.format, source.size(), source_stats.num_skipped,
                 args.target, target_stats.format, target.size(), target_stats.num_skipped);
    if (!args.scale_range.empty()) return RunScaleSearch(args, options, source, target);
    result = registration::RegisterClouds(source, target, options);
    result.runtime.insert(result.runtime.begin(),
                          {"read", read_seconds,
                           static_cast<double>(read_cpu_end - read_cpu) / CLOCKS_PER_SEC});
  }

  nlohmann::ordered_json json = RegistrationJson(result);
  json["source"] = args.source;
  json["target"] = args.target;
  const double max_m = args.error_map_max_m > 0 ? args.error_map_max_m : 5.0 * result.point_spacing_m;
  WriteResult(args, json,
              result.ok() && !args.error_map.empty()
                  ? registration::MakeErrorMap(source, target, result.target_from_source, max_m)
                  : io::PointCloud(),
              max_m);
  // The summary once: on stdout when registered; in the log before the failure's message.
  if (!result.ok()) {
    if (not_finite.empty()) spdlog::info("{}", result.BriefReport());
    throw CommandFailed("registration failed: " + result.reason);
  }
  std::cout << result.BriefReport() << "\n";
  return kExitOk;
}

// A length option: a number >= 0 (0 = derived from the measured point spacing).
const CLI::Validator kLength(
    [](std::string& value) -> std::string {
      char* end = nullptr;
      const double v = std::strtod(value.c_str(), &end);
      if (end == value.c_str() || *end != '\0' || !(v >= 0) || !std::isfinite(v)) {
        return "found '" + value + "', expected a length in metres >= 0 (0: from the spacing)";
      }
      return std::string();
    },
    "M>=0");

std::function<int()> SetupRegisterCloud(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<RegisterCloudArgs>();
  CLI::App* sub = app.add_subcommand(
      "register-cloud",
      "Register a source point cloud onto a target (Kim & Hilton 3DV 2013 pipeline + robust "
      "hypotheses); writes target_from_source as JSON. Exit 0 ok, 3 failed, 2 bad input.");
  sub->add_option("--source", args->source, "source cloud (.ply .pcd .las .xyz .bin)")
      ->required();
  sub->add_option("--target", args->target, "target cloud (the reference)")->required();
  sub->add_option("--output", args->output, "result JSON")->required();
  sub->add_option("--descriptor", args->descriptor, "fpfh | shot | si | sc3d | auto")
      ->capture_default_str();
  sub->add_option("--normal-radius", args->normal_radius_m,
                  "R_n in metres (default 4 × measured point spacing)")
      ->check(kLength);
  sub->add_option("--support-radius", args->support_radius_m,
                  "R_s in metres (default 12 × measured point spacing)")
      ->check(kLength);
  sub->add_option("--normal-orientation", args->normal_orientation,
                  "sign of estimated normals: viewpoint (towards each cloud's origin, or its "
                  "--*-viewpoints), consistent (over the neighbour graph, Hoppe et al. 1992), "
                  "consistent-turned (and the source's turned), auto (viewpoint; when no pose "
                  "fits, retried consistent-turned, then consistent; not with --scale-range)")
      ->capture_default_str();
  sub->add_flag("--gravity-aligned", args->gravity_aligned,
                "both clouds are levelled: search the rotation about --up only");
  sub->add_option("--up", args->up, "up direction x y z (default 0 0 1)")->expected(3);
  sub->add_option("--search-window", args->search_window,
                  "M DEG: the source is already within M metres and DEG degrees of its place (an "
                  "approximate pose applied): the identity is a hypothesis, poses outside are dropped")
      ->expected(2);
  sub->add_flag("--no-icp", args->no_icp, "skip the ICP refinement");
  sub->add_flag("--no-local-search", args->no_local_search,
                "do not move an unresolved best pose along the directions it slides in");
  sub->add_flag("--no-intensity", args->no_intensity,
                "geometry only: do not let the clouds' intensity (or colour) settle a tie "
                "between pseudo-symmetric poses");
  sub->add_flag("--keep-blunders", args->keep_blunders,
                "keep scattered blunders (default: points with fewer than 4 others within about "
                "3 times the cloud's 90th-percentile spacing and off the surface of their "
                "neighbours are removed first when they are >= 1 % of a cloud)");
  sub->add_flag("--paper", args->paper,
                "the paper's pipeline only: best SAC-IA hypothesis + ICP, no verification "
                "(status \"unverified\", exit 3)");
  sub->add_flag("--skip-invalid", args->skip_invalid,
                "drop points with NaN/Inf coordinates while reading (default: error)");
  sub->add_option("--error-map", args->error_map,
                  "PLY of the registered source coloured by distance to the target");
  sub->add_option("--error-map-max", args->error_map_max_m,
                  "distance shown red in metres (> 0; default 5 × point spacing)");
  sub->add_option("--seed", args->seed, "random seed")->capture_default_str();
  sub->add_option("--set", args->settings,
                  "NAME=VALUE ...: any other setting of the pipeline (F_t, keypoints, SAC-IA, ICP, the "
                  "checks); the names are listed below");
  sub->footer(registration::CloudRegistrationSettingsTable().Footer(
      "Settings for --set NAME=VALUE (default; accepted values):"));
  sub->add_option("--min-fitness", args->min_fitness,
                  "fraction of the source that must lie on the target for \"ok\", in (0, 1]")
      ->capture_default_str();
  sub->add_option("--scale-range", args->scale_range,
                  "MIN MAX: the source is in a scale of its own (an SfM cloud): registered at trial scales "
                  "MIN·step^k (target units per source unit), each ok refined as a similarity; "
                  "target_from_source is then [sR | t]")
      ->expected(2);
  sub->add_option("--scale-step", args->scale_step, "factor between trial scales (a rigid registration holds to about ±3–5 %)")
      ->capture_default_str();
  sub->add_option("--source-viewpoints", args->source_viewpoints,
                  "text file of the source's sensor positions in its frame (x y z a line): "
                  "enables the free-space (visibility) test");
  sub->add_option("--target-viewpoints", args->target_viewpoints,
                  "the same for the target");
  AddCommonOptions(sub, common);
  return [args, sub] {
    args->error_map_max_given = sub->count("--error-map-max") > 0;
    return RunRegisterCloud(*args);
  };
}

}  // namespace

MMBA_REGISTER_COMMAND(50, SetupRegisterCloud);

}  // namespace mmba::app
