#include "mmba/registration/mi/job.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/io/kitti.h"
#include "mmba/io/point_cloud.h"
#include "mmba/io/text_reader.h"
#include "mmba/io/trajectory.h"
#include "mmba/registration/mi/result_json.h"

namespace mmba::registration::mi {
namespace {

namespace fs = std::filesystem;

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
  if (!Matrix4FromJson(json[key], v, &problem)) {
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

// PrepareJob's steps, in order: the policy and checks of the request, the frames' files, the
// images and camera (or rig), the views' kind, the start pose, the clouds, the frames.
class JobBuilder {
 public:
  explicit JobBuilder(const JobRequest& request)
      : request(request), view_options(request.view), view_name(request.view_name) {
    job.options = request.options;
  }
  void ApplyPolicy(bool log);
  std::vector<std::pair<std::string, std::string>> ListPairs() const;
  void ReadImagesAndCamera();
  void ResolveViews();
  void StartPose();
  void PrepareClouds();
  void PrepareCloud(const std::string& lidar_path);
  void MakeFrames();

  const JobRequest& request;
  Job job;
  RegistrationOptions& options = job.options;
  ViewOptions view_options;
  std::string view_name;
  bool correct_incidence = false;
  bool rig_mode = false;
  bool panorama = false;
  std::vector<std::pair<std::string, std::string>> pairs;
  std::vector<GrayImage> images;
  sensors::Camera& camera = job.camera;
  Rigid3d cam_from_lidar_calibration;
  bool have_calibration_pose = false;
  // With a rig: each frame's IMAGE is a pattern with {camera}, one image per rig camera
  // (rig_images[frame][camera]); the pose is rig_from_lidar.
  io::RigYaml& rig_yaml = job.rig;
  std::vector<std::vector<GrayImage>> rig_images;
  std::vector<std::vector<std::string>> rig_paths;
  Rigid3d start, reference;
  Eigen::Vector3d& origin = job.origin;
  std::vector<std::pair<double, Rigid3d>> trajectory;
  Rigid3d body_from_lidar;
  std::vector<Eigen::Vector3d> camera_centres;
  double keep_within_m = 0;
  std::vector<LidarPoints>& clouds = job.clouds;
  nlohmann::json& incidence_json = job.incidence_json;
  nlohmann::json& clouds_json = job.clouds_json;
  std::vector<Frame>& frames = job.frames;
  Rigid3d ToLocal(const Rigid3d& pose) const { return job.ToLocal(pose); }
};

void JobBuilder::ApplyPolicy(bool log) {
  // A points image is constant over the overlap (MI = 0 there): points are compared over the
  // whole image unless --region was given.
  if (options.render.representation == Representation::kPoints && !request.region_given) {
    options.metric.region = Region::kWholeImage;
    job.region_note = "whole: the default for --representation points (its LiDAR image is constant over the overlap)";
    if (log) spdlog::info("--representation points: the metric over the whole image (--region whole)");
  }
  if (request.surface_classes && options.render.representation == Representation::kIntensity) {
    options.metric.lidar_classes = 2;
  }
  // The default: conditioned on the orientation where the intensity is compared and no other
  // classes were asked for.
  job.orientation_sectors =
      request.orientation_classes >= 0 ? request.orientation_classes
      : options.render.representation == Representation::kIntensity && !request.surface_classes
          ? kDefaultOrientationSectors
          : 0;
  if (job.orientation_sectors > 0) {
    if (request.surface_classes) {
      throw InputError::Message("--orientation-classes", "cannot be combined with --surface-classes "
                                                         "(both set the metric's classes)");
    }
    if (options.render.representation != Representation::kIntensity) {
      throw InputError::Message("--orientation-classes",
                                "conditions the intensity on the surface's orientation; it needs "
                                "--representation intensity");
    }
    // Facing up, facing down, the sectors, no plane.
    options.metric.lidar_classes = job.orientation_sectors + 3;
  }
  if (options.metric.region == Region::kOverlap &&
      options.render.representation == Representation::kPoints) {
    throw InputError::Message("--region", "overlap with --representation points has a constant "
                                          "LiDAR image (MI = 0); use --region whole (the default "
                                          "for points)");
  }
  std::string error;
  if (!options.Check(&error)) throw InputError::Message("options", error);
  if (!request.perturb.empty() && request.perturb.size() != 6) {
    throw InputError::Message("--perturb", "found " + std::to_string(request.perturb.size()) +
                                               " values, expected 6: tx,ty,tz,roll,pitch,yaw");
  }
  // Incidence correction (IncidenceCorrection): where the scanner's position is known.
  if (request.incidence_correction != "auto" && request.incidence_correction != "on" &&
      request.incidence_correction != "off") {
    throw InputError::Message("--incidence-correction",
                              "found '" + request.incidence_correction + "', expected auto, on or off");
  }
  if (!request.scanner_origin.empty() && request.scanner_origin.size() != 3) {
    throw InputError::Message("--scanner-origin", "found " + std::to_string(request.scanner_origin.size()) +
                                                      " values, expected 3: x,y,z in the cloud's frame");
  }
  if (request.trajectory.empty() != request.lidar_mount.empty()) {
    throw InputError::Message(request.trajectory.empty() ? "--lidar-mount" : "--trajectory",
                              "--trajectory and --lidar-mount go together (the scanner's centre at "
                              "a point's time is world_from_body(t) * body_from_lidar)");
  }
  if (!request.scanner_origin.empty() && !request.trajectory.empty()) {
    throw InputError::Message("--scanner-origin", "give either --scanner-origin or --trajectory, not both");
  }
  correct_incidence = request.incidence_correction != "off" &&
                                 options.render.representation == Representation::kIntensity;
  rig_mode = !request.rig.empty();
  if (rig_mode) {
    if (!request.camera.empty() || !request.kitti_calib.empty()) {
      throw InputError::Message("--rig", "give either --rig or one of --camera/--kitti-calib, not both");
    }
    if (request.view_name != "image" && !request.view_auto) {
      throw InputError::Message("--view", "found '" + request.view_name + "' with --rig; a rig's cameras are "
                                                                  "registered as their own images (image)");
    }
  } else if (request.camera.empty() == request.kitti_calib.empty()) {
    throw InputError::Message("--camera/--kitti-calib", "give exactly one of them (or --rig)");
  }
  if (request.kitti_camera < 0 || request.kitti_camera > 3) {
    throw InputError::Message("--kitti-camera", "found " + std::to_string(request.kitti_camera) +
                                                    ", expected a KITTI camera index 0..3");
  }
}

// --image/--lidar pairs, then a list file's (IMAGE LIDAR per line).
std::vector<std::pair<std::string, std::string>> JobBuilder::ListPairs() const {
  // ---- Frames: --image/--lidar pairs or a list file (IMAGE LIDAR per line).
  std::vector<std::pair<std::string, std::string>> pairs;
  if (request.image.size() != request.lidar.size()) {
    throw InputError::Message("--image/--lidar", std::to_string(request.image.size()) +
                                                     " images but " +
                                                     std::to_string(request.lidar.size()) +
                                                     " clouds; give them in pairs");
  }
  for (size_t i = 0; i < request.image.size(); ++i) pairs.emplace_back(request.image[i], request.lidar[i]);
  if (!request.list.empty()) {
    // IMAGE LIDAR per line; relative paths are relative to the list file's folder. A file
    // not found is named with the list's line (with --rig, IMAGE is a pattern: checked later).
    const std::string text = io::ReadWholeFile(request.list);
    const fs::path base = fs::path(request.list).parent_path();
    io::LineCursor cursor(text, request.list);
    std::string_view line_text;
    const size_t before = pairs.size();
    while (cursor.Next(&line_text)) {
      const std::string where = request.list + ":" + std::to_string(cursor.line_number());
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
      throw InputError::Message(request.list, "no frames in the list (expected lines IMAGE LIDAR; blank lines and "
                                           "lines starting with # are skipped)");
    }
  }
  if (pairs.empty()) {
    throw InputError::Message("--image/--lidar", "no frame given (use --image and --lidar, "
                                                 "or --list)");
  }
  return pairs;
}

void JobBuilder::ReadImagesAndCamera() {
  // With --rig: each frame's IMAGE is a pattern with {camera}, one image per rig camera
  // (rig_images[frame][camera]); the pose is rig_from_lidar.
  if (rig_mode) {
    rig_yaml = io::ReadRigYaml(request.rig);
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
        rig_images.back().push_back(ReadGrayImage(path));
        rig_paths.back().push_back(path);
        const sensors::Camera& c = rig_yaml.cameras[k];
        if (rig_images.back().back().width != static_cast<int>(c.width) ||
            rig_images.back().back().height != static_cast<int>(c.height)) {
          throw InputError::Message(path, "image is " + std::to_string(rig_images.back().back().width) + "x" +
                                              std::to_string(rig_images.back().back().height) + " but camera " +
                                              rig_yaml.names[k] + " of " + request.rig + " is " +
                                              std::to_string(c.width) + "x" + std::to_string(c.height));
        }
      }
    }
    if (rig_yaml.rig_from_lidar) {
      cam_from_lidar_calibration = *rig_yaml.rig_from_lidar;
      have_calibration_pose = true;
    }
  } else {
    for (const auto& [image_path, lidar_path] : pairs) images.push_back(ReadGrayImage(image_path));
    if (!request.kitti_calib.empty()) {
      const io::KittiCalibration calibration = io::ReadKittiCalibration(request.kitti_calib, request.kitti_camera);
      const io::KittiCameraPose kitti =
          io::KittiCamera(calibration, request.kitti_camera, images[0].width, images[0].height,
                          request.kitti_calib);
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
              << request.kitti_camera << " in " << request.kitti_calib << " is (" << cx << ", " << cy
              << "): expected an image of about " << std::lround(2 * cx) << "x" << std::lround(2 * cy)
              << " (2 cx x 2 cy, within 20 %; KITTI: about 1242x375)";
          throw InputError::Message(pairs[i].first, why.str());
        }
      }
      cam_from_lidar_calibration = kitti.cam_from_lidar;
      have_calibration_pose = true;
    } else {
      const io::CameraYaml camera_yaml = io::ReadCameraYaml(request.camera);
      camera = camera_yaml.camera;
      if (camera_yaml.cam_from_lidar) {
        cam_from_lidar_calibration = *camera_yaml.cam_from_lidar;
        have_calibration_pose = true;
      }
    }
  }
}

