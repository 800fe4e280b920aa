// mmba register-mi: mutual-information registration of LiDAR to images and panoramas
// (Wang, Ferrie & Macfarlane, CVPRW 2012), one frame or a rig over many frames. The job's
// policy (views, headings, classes, incidence, local origin, frames) is mi::PrepareJob's and
// OUT.json is mi::JobResultToJson's; this file reads the arguments and writes the files.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "command.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/core/version.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io/pose_json.h"
#include "mmba/io_kitti/camera_file.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/registration_settings.h"
#include "mmba/registration/mi/result_json.h"

namespace mmba::app {
namespace {
namespace fs = std::filesystem;
namespace mi = registration::mi;

struct RegisterMiArgs {
  std::vector<std::string> lidar;
  std::vector<std::string> image;
  std::string list;
  std::vector<std::string> camera;  ///< one, or several: a ring, each paired with its --image
  std::string kitti_calib;
  int kitti_camera = 2;
  std::string rig;
  std::vector<std::string> initial;  ///< none, or one per --camera
  std::string metric = "nmi";
  std::string representation = "intensity";
  bool representation_given = false;  ///< --representation on the command line
  // auto: perspective cuts of a panorama (EQUIRECTANGULAR camera), the image itself otherwise.
  std::string view = "auto";
  // The cuts that see the most LiDAR: on the simulated panoramas better than the paper's -90,90
  // (bench/RESULTS.md, "Simulated panoramas through the command line": 70 against 56 ok of 80).
  std::string headings = "auto";
  bool surface_classes = false;
  int orientation_classes = -1;  ///< -1: kDefaultOrientationSectors with intensity, else 0
  double surface_voxel_m = mi::kDefaultSurfaceVoxelM;
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
  /// (option, value) of each option that is a setting of mi::RegistrationSettingsTable
  /// (--bound-m, and the hidden --bins, --restarts, --halves, …), in the order of the options.
  std::vector<std::pair<std::string, std::string>> setting_options;
  std::vector<std::string> settings;  ///< --set NAME=VALUE
};

// The setting an option names: "--bound-m" -> "bound_m".
std::string SettingOf(const std::string& option) {
  std::string name = option.substr(2);
  std::replace(name.begin(), name.end(), '-', '_');
  return name;
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

// The registration's options: the setting options (each refused naming its option), then
// --set (the last word). `region_given` tells whether the metric's region was chosen.
mi::RegistrationOptions RegistrationOptionsOf(const RegisterMiArgs& args, bool* region_given) {
  mi::RegistrationOptions options;
  if (!mi::ParseMetric(args.metric, &options.metric.kind)) {
    throw InputError::Message("--metric", "found '" + args.metric + "', expected mi, nmi or nid");
  }
  if (!mi::ParseRepresentation(args.representation, &options.render.representation)) {
    throw InputError::Message("--representation", "found '" + args.representation +
                                                      "', expected intensity, points or depth");
  }
  const SettingsTable<mi::RegistrationOptions>& table = mi::RegistrationSettingsTable();
  std::vector<std::string> names;
  std::string problem;
  for (const auto& [option, value] : args.setting_options) {
    if (!table.Set(SettingOf(option), value, &options, &problem)) throw InputError::Message(option, problem);
    names.push_back(SettingOf(option));
  }
  if (!table.Apply(args.settings, &options, &problem, &names)) throw InputError::Message("--set", problem);
  *region_given = std::find(names.begin(), names.end(), "region") != names.end();
  return options;
}

// --view and --headings: the views asked for (auto ones are resolved by PrepareJob).
void ParseViews(const RegisterMiArgs& args, mi::JobRequest* request) {
  request->view_name = args.view;
  request->view_auto = args.view == "auto";
  if (!request->view_auto && !mi::ParseViewKind(args.view, &request->view.kind)) {
    throw InputError::Message("--view", "found '" + args.view +
                                            "', expected auto, image, equirect, perspective or cube");
  }
  request->headings_auto = args.headings == "auto";
  if (request->headings_auto) return;
  request->view.perspective_yaw_deg.clear();
  std::stringstream list(args.headings);
  for (std::string item; std::getline(list, item, ',');) {
    char* end = nullptr;
    const double yaw = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(yaw)) {
      throw InputError::Message("--headings", "found '" + args.headings +
                                                  "', expected 'auto' or degrees like -90,90");
    }
    request->view.perspective_yaw_deg.push_back(yaw);
  }
}

mi::JobRequest RequestOf(const RegisterMiArgs& args) {
  for (const auto& [option, values] : std::vector<std::pair<const char*, std::vector<double>>>{
           {"--surface-voxel-m", {args.surface_voxel_m}},
           {"--scanner-origin", args.scanner_origin},
           {"--perturb", args.perturb}}) {
    RequireFinite(option, values);
  }
  mi::JobRequest request;
  request.options = RegistrationOptionsOf(args, &request.region_given);
  request.representation_given = args.representation_given;
  ParseViews(args, &request);
  request.lidar = args.lidar;
  request.image = args.image;
  request.list = args.list;
  request.camera = args.camera.empty() ? "" : args.camera[0];
  request.kitti_calib = args.kitti_calib;
  request.kitti_camera = args.kitti_camera;
  request.rig = args.rig;
  request.initial = args.initial.empty() ? "" : args.initial[0];
  request.perturb = args.perturb;
  request.surface_classes = args.surface_classes;
  request.orientation_classes = args.orientation_classes;
  request.surface_voxel_m = args.surface_voxel_m;
  request.incidence_correction = args.incidence_correction;
  request.scanner_origin = args.scanner_origin;
  request.trajectory = args.trajectory;
  request.lidar_mount = args.lidar_mount;
  return request;
}

// The inputs the outputs must not overwrite: the files given and every frame's.
std::vector<FileArg> InputsOf(const RegisterMiArgs& args, const std::vector<mi::FramePaths>& paths) {
  std::vector<FileArg> inputs = {{"--list", args.list},
                                 {"--kitti-calib", args.kitti_calib},
                                 {"--rig", args.rig},
                                 {"--trajectory", args.trajectory},
                                 {"--lidar-mount", args.lidar_mount}};
  for (const std::string& camera : args.camera) inputs.push_back({"--camera", camera});
  for (const std::string& initial : args.initial) inputs.push_back({"--initial", initial});
  for (const mi::FramePaths& frame : paths) {
    inputs.push_back({"--image", frame.image});
    inputs.push_back({"--lidar", frame.lidar});
  }
  return inputs;
}

// --probe: the metric along each axis around the start, at --probe-level, in bounds of at
// least 2 m and 2 degrees.
void WriteProbe(const RegisterMiArgs& args, const mi::Job& job, OutputFolder* folder) {
  mi::RegistrationOptions probe_options = job.options;
  probe_options.bound_translation_m = std::max(job.options.bound_translation_m, 2.0);
  probe_options.bound_rotation_deg = std::max(job.options.bound_rotation_deg, 2.0);
  probe_options.pyramid_levels = std::max(1, args.probe_level + 1);
  std::string error;
  if (!probe_options.Check(&error)) throw InputError::Message("--probe-level", error);
  mi::FrameSetEvaluator evaluator(job.frames, job.start, probe_options);
  mi::WriteProbe(mi::Probe(evaluator, job.start, 2.0, 0.1, args.probe_level), folder->staging().string());
  folder->Commit();
  spdlog::info("probe written to {}", args.probe);
}

// OUT.json, and the --lidar-image and --overlay PNGs of the first view, as one set of files.
void WriteOutputs(const RegisterMiArgs& args, const mi::Job& job, const mi::RegistrationResult& result,
                  const Rigid3d& cam_from_local, nlohmann::json out) {
  RecordBuild(&out);
  AtomicFileSet files;
  files.Add(args.output, [&](std::ostream& stream) { stream << out.dump(2) << "\n"; });
  const mi::View& view = job.frames[0].views[0];
  if (!args.lidar_image.empty()) {
    // OUT.json is the index of this run's files (core/atomic_file.h): the earlier one goes
    // before a partner written on its own, so it never stands beside this run's image.
    std::error_code ec;
    if (!fs::remove(args.output, ec) && ec) {
      throw std::runtime_error("cannot remove the earlier '" + args.output + "': " + ec.message());
    }
    mi::LidarImage rendered;
    mi::RenderLidarImage(job.clouds[0], view, cam_from_local, job.options.render, &rendered);
    mi::WriteGrayPng(mi::LidarImageToGray(rendered), args.lidar_image);
  }
  if (!args.overlay.empty()) {
    mi::LidarImage at_start, at_result;
    mi::RenderLidarImage(job.clouds[0], view, job.start, job.options.render, &at_start);
    mi::RenderLidarImage(job.clouds[0], view, cam_from_local, job.options.render, &at_result);
    std::vector<const mi::LidarImage*> panels = {&at_start, &at_result};
    std::vector<std::string> labels = {"start (" + view.name + ")", "result: " + result.status};
    // With the geometric term, its LiDAR edge points at the start and at the result too.
    mi::LidarImage edges_at_start, edges_at_result;
    if (job.options.edges == "on") {
      const mi::LidarPoints edges = mi::EdgeCloud(job.clouds[0], job.options.edge);
      mi::RenderLidarImage(edges, view, job.start, job.options.render, &edges_at_start);
      mi::RenderLidarImage(edges, view, cam_from_local, job.options.render, &edges_at_result);
      panels.insert(panels.end(), {&edges_at_start, &edges_at_result});
      labels.insert(labels.end(), {"LiDAR edges at the start", "LiDAR edges at the result"});
    }
    const std::vector<uint8_t> png = mi::EncodeRangeOverlayPng(view.image, panels, labels);
    files.Add(
        args.overlay,
        [png](std::ostream& stream) {
          stream.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
        },
        /*binary=*/true);
  }
  files.Commit();
}

// OpenCalib files given as --camera (calib.txt, NAME-intrinsic.json) or --initial (calib.txt,
// NAME-extrinsic.json), read by io_kitti/camera_file.h and handed to the job as the camera YAML
// and pose JSON it reads, in a folder removed on return.
class OpenCalibInputs {
 public:
  OpenCalibInputs(const RegisterMiArgs& args, const std::vector<mi::FramePaths>& paths, mi::JobRequest* request) {
    const std::string camera_path = args.camera.empty() ? "" : args.camera[0];
    const std::string initial_path = args.initial.empty() ? "" : args.initial[0];
    const bool camera = !camera_path.empty() && args.rig.empty() && io::IsOpenCalibFile(camera_path);
    const bool initial = !initial_path.empty() && io::IsOpenCalibFile(initial_path);
    if (!camera && !initial) return;
    // Everything is read and checked before the folder is made.
    std::optional<io::CameraYaml> camera_yaml;
    if (camera) {
      // The size of the first image: calib.txt states none (each further frame's image is
      // checked against it by the job).
      const mi::GrayImage image = mi::ReadGrayImage(paths.at(0).image);
      std::string note;
      camera_yaml = io::ReadCameraFile(camera_path, paths[0].image, image.width, image.height, &note);
      if (!note.empty()) spdlog::warn("{}", note);
      if (!camera_yaml->cam_from_lidar && initial_path.empty()) {
        throw InputError::Message(camera_path, "holds no cam_from_lidar (an intrinsic JSON); give the start pose "
                                               "as --initial NAME-extrinsic.json, calib.txt or POSE.json");
      }
      spdlog::info("{}: {} camera {}x{} (OpenCalib, principal point + 0.5 px to mmba's pixel centres)", camera_path,
                   camera_yaml->camera.ModelName(), image.width, image.height);
    }
    const std::string key = args.rig.empty() ? "cam_from_lidar" : "rig_from_lidar";
    nlohmann::json pose;
    if (initial) pose[key] = io::PoseToJson(io::ReadStartPoseFile(initial_path, key));
    std::error_code ec;
    folder_ = fs::temp_directory_path(ec) / ("mmba-register-mi-" + std::to_string(::getpid()));
    fs::create_directories(folder_, ec);
    if (camera_yaml) {
      request->camera = (folder_ / "camera.yaml").string();
      io::WriteCameraYaml(*camera_yaml, request->camera);
    }
    if (initial) {
      request->initial = (folder_ / "initial.json").string();
      WriteFileAtomically(request->initial, [&](std::ostream& out) { out << pose.dump(2) << "\n"; });
    }
  }
  ~OpenCalibInputs() {
    std::error_code ec;
    if (!folder_.empty()) fs::remove_all(folder_, ec);
  }
  OpenCalibInputs(const OpenCalibInputs&) = delete;
  OpenCalibInputs& operator=(const OpenCalibInputs&) = delete;

