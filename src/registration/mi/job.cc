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
#include "mmba/io/camera_yaml.h"
#include "mmba/io_kitti/kitti.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/pose_json.h"
#include "mmba/io/text_reader.h"
#include "mmba/io/trajectory.h"
#include "mmba/registration/mi/result_json.h"
#include "registration/mi/job_builder.h"

namespace mmba::registration::mi {

using internal::JobBuilder;

namespace fs = std::filesystem;

namespace internal {

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
  job.orientation_sectors = OrientationSectors(request.orientation_classes,
                                                options.render.representation, request.surface_classes);
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
    options.metric.lidar_classes = OrientationClassCount(job.orientation_sectors);
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
  CheckScannerOptions();
  correct_incidence =
      request.incidence_correction != "off" && options.render.representation == Representation::kIntensity;
  rig_mode = !request.rig.empty();
  CheckCameraOptions();
}

// The incidence correction's options (IncidenceCorrection: where the scanner's position is
// known): --incidence-correction, --scanner-origin, --trajectory with --lidar-mount.
void JobBuilder::CheckScannerOptions() const {
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
}

// The camera's options: --rig, or one of --camera/--kitti-calib; --view; --kitti-camera.
void JobBuilder::CheckCameraOptions() const {
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
    // (bench/RESULTS.md, "Simulated panoramas through the command line").
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
    start = io::ReadPoseJson(request.initial, pose_key);
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

}  // namespace internal

int OrientationSectors(int asked, Representation representation, bool surface_classes) {
  // The default: conditioned on the orientation where the intensity is compared and no other
  // classes were asked for.
  if (asked >= 0) return asked;
  return representation == Representation::kIntensity && !surface_classes ? kDefaultOrientationSectors : 0;
}

int OrientationClassCount(int sectors) {
  return sectors + 3;  // facing up, facing down, the sectors, no plane
}

std::vector<FramePaths> ListFrames(const JobRequest& request) {
  JobBuilder builder(request);
  builder.ApplyPolicy(true);
  std::vector<FramePaths> paths;
  for (const auto& [image, lidar] : builder.ListPairs()) paths.push_back({image, lidar});
  return paths;
}

namespace {

// RegistrationOptions::edges "auto": on where each cloud is a LiDAR sweep about its own origin
// (no map-grid origin, no scanner given by --scanner-origin, a trajectory or a sidecar) and the
// camera is perspective (not a panorama, not a rig): the geometric term's rings are found
// about the cloud's origin.
void ResolveEdges(const JobRequest& request, Job* job) {
  if (job->options.edges != "auto") return;
  bool sweeps = !job->rig_mode && job->view_name == "image" && !job->camera.IsSpherical() &&
                job->origin.isZero() && request.scanner_origin.empty() && request.trajectory.empty();
  for (const FramePaths& p : job->paths) {
    if (sweeps && io::ReadScannerSidecar(p.lidar)) sweeps = false;
  }
  job->options.edges = sweeps ? "on" : "off";
}

}  // namespace

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
  ResolveEdges(request, &job);
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

RegistrationResult RegisterJob(const Job& job, Rigid3d* cam_from_local) {
  RegistrationResult result;
  if (job.options.edges == "on") {
    result = RegisterEdges(job.frames, job.start, job.options);
  } else if (job.frames.size() == 1) {
    result = RegisterFrames(job.frames, job.start, job.options);
  } else {
    RigOptions rig;
    rig.registration = job.options;
    result = RegisterRig(job.frames, job.start, rig);
  }
  *cam_from_local = result.cam_from_lidar;
  result.cam_from_lidar = job.ToGiven(result.cam_from_lidar);
  for (RegistrationResult& r : result.frame_results) r.cam_from_lidar = job.ToGiven(r.cam_from_lidar);
  return result;
}

}  // namespace mmba::registration::mi
