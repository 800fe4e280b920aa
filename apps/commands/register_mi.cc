// mmba register-mi: mutual-information registration of LiDAR to images and panoramas
// (Wang, Ferrie & Macfarlane, CVPRW 2012), one frame or a rig over many frames (issue 6).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/io/kitti.h"
#include "mmba/io/point_cloud.h"
#include "mmba/io/text_reader.h"
#include "mmba/io/trajectory.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/result_json.h"
#include "mmba/core/version.h"

namespace mmba::app {
namespace {
namespace fs = std::filesystem;
namespace mi = registration::mi;

struct RegisterMiArgs {
  std::vector<std::string> lidar;
  std::vector<std::string> image;
  std::string list;
  std::string camera;
  std::string kitti_calib;
  int kitti_camera = 2;
  std::string rig;
  std::string initial;
  std::string metric = "nmi";
  std::string representation = "intensity";
  std::string smoothing = "bspline";
  std::string region = "overlap";
  bool region_given = false;          ///< --region on the command line (not the default)
  bool representation_given = false;  ///< --representation on the command line
  // auto: perspective cuts of a panorama (EQUIRECTANGULAR camera), the image itself otherwise.
  std::string view = "auto";
  // The cuts that see the most LiDAR: on the simulated panoramas better than the paper's -90,90
  // (bench/RESULTS.md, register-mi on simulated panoramas: 70 against 56 ok of 80).
  std::string headings = "auto";
  int bins = 64;
  int pyramid_levels = 3;
  double bound_m = 0.5;
  double bound_deg = 3.0;
  double simplex = 1.0;
  int max_iterations = 200;
  int pyramid_paths = mi::RegistrationOptions().pyramid_paths;
  bool pyramid_paths_adaptive = mi::RegistrationOptions().pyramid_paths_adaptive;
  int coarse_starts = mi::RegistrationOptions().coarse_starts;
  int coarse_candidates = mi::RegistrationOptions().coarse_candidates;
  double coarse_spread = mi::RegistrationOptions().coarse_start_spread;
  int restarts = 3;
  int polish_rounds = 2;
  int restart_level = 1;
  int threads = 2;
  double restart_tolerance_px = 1.0;
  double max_sigma_px = 0.5;
  double max_calibrated_sigma_px = 1.0;
  bool halves = true;
  bool whole_image_checks = true;
  bool weak_direction_scan = true;
  bool all_checks = false;
  bool point_samples = true;
  int sample_block_px = 8;
  int split_level = 0;
  double split_tolerance_px = 1.0;
  bool calibrate_covariance = true;
  bool covariance_pixel_floor = true;
  int effective_sample_lag = 8;
  double point_radius_m = 0.03;
  int max_point_radius_px = 2;
  double max_range_m = 200.0;
  bool surface_classes = false;
  int orientation_classes = -1;  ///< -1: kDefaultOrientationSectors with intensity, else 0
  double surface_voxel_m = 0.5;
  std::string incidence_correction = "auto";
  std::vector<double> scanner_origin;
  std::string trajectory;
  std::string lidar_mount;
  std::vector<double> perturb;
  std::string probe;
  int probe_level = 0;
  std::string output;
  std::string lidar_image;
  std::string overlay;
};

nlohmann::json OffsetJson(const mi::PixelOffsetStats& s) {
  return {{"points", s.points},
          {"median_px", s.median_px},
          {"mean_px", s.mean_px},
          {"p90_px", s.p90_px},
          {"max_px", s.max_px}};
}

// A number option must be finite: CLI11 reads "nan" and "inf" as numbers, and a NaN passes
// every "> 0" check written as a negated "<= 0".
void RequireFinite(const std::string& option, const std::vector<double>& values) {
  for (const double v : values) {
    if (!std::isfinite(v)) {
      std::ostringstream found;
      found << v;
      throw InputError::Message(option, "found '" + found.str() + "', expected a finite number");
    }
  }
}

int RunRegisterMi(const RegisterMiArgs& args) {
  Timer wall;
  // ---- Options (validated before any reading).
  for (const auto& [option, values] : std::vector<std::pair<const char*, std::vector<double>>>{
           {"--bound-m", {args.bound_m}},
           {"--bound-deg", {args.bound_deg}},
           {"--simplex", {args.simplex}},
           {"--coarse-spread", {args.coarse_spread}},
           {"--restart-tolerance-px", {args.restart_tolerance_px}},
           {"--max-sigma-px", {args.max_sigma_px}},
           {"--max-calibrated-sigma-px", {args.max_calibrated_sigma_px}},
           {"--split-tolerance-px", {args.split_tolerance_px}},
           {"--point-radius-m", {args.point_radius_m}},
           {"--max-range-m", {args.max_range_m}},
           {"--surface-voxel-m", {args.surface_voxel_m}},
           {"--scanner-origin", args.scanner_origin},
           {"--perturb", args.perturb}}) {
    RequireFinite(option, values);
  }
  mi::RegistrationOptions options;
  if (!mi::ParseMetric(args.metric, &options.metric.kind)) {
    throw InputError::Message("--metric", "found '" + args.metric + "', expected mi, nmi or nid");
  }
  if (!mi::ParseRepresentation(args.representation, &options.render.representation)) {
    throw InputError::Message("--representation", "found '" + args.representation +
                                                      "', expected intensity, points or depth");
  }
  if (!mi::ParseSmoothing(args.smoothing, &options.metric.smoothing)) {
    throw InputError::Message("--smoothing", "found '" + args.smoothing +
                                                 "', expected none, parzen or bspline");
  }
  if (!mi::ParseRegion(args.region, &options.metric.region)) {
    throw InputError::Message("--region", "found '" + args.region +
                                              "', expected whole or overlap");
  }
  mi::ViewOptions view_options;
  const bool auto_view = args.view == "auto";  // resolved below, once the camera is known
  if (!auto_view && !mi::ParseViewKind(args.view, &view_options.kind)) {
    throw InputError::Message("--view", "found '" + args.view +
                                            "', expected auto, image, equirect, perspective or cube");
  }
  const bool auto_headings = args.headings == "auto";
  if (!auto_headings) {
    view_options.perspective_yaw_deg.clear();
    std::stringstream list(args.headings);
    for (std::string item; std::getline(list, item, ',');) {
      char* end = nullptr;
      const double yaw = std::strtod(item.c_str(), &end);
      if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(yaw)) {
        throw InputError::Message("--headings", "found '" + args.headings +
                                                    "', expected 'auto' or degrees like -90,90");
      }
      view_options.perspective_yaw_deg.push_back(yaw);
    }
  }
  options.metric.bins = args.bins;
  options.pyramid_levels = args.pyramid_levels;
  options.bound_translation_m = args.bound_m;
  options.bound_rotation_deg = args.bound_deg;
  options.nelder_mead.initial_step = mi::Vector6d::Constant(args.simplex);
  options.nelder_mead.max_iterations = args.max_iterations;
  options.pyramid_paths = args.pyramid_paths;
  options.pyramid_paths_adaptive = args.pyramid_paths_adaptive;
  options.coarse_starts = args.coarse_starts;
  options.coarse_candidates = args.coarse_candidates;
  options.coarse_start_spread = args.coarse_spread;
  options.restarts = args.restarts;
  options.polish_rounds = args.polish_rounds;
  options.restart_level = args.restart_level;
  options.threads = args.threads;
  options.restart_tolerance_px = args.restart_tolerance_px;
  options.max_sigma_px = args.max_sigma_px;
  options.max_calibrated_sigma_px = args.max_calibrated_sigma_px;
  options.split_check = args.halves;
  options.whole_image_checks = args.whole_image_checks;
  options.scan_weak_direction = args.weak_direction_scan;
  options.measure_all_checks = args.all_checks;
  options.point_samples = args.point_samples;
  options.sample_block_px = args.sample_block_px;
  options.split_level = args.split_level;
  options.split_tolerance_px = args.split_tolerance_px;
  options.calibrate_covariance = args.calibrate_covariance;
  options.covariance_pixel_floor = args.covariance_pixel_floor;
  options.effective_sample_max_lag = args.effective_sample_lag;
  options.render.point_radius_m = args.point_radius_m;
  options.render.max_point_radius_px = args.max_point_radius_px;
  options.render.max_range_m = args.max_range_m;
  mi::JobRequest request;
  request.lidar = args.lidar;
  request.image = args.image;
  request.list = args.list;
  request.camera = args.camera;
  request.kitti_calib = args.kitti_calib;
  request.kitti_camera = args.kitti_camera;
  request.rig = args.rig;
  request.initial = args.initial;
  request.perturb = args.perturb;
  request.options = options;
  request.region_given = args.region_given;
  request.representation_given = args.representation_given;
  request.view_auto = auto_view;
  request.view = view_options;
  request.view_name = args.view;
  request.headings_auto = auto_headings;
  request.surface_classes = args.surface_classes;
  request.orientation_classes = args.orientation_classes;
  request.surface_voxel_m = args.surface_voxel_m;
  request.incidence_correction = args.incidence_correction;
  request.scanner_origin = args.scanner_origin;
  request.trajectory = args.trajectory;
  request.lidar_mount = args.lidar_mount;
  const std::vector<mi::FramePaths> paths = mi::ListFrames(request);
  std::vector<FileArg> inputs = {{"--list", args.list},         {"--camera", args.camera},
                                 {"--kitti-calib", args.kitti_calib}, {"--rig", args.rig},
                                 {"--initial", args.initial},     {"--trajectory", args.trajectory},
                                 {"--lidar-mount", args.lidar_mount}};
  for (const mi::FramePaths& frame : paths) {
    inputs.push_back({"--image", frame.image});
    inputs.push_back({"--lidar", frame.lidar});
  }
  RefuseToOverwriteInputs(
      {{"--output", args.output}, {"--lidar-image", args.lidar_image}, {"--overlay", args.overlay}},
      inputs);
  std::optional<OutputFolder> probe_folder;
  if (!args.probe.empty()) probe_folder.emplace(args.probe, "--probe", "mmba register-mi --probe", AsNamedPaths(inputs));
  // ---- Read everything before any work.
  mi::Job job = mi::PrepareJob(request, paths);
  options = job.options;
  const std::string region = job.region_note.empty() ? args.region : "whole";
  const std::string& region_note = job.region_note;
  const int orientation_sectors = job.orientation_sectors;
  const bool rig_mode = job.rig_mode;
  const std::string& view_name = job.view_name;
  const io::RigYaml& rig_yaml = job.rig;
  const std::vector<mi::Frame>& frames = job.frames;
  const std::vector<mi::LidarPoints>& clouds = job.clouds;
  std::vector<std::pair<std::string, std::string>> pairs;
  for (const mi::FramePaths& frame : job.paths) pairs.emplace_back(frame.image, frame.lidar);
  const Rigid3d start = job.start;
  const Rigid3d start_given = job.start_given;
  const Rigid3d reference_local = job.reference;
  const bool have_calibration_pose = job.have_calibration_pose;
  const auto to_given = [&job](const Rigid3d& pose) { return job.ToGiven(pose); };
  const nlohmann::json& clouds_json = job.clouds_json;
  const nlohmann::json& incidence_json = job.incidence_json;
  std::string error;
  // ---- Probe (around the start), then registration.
  if (!args.probe.empty()) {
    mi::RegistrationOptions probe_options = options;
    probe_options.bound_translation_m = std::max(options.bound_translation_m, 2.0);
    probe_options.bound_rotation_deg = std::max(options.bound_rotation_deg, 2.0);
    probe_options.pyramid_levels = std::max(1, args.probe_level + 1);
    if (!probe_options.Check(&error)) throw InputError::Message("--probe-level", error);
    mi::FrameSetEvaluator evaluator(frames, start, probe_options);
    mi::WriteProbe(mi::Probe(evaluator, start, 2.0, 0.1, args.probe_level), probe_folder->staging().string());
    probe_folder->Commit();
    spdlog::info("probe written to {}", args.probe);
  }
  mi::RegistrationResult result;
  if (frames.size() == 1) {
    result = mi::RegisterFrames(frames, start, options);
  } else {
    mi::RigOptions rig;
    rig.registration = options;
    result = mi::RegisterRig(frames, start, rig);
  }
  // ---- Output (poses in the clouds' own frame again).
  const Rigid3d cam_from_local = result.cam_from_lidar;
  result.cam_from_lidar = to_given(result.cam_from_lidar);
  for (mi::RegistrationResult& r : result.frame_results) r.cam_from_lidar = to_given(r.cam_from_lidar);
  nlohmann::json out = mi::ResultToJson(result, options, start_given);
  out["settings"] = {{"metric", args.metric},
                     {"representation", args.representation}, {"view", view_name},
                     {"bins", args.bins},                     {"smoothing", args.smoothing},
                     {"region", region},                      {"pyramid_levels", args.pyramid_levels},
                     {"bound_m", args.bound_m},               {"bound_deg", args.bound_deg},
                     {"pyramid_paths", args.pyramid_paths},   {"pyramid_paths_adaptive", args.pyramid_paths_adaptive},
                     {"whole_image_checks", args.whole_image_checks},
                     {"weak_direction_scan", args.weak_direction_scan},
                     {"all_checks", args.all_checks},         {"point_samples", args.point_samples},
                     {"sample_block_px", args.sample_block_px},
                     {"covariance_pixel_floor", args.covariance_pixel_floor},
                     {"covariance_per_point_samples", options.covariance_per_point_samples},
                     {"surface_classes", args.surface_classes},
                     {"orientation_classes", orientation_sectors},
                     {"surface_voxel_m", args.surface_voxel_m},
                     {"incidence_correction", args.incidence_correction}};
  if (!region_note.empty()) out["settings"]["region_note"] = region_note;
  // Per cloud: points read, and dropped as beyond every camera's range (or not finite).
  out["clouds"] = clouds_json;
  // Per cloud: the fitted exponent of I = rho * cos^k (null: not corrected).
  out["incidence_correction"] = incidence_json;
  if (rig_mode) {
    // The pose is the rig's: rig_from_lidar (the correction about the rig's origin), and each
    // camera's own cam_from_lidar = cam_from_rig · rig_from_lidar.
    for (const char* key : {"cam_from_lidar", "cam_from_lidar_start", "failed_attempt_cam_from_lidar"}) {
      std::string renamed = key;
      renamed.replace(renamed.find("cam_from_lidar"), 14, "rig_from_lidar");
      out[renamed] = out[key];
      out.erase(key);
    }
    out["correction_convention"] =
        "lidar_from_rig' = [Rz(yaw) Ry(pitch) Rx(roll) R | c + t] about the rig's origin, "
        "axes of the LiDAR frame; metres and degrees";
    nlohmann::json cameras = nlohmann::json::array();
    for (size_t k = 0; k < rig_yaml.cameras.size(); ++k) {
      bool used = false;
      for (const mi::Frame& frame : frames) {
        for (const mi::View& view : frame.views) used = used || view.name == rig_yaml.names[k];
      }
      cameras.push_back({{"name", rig_yaml.names[k]},
                         {"used", used},
                         {"cam_from_lidar", result.ok() ? mi::PoseToJson(rig_yaml.cam_from_rig[k] * result.cam_from_lidar)
                                                        : nlohmann::json(nullptr)}});
    }
    out["cameras"] = cameras;
  }
  if (frames.size() > 1) {
    // Each frame by its index (its order in --image/--lidar, then --list), image and cloud;
    // its status in the calibration: used, rejected (with the reason: alone it carried no
    // information, or it disagreed with the others), or not used (the calibration stopped
    // before the frames' agreement was tested); and its own screening registration.
    const auto index_of = [&](const std::string& name) {
      for (size_t i = 0; i < frames.size(); ++i) {
        if (frames[i].name == name) return static_cast<int>(i);
      }
      return -1;
    };
    out["used_frames"] = result.used_frames;
    nlohmann::json rejected = nlohmann::json::array();
    for (const auto& [name, why] : result.rejected_frames) {
      const int i = index_of(name);
      rejected.push_back({{"index", i},
                          {"image", name},
                          {"lidar", i >= 0 ? nlohmann::json(pairs[i].second) : nlohmann::json(nullptr)},
                          {"frame", name},
                          {"reason", why}});
    }
    out["rejected_frames"] = rejected;
    nlohmann::json per_frame = nlohmann::json::array();
    for (size_t i = 0; i < result.frame_results.size(); ++i) {
      const mi::RegistrationResult& r = result.frame_results[i];
      std::string status = "not used", reason = result.reason;
      for (const auto& [name, why] : result.rejected_frames) {
        if (name == frames[i].name) status = "rejected", reason = why;
      }
      for (const std::string& name : result.used_frames) {
        if (name == frames[i].name) status = "used", reason.clear();
      }
      per_frame.push_back({{"index", i},
                           {"image", pairs[i].first},
                           {"lidar", pairs[i].second},
                           {"frame", frames[i].name},
                           {"status", status},
                           {"reason", reason},
                           {"screening", {{"status", r.status}, {"reason", r.reason}}},
                           {"correction", mi::CorrectionToJson(r.correction)}});
    }
    out["frames"] = per_frame;
  }
  // How far the start and the result put the LiDAR points from where `reference` puts them,
  // per view of the first frame.
  const auto offsets_against = [&](const Rigid3d& reference) {
    nlohmann::json offsets = nlohmann::json::array();
    for (const mi::View& view : frames[0].views) {
      offsets.push_back(
          {{"view", view.name},
           {"before", OffsetJson(mi::PixelOffsets(clouds[0], view, reference, start, options.render))},
           {"after", OffsetJson(mi::PixelOffsets(clouds[0], view, reference, cam_from_local, options.render))}});
    }
    return offsets;
  };
  if (!args.perturb.empty()) {  // against the unperturbed start
    out["perturbation"] = mi::CorrectionToJson(Eigen::Map<const mi::Vector6d>(args.perturb.data()));
    out["pixel_offset_vs_reference"] = offsets_against(reference_local);
  }
  if (!args.initial.empty() && have_calibration_pose) {
    // A start from --initial while the calibration file (or camera/rig YAML) holds its own
    // pose: the check against the calibration, also for a start not made by --perturb.
    out["pixel_offset_vs_calibration"] = offsets_against(job.calibration);
  }
  RecordBuild(&out);
  AtomicFileSet files;
  files.Add(args.output, [&](std::ostream& stream) { stream << out.dump(2) << "\n"; });
  if (!args.lidar_image.empty()) {
    // OUT.json is the index of this run's files (core/atomic_file.h): the earlier one goes
    // before a partner written on its own, so it never stands beside this run's image.
    std::error_code ec;
    if (!fs::remove(args.output, ec) && ec) {
      throw std::runtime_error("cannot remove the earlier '" + args.output + "': " + ec.message());
    }
    mi::LidarImage rendered;
    mi::RenderLidarImage(clouds[0], frames[0].views[0], cam_from_local, options.render,
                         &rendered);
    mi::WriteGrayPng(mi::LidarImageToGray(rendered), args.lidar_image);
  }
  if (!args.overlay.empty()) {
    const mi::View& view = frames[0].views[0];
    mi::LidarImage at_start, at_result;
    mi::RenderLidarImage(clouds[0], view, start, options.render, &at_start);
    mi::RenderLidarImage(clouds[0], view, cam_from_local, options.render, &at_result);
    const std::vector<uint8_t> png = mi::EncodeRangeOverlayPng(
        view.image, {&at_start, &at_result},
        {"start (" + view.name + ")", "result: " + result.status});
    files.Add(
        args.overlay,
        [png](std::ostream& stream) {
          stream.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
        },
        /*binary=*/true);
  }
  files.Commit();
  spdlog::info("wrote {} ({:.2f} s)", args.output, wall.ElapsedSeconds());
  // The summary on stdout when registered; a failure on stderr, as register-cloud's.
  if (!result.ok()) throw CommandFailed(result.BriefReport());
  std::cout << result.BriefReport() << std::endl;
  return kExitOk;
}

std::function<int()> SetupRegisterMi(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<RegisterMiArgs>();
  CLI::App* sub = app.add_subcommand(
      "register-mi",
      "Register LiDAR to images/panoramas by maximising mutual information (Wang et al. "
      "2012): pose correction with covariance; several frames give a rig calibration");
  sub->add_option("--lidar", args->lidar, "Cloud (.bin KITTI, .ply, .pcd, .las, .xyz); "
                                          "repeat with --image for several frames");
  sub->add_option("--image", args->image, "Image or equirectangular panorama; repeatable");
  sub->add_option("--list", args->list, "Text file of frames: IMAGE LIDAR per line");
  sub->add_option("--camera", args->camera, "Camera YAML (calib/README.md)");
  sub->add_option("--kitti-calib", args->kitti_calib, "KITTI calibration file (camera 2)");
  sub->add_option("--rig", args->rig,
                  "Rig YAML (calib/README.md camera_rig, optional rig_from_lidar): each --image is "
                  "a pattern with {camera}; the pose is rig_from_lidar");
  sub->add_option("--kitti-camera", args->kitti_camera, "KITTI camera index 0..3")
      ->capture_default_str();
  sub->add_option("--initial", args->initial,
                  "POSE.json with cam_from_lidar (with --rig: rig_from_lidar), 4x4 row-major");
  sub->add_option("--metric", args->metric, "mi | nmi | nid")->capture_default_str();
  sub->add_option("--representation", args->representation, "intensity | points | depth")
      ->capture_default_str();
  sub->add_option("--bins", args->bins, "Histogram bins per axis (paper: 256)")
      ->capture_default_str();
  sub->add_option("--smoothing", args->smoothing, "none | parzen | bspline")
      ->capture_default_str();
  sub->add_option("--region", args->region, "whole | overlap")->capture_default_str();
  sub->add_option("--view", args->view,
                  "auto (a panorama: perspective; any other image: image) | image (= equirect for a "
                  "panorama) | perspective | cube")
      ->capture_default_str();
  sub->add_option("--headings", args->headings,
                  "Perspective cuts: 'auto' = the two 90-degree cuts (at least 90 degrees apart, of 8 "
                  "headings) that see the most LiDAR at the start pose, or headings in degrees right "
                  "of the panorama's centre column (the paper: -90,90, perpendicular to the driving "
                  "direction when that is the centre column)")
      ->capture_default_str();
  sub->add_option("--pyramid-levels", args->pyramid_levels, "Coarse-to-fine levels")
      ->capture_default_str();
  sub->add_option("--bound-m", args->bound_m, "Search bound on the translation, m")
      ->capture_default_str();
  sub->add_option("--bound-deg", args->bound_deg, "Search bound on the rotation, deg")
      ->capture_default_str();
  sub->add_option("--simplex", args->simplex, "Initial simplex size, units (paper: 1)")
      ->capture_default_str();
  sub->add_option("--max-iterations", args->max_iterations, "Nelder-Mead iterations per level")
      ->capture_default_str();
  sub->add_option("--pyramid-paths", args->pyramid_paths,
                  "Coarse-to-fine searches entering the pyramid at the coarsest level and at "
                  "each of the next N-1 finer ones; the best at full resolution wins")
      ->capture_default_str();
  sub->add_option("--pyramid-paths-adaptive", args->pyramid_paths_adaptive,
                  "Enter at the finest level only when the coarser entries end more than "
                  "--restart-tolerance-px apart (true|false)")
      ->capture_default_str();
  sub->add_option("--coarse-starts", args->coarse_starts,
                  "Coarse global stage: extra Nelder-Mead starts at the coarsest level, spread "
                  "over the bounds (0 = the paper's single local search)")
      ->capture_default_str();
  sub->add_option("--coarse-candidates", args->coarse_candidates,
                  "Coarse global stage: distinct coarse optima (the start's always among them) "
                  "carried to full resolution; the best there wins")
      ->capture_default_str();
  sub->add_option("--coarse-spread", args->coarse_spread,
                  "Coarse global stage: starts within +-this fraction of the bounds")
      ->capture_default_str();
  sub->add_option("--restarts", args->restarts,
                  "Acceptance: re-optimisations from around the optimum that must agree")
      ->capture_default_str();
  sub->add_option("--polish-rounds", args->polish_rounds,
                  "Search: a restart that ends beyond the tolerance where the metric is higher "
                  "becomes the optimum, at most this often (0 = off)")
      ->capture_default_str();
  sub->add_option("--restart-level", args->restart_level,
                  "Pyramid level of the restarts (0 = full resolution: more precise, ~4x cost)")
      ->capture_default_str();
  sub->add_option("--threads", args->threads,
                  "Threads for independent metric evaluations (covariance, restarts, scans)")
      ->capture_default_str();
  sub->add_option("--restart-tolerance-px", args->restart_tolerance_px,
                  "Acceptance: largest median pixel distance of a restart from the optimum")
      ->capture_default_str();
  sub->add_option("--max-sigma-px", args->max_sigma_px,
                  "Acceptance: largest predicted pixel sigma (from the covariance)")
      ->capture_default_str();
  sub->add_option("--max-calibrated-sigma-px", args->max_calibrated_sigma_px,
                  "Acceptance: largest pixel sigma of the calibrated covariance (the one "
                  "reported: the halves' and restarts' scatter included)")
      ->capture_default_str();
  sub->add_option("--halves", args->halves,
                  "Acceptance: re-optimise two independent halves of the data (several frames: "
                  "the frames alternately; one frame: its views alternately, or the left/right "
                  "halves of one image) alone; each must agree "
                  "with the joint optimum (and they calibrate the covariance)")
      ->capture_default_str();
  sub->add_option("--whole-image-checks", args->whole_image_checks,
                  "Acceptance: a panorama registered on perspective/cube cuts must also pass the "
                  "calibrated-sigma check over the whole panorama (a roll the cuts barely see; "
                  "bench/RESULTS.md)")
      ->capture_default_str();
  sub->add_option("--weak-direction-scan", args->weak_direction_scan,
                  "Acceptance: besides the six axes, scan the metric across the search box along "
                  "its weakly observed direction (the combination of corrections that moves the "
                  "visible points least, e.g. a camera lowered and tilted back); a higher MI "
                  "or a flat metric there fails as on an axis")
      ->capture_default_str();
  sub->add_option("--all-checks", args->all_checks,
                  "Acceptance: measure every check also after one has failed (diagnostics in "
                  "OUT.json checks; slower). By default the checks stop at the first failure: "
                  "the status is the same, checks.stopped_after names where they stopped")
      ->capture_default_str();
  sub->add_option("--point-samples", args->point_samples,
                  "Evaluate the metric from the visible LiDAR points' projections (visibility "
                  "frozen per reference pose; about half the CPU, more results ok) instead of "
                  "rendering each pose; false = every pose rendered (slower; "
                  "bench/RESULTS.md, \"Point samples as the default\")")
      ->capture_default_str();
  sub->add_option("--sample-block-px", args->sample_block_px,
                  "Point samples: each visible point sampled at its own projection, weighted "
                  "by its share of the covered pixels of its N x N block (the footprint decides "
                  "visibility only); 0 = at the pixel it won, weighted by its won pixels "
                  "(bench/RESULTS.md, \"The footprint decides visibility only\")")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  sub->add_option("--split-level", args->split_level,
                  "Pyramid level of the halves' re-optimisation (0 = full resolution)")
      ->capture_default_str();
  sub->add_option("--split-tolerance-px", args->split_tolerance_px,
                  "Acceptance: largest median pixel distance of a half's own points between "
                  "its optimum and the joint one")
      ->capture_default_str();
  sub->add_option("--calibrate-covariance", args->calibrate_covariance,
                  "Scale the Laplace covariance by the scatter of the halves and restarts "
                  "(checks.covariance_factor: checks.variance_factor, or for a panorama's cuts "
                  "the larger of it and checks.image_variance_factor; the Laplace one is "
                  "covariance_laplace)")
      ->capture_default_str();
  sub->add_option("--covariance-pixel-floor", args->covariance_pixel_floor,
                  "With --calibrate-covariance: raise the reported covariance in every direction "
                  "to at least the one that moves the visible points by its calibrated pixel "
                  "sigma (checks.covariance_floor_directions counts the directions raised)")
      ->capture_default_str();
  sub->add_option("--effective-sample-lag", args->effective_sample_lag,
                  "Covariance: correlated pixels counted by Bartlett's factor over lags within "
                  "this many pixels (0 = every visible point independent)")
      ->capture_default_str();
  sub->add_option("--point-radius-m", args->point_radius_m,
                  "Point footprint: radius = this * f / range pixels")
      ->capture_default_str();
  sub->add_option("--max-point-radius-px", args->max_point_radius_px, "Footprint cap, px")
      ->capture_default_str();
  sub->add_option("--surface-classes", args->surface_classes,
                  "Metric conditioned on the surface: horizontal planes (normal within 45 deg of the "
                  "cloud's z axis) against the rest, one joint histogram each (intensity)")
      ->capture_default_str();
  sub->add_option("--orientation-classes", args->orientation_classes,
                  "Metric conditioned on which way each surface faces (sun shading): facing up, "
                  "facing down, steep faces in this many azimuth sectors, no plane; one joint "
                  "histogram each (intensity; 0 = off; default " +
                      std::to_string(mmba::registration::mi::kDefaultOrientationSectors) +
                      " with --representation intensity)")
      ->check(CLI::Range(0, mmba::registration::mi::kMaxLidarClasses - 3));
  sub->add_option("--surface-voxel-m", args->surface_voxel_m,
                  "Voxel of the local planes of --surface-classes and --orientation-classes, m")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--incidence-correction", args->incidence_correction,
                  "Intensity corrected for the angle of incidence, I / cos^k with k fitted to the "
                  "cloud (Lambert: 1; a normalising scanner: 0): auto = where the scanner's position "
                  "is known (--scanner-origin, --trajectory + --lidar-mount, else the cloud's sidecar "
                  "CLOUD.scanner.yaml (keys scanner_origin, or trajectory + lidar_mount; mmba simulate "
                  "writes one for each mobile cloud), or a KITTI .bin), on (error without it), off")
      ->capture_default_str();
  sub->add_option("--scanner-origin", args->scanner_origin,
                  "The scanner's centre in the cloud's frame (a static scan): x,y,z")
      ->delimiter(',');
  sub->add_option("--trajectory", args->trajectory,
                  "GNSS/INS trajectory CSV of a mobile cloud (time_s,x_east_m,y_north_m,z_up_m,"
                  "qw,qx,qy,qz: world_from_body); with --lidar-mount and the cloud's per-point time "
                  "it places the scanner of each point");
  sub->add_option("--lidar-mount", args->lidar_mount,
                  "The mobile LiDAR's calibration YAML (body_from_lidar: {qvec_wxyz, tvec})");
  sub->add_option("--max-range-m", args->max_range_m, "Ignore points farther than this")
      ->capture_default_str();
  sub->add_option("--perturb", args->perturb,
                  "Test: start from the start pose corrected by tx,ty,tz,roll,pitch,yaw "
                  "(m, deg) and report pixel offsets against the unperturbed pose")
      ->delimiter(',');
  sub->add_option("--probe", args->probe, "Write the probe (CSV, PNG) into this folder");
  sub->add_option("--probe-level", args->probe_level,
                  "Pyramid level of the probe (0 = full resolution)")
      ->capture_default_str();
  sub->add_option("--lidar-image", args->lidar_image,
                  "Write the LiDAR image of the result (first view) as PNG");
  sub->add_option("--overlay", args->overlay,
                  "Write a PNG of the first view: the photo with the LiDAR coloured by range at "
                  "the start (top) and at the result (bottom)");
  sub->add_option("--output", args->output, "OUT.json")->required();
  AddCommonOptions(sub, common);
  return [args, sub] {
    args->region_given = sub->count("--region") > 0;
    args->representation_given = sub->count("--representation") > 0;
    return RunRegisterMi(*args);
  };
}

}  // namespace

MMBA_REGISTER_COMMAND(60, SetupRegisterMi);

}  // namespace mmba::app