// The views' kind: image = the image with its own camera; equirect (its synonym),
// perspective and cube = the whole panorama or cuts of it, for an EQUIRECTANGULAR camera only.
void JobBuilder::ResolveViews() {
  panorama = !rig_mode && camera.model_id == sensors::CameraModelId::kEquirectangular;
  if (request.view_auto) {
    // Perspective cuts (the paper's views, with --headings auto) registered more simulated
    // panoramas than the whole panorama: 70 against 56 ok of 80, neither with a wrong ok
    // (bench/RESULTS.md, "the must-show through the issue's command line").
    view_options.kind = panorama ? ViewKind::kPerspective : ViewKind::kImage;
    view_name = panorama ? "perspective" : "image";
    if (panorama) spdlog::info("--view auto: perspective cuts of the panorama");
  }
  if (!rig_mode && view_name != "image" && !panorama) {
    throw InputError::Message("--view", "found '" + view_name + "' but the camera of " +
                                            (request.camera.empty() ? request.kitti_calib : request.camera) + " is " +
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
}

void JobBuilder::StartPose() {
  const std::string pose_key = rig_mode ? "rig_from_lidar" : "cam_from_lidar";
  start = cam_from_lidar_calibration;
  if (!request.initial.empty()) {
    start = ReadPoseJson(request.initial, pose_key);
  } else if (!have_calibration_pose) {
    throw InputError::Message(rig_mode ? request.rig : request.camera,
                              "no " + pose_key + " in the " + (rig_mode ? "rig" : "camera") +
                                  " file and no --initial POSE.json: the start pose is unknown");
  }
  reference = start;
  if (!request.perturb.empty()) {
    Vector6d perturb;
    for (int i = 0; i < 6; ++i) perturb[i] = request.perturb[i];
    start = ApplyCorrection(start, perturb);
  }
}

void JobBuilder::PrepareClouds() {
  // Clouds in map-grid coordinates (a georeferenced mobile-mapping cloud in UTM with the
  // camera's pose in the grid): the renderer holds points as floats, which resolve 0.5 m at
  // 5,000 km. Every cloud is moved by −o (o = io::LocalOrigin of the first cloud: its
  // centroid rounded to whole km, 0 for a cloud in its sensor's frame, which is then used as
  // given), the poses by cam_from_local = cam_from_lidar · [I | o], and the result back. The
  // correction (a shift of the camera centre and a turn about it, in the cloud's axes) and its
  // covariance do not change under a shift of the cloud's frame.
  if (!request.trajectory.empty()) {
    trajectory = io::ReadTrajectory(request.trajectory);
    body_from_lidar = io::ReadLidarMountYaml(request.lidar_mount);
  }
  // The camera centres in the clouds' frame (each rig camera's; the start's and, with
  // --perturb, the unperturbed reference's). A point farther than --max-range-m from all of
  // them (plus the search bound, or the probe's 2 m) is never rendered: it is dropped before
  // anything else uses the cloud, so that one absurd point (a 1e12 m glitch) does not move the
  // map-grid origin or enter the incidence fit and the surface classes.
  for (const Rigid3d& pose : {start, reference}) {
    if (rig_mode) {
      for (const Rigid3d& cam_from_rig : rig_yaml.cam_from_rig) {
        camera_centres.push_back((cam_from_rig * pose).Inverse().translation);
      }
    } else {
      camera_centres.push_back(pose.Inverse().translation);
    }
  }
  keep_within_m = options.render.max_range_m + std::max(options.bound_translation_m, 2.0);

  for (const auto& [image_path, lidar_path] : pairs) PrepareCloud(lidar_path);
}

void JobBuilder::PrepareCloud(const std::string& lidar_path) {
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
  if (options.render.representation == Representation::kIntensity &&
      !cloud.has_intensity()) {
    throw InputError::Message(lidar_path, std::string("cloud has no intensity, which --representation intensity") +
                                              (request.representation_given ? "" : " (the default)") +
                                              " needs; use --representation depth or points (points are "
                                              "compared over the whole image)");
  }
  if (options.render.representation == Representation::kIntensity) {
    // A LAS file always has the field; a cloud without a measured intensity holds one value
    // (often 0) in it, and an image of one grey level has no information to register by.
    const auto [lowest, highest] = std::minmax_element(cloud.intensity.begin(), cloud.intensity.end());
    if (*lowest == *highest) {
      throw InputError::Message(lidar_path, "every point's intensity is " + fmt::format("{:g}", *lowest) +
                                                ": no intensity to register by, which --representation intensity" +
                                                (request.representation_given ? "" : " (the default)") +
                                                " needs; use --representation depth or points");
    }
  }
  // The scanner's centre for each point, in the local frame: given (the options, else the
  // cloud's sidecar CLOUD.scanner.yaml, io::ReadScannerSidecar), from the trajectory at the
  // point's time, or the origin of a KITTI scan (its sensor frame).
  std::optional<Eigen::Vector3d> scanner_origin;
  if (!request.scanner_origin.empty()) {
    scanner_origin = Eigen::Vector3d(request.scanner_origin[0], request.scanner_origin[1], request.scanner_origin[2]);
  }
  const std::vector<std::pair<double, Rigid3d>>* scanner_trajectory = &trajectory;
  const Rigid3d* scanner_mount = &body_from_lidar;
  std::string trajectory_named = "the --trajectory " + request.trajectory;
  std::string scanner_from = !request.scanner_origin.empty() ? "--scanner-origin"
                             : !request.trajectory.empty()   ? "--trajectory " + request.trajectory
                                                          : "";
  std::vector<std::pair<double, Rigid3d>> sidecar_trajectory;
  Rigid3d sidecar_mount;
  // (Read only where it is used: a depth or points image is not corrected.)
  if ((correct_incidence || request.incidence_correction == "on") && scanner_from.empty()) {
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
  IncidenceCorrection correction;
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
    correction.scanner = [&o = origin](size_t) -> Eigen::Vector3d { return -o; };
    scanner_from = "the KITTI scan's origin";
  }
  if (request.incidence_correction == "on" && !correction.scanner) {
    throw InputError::Message("--incidence-correction", "on needs the scanner's position of " + lidar_path +
                                                            ": --scanner-origin, --trajectory with "
                                                            "--lidar-mount, a sidecar " +
                                                            io::ScannerSidecarPath(lidar_path) +
                                                            ", or a KITTI .bin scan");
  }
  std::vector<Eigen::Vector3f> normals;  // the local planes, when computed for the correction
  if (correct_incidence && correction.scanner && cloud.has_intensity()) {
    correction.voxel_m = static_cast<float>(request.surface_voxel_m);
    IncidenceFit fit;
    clouds.push_back(PrepareLidarPoints(cloud, correction, &fit, &normals));
    spdlog::info("{}: intensity corrected for the angle of incidence: I / cos^{:.2f} (fitted to {} points, "
                 "correlation {:.2f})",
                 lidar_path, fit.exponent, fit.points, fit.correlation);
    incidence_json.push_back({{"lidar", lidar_path},
                              {"scanner_from", scanner_from},
                              {"exponent", fit.exponent},
                              {"correlation", fit.correlation},
                              {"points", fit.points}});
  } else {
    clouds.push_back(PrepareLidarPoints(cloud));
    incidence_json.push_back(nullptr);
  }
  if (request.surface_classes && options.render.representation == Representation::kIntensity) {
    // The metric conditioned on the surface: ground (a plane within 45° of the cloud's z
    // axis) against the rest (bench/RESULTS.md "Surface classes").
    const std::vector<uint8_t> classes =
        SurfaceClasses(clouds.back().points_in_lidar, Eigen::Vector3f::UnitZ(),
                           static_cast<float>(request.surface_voxel_m));
    EncodeSurfaceClasses(classes, &clouds.back());
    const size_t horizontal = static_cast<size_t>(std::count(classes.begin(), classes.end(), 0));
    spdlog::info("{}: surface classes: {} points on horizontal planes, {} others", lidar_path,
                 horizontal, classes.size() - horizontal);
  }
  if (job.orientation_sectors > 0) {
    // The metric conditioned on which way each surface faces, seen from the start's camera
    // (rig) centre (bench/RESULTS.md "Orientation classes").
    const Rigid3d cam_from_local = ToLocal(start);
    const Eigen::Vector3f viewpoint =
        cam_from_local.Inverse().translation.cast<float>();
    std::vector<size_t> per_class;
    if (normals.empty()) {
      EncodeOrientationClasses(viewpoint, job.orientation_sectors,
                                   static_cast<float>(request.surface_voxel_m), &clouds.back(), &per_class);
    } else {
      EncodeOrientationClasses(viewpoint, job.orientation_sectors, normals, &clouds.back(), &per_class);
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

void JobBuilder::MakeFrames() {
  for (size_t i = 0; i < pairs.size(); ++i) {
    Frame frame;
    // Frames are told apart by name in the calibration's used/rejected lists: an image given
    // for two frames (against two clouds) gets its index as well.
    const bool shared_image =
        std::count_if(pairs.begin(), pairs.end(), [&](const auto& p) { return p.first == pairs[i].first; }) > 1;
    frame.name = shared_image ? pairs[i].first + " #" + std::to_string(i) : pairs[i].first;
    frame.points = &clouds[i];
    if (rig_mode) {
      // The cameras that see the cloud at the start (a Ladybug's upward camera sees no
      // LiDAR); if none does, all of them, and the registration reports the missing overlap.
      std::vector<View> all;
      for (size_t k = 0; k < rig_yaml.cameras.size(); ++k) {
        View view = MakeRigCameraView(rig_images[i][k], rig_yaml.cameras[k], rig_yaml.cam_from_rig[k],
                                      rig_paths[i][k]);
        view.name = rig_yaml.names[k];
        if (RigCameraSeesCloud(view, clouds[i], start, options.render)) {
          frame.views.push_back(view);
        } else {
          spdlog::info("{}: camera {} sees fewer than {} LiDAR points at the start, left out", pairs[i].first,
                       rig_yaml.names[k], kMinRigViewPoints);
        }
        all.push_back(std::move(view));
      }
      if (frame.views.empty()) frame.views = std::move(all);
      frames.push_back(std::move(frame));
      continue;
    }
    if (request.headings_auto && view_options.kind == ViewKind::kPerspective && camera.IsSpherical()) {
      std::vector<double> headings;
      frame.views = AutoPerspectiveViews(images[i], camera, clouds[i], start, view_options, options.render,
                                         pairs[i].first, &headings);
      std::string list;
      for (double yaw : headings) {
        list += (list.empty() ? "" : ", ") + std::to_string(static_cast<int>(std::lround(yaw)));
      }
      spdlog::info("{}: perspective cuts at headings {} deg", pairs[i].first, list);
    } else {
      frame.views = MakeViews(images[i], camera, view_options, pairs[i].first);
    }
    frames.push_back(std::move(frame));
  }
}

}  // namespace

std::vector<FramePaths> ListFrames(const JobRequest& request) {
  JobBuilder builder(request);
  builder.ApplyPolicy(true);
  std::vector<FramePaths> paths;
  for (const auto& [image, lidar] : builder.ListPairs()) paths.push_back({image, lidar});
  return paths;
}

Job PrepareJob(const JobRequest& request, std::vector<FramePaths> paths) {
  JobBuilder builder(request);
  builder.ApplyPolicy(false);
  for (const FramePaths& p : paths) builder.pairs.emplace_back(p.image, p.lidar);
  builder.ReadImagesAndCamera();
  builder.ResolveViews();
  builder.StartPose();
  builder.PrepareClouds();
  Job& job = builder.job;
  job.start_given = builder.start;
  job.start = job.ToLocal(builder.start);
  job.reference = job.ToLocal(builder.reference);
  job.have_calibration_pose = builder.have_calibration_pose;
  job.calibration = job.ToLocal(builder.cam_from_lidar_calibration);
  builder.start = job.start;
  builder.MakeFrames();
  job.rig_mode = builder.rig_mode;
  job.view_name = builder.view_name;
  job.paths = std::move(paths);
  return std::move(builder.job);
}

std::vector<View> AutoPerspectiveViews(const GrayImage& image, const sensors::Camera& camera,
                                       const LidarPoints& points, const Rigid3d& start,
                                       const ViewOptions& views, const RenderOptions& render,
                                       const std::string& name, std::vector<double>* headings) {
  ViewOptions cuts = views;
  cuts.perspective_yaw_deg = SelectPerspectiveHeadings(points, camera, start, views, render, kAutoHeadings);
  if (headings != nullptr) *headings = cuts.perspective_yaw_deg;
  return MakeViews(image, camera, cuts, name);
}

bool RigCameraSeesCloud(const View& view, const LidarPoints& points, const Rigid3d& rig_from_lidar,
                        const RenderOptions& render) {
  return CountPointsInView(points, view, rig_from_lidar, render, kMinRigViewPoints) >= kMinRigViewPoints;
}

}  // namespace mmba::registration::mi