 private:
  fs::path folder_;
};

// A ring of cameras (several --camera, each paired in order with its --image and --initial)
// about one LiDAR sweep: the options a ring cannot take are refused before any reading.
void CheckRing(const RegisterMiArgs& args) {
  const size_t n = args.camera.size();
  if (args.initial.size() > std::max<size_t>(n, 1) || (n > 1 && !args.initial.empty() && args.initial.size() != n)) {
    throw InputError::Message("--initial", "found " + std::to_string(args.initial.size()) + " for " +
                                               std::to_string(n) + " --camera: give none or one per camera, in order");
  }
  if (n < 2) return;
  for (const auto& [option, given] : std::vector<std::pair<std::string, bool>>{
           {"--rig", !args.rig.empty()},
           {"--kitti-calib", !args.kitti_calib.empty()},
           {"--list", !args.list.empty()},
           {"--probe", !args.probe.empty()},
           {"--lidar-image", !args.lidar_image.empty()},
           {"--overlay", !args.overlay.empty()}}) {
    if (given) {
      throw InputError::Message(option, "cannot be combined with several --camera (a ring: each camera with its "
                                            "own --image and --initial, one --lidar); run one camera for it");
    }
  }
  if (args.image.size() != n || args.lidar.size() != 1) {
    throw InputError::Message("--camera/--image/--lidar", "a ring of " + std::to_string(n) + " --camera needs " +
                                                              std::to_string(n) + " --image (in the same order) and "
                                                              "one --lidar; found " +
                                                              std::to_string(args.image.size()) + " and " +
                                                              std::to_string(args.lidar.size()));
  }
}

// One camera of a ring: its own job (the sweep, its image, its camera and start), its result as
// register-mi writes it for one camera, with the camera's and the image's files.
nlohmann::json RegisterRingCamera(const RegisterMiArgs& args, size_t k, bool* ok, std::string* brief) {
  RegisterMiArgs one = args;
  one.camera = {args.camera[k]};
  one.image = {args.image[k]};
  one.initial = args.initial.empty() ? std::vector<std::string>{} : std::vector<std::string>{args.initial[k]};
  mi::JobRequest request = RequestOf(one);
  const std::vector<mi::FramePaths> paths = mi::ListFrames(request);
  const OpenCalibInputs opencalib(one, paths, &request);
  const mi::Job job = mi::PrepareJob(request, paths);
  Rigid3d cam_from_local;
  const mi::RegistrationResult result = mi::RegisterJob(job, &cam_from_local);
  nlohmann::json out = mi::JobResultToJson(request, job, result, cam_from_local);
  out["camera"] = args.camera[k];
  out["image"] = args.image[k];
  *ok = result.ok();
  *brief = result.BriefReport();
  return out;
}

// Every camera of the ring registered to the one sweep, each its own cam_from_lidar; "ok" when
// every camera's is. The jobs are prepared one after the other (a bad file of the last camera
// is found after the first is registered; nothing is written then).
int RunRing(const RegisterMiArgs& args) {
  Timer wall;
  RefuseToOverwriteInputs({{"--output", args.output}}, InputsOf(args, {{args.image[0], args.lidar[0]}}));
  nlohmann::json out = {{"status", "ok"}, {"reason", ""}, {"lidar", args.lidar[0]}};
  out["cameras"] = nlohmann::json::array();
  std::string reasons, briefs;
  for (size_t k = 0; k < args.camera.size(); ++k) {
    bool ok = false;
    std::string brief;
    out["cameras"].push_back(RegisterRingCamera(args, k, &ok, &brief));
    briefs += "camera " + std::to_string(k) + " (" + args.camera[k] + "): " + brief + "\n";
    if (!ok) {
      reasons += (reasons.empty() ? "" : "; ") + std::string("camera ") + std::to_string(k) + " (" +
                 args.camera[k] + "): " + out["cameras"][k]["reason"].get<std::string>();
    }
  }
  if (!reasons.empty()) {
    out["status"] = "failed";
    out["reason"] = reasons;
  }
  RecordBuild(&out);
  AtomicFileSet files;
  files.Add(args.output, [&](std::ostream& stream) { stream << out.dump(2) << "\n"; });
  files.Commit();
  spdlog::info("wrote {} ({:.2f} s)", args.output, wall.ElapsedSeconds());
  if (!reasons.empty()) throw CommandFailed("MI registration of a ring: failed (" + reasons + ")");
  std::cout << briefs << std::flush;
  return kExitOk;
}

int RunRegisterMi(const RegisterMiArgs& args) {
  CheckRing(args);
  if (args.camera.size() > 1) return RunRing(args);
  Timer wall;
  // Options and files are checked before any reading.
  mi::JobRequest request = RequestOf(args);
  const std::vector<mi::FramePaths> paths = mi::ListFrames(request);
  const std::vector<FileArg> inputs = InputsOf(args, paths);
  RefuseToOverwriteInputs(
      {{"--output", args.output}, {"--lidar-image", args.lidar_image}, {"--overlay", args.overlay}}, inputs);
  const OpenCalibInputs opencalib(args, paths, &request);
  std::optional<OutputFolder> probe_folder;
  if (!args.probe.empty()) probe_folder.emplace(args.probe, "--probe", "mmba register-mi --probe", AsNamedPaths(inputs));
  const mi::Job job = mi::PrepareJob(request, paths);
  if (probe_folder) WriteProbe(args, job, &*probe_folder);
  Rigid3d cam_from_local;
  const mi::RegistrationResult result = mi::RegisterJob(job, &cam_from_local);
  WriteOutputs(args, job, result, cam_from_local, mi::JobResultToJson(request, job, result, cam_from_local));
  spdlog::info("wrote {} ({:.2f} s)", args.output, wall.ElapsedSeconds());
  // The summary on stdout when registered; a failure on stderr, as register-cloud's.
  if (!result.ok()) throw CommandFailed(result.BriefReport());
  std::cout << result.BriefReport() << std::endl;
  return kExitOk;
}

void AddInputOptions(CLI::App* sub, RegisterMiArgs* args) {
  sub->add_option("--lidar", args->lidar, "Cloud (.bin KITTI, .pcd.bin nuScenes, .ply, .pcd, .las, .xyz); "
                                          "repeat with --image for several frames");
  sub->add_option("--image", args->image, "Image or equirectangular panorama; repeatable");
  sub->add_option("--list", args->list, "Text file of frames: IMAGE LIDAR per line");
  sub->add_option("--camera", args->camera,
                  "Camera YAML (calib/README.md), or OpenCalib calib.txt / NAME-intrinsic.json; repeat for "
                  "a ring of cameras about one --lidar, each paired in order with its --image and --initial");
  sub->add_option("--kitti-calib", args->kitti_calib, "KITTI calibration file (camera 2)");
  sub->add_option("--rig", args->rig,
                  "Rig YAML (calib/README.md camera_rig, optional rig_from_lidar): each --image is "
                  "a pattern with {camera}; the pose is rig_from_lidar");
  sub->add_option("--kitti-camera", args->kitti_camera, "KITTI camera index 0..3")->capture_default_str();
  sub->add_option("--initial", args->initial,
                  "POSE.json with cam_from_lidar (with --rig: rig_from_lidar), 4x4 row-major; or "
                  "OpenCalib calib.txt / NAME-extrinsic.json; one per --camera of a ring");
  sub->add_option("--perturb", args->perturb,
                  "Test: start from the start pose corrected by tx,ty,tz,roll,pitch,yaw "
                  "(m, deg) and report pixel offsets against the unperturbed pose")
      ->delimiter(',');
}

void AddMetricOptions(CLI::App* sub, RegisterMiArgs* args) {
  sub->add_option("--metric", args->metric, "mi | nmi | nid")->capture_default_str();
  sub->add_option("--representation", args->representation, "intensity | points | depth")->capture_default_str();
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
  sub->add_option("--surface-classes", args->surface_classes,
                  "Metric conditioned on the surface: horizontal planes (normal within 45 deg of the "
                  "cloud's z axis) against the rest, one joint histogram each (intensity)")
      ->capture_default_str();
  sub->add_option("--orientation-classes", args->orientation_classes,
                  "Metric conditioned on which way each surface faces (sun shading): facing up, "
                  "facing down, steep faces in this many azimuth sectors, no plane; one joint "
                  "histogram each (intensity; 0 = off; default " +
                      std::to_string(mi::kDefaultOrientationSectors) + " with --representation intensity)")
      ->check(CLI::Range(0, mi::kMaxLidarClasses - 3));
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
}

// The options that set a setting of mi::RegistrationSettingsTable: those a user sets are
// listed by --help; the others (--bins, --restarts, --halves, …) are accepted as before and
// hidden, --set reaching every setting.
void AddSettingOptions(CLI::App* sub, RegisterMiArgs* args) {
  const SettingsTable<mi::RegistrationOptions>& table = mi::RegistrationSettingsTable();
  const mi::RegistrationOptions defaults;
  const std::vector<SettingInfo> settings = table.List(defaults);
  const auto add = [&](const std::string& option, const std::string& help) {
    CLI::Option* o = sub->add_option_function<std::string>(
        option, [args, option](const std::string& value) { args->setting_options.emplace_back(option, value); },
        help);
    if (help.empty()) o->group("");
    o->default_str(table.Value(SettingOf(option), defaults));
    for (const SettingInfo& setting : settings) {
      if (setting.name == SettingOf(option)) o->type_name(setting.kind == "integer" ? "INT" : "FLOAT");
    }
  };
  add("--bound-m", "Search bound on the translation, m (an optimum on the bound is refused)");
  add("--bound-deg", "Search bound on the rotation, deg (<= 45)");
  add("--max-range-m", "Ignore points farther than this, m");
  add("--threads", "Threads for independent metric evaluations (covariance, restarts, scans)");
  for (const char* hidden :
       {"--bins", "--smoothing", "--region", "--pyramid-levels", "--simplex", "--max-iterations", "--pyramid-paths",
        "--pyramid-paths-adaptive", "--coarse-starts", "--coarse-candidates", "--coarse-spread", "--restarts",
        "--polish-rounds", "--restart-level", "--restart-tolerance-px", "--max-sigma-px",
        "--max-calibrated-sigma-px", "--halves", "--whole-image-checks", "--weak-direction-scan", "--all-checks",
        "--point-samples", "--sample-block-px", "--split-level", "--split-tolerance-px", "--calibrate-covariance",
        "--covariance-pixel-floor", "--effective-sample-lag", "--point-radius-m", "--max-point-radius-px"}) {
    add(hidden, "");
  }
  sub->add_option("--set", args->settings,
                  "NAME=VALUE ...: a setting of the search and its acceptance checks (histogram, pyramid, "
                  "simplex, restarts, halves, point samples, covariance); the names are listed below");
  sub->footer(table.Footer("Settings for --set NAME=VALUE (default; accepted values); leave them at their "
                           "defaults unless bench/RESULTS.md says otherwise for your case:"));
}

void AddOutputOptions(CLI::App* sub, RegisterMiArgs* args) {
  sub->add_option("--probe", args->probe, "Write the probe (CSV, PNG) into this folder");
  sub->add_option("--probe-level", args->probe_level, "Pyramid level of the probe (0 = full resolution)")
      ->capture_default_str();
  sub->add_option("--lidar-image", args->lidar_image, "Write the LiDAR image of the result (first view) as PNG");
  sub->add_option("--overlay", args->overlay,
                  "Write a PNG of the first view: the photo with the LiDAR coloured by range at "
                  "the start (top) and at the result (bottom)");
  sub->add_option("--output", args->output, "OUT.json")->required();
}

std::function<int()> SetupRegisterMi(CLI::App& app, CommonOptions* common) {
  auto args = std::make_shared<RegisterMiArgs>();
  CLI::App* sub = app.add_subcommand(
      "register-mi",
      "Register LiDAR to images/panoramas by maximising mutual information (Wang et al. "
      "2012): pose correction with covariance; several frames give a rig calibration");
  AddInputOptions(sub, args.get());
  AddMetricOptions(sub, args.get());
  AddSettingOptions(sub, args.get());
  AddOutputOptions(sub, args.get());
  AddCommonOptions(sub, common);
  return [args, sub] {
    args->representation_given = sub->count("--representation") > 0;
    return RunRegisterMi(*args);
  };
}

}  // namespace

MMBA_REGISTER_COMMAND(60, SetupRegisterMi);

}  // namespace mmba::app
