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
#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/result_json.h"

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
  // (bench/RESULTS.md, session 43: 70 against 56 ok of 80, no wrong ok against 2).
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

Rigid3d ReadPoseJson(const std::string& path, const std::string& key) {
  const std::string text = io::ReadWholeFile(path);
  nlohmann::json json;
  // The last key read names the field of a number out of range (1e400), which nlohmann
  // reports without a position.
  std::string last_key = "json";
  const nlohmann::json::parser_callback_t track_key = [&last_key](int, nlohmann::json::parse_event_t event,
                                                                 nlohmann::json& parsed) {
    if (event == nlohmann::json::parse_event_t::key && parsed.is_string()) last_key = parsed.get<std::string>();
    return true;
  };
  try {
    json = nlohmann::json::parse(text, track_key);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError::AtByte(path, e.byte, "json", e.what(), "valid JSON");
  } catch (const nlohmann::json::exception& e) {
    // e.g. "[json.exception.out_of_range.406] number overflow parsing '1e400'"
    std::string found = e.what();
    const size_t quote = found.find('\'');
    if (quote != std::string::npos) found = found.substr(quote + 1, found.rfind('\'') - quote - 1);
    int64_t line = 0;
    if (const size_t at = text.find(found); quote != std::string::npos && at != std::string::npos) {
      line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
    }
    throw InputError(path, line, last_key, found, "a finite number (a double)");
  }
  if (!json.is_object() || !json.contains(key)) {
    throw InputError(path, 0, key, "(missing)",
                     "an object with \"" + key + "\": 16 numbers (4x4 row-major) or 4 rows of 4");
  }
  double v[16];
  std::string problem;
  if (!registration::mi::Matrix4FromJson(json[key], v, &problem)) {
    throw InputError(path, 0, key, problem, "16 numbers (4x4 row-major) or 4 rows of 4 numbers");
  }
  return io::RigidFromRowMajor4x4(v, path, key);
}

// Keeps the points of `cloud` (and their attributes) within `range_m` of any of `centres`
// and finite; returns the number dropped.
size_t KeepNearAny(const std::vector<Eigen::Vector3d>& centres, double range_m, io::PointCloud* cloud) {
  const double range_sq = range_m * range_m;
  std::vector<char> far(cloud->size(), 1);
  size_t dropped = 0;
  for (size_t i = 0; i < cloud->size(); ++i) {
    const Eigen::Vector3d& p = cloud->points[i];
    if (p.allFinite()) {
      for (const Eigen::Vector3d& c : centres) far[i] = far[i] && (p - c).squaredNorm() > range_sq;
    }
    dropped += far[i] ? 1 : 0;
  }
  if (dropped > 0) *cloud = io::WithoutMarked(*cloud, far);
  return dropped;
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
  // A points image is constant over the overlap (MI = 0 there): points are compared over the
  // whole image unless --region was given.
  std::string region = args.region;
  std::string region_note;
  if (options.render.representation == mi::Representation::kPoints && !args.region_given) {
    region = "whole";
    options.metric.region = mi::Region::kWholeImage;
    region_note = "whole: the default for --representation points (its LiDAR image is constant over the overlap)";
    spdlog::info("--representation points: the metric over the whole image (--region whole)");
  }
  mi::ViewOptions view_options;
  const bool auto_view = args.view == "auto";  // resolved below, once the camera is known
  std::string view_name = args.view;
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
  if (args.surface_classes && options.render.representation == mi::Representation::kIntensity) {
    options.metric.lidar_classes = 2;
  }
  // The default: conditioned on the orientation where the intensity is compared and no other
  // classes were asked for.
  const int orientation_sectors =
      args.orientation_classes >= 0 ? args.orientation_classes
      : options.render.representation == mi::Representation::kIntensity && !args.surface_classes
          ? mi::kDefaultOrientationSectors
          : 0;
  if (orientation_sectors > 0) {
    if (args.surface_classes) {
      throw InputError::Message("--orientation-classes", "cannot be combined with --surface-classes "
                                                         "(both set the metric's classes)");
    }
    if (options.render.representation != mi::Representation::kIntensity) {
      throw InputError::Message("--orientation-classes",
                                "conditions the intensity on the surface's orientation; it needs "
                                "--representation intensity");
    }
    // Facing up, facing down, the sectors, no plane.
    options.metric.lidar_classes = orientation_sectors + 3;
  }
  if (options.metric.region == mi::Region::kOverlap &&
      options.render.representation == mi::Representation::kPoints) {
    throw InputError::Message("--region", "overlap with --representation points has a constant "
                                          "LiDAR image (MI = 0); use --region whole (the default "
                                          "for points)");
  }
  std::string error;
  if (!options.Check(&error)) throw InputError::Message("options", error);
  if (!args.perturb.empty() && args.perturb.size() != 6) {
    throw InputError::Message("--perturb", "found " + std::to_string(args.perturb.size()) +
                                               " values, expected 6: tx,ty,tz,roll,pitch,yaw");
  }
  // Incidence correction (mi::IncidenceCorrection): where the scanner's position is known.
  if (args.incidence_correction != "auto" && args.incidence_correction != "on" &&
      args.incidence_correction != "off") {
    throw InputError::Message("--incidence-correction",
                              "found '" + args.incidence_correction + "', expected auto, on or off");
  }
  if (!args.scanner_origin.empty() && args.scanner_origin.size() != 3) {
    throw InputError::Message("--scanner-origin", "found " + std::to_string(args.scanner_origin.size()) +
                                                      " values, expected 3: x,y,z in the cloud's frame");
  }
  if (args.trajectory.empty() != args.lidar_mount.empty()) {
    throw InputError::Message(args.trajectory.empty() ? "--lidar-mount" : "--trajectory",
                              "--trajectory and --lidar-mount go together (the scanner's centre at "
                              "a point's time is world_from_body(t) * body_from_lidar)");
  }
  if (!args.scanner_origin.empty() && !args.trajectory.empty()) {
    throw InputError::Message("--scanner-origin", "give either --scanner-origin or --trajectory, not both");
  }
  const bool correct_incidence = args.incidence_correction != "off" &&
                                 options.render.representation == mi::Representation::kIntensity;
  const bool rig_mode = !args.rig.empty();
  if (rig_mode) {
    if (!args.camera.empty() || !args.kitti_calib.empty()) {
      throw InputError::Message("--rig", "give either --rig or one of --camera/--kitti-calib, not both");
    }
    if (args.view != "image" && !auto_view) {
      throw InputError::Message("--view", "found '" + args.view + "' with --rig; a rig's cameras are "
                                                                  "registered as their own images (image)");
    }
  } else if (args.camera.empty() == args.kitti_calib.empty()) {
    throw InputError::Message("--camera/--kitti-calib", "give exactly one of them (or --rig)");
  }
  if (args.kitti_camera < 0 || args.kitti_camera > 3) {
    throw InputError::Message("--kitti-camera", "found " + std::to_string(args.kitti_camera) +
                                                    ", expected a KITTI camera index 0..3");
  }
  // ---- Frames: --image/--lidar pairs or a list file (IMAGE LIDAR per line).
  std::vector<std::pair<std::string, std::string>> pairs;
  if (args.image.size() != args.lidar.size()) {
    throw InputError::Message("--image/--lidar", std::to_string(args.image.size()) +
                                                     " images but " +
                                                     std::to_string(args.lidar.size()) +
                                                     " clouds; give them in pairs");
  }
  for (size_t i = 0; i < args.image.size(); ++i) pairs.emplace_back(args.image[i], args.lidar[i]);
  if (!args.list.empty()) {
    // IMAGE LIDAR per line; relative paths are relative to the list file's folder. A file
    // not found is named with the list's line (with --rig, IMAGE is a pattern: checked later).
    const std::string text = io::ReadWholeFile(args.list);
    const fs::path base = fs::path(args.list).parent_path();
    io::LineCursor cursor(text, args.list);
    std::string_view line_text;
    const size_t before = pairs.size();
    while (cursor.Next(&line_text)) {
      const std::string where = args.list + ":" + std::to_string(cursor.line_number());
      // Blank-separated; a path with blanks in double quotes: "survey 2/img 001.png" a.ply
      std::vector<std::string> fields;
      bool quoted = false, in_field = false;
      for (const char c : line_text) {
        if (c == '"') {
          quoted = !quoted;
          if (!in_field) fields.emplace_back();
          in_field = true;
        } else if (!quoted && std::isspace(static_cast<unsigned char>(c))) {
          in_field = false;
        } else {
          if (!in_field) fields.emplace_back();
          in_field = true;
          fields.back() += c;
        }
      }
      if (quoted) throw InputError::Message(where, "a '\"' is not closed: found '" + std::string(line_text) + "'");
      if (fields.empty() || fields[0].front() == '#') continue;
      if (fields.size() != 2) {
        throw InputError::Message(where, "found " + std::to_string(fields.size()) +
                                             " values, expected 2: IMAGE LIDAR (a path with blanks in "
                                             "double quotes: \"my dir/img 1.png\" scan.ply)");
      }
      auto resolve = [&](const std::string& p) {
        return fs::path(p).is_absolute() ? p : (base / p).string();
      };
      const std::string image = resolve(fields[0]), lidar = resolve(fields[1]);
      for (const auto& [what, path] : {std::pair<std::string, std::string>{"image", image}, {"lidar", lidar}}) {
        if (what == "image" && rig_mode) continue;
        std::error_code ec;
        if (!fs::is_regular_file(path, ec)) {
          throw InputError::Message(where, what + " file not found: '" + path + "'" +
                                               (fs::path(fields[what == "image" ? 0 : 1]).is_absolute()
                                                    ? ""
                                                    : " (a relative path in a list is relative to the list "
                                                      "file's folder)"));
        }
      }
      pairs.emplace_back(image, lidar);
    }
    if (pairs.size() == before) {
      throw InputError::Message(args.list, "no frames in the list (expected lines IMAGE LIDAR; blank lines and "
                                           "lines starting with # are skipped)");
    }
  }
  if (pairs.empty()) {
    throw InputError::Message("--image/--lidar", "no frame given (use --image and --lidar, "
                                                 "or --list)");
  }
  std::vector<FileArg> inputs = {{"--list", args.list},         {"--camera", args.camera},
                                 {"--kitti-calib", args.kitti_calib}, {"--rig", args.rig},
                                 {"--initial", args.initial},     {"--trajectory", args.trajectory},
                                 {"--lidar-mount", args.lidar_mount}};
  for (const auto& [image, lidar] : pairs) {
    inputs.push_back({"--image", image});
    inputs.push_back({"--lidar", lidar});
  }
  RefuseToOverwriteInputs(
      {{"--output", args.output}, {"--lidar-image", args.lidar_image}, {"--overlay", args.overlay}},
      inputs);
  std::optional<OutputFolder> probe_folder;
  if (!args.probe.empty()) probe_folder.emplace(args.probe, "--probe", "mmba register-mi --probe", AsNamedPaths(inputs));
  // ---- Read everything before any work.
  std::vector<mi::GrayImage> images;
  sensors::Camera camera;
  Rigid3d cam_from_lidar_calibration;
  bool have_calibration_pose = false;
  // With --rig: each frame's IMAGE is a pattern with {camera}, one image per rig camera
  // (rig_images[frame][camera]); the pose is rig_from_lidar.
  io::RigYaml rig_yaml;
  std::vector<std::vector<mi::GrayImage>> rig_images;
  std::vector<std::vector<std::string>> rig_paths;
  if (rig_mode) {
    rig_yaml = io::ReadRigYaml(args.rig);
    for (const auto& [pattern, lidar_path] : pairs) {
      const size_t at = pattern.find("{camera}");
      if (at == std::string::npos) {
        throw InputError::Message(pattern, "with --rig each image is a pattern with {camera} for the "
                                           "camera's name (e.g. frame_000_{camera}.png)");
      }
      rig_images.emplace_back();
      rig_paths.emplace_back();
      for (size_t k = 0; k < rig_yaml.cameras.size(); ++k) {
        const std::string path = pattern.substr(0, at) + rig_yaml.names[k] + pattern.substr(at + 8);
        rig_images.back().push_back(mi::ReadGrayImage(path));
        rig_paths.back().push_back(path);
        const sensors::Camera& c = rig_yaml.cameras[k];
        if (rig_images.back().back().width != static_cast<int>(c.width) ||
            rig_images.back().back().height != static_cast<int>(c.height)) {
          throw InputError::Message(path, "image is " + std::to_string(rig_images.back().back().width) + "x" +
                                              std::to_string(rig_images.back().back().height) + " but camera " +
                                              rig_yaml.names[k] + " of " + args.rig + " is " +
                                              std::to_string(c.width) + "x" + std::to_string(c.height));
        }
      }
    }
    if (rig_yaml.rig_from_lidar) {
      cam_from_lidar_calibration = *rig_yaml.rig_from_lidar;
      have_calibration_pose = true;
    }
  } else {
    for (const auto& [image_path, lidar_path] : pairs) images.push_back(mi::ReadGrayImage(image_path));
    if (!args.kitti_calib.empty()) {
      const io::KittiCalibration calibration = io::ReadKittiCalibration(args.kitti_calib, args.kitti_camera);
      const io::KittiCameraPose kitti =
          io::KittiCamera(calibration, args.kitti_camera, images[0].width, images[0].height,
                          args.kitti_calib);
      camera = kitti.camera;
      // The calibration has no image size; the image's is taken. KITTI's principal points lie
      // near the image centre (cx ~ 609 of 1242, cy ~ 173 of 375; raw sequences 1224..1242 x
      // 370..376), so an image whose centre is more than 20 % of its size from the principal
      // point is not one of this camera (a crop, a thumbnail, a panorama, another camera).
      const double cx = camera.params[2], cy = camera.params[3];
      for (size_t i = 0; i < images.size(); ++i) {
        const double w = images[i].width, h = images[i].height;
        if (std::abs(2 * cx - w) > 0.2 * w || std::abs(2 * cy - h) > 0.2 * h) {
          std::ostringstream why;
          why << "image is " << images[i].width << "x" << images[i].height << " but the principal point of KITTI camera "
              << args.kitti_camera << " in " << args.kitti_calib << " is (" << cx << ", " << cy
              << "): expected an image of about " << std::lround(2 * cx) << "x" << std::lround(2 * cy)
              << " (2 cx x 2 cy, within 20 %; KITTI: about 1242x375)";
          throw InputError::Message(pairs[i].first, why.str());
        }
      }
      cam_from_lidar_calibration = kitti.cam_from_lidar;
      have_calibration_pose = true;
    } else {
      const io::CameraYaml camera_yaml = io::ReadCameraYaml(args.camera);
      camera = camera_yaml.camera;
      if (camera_yaml.cam_from_lidar) {
        cam_from_lidar_calibration = *camera_yaml.cam_from_lidar;
        have_calibration_pose = true;
      }
    }
  }
  // --view: image = the image with its own camera; equirect (its synonym), perspective and cube
  // = the whole panorama or cuts of it, for an EQUIRECTANGULAR camera only.
  const bool panorama = !rig_mode && camera.model_id == sensors::CameraModelId::kEquirectangular;
  if (auto_view) {
    // Perspective cuts (the paper's views, with --headings auto) registered more simulated
    // panoramas than the whole panorama: 70 against 56 ok of 80, neither with a wrong ok
    // (bench/RESULTS.md, session 43).
    view_options.kind = panorama ? mi::ViewKind::kPerspective : mi::ViewKind::kImage;
    view_name = panorama ? "perspective" : "image";
    if (panorama) spdlog::info("--view auto: perspective cuts of the panorama");
  }
  if (!rig_mode && view_name != "image" && !panorama) {
    throw InputError::Message("--view", "found '" + view_name + "' but the camera of " +
                                            (args.camera.empty() ? args.kitti_calib : args.camera) + " is " +
                                            camera.ModelName() + "; equirect, perspective and cube need an "
                                            "EQUIRECTANGULAR camera (a panorama), expected image");
  }
  for (size_t i = 0; i < images.size(); ++i) {  // (none with --rig: checked above)
    if (images[i].width != static_cast<int>(camera.width) ||
        images[i].height != static_cast<int>(camera.height)) {
      throw InputError::Message(pairs[i].first, "image is " + std::to_string(images[i].width) +
                                                    "x" + std::to_string(images[i].height) +
                                                    " but the camera is " +
                                                    std::to_string(camera.width) + "x" +
                                                    std::to_string(camera.height));
    }
  }
  const std::string pose_key = rig_mode ? "rig_from_lidar" : "cam_from_lidar";
  Rigid3d start = cam_from_lidar_calibration;
  if (!args.initial.empty()) {
    start = ReadPoseJson(args.initial, pose_key);
  } else if (!have_calibration_pose) {
    throw InputError::Message(rig_mode ? args.rig : args.camera,
                              "no " + pose_key + " in the " + (rig_mode ? "rig" : "camera") +
                                  " file and no --initial POSE.json: the start pose is unknown");
  }
  const Rigid3d reference = start;
  if (!args.perturb.empty()) {
    mi::Vector6d perturb;
    for (int i = 0; i < 6; ++i) perturb[i] = args.perturb[i];
    start = mi::ApplyCorrection(start, perturb);
  }
  // Clouds in map-grid coordinates (a georeferenced mobile-mapping cloud in UTM with the
  // camera's pose in the grid): the renderer holds points as floats, which resolve 0.5 m at
  // 5,000 km. Every cloud is moved by −o (o = io::LocalOrigin of the first cloud: its
  // centroid rounded to whole km, 0 for a cloud in its sensor's frame, which is then used as
  // given), the poses by cam_from_local = cam_from_lidar · [I | o], and the result back. The
  // correction (a shift of the camera centre and a turn about it, in the cloud's axes) and its
  // covariance do not change under a shift of the cloud's frame.
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  const auto to_local = [&origin](Rigid3d cam_from_lidar) {
    cam_from_lidar.translation += cam_from_lidar.rotation * origin;
    return cam_from_lidar;
  };
  const auto to_given = [&origin](Rigid3d cam_from_local) {
    cam_from_local.translation -= cam_from_local.rotation * origin;
    return cam_from_local;
  };
  std::vector<std::pair<double, Rigid3d>> trajectory;
  Rigid3d body_from_lidar;
  if (!args.trajectory.empty()) {
    trajectory = io::ReadTrajectory(args.trajectory);
    body_from_lidar = io::ReadLidarMountYaml(args.lidar_mount);
  }
  // The camera centres in the clouds' frame (each rig camera's; the start's and, with
  // --perturb, the unperturbed reference's). A point farther than --max-range-m from all of
  // them (plus the search bound, or the probe's 2 m) is never rendered: it is dropped before
  // anything else uses the cloud, so that one absurd point (a 1e12 m glitch) does not move the
  // map-grid origin or enter the incidence fit and the surface classes.
  std::vector<Eigen::Vector3d> camera_centres;
  for (const Rigid3d& pose : {start, reference}) {
    if (rig_mode) {
      for (const Rigid3d& cam_from_rig : rig_yaml.cam_from_rig) {
        camera_centres.push_back((cam_from_rig * pose).Inverse().translation);
      }
    } else {
      camera_centres.push_back(pose.Inverse().translation);
    }
  }
  const double keep_within_m = args.max_range_m + std::max(args.bound_m, 2.0);
  std::vector<mi::LidarPoints> clouds;
  nlohmann::json incidence_json = nlohmann::json::array();
  nlohmann::json clouds_json = nlohmann::json::array();
  for (const auto& [image_path, lidar_path] : pairs) {
    // Points with a non-finite coordinate or intensity (a scanner's "no return") could never
    // be rendered: dropped and counted, as the far ones below.
    io::ReadOptions read_options;
    read_options.skip_invalid_points = true;
    io::ReadStats read_stats;
    io::PointCloud cloud = io::ReadPointCloud(lidar_path, read_options, &read_stats);
    const size_t not_finite = read_stats.num_skipped;
    if (not_finite > 0) {
      spdlog::info("{}: {} of {} points with a non-finite coordinate or intensity, dropped", lidar_path, not_finite,
                   not_finite + cloud.size());
    }
    if (cloud.empty()) throw InputError::Message(lidar_path, "cloud has no (finite) points");
    const size_t points_read = cloud.size() + not_finite;
    const size_t dropped = KeepNearAny(camera_centres, keep_within_m, &cloud);
    if (dropped > 0) {
      spdlog::info("{}: {} of {} points farther than {:.1f} m from the camera (--max-range-m + the search bound), "
                   "dropped",
                   lidar_path, dropped, points_read, keep_within_m);
    }
    clouds_json.push_back({{"lidar", lidar_path},
                           {"points_read", points_read},
                           {"points_not_finite", not_finite},
                           {"points_beyond_range", dropped}});
    if (cloud.empty()) {
      throw InputError::Message(lidar_path, "no point within " + std::to_string(keep_within_m) +
                                                " m of the camera (--max-range-m + the search bound): is the "
                                                "start pose (--initial, the calibration) one of this cloud?");
    }
    if (clouds.empty()) {
      origin = io::LocalOrigin(cloud.points);
      if (!origin.isZero()) {
        spdlog::info("{}: map-grid coordinates, registered relative to ({:.0f}, {:.0f}, {:.0f})",
                     lidar_path, origin.x(), origin.y(), origin.z());
      }
    }
    if (!origin.isZero()) {
      for (Eigen::Vector3d& p : cloud.points) p -= origin;
    }
    if (options.render.representation == mi::Representation::kIntensity &&
        !cloud.has_intensity()) {
      throw InputError::Message(lidar_path, std::string("cloud has no intensity, which --representation intensity") +
                                                (args.representation_given ? "" : " (the default)") +
                                                " needs; use --representation depth or points (points are "
                                                "compared over the whole image)");
    }
    if (options.render.representation == mi::Representation::kIntensity) {
      // A LAS file always has the field; a cloud without a measured intensity holds one value
      // (often 0) in it, and an image of one grey level has no information to register by.
      const auto [lowest, highest] = std::minmax_element(cloud.intensity.begin(), cloud.intensity.end());
      if (*lowest == *highest) {
        throw InputError::Message(lidar_path, "every point's intensity is " + fmt::format("{:g}", *lowest) +
                                                  ": no intensity to register by, which --representation intensity" +
                                                  (args.representation_given ? "" : " (the default)") +
                                                  " needs; use --representation depth or points");
      }
    }
    // The scanner's centre for each point, in the local frame: given (the options, else the
    // cloud's sidecar CLOUD.scanner.yaml, io::ReadScannerSidecar), from the trajectory at the
    // point's time, or the origin of a KITTI scan (its sensor frame).
    std::optional<Eigen::Vector3d> scanner_origin;
    if (!args.scanner_origin.empty()) {
      scanner_origin = Eigen::Vector3d(args.scanner_origin[0], args.scanner_origin[1], args.scanner_origin[2]);
    }
    const std::vector<std::pair<double, Rigid3d>>* scanner_trajectory = &trajectory;
    const Rigid3d* scanner_mount = &body_from_lidar;
    std::string trajectory_named = "the --trajectory " + args.trajectory;
    std::string scanner_from = !args.scanner_origin.empty() ? "--scanner-origin"
                               : !args.trajectory.empty()   ? "--trajectory " + args.trajectory
                                                            : "";
    std::vector<std::pair<double, Rigid3d>> sidecar_trajectory;
    Rigid3d sidecar_mount;
    // (Read only where it is used: a depth or points image is not corrected.)
    if ((correct_incidence || args.incidence_correction == "on") && scanner_from.empty()) {
      if (const std::optional<io::ScannerSidecar> sidecar = io::ReadScannerSidecar(lidar_path)) {
        scanner_from = sidecar->path;
        scanner_origin = sidecar->origin;
        if (!sidecar->trajectory.empty()) {
          sidecar_trajectory = io::ReadTrajectory(sidecar->trajectory);
          sidecar_mount = io::ReadLidarMountYaml(sidecar->lidar_mount);
          scanner_trajectory = &sidecar_trajectory;
          scanner_mount = &sidecar_mount;
          trajectory_named = "the trajectory " + sidecar->trajectory + " (named in " + sidecar->path + ")";
        }
        spdlog::info("{}: the scanner's position from {}", lidar_path, sidecar->path);
      }
    }
    mi::IncidenceCorrection correction;
    if (scanner_origin) {
      const Eigen::Vector3d at = *scanner_origin - origin;
      correction.scanner = [at](size_t) -> Eigen::Vector3d { return at; };
    } else if (!scanner_trajectory->empty()) {
      if (!cloud.has_time()) {
        throw InputError::Message(lidar_path, "has no per-point time, which " + trajectory_named +
                                                  " needs to place the scanner of each point");
      }
      // A cloud whose times the trajectory does not span (another time base, another drive)
      // would be corrected with the scanner at the trajectory's ends.
      const auto [first, last] = std::minmax_element(cloud.time.begin(), cloud.time.end());
      if (*first < scanner_trajectory->front().first || *last > scanner_trajectory->back().first) {
        throw InputError::Message(lidar_path, "point times " + std::to_string(*first) + " .. " + std::to_string(*last) +
                                                  " s are not within " + trajectory_named + "'s " +
                                                  std::to_string(scanner_trajectory->front().first) + " .. " +
                                                  std::to_string(scanner_trajectory->back().first) + " s");
      }
      correction.scanner = [&](size_t i) -> Eigen::Vector3d {
        // (An explicit return type: `.translation - origin` would return an Eigen expression
        // referring to the destroyed temporary.)
        return (io::InterpolateTrajectory(*scanner_trajectory, cloud.time[i]) * *scanner_mount).translation - origin;
      };
    } else if (fs::path(lidar_path).extension() == ".bin") {
      correction.scanner = [&origin](size_t) -> Eigen::Vector3d { return -origin; };
      scanner_from = "the KITTI scan's origin";
    }
    if (args.incidence_correction == "on" && !correction.scanner) {
      throw InputError::Message("--incidence-correction", "on needs the scanner's position of " + lidar_path +
                                                              ": --scanner-origin, --trajectory with "
                                                              "--lidar-mount, a sidecar " +
                                                              io::ScannerSidecarPath(lidar_path) +
                                                              ", or a KITTI .bin scan");
    }
    std::vector<Eigen::Vector3f> normals;  // the local planes, when computed for the correction
    if (correct_incidence && correction.scanner && cloud.has_intensity()) {
      correction.voxel_m = static_cast<float>(args.surface_voxel_m);
      mi::IncidenceFit fit;
      clouds.push_back(mi::PrepareLidarPoints(cloud, correction, &fit, &normals));
      spdlog::info("{}: intensity corrected for the angle of incidence: I / cos^{:.2f} (fitted to {} points, "
                   "correlation {:.2f})",
                   lidar_path, fit.exponent, fit.points, fit.correlation);
      incidence_json.push_back({{"lidar", lidar_path},
                                {"scanner_from", scanner_from},
                                {"exponent", fit.exponent},
                                {"correlation", fit.correlation},
                                {"points", fit.points}});
    } else {
      clouds.push_back(mi::PrepareLidarPoints(cloud));
      incidence_json.push_back(nullptr);
    }
    if (args.surface_classes && options.render.representation == mi::Representation::kIntensity) {
      // The metric conditioned on the surface: ground (a plane within 45° of the cloud's z
      // axis) against the rest (bench/RESULTS.md "Surface classes").
      const std::vector<uint8_t> classes =
          mi::SurfaceClasses(clouds.back().points_in_lidar, Eigen::Vector3f::UnitZ(),
                             static_cast<float>(args.surface_voxel_m));
      mi::EncodeSurfaceClasses(classes, &clouds.back());
      const size_t horizontal = static_cast<size_t>(std::count(classes.begin(), classes.end(), 0));
      spdlog::info("{}: surface classes: {} points on horizontal planes, {} others", lidar_path,
                   horizontal, classes.size() - horizontal);
    }
    if (orientation_sectors > 0) {
      // The metric conditioned on which way each surface faces, seen from the start's camera
      // (rig) centre (bench/RESULTS.md "Orientation classes").
      const Rigid3d cam_from_local = to_local(start);
      const Eigen::Vector3f viewpoint =
          cam_from_local.Inverse().translation.cast<float>();
      std::vector<size_t> per_class;
      if (normals.empty()) {
        mi::EncodeOrientationClasses(viewpoint, orientation_sectors,
                                     static_cast<float>(args.surface_voxel_m), &clouds.back(), &per_class);
      } else {
        mi::EncodeOrientationClasses(viewpoint, orientation_sectors, normals, &clouds.back(), &per_class);
      }
      std::string counts;
      for (size_t c = 2; c + 1 < per_class.size(); ++c) counts += (c > 2 ? "/" : "") + std::to_string(per_class[c]);
      spdlog::info("{}: orientation classes: {} facing up, {} facing down, {} steep by azimuth, {} "
                   "without a plane",
                   lidar_path, per_class[0], per_class[1], counts, per_class.back());
    }
    spdlog::info("read {}: {} points{}", lidar_path, cloud.size(),
                 cloud.has_intensity() ? " with intensity" : "");
  }
  const Rigid3d start_given = start;
  start = to_local(start);
  const Rigid3d reference_local = to_local(reference);
  std::vector<mi::Frame> frames;
  for (size_t i = 0; i < pairs.size(); ++i) {
    mi::Frame frame;
    // Frames are told apart by name in the calibration's used/rejected lists: an image given
    // for two frames (against two clouds) gets its index as well.
    const bool shared_image =
        std::count_if(pairs.begin(), pairs.end(), [&](const auto& p) { return p.first == pairs[i].first; }) > 1;
    frame.name = shared_image ? pairs[i].first + " #" + std::to_string(i) : pairs[i].first;
    frame.points = &clouds[i];
    if (rig_mode) {
      // The cameras that see the cloud at the start (a Ladybug's upward camera sees no
      // LiDAR); if none does, all of them, and the registration reports the missing overlap.
      constexpr size_t kMinViewPoints = 1000;
      std::vector<mi::View> all;
      for (size_t k = 0; k < rig_yaml.cameras.size(); ++k) {
        mi::View view = mi::MakeRigCameraView(rig_images[i][k], rig_yaml.cameras[k], rig_yaml.cam_from_rig[k],
                                              rig_paths[i][k]);
        view.name = rig_yaml.names[k];
        if (mi::CountPointsInView(clouds[i], view, start, options.render, kMinViewPoints) >= kMinViewPoints) {
          frame.views.push_back(view);
        } else {
          spdlog::info("{}: camera {} sees fewer than {} LiDAR points at the start, left out", pairs[i].first,
                       rig_yaml.names[k], kMinViewPoints);
        }
        all.push_back(std::move(view));
      }
      if (frame.views.empty()) frame.views = std::move(all);
      frames.push_back(std::move(frame));
      continue;
    }
    mi::ViewOptions frame_view_options = view_options;
    if (auto_headings && view_options.kind == mi::ViewKind::kPerspective &&
        camera.IsSpherical()) {
      frame_view_options.perspective_yaw_deg =
          mi::SelectPerspectiveHeadings(clouds[i], camera, start, view_options, options.render, 2);
      std::string list;
      for (double yaw : frame_view_options.perspective_yaw_deg) {
        list += (list.empty() ? "" : ", ") + std::to_string(static_cast<int>(std::lround(yaw)));
      }
      spdlog::info("{}: perspective cuts at headings {} deg", pairs[i].first, list);
    }
    frame.views = mi::MakeViews(images[i], camera, frame_view_options, pairs[i].first);
    frames.push_back(std::move(frame));
  }
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
    // pose: the issue's check against the calibration, also for a start not made by --perturb.
    out["pixel_offset_vs_calibration"] = offsets_against(to_local(cam_from_lidar_calibration));
  }
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
                  "rendering each pose; false = every pose rendered (the default until 2 Dec; "
                  "bench/RESULTS.md, \"Point samples as the default\")")
      ->capture_default_str();
  sub->add_option("--sample-block-px", args->sample_block_px,
                  "Point samples: each visible point sampled at its own projection, weighted "
                  "by its share of the covered pixels of its N x N block (the footprint decides "
                  "visibility only); 0 = at the pixel it won, weighted by its won pixels (the "
                  "default until session 18; bench/RESULTS.md, \"The footprint decides "
                  "visibility only\")")
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
