// The initialisation step "MI → camera corrections": photos and the rig's stitched
// panoramas registered to the static LiDAR by mutual information (Wang, Ferrie & Macfarlane,
// CVPRW 2012; `mmba register-mi`'s library call with its default settings, not a copy), and
// register-mi result files read as weighted pose priors (registration/mi/mi_prior.h).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <utility>

#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/core/error.h"
#include "mmba/core/progress.h"
#include "mmba/io/pose_json.h"
#include "mmba/io/text_reader.h"
#include "mmba/io_kitti/kitti.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_prior.h"
#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/result_json.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;
namespace mi = registration::mi;
using json = nlohmann::json;

namespace {

/// The status of a register-mi result file: "ok", or any other text (failed, unverified …).
enum class MiFileStatus { kOk, kNotOk };
MiFileStatus ParseMiFileStatus(const json& j) {
  return j.value("status", "") == "ok" ? MiFileStatus::kOk : MiFileStatus::kNotOk;
}

/// The result in `file` as a pose prior; false with `why` when it is not usable.
bool ParseMiResultFile(const std::string& file, MiResult* result, std::string* why) {
  json j;
  io::RequireRegularFile(file);
  try {
    std::ifstream in(file);
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(file, 0, "JSON", e.what(), "a register-mi result");
  }
  if (!j.is_object()) throw InputError(file, 0, "JSON", j.type_name(), "a register-mi result (an object)");
  if (ParseMiFileStatus(j) != MiFileStatus::kOk || !j.value("covariance_valid", false)) {
    *why = "status " + j.value("status", std::string("?")) + (j.value("covariance_valid", false) ? "" : ", no valid covariance");
    return false;
  }
  double m[16];
  std::string problem = "missing";
  if (!j.contains("cam_from_lidar") || !io::Matrix4FromJson(j["cam_from_lidar"], m, &problem)) {
    throw InputError(file, 0, "cam_from_lidar", problem, "16 numbers (4x4 row-major) or 4 rows of 4 numbers");
  }
  if (!j.contains("covariance") || !j["covariance"].is_array() || j["covariance"].size() != 6) {
    throw InputError(file, 0, "covariance", "missing or wrong size", "a 6x6 covariance");
  }
  try {
    result->cam_from_world = io::RigidFromRowMajor4x4(m, file, "cam_from_lidar");
    for (int a = 0; a < 6; ++a) {
      if (!j["covariance"][a].is_array() || j["covariance"][a].size() != 6) {
        throw InputError(file, 0, "covariance[" + std::to_string(a) + "]", "not 6 numbers", "a 6x6 covariance");
      }
      for (int b = 0; b < 6; ++b) result->covariance(a, b) = j["covariance"][a][b].get<double>();
    }
  } catch (const json::exception& e) {
    throw InputError(file, 0, "cam_from_lidar/covariance", e.what(), "numbers");
  }
  Eigen::Matrix<double, 6, 6> sqrt_information;
  if (!mi::MiPosePrior::SqrtInformation(result->covariance, &sqrt_information)) {
    *why = "covariance not symmetric positive definite";
    return false;
  }
  result->source = file;
  return true;
}

}  // namespace

bool ReadMiResultFile(JointState* s, const std::string& file, MiResult* result) {
  if (!fs::exists(file)) return false;
  std::string why;
  if (ParseMiResultFile(file, result, &why)) return true;
  s->warnings.push_back("MI result " + file + " not used: " + why);
  return false;
}

namespace {

/// What one MI task registers: a photo, a rig frame's stitched panorama, or a rig frame's own
/// images (mi_views: cameras).
enum class TaskKind { kPhoto, kPanorama, kRigCameras };
/// "photo", "panorama", "rig cameras" (report.json `mi_registration[].kind`).
const char* TaskKindName(TaskKind kind) {
  switch (kind) {
    case TaskKind::kPhoto: return "photo";
    case TaskKind::kPanorama: return "panorama";
    case TaskKind::kRigCameras: return "rig cameras";
  }
  return "photo";
}

/// One image to register: its grey image, camera, start pose and where an "ok" goes.
struct MiTask {
  std::string name;   ///< image name (photos) or frame name (rig)
  TaskKind kind = TaskKind::kPhoto;
  std::string path;
  sensors::Camera camera;
  Rigid3d start;
  ImageId image_id{0};  ///< photos
  size_t frame = 0;     ///< rig
  bool mobile = false;  ///< registered against the mobile LiDAR's delivered cloud (mi_lidar: mobile)
  double time_s = 0.0;  ///< rig: the frame's time
  /// TaskKind::kRigCameras: the frame's images and their cameras' indices in the rig (`path`
  /// is the first).
  std::vector<std::string> view_paths;
  std::vector<size_t> view_cameras;
};

/// The views of one task against `points` from `start`: a photo is its own view; a stitched
/// panorama the perspective cuts where the LiDAR is (mi::AutoPerspectiveViews, as register-mi
/// --view perspective --headings auto); a rig frame's own images each a view through its camera
/// and cam_from_rig, those that do not see the points at the start (mi::RigCameraSeesCloud)
/// left out.
std::vector<mi::View> TaskViews(const MiTask& t, const std::vector<mi::GrayImage>& images, const mi::LidarPoints& points,
                                const Rigid3d& start, const RigBlock* rig, const Scene& scene,
                                const mi::RegistrationOptions& options) {
  if (t.kind == TaskKind::kPhoto) return mi::MakeViews(images[0], t.camera, mi::ViewOptions(), t.path);
  if (t.kind == TaskKind::kPanorama) {
    mi::ViewOptions views;
    views.kind = mi::ViewKind::kPerspective;
    return mi::AutoPerspectiveViews(images[0], t.camera, points, start, views, options.render, t.path, nullptr);
  }
  std::vector<mi::View> out;
  for (size_t v = 0; v < t.view_cameras.size(); ++v) {
    const size_t k = t.view_cameras[v];
    const sensors::Camera& camera = scene.Camera(rig->cameras[k]);
    mi::View view = mi::MakeRigCameraView(images[v], camera, scene.CamFromRig(rig->cameras[k]), t.view_paths[v]);
    if (mi::RigCameraSeesCloud(view, points, start, options.render)) out.push_back(std::move(view));
  }
  return out;
}

/// A registration's calibrated pixel σ, or null when its checks stopped before it was
/// measured (register-mi stops at the first failed check: −1 then).
json SigmaOrNull(double sigma_px) { return sigma_px >= 0 ? json(sigma_px) : json(nullptr); }

bool Wanted(const std::vector<std::string>& only, const std::string& name) {
  if (only.empty()) return true;
  const std::string stem = fs::path(name).stem().string();
  return std::find(only.begin(), only.end(), name) != only.end() || std::find(only.begin(), only.end(), stem) != only.end();
}

/// The static LiDAR's reference cloud within `radius` of any of the cameras, streamed, at most
/// `cap` points (an even subsample), with its intensity.
io::PointCloud CloudNear(const std::string& path, const std::vector<Eigen::Vector3d>& centres, double radius, size_t cap) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Eigen::Vector3d& c : centres) {
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  }
  lo.array() -= radius;
  hi.array() += radius;
  // The cameras in a horizontal grid of cells of `radius`: a point is tested against the
  // cameras of its cell and the 8 around it only (a drive has hundreds of frames).
  const auto cell = [&](const Eigen::Vector3d& p) {
    return std::make_pair(static_cast<int64_t>(std::floor((p.x() - lo.x()) / radius)),
                          static_cast<int64_t>(std::floor((p.y() - lo.y()) / radius)));
  };
  std::map<std::pair<int64_t, int64_t>, std::vector<Eigen::Vector3d>> grid;
  for (const Eigen::Vector3d& c : centres) grid[cell(c)].push_back(c);
  io::PointCloud out;
  bool intensity = true;
  io::StreamPointCloud(path, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t first, size_t) {
    if (first == 0) intensity = chunk.has_intensity();
    for (size_t i = 0; i < chunk.size(); ++i) {
      const Eigen::Vector3d& p = chunk.points[i];
      if (!((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all())) continue;
      bool near = false;
      const auto [cx, cy] = cell(p);
      for (int64_t dx = -1; dx <= 1 && !near; ++dx) {
        for (int64_t dy = -1; dy <= 1 && !near; ++dy) {
          const auto it = grid.find({cx + dx, cy + dy});
          if (it == grid.end()) continue;
          for (const Eigen::Vector3d& c : it->second) near = near || (p - c).squaredNorm() <= radius * radius;
        }
      }
      if (!near) continue;
      out.points.push_back(p);
      if (intensity) out.intensity.push_back(chunk.intensity[i]);
    }
  });
  if (out.size() > cap) {
    io::PointCloud thinned;
    const double step = static_cast<double>(out.size()) / cap;
    for (size_t k = 0; k < cap; ++k) {
      const size_t i = static_cast<size_t>(k * step);
      thinned.points.push_back(out.points[i]);
      if (intensity) thinned.intensity.push_back(out.intensity[i]);
    }
    out = std::move(thinned);
  }
  return out;
}

/// The points of `cloud` within `radius` of `centre` (and, when `window` > 0, captured
/// within `window` seconds of `time`).
io::PointCloud Crop(const io::PointCloud& cloud, const Eigen::Vector3d& centre, double radius, double time = 0.0,
                    double window = 0.0) {
  io::PointCloud out;
  for (size_t i = 0; i < cloud.size(); ++i) {
    if ((cloud.points[i] - centre).squaredNorm() > radius * radius) continue;
    if (window > 0 && std::abs(cloud.time[i] - time) > window) continue;
    out.points.push_back(cloud.points[i]);
    if (cloud.has_intensity()) out.intensity.push_back(cloud.intensity[i]);
    if (cloud.has_time()) out.time.push_back(cloud.time[i]);
  }
  return out;
}

/// The mobile LiDAR's delivered cloud (world frame as georeferenced by the GNSS/INS) near
/// rig frames (sorted by time): points within `radius` of a frame and captured within `window`
/// seconds of its time, streamed, with time and intensity. At most 2·`cap` points are held:
/// when that many are kept, every other one is dropped and from then on only every 2nd
/// candidate is considered (an even subsample whatever the cloud's size).
io::PointCloud MobileCloudNear(const std::string& path, const std::vector<std::pair<double, Eigen::Vector3d>>& frames,
                               double radius, double window, size_t cap) {
  io::PointCloud out;
  bool intensity = true;
  size_t stride = 1, candidates = 0;
  io::StreamPointCloud(path, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t first, size_t) {
    if (first == 0) intensity = chunk.has_intensity();
    if (!chunk.has_time()) throw InputError::Message(path, "no time per point: the mobile cloud cannot be cut by frame time");
    for (size_t i = 0; i < chunk.size(); ++i) {
      const double t = chunk.time[i];
      // `frames` sorted by time: the first frame that is not earlier than t − window.
      auto it = std::lower_bound(frames.begin(), frames.end(), t - window,
                                 [](const std::pair<double, Eigen::Vector3d>& f, double v) { return f.first < v; });
      bool near = false;
      for (; it != frames.end() && it->first <= t + window && !near; ++it) {
        near = (chunk.points[i] - it->second).squaredNorm() <= radius * radius;
      }
      if (!near || candidates++ % stride != 0) continue;
      out.points.push_back(chunk.points[i]);
      out.time.push_back(t);
      if (intensity) out.intensity.push_back(chunk.intensity[i]);
      if (out.size() >= 2 * cap) {
        size_t n = 0;
        for (size_t k = 0; k < out.size(); k += 2, ++n) {
          out.points[n] = out.points[k];
          out.time[n] = out.time[k];
          if (intensity) out.intensity[n] = out.intensity[k];
        }
        out.points.resize(n);
        out.time.resize(n);
        if (intensity) out.intensity.resize(n);
        stride *= 2;
      }
    }
  });
  return out;
}

/// register-mi --surface-voxel-m of the orientation classes and the incidence fit.
constexpr float kSurfaceVoxel = static_cast<float>(mi::kDefaultSurfaceVoxelM);
/// m: what a street-level image sees of a building's LiDAR.
constexpr double kRadius = 60.0;
/// LiDAR points held for the registrations at most.
constexpr size_t kMaxPoints = 8000000;
/// Rig frames in the joint MI rig calibration at most (the joint metric costs every frame's
/// render).
constexpr size_t kJointFrames = 8;

/// The rig's register-mi result files (one per frame, <frame>.json in mi_results) as frame
/// priors, or with mi_lidar: mobile as frame poses on the mobile LiDAR.
void ReadRigMiResults(JointState* s) {
  RigBlock& rig = *s->rig;
  const bool against_mobile = rig.config->mi_lidar == MiLidar::kMobile;
  for (size_t k = 0; k < rig.frame_names.size(); ++k) {
    const fs::path file = fs::path(rig.config->mi_results) / (rig.frame_names[k] + ".json");
    MiResult result;
    if (!ReadMiResultFile(s, file.string(), &result)) continue;
    if (against_mobile) {
      if (!s->mobile || !s->mobile->with_rig) {
        s->warnings.push_back("MI result " + file.string() + " not used: mi_lidar mobile, but no mobile LiDAR on the rig's vehicle");
        continue;
      }
      const FrameOnTrajectory& on = s->mobile->frames.at(k);
      rig.mi_mobile.push_back({k, on.weight, on.ins, result.cam_from_world, result.covariance, result.source});
      continue;
    }
    rig.mi.push_back(result);
    rig.mi_frame.push_back(k);
  }
  s->log.push_back("rig MI results: " + std::to_string(rig.mi.size() + rig.mi_mobile.size()) + " frame priors from " +
                   rig.config->mi_results + (against_mobile ? " (against the mobile LiDAR)" : ""));
}

/// One task per photo of mi_register (mi_only when given), from its current pose.
void AddPhotoTasks(const JointState& s, std::vector<MiTask>* tasks) {
  const PhotoCollection& p = *s.photos->config;
  for (const auto& [id, image] : s.photos->model.images) {
    if (!Wanted(p.mi_only, image.name)) continue;
    MiTask t;
    t.name = image.name;
    t.kind = TaskKind::kPhoto;
    t.path = (fs::path(p.images) / image.name).string();
    t.camera = s.scene.Camera(image.camera_id);
    t.start = s.scene.Image(id).cam_from_world;
    t.image_id = id;
    tasks->push_back(t);
  }
}

/// One task per rig frame of mi_register: its stitched panorama, or with mi_views: cameras its
/// own images. A frame without images is skipped with a warning.
void AddRigTasks(JointState* s, std::vector<MiTask>* tasks) {
  const RigBlock& rig = *s->rig;
  const bool cameras = rig.config->mi_views == MiViews::kCameras;
  for (size_t k = 0; k < rig.frame_names.size(); ++k) {
    if (!Wanted(rig.config->mi_only, rig.frame_names[k])) continue;
    MiTask t;
    if (cameras) {
      for (size_t c = 0; c < rig.camera_names.size(); ++c) {
        const std::string path = FindImage(rig.config->images, rig.frame_names[k] + "_" + rig.camera_names[c]);
        if (path.empty()) continue;
        t.view_paths.push_back(path);
        t.view_cameras.push_back(c);
      }
      if (t.view_paths.empty()) {
        s->warnings.push_back("rig frame " + rig.frame_names[k] + ": no image " + rig.frame_names[k] + "_<camera>.* in " +
                              rig.config->images + ", not registered by MI");
        continue;
      }
      t.kind = TaskKind::kRigCameras;
      t.path = t.view_paths.front();
    } else {
      t.path = FindImage(rig.config->panoramas, rig.frame_names[k]);
      if (t.path.empty()) {
        s->warnings.push_back("rig frame " + rig.frame_names[k] + ": no panorama " + rig.frame_names[k] + ".* in " +
                              rig.config->panoramas + ", not registered by MI");
        continue;
      }
      t.kind = TaskKind::kPanorama;
    }
    t.name = rig.frame_names[k];
    t.start = s->scene.RigFrame(FrameId(k));
    t.frame = k;
    t.mobile = rig.config->mi_lidar == MiLidar::kMobile;
    t.time_s = rig.frame_times[k];
    if (t.mobile && (!s->mobile || !s->mobile->with_rig)) {
      s->warnings.push_back("rig frame " + t.name + ": mi_lidar mobile, but no mobile LiDAR on the rig's vehicle: not registered by MI");
      continue;
    }
    tasks->push_back(t);
  }
}

/// A warning for each mi_only name of this stage's sensor that names no task.
void WarnUnmatchedOnly(JointState* s, MiStage stage, const std::vector<MiTask>& tasks) {
  for (const std::string& name : {std::string("photos"), std::string("rig")}) {
    if ((name == "photos") != (stage == MiStage::kPhotos)) continue;
    const std::vector<std::string>& only = name == "photos" ? (s->photos ? s->photos->config->mi_only : std::vector<std::string>())
                                                             : (s->rig ? s->rig->config->mi_only : std::vector<std::string>());
    for (const std::string& wanted : only) {
      const bool found = std::any_of(tasks.begin(), tasks.end(), [&](const MiTask& t) {
        return t.name == wanted || fs::path(t.name).stem().string() == wanted;
      });
      if (!found) s->warnings.push_back("mi_register of the " + name + ": '" + wanted + "' is not one of its images/frames");
    }
  }
}

/// Reads a task's images and checks their size against its cameras (a panorama: a full
/// equirectangular one, which sets the task's camera).
std::vector<mi::GrayImage> ReadTaskImages(const JointState& s, MiTask* t) {
  std::vector<mi::GrayImage> images;
  if (t->kind == TaskKind::kRigCameras) {
    for (size_t v = 0; v < t->view_paths.size(); ++v) {
      images.push_back(mi::ReadGrayImage(t->view_paths[v]));
      const mi::GrayImage& g = images.back();
      const sensors::Camera& camera = s.scene.Camera(s.rig->cameras[t->view_cameras[v]]);
      if (g.width != static_cast<int>(camera.width) || g.height != static_cast<int>(camera.height)) {
        throw InputError::Message(t->view_paths[v], "image is " + std::to_string(g.width) + "x" + std::to_string(g.height) +
                                                        " but its camera " + s.rig->camera_names[t->view_cameras[v]] + " is " +
                                                        std::to_string(camera.width) + "x" + std::to_string(camera.height));
      }
    }
    return images;
  }
  images.push_back(mi::ReadGrayImage(t->path));
  const mi::GrayImage& g = images.front();
  if (t->kind == TaskKind::kPanorama) {
    // A stitched panorama: EQUIRECTANGULAR in the rig frame, f = width / 2π (full sphere).
    if (g.width != 2 * g.height) {
      throw InputError::Message(t->path, "panorama is " + std::to_string(g.width) + "x" + std::to_string(g.height) +
                                             ", expected a full equirectangular panorama (width = 2 x height)");
    }
    t->camera.model_id = sensors::CameraModelId::kEquirectangular;
    t->camera.width = g.width;
    t->camera.height = g.height;
    t->camera.params = {g.width / (2.0 * M_PI), g.width / 2.0, g.height / 2.0};
  } else if (g.width != static_cast<int>(t->camera.width) || g.height != static_cast<int>(t->camera.height)) {
    throw InputError::Message(t->path, "image is " + std::to_string(g.width) + "x" + std::to_string(g.height) +
                                           " but its camera is " + std::to_string(t->camera.width) + "x" +
                                           std::to_string(t->camera.height));
  }
  return images;
}

/// This stage's registrations: their tasks and images, register-mi's options, the counts.
struct MiRun {
  std::vector<MiTask> tasks;
  std::vector<std::vector<mi::GrayImage>> images;  ///< per task
  mi::RegistrationOptions options;                 ///< register-mi's defaults
  int photo_sectors = 0;  ///< register-mi --orientation-classes of the photos (mi_orientation_classes)
  int rig_sectors = 0;    ///< … of the rig
  size_t ok = 0;          ///< registrations that gave a prior
  size_t done = 0;        ///< registrations run
};

/// A registration not attempted: its report entry (status failed, `reason`) and a warning.
void NotAttempted(JointState* s, json entry, const Rigid3d& start, const std::string& reason, const std::string& warning) {
  entry["status"] = "failed";
  entry["reason"] = reason;
  entry.erase("file");
  s->mi_registration.push_back(entry);
  s->mi_registered.push_back(start);
  s->warnings.push_back(warning + reason);
}

/// Task `i` against the static LiDAR points `near` (already cut to the task): its report entry,
/// its register-mi result file, and for a usable result ("ok" with a valid covariance) a pose
/// prior on the photo or the rig frame (a panorama's frame also starts at the MI pose: closer
/// than the GNSS/INS one when MI is "ok").
void RegisterOne(JointState* s, MiRun* run, size_t i, const io::PointCloud& near, const std::string& cloud_path) {
  const MiTask& t = run->tasks[i];
  mi::LidarPoints points = mi::PrepareLidarPoints(near);
  mi::RegistrationOptions task_options = run->options;
  const int sectors = t.kind == TaskKind::kPhoto ? run->photo_sectors : run->rig_sectors;
  if (sectors > 0 && points.has_intensity()) {
    // The metric conditioned on the surfaces' orientation, seen from the camera's start
    // centre (register-mi --orientation-classes).
    task_options.metric.lidar_classes =
        mi::EncodeOrientationClasses(CameraCentre(t.start).cast<float>(), sectors, kSurfaceVoxel, &points);
  }
  ++run->done;
  json entry = {{"image", t.name}, {"kind", TaskKindName(t.kind)}, {"file", "mi/" + fs::path(t.name).stem().string() + ".json"},
                {"lidar", "static"}};
  if (t.kind == TaskKind::kPhoto) entry["image_id"] = t.image_id.value;
  else entry["frame"] = t.frame;
  const std::string not_attempted = "MI registration of " + t.name + " not attempted: ";
  if (points.size() < 1000) {
    NotAttempted(s, entry, t.start, "only " + std::to_string(points.size()) + " LiDAR points within " + std::to_string(kRadius) + " m",
                 not_attempted);
    return;
  }
  mi::Frame frame;
  frame.name = t.name;
  frame.points = &points;
  frame.views = TaskViews(t, run->images[i], points, t.start, s->rig ? &*s->rig : nullptr, s->scene, task_options);
  if (frame.views.empty()) {
    NotAttempted(s, entry, t.start, "none of the frame's cameras sees " + std::to_string(mi::kMinRigViewPoints) +
                                        " LiDAR points at the start", not_attempted);
    return;
  }
  Timer one;
  const mi::RegistrationResult result = mi::RegisterFrames({frame}, t.start, task_options);
  json file = mi::ResultToJson(result, task_options, t.start);
  file["image"] = t.path;
  file["registered_by"] = "mmba adjust (mi_register), register-mi's default settings with --orientation-classes " +
                          std::to_string(sectors) + ", LiDAR = " + cloud_path;
  s->mi_files.emplace_back(fs::path(t.name).stem().string(), file);
  entry["status"] = result.status;
  entry["reason"] = result.reason;
  entry["correction"] = mi::CorrectionToJson(result.correction);
  entry["sigma_px"] = SigmaOrNull(result.checks.sigma_px_calibrated);
  entry["runtime_seconds"] = result.runtime_seconds;
  const bool usable = result.ok() && result.covariance_valid;
  entry["prior"] = usable;
  s->mi_registration.push_back(entry);
  s->mi_registered.push_back(result.cam_from_lidar);
  spdlog::info("adjust: MI {}/{} {}: {} ({:.1f} s){}", run->done, run->tasks.size(), t.name, result.status, one.ElapsedSeconds(),
               result.ok() ? "" : ": " + result.reason);
  if (!usable) return;
  ++run->ok;
  MiResult prior;
  prior.cam_from_world = result.cam_from_lidar;
  prior.covariance = result.covariance;
  prior.source = "mi/" + fs::path(t.name).stem().string() + ".json (registered by the adjustment)";
  if (t.kind == TaskKind::kPhoto) {
    prior.image_id = t.image_id;
    s->photos->mi.push_back(prior);
  } else {
    if (t.kind == TaskKind::kPanorama) s->scene.RigFrame(FrameId(t.frame)) = result.cam_from_lidar;
    s->rig->mi.push_back(prior);
    s->rig->mi_frame.push_back(t.frame);
  }
}

/// The tasks `fixed` against the static LiDAR's reference cloud (world frame), near the cameras.
void RegisterToStaticLidar(JointState* s, MiRun* run, const std::vector<size_t>& fixed) {
  const std::string& cloud_path = s->project->lidar_static.front().reference_cloud;
  std::vector<Eigen::Vector3d> centres;
  for (size_t i : fixed) centres.push_back(CameraCentre(run->tasks[i].start));
  const io::PointCloud cloud = CloudNear(cloud_path, centres, kRadius, kMaxPoints);
  if (!cloud.has_intensity()) {
    throw InputError::Message(cloud_path, "has no intensity, which the MI registration of mi_register compares with "
                                          "the images (register-mi --representation intensity)");
  }
  spdlog::info("adjust: MI registration of {} image(s) to {} ({} points within {:.0f} m)", fixed.size(), cloud_path,
               cloud.size(), kRadius);
  for (size_t i : fixed) RegisterOne(s, run, i, Crop(cloud, CameraCentre(run->tasks[i].start), kRadius), cloud_path);
}

/// A frame of the rig calibration dropped: its report entry and a warning.
void FrameNotUsed(JointState* s, const MiTask& t, const std::string& reason) {
  json entry = {{"image", t.name}, {"kind", TaskKindName(t.kind)}, {"lidar", "mobile"}, {"status", "failed"}, {"reason", reason}};
  s->mi_registration.push_back(entry);
  s->mi_registered.push_back(t.start);
  s->warnings.push_back("MI rig calibration: frame " + t.name + " not used: " + reason);
}

/// The mobile points of task `t`'s frame (near it in time and space) in the LiDAR's own frame
/// at the frame's time, with the scanner's centre when each was measured (in the same frame).
/// The delivered cloud was georeferenced with the nominal mounting, so the raw measurement is
/// p = (T_ins(t_p)·B_nominal)⁻¹·X; the vehicle's motion from t_p to t moves it to
/// (T_ins(t)·B)⁻¹·T_ins(t_p)·B·p under the current estimate B of the mounting (after the first
/// solve: the adjusted extrinsic). With B = B_nominal this is (T_ins(t)·B_nominal)⁻¹·X; a
/// mounting error δ in B shears the frame's points by δ × (the motion from t_p to t): 2 cm for
/// 0.2° over the 6 m a vehicle at 3 m/s drives in 2 s.
io::PointCloud FramePointsInLidar(const JointState& s, const MiTask& t, const io::PointCloud& cloud, double window,
                                  std::vector<Eigen::Vector3f>* scanner) {
  const MobileBlock& m = *s.mobile;
  io::PointCloud local = Crop(cloud, CameraCentre(t.start), kRadius, t.time_s, window);
  const Rigid3d body_from_lidar = m.body_from_vehicle * s.scene.Mount(m.mount);
  const Rigid3d lidar_from_world_t = (m.frames.at(t.frame).ins * body_from_lidar).Inverse();
  const Rigid3d mounting = body_from_lidar * m.body_from_lidar_nominal.Inverse();
  scanner->resize(local.size());
  for (size_t k = 0; k < local.size(); ++k) {
    const Rigid3d ins = InterpolateTrajectory(m.trajectory, local.time[k]);
    local.points[k] = lidar_from_world_t * (ins * (mounting * (ins.Inverse() * local.points[k])));
    (*scanner)[k] = (lidar_from_world_t * (ins * body_from_lidar).translation).cast<float>();
  }
  return local;
}

/// The frame's LiDAR points for MI: the intensity corrected for the angle of incidence, I /
/// cos^k with k fitted to the frame's points (register-mi --incidence-correction;
/// bench/RESULTS.md "Incidence"), unless the rig's `mi_incidence_correction` is false; the
/// rig's orientation classes seen from the rig's start centre. `incidence` gets the fit.
mi::LidarPoints PrepareFramePoints(const JointState& s, const MiRun& run, const MiTask& t, const io::PointCloud& local,
                                   const std::vector<Eigen::Vector3f>& scanner, json* incidence) {
  const Eigen::Vector3f centre = CameraCentre(s.scene.Mount(s.mobile->mount)).cast<float>();
  if (!s.rig->config->mi_incidence_correction) {
    mi::LidarPoints points = mi::PrepareLidarPoints(local);
    incidence->push_back({{"frame", t.name}, {"exponent", nullptr}});  // not corrected
    if (run.rig_sectors > 0) mi::EncodeOrientationClasses(centre, run.rig_sectors, kSurfaceVoxel, &points);
    return points;
  }
  mi::IncidenceCorrection correction;
  correction.scanner = [&scanner](size_t k) -> Eigen::Vector3d { return scanner[k].cast<double>(); };
  correction.voxel_m = kSurfaceVoxel;
  mi::IncidenceFit fit;
  std::vector<Eigen::Vector3f> normals;
  mi::LidarPoints points = mi::PrepareLidarPoints(local, correction, &fit, &normals);
  spdlog::info("adjust: MI rig calibration: frame {}: intensity corrected for the angle of incidence, I / cos^{:.2f}",
               t.name, fit.exponent);
  incidence->push_back({{"frame", t.name}, {"exponent", fit.exponent}, {"correlation", fit.correlation},
                        {"points", fit.points}});
  if (run.rig_sectors > 0) mi::EncodeOrientationClasses(centre, run.rig_sectors, normals, &points);
  return points;
}

/// The joint rig calibration's report: each frame's own screening registration (not a prior:
/// the joint one is), the result file, the joint entry; a usable result becomes the MI prior on
/// the extrinsic.
void ReportRigCalibration(JointState* s, MiRun* run, const mi::RegistrationResult& result, const std::vector<size_t>& frame_task,
                          size_t num_frames, json file) {
  for (size_t i = 0; i < result.frame_results.size(); ++i) {
    const MiTask& t = run->tasks[frame_task[i]];
    const mi::RegistrationResult& r = result.frame_results[i];
    std::string rejected;
    for (const auto& [name, why] : result.rejected_frames) {
      if (name == t.name) rejected = why;
    }
    json entry = {{"image", t.name}, {"kind", TaskKindName(t.kind)}, {"lidar", "mobile"},
                  {"status", rejected.empty() ? "used" : "rejected"}, {"reason", rejected},
                  {"correction", mi::CorrectionToJson(r.correction)}, {"sigma_px", SigmaOrNull(r.checks.sigma_px_calibrated)},
                  {"runtime_seconds", r.runtime_seconds}, {"prior", false}};
    s->mi_registration.push_back(entry);
    s->mi_registered.push_back(t.start);
  }
  s->mi_files.emplace_back("rig_calibration", file);
  const bool usable = result.ok() && result.covariance_valid;
  json entry = {{"image", "rig_from_lidar (" + std::to_string(result.used_frames.size()) + " of " +
                          std::to_string(num_frames) + " frames)"},
                {"kind", "rig calibration"}, {"lidar", "mobile"}, {"file", "mi/rig_calibration.json"},
                {"status", result.status}, {"reason", result.reason}, {"correction", mi::CorrectionToJson(result.correction)},
                {"sigma_px", SigmaOrNull(result.checks.sigma_px_calibrated)}, {"runtime_seconds", result.runtime_seconds},
                {"prior", usable}, {"extrinsic", true}};
  s->mi_registration.push_back(entry);
  s->mi_registered.push_back(result.cam_from_lidar);
  spdlog::info("adjust: MI rig calibration: {} ({:.1f} s){}", result.status, result.runtime_seconds,
               result.ok() ? "" : ": " + result.reason);
  run->done += num_frames;
  if (!usable) return;
  run->ok += result.used_frames.size();
  MiResult prior;
  prior.cam_from_world = result.cam_from_lidar;
  prior.covariance = result.covariance;
  prior.source = "mi/rig_calibration.json (registered by the adjustment)";
  s->mobile->mi_extrinsic.push_back(prior);
}

/// The tasks `moving` against the mobile LiDAR's delivered cloud: the rig calibration of the
/// MI paper. Each frame's points near it are expressed in the LiDAR's own frame at the frame's
/// time (FramePointsInLidar), where the panorama's pose is the camera–LiDAR extrinsic
/// rig_from_lidar, the same for every frame: register-mi's multi-frame calibration (RegisterRig:
/// each frame alone, the failed and disagreeing rejected, the rest jointly) gives it with its
/// covariance, a prior on the extrinsic. At most kJointFrames frames, evenly spread over those
/// asked for.
void CalibrateRigOnMobileLidar(JointState* s, MiRun* run, std::vector<size_t> moving) {
  const MobileBlock& m = *s->mobile;
  const std::string& cloud_path = m.config->cloud;
  const double window = s->rig->config->mi_time_window_s;
  const std::vector<MiTask>& tasks = run->tasks;
  // Sorted by time (MobileCloudNear looks frames up by time).
  std::sort(moving.begin(), moving.end(), [&](size_t a, size_t b) { return tasks[a].time_s < tasks[b].time_s; });
  if (moving.size() > kJointFrames) {
    std::vector<size_t> spread;
    for (size_t k = 0; k < kJointFrames; ++k) spread.push_back(moving[k * (moving.size() - 1) / (kJointFrames - 1)]);
    s->warnings.push_back("MI rig calibration: " + std::to_string(kJointFrames) + " of the " + std::to_string(moving.size()) +
                          " panoramas asked for used, evenly over time");
    moving = spread;
  }
  std::vector<mi::LidarPoints> points;  // one per frame, kept for the joint registration
  json incidence = json::array();         // each frame's incidence correction (exponent fitted)
  points.reserve(moving.size());
  std::vector<mi::Frame> frames;
  std::vector<size_t> frame_task;
  const Rigid3d start = s->scene.Mount(m.mount);  // rig_from_lidar (the rig frame is the vehicle's)
  // One streamed pass for all of them (≤ kJointFrames frames, ≤ 2·kMaxPoints points held).
  std::vector<std::pair<double, Eigen::Vector3d>> near;
  for (size_t i : moving) near.emplace_back(tasks[i].time_s, CameraCentre(tasks[i].start));
  const io::PointCloud cloud = MobileCloudNear(cloud_path, near, kRadius, window, kMaxPoints);
  if (!cloud.has_intensity() && !cloud.points.empty()) {
    throw InputError::Message(cloud_path, "has no intensity, which the MI registration of mi_register compares with "
                                          "the panoramas (register-mi --representation intensity)");
  }
  for (size_t i : moving) {
    const MiTask& t = tasks[i];
    std::vector<Eigen::Vector3f> scanner;
    const io::PointCloud local = FramePointsInLidar(*s, t, cloud, window, &scanner);
    spdlog::info("adjust: MI rig calibration: frame {} sees {} mobile points within {:.0f} m and {:.1f} s", t.name,
                 local.size(), kRadius, window);
    if (local.size() < 1000) {
      FrameNotUsed(s, t, "only " + std::to_string(local.size()) + " mobile LiDAR points within " + std::to_string(kRadius) +
                             " m captured within " + std::to_string(window) + " s");
      continue;
    }
    points.push_back(PrepareFramePoints(*s, *run, t, local, scanner, &incidence));
    mi::Frame frame;
    frame.name = t.name;
    frame.points = &points.back();
    frame.views = TaskViews(t, run->images[i], points.back(), start, &*s->rig, s->scene, run->options);
    if (frame.views.empty()) {
      FrameNotUsed(s, t, "none of the frame's cameras sees " + std::to_string(mi::kMinRigViewPoints) +
                             " of its mobile LiDAR points at the start");
      points.pop_back();
      continue;
    }
    frames.push_back(std::move(frame));
    frame_task.push_back(i);
  }
  if (frames.empty()) return;
  mi::RigOptions rig_options;
  rig_options.registration = run->options;
  if (run->rig_sectors > 0) rig_options.registration.metric.lidar_classes = run->rig_sectors + 3;
  spdlog::info("adjust: MI rig calibration: {} frame(s) jointly against the mobile LiDAR {}", frames.size(), cloud_path);
  const mi::RegistrationResult result = mi::RegisterRig(frames, start, rig_options);
  json file = mi::ResultToJson(result, rig_options.registration, start);
  file["incidence_correction"] = incidence;  // per frame, as register-mi's OUT.json
  file["registered_by"] = "mmba adjust (mi_register, mi_lidar: mobile): register-mi's multi-frame rig calibration, "
                          "cam_from_lidar = rig_from_lidar, LiDAR = " + cloud_path + " (points within " +
                          std::to_string(window) + " s of each frame, in the LiDAR frame at that time)";
  ReportRigCalibration(s, run, result, frame_task, frames.size(), file);
}

/// This stage's tasks with their images. Every image of both stages is read and checked at
/// the first (a bad one is an input error before any work); the panoramas are registered at
/// the first stage, the photos and the rig's own cameras (mi_views: cameras) after the first
/// solve, with their intrinsics and cam_from_rig adjusted (a fisheye's design focal 1 % off
/// moves its edge by ~4 px).
MiRun PrepareRun(JointState* s, MiStage stage) {
  MiRun run;
  if (s->photos && s->photos->config->mi_register) AddPhotoTasks(*s, &run.tasks);
  const bool rig_cameras = s->rig && s->rig->config->mi_views == MiViews::kCameras;
  if (s->rig && s->rig->config->mi_register && (stage == MiStage::kRigFrames || rig_cameras)) AddRigTasks(s, &run.tasks);
  WarnUnmatchedOnly(s, stage, run.tasks);
  for (MiTask& t : run.tasks) run.images.push_back(ReadTaskImages(*s, &t));
  for (size_t i = run.tasks.size(); i-- > 0;) {
    const TaskKind kind = run.tasks[i].kind;
    if ((kind == TaskKind::kPhoto || kind == TaskKind::kRigCameras) != (stage == MiStage::kPhotos)) {
      run.tasks.erase(run.tasks.begin() + i);
      run.images.erase(run.images.begin() + i);
    }
  }
  run.photo_sectors = s->photos ? s->photos->config->mi_orientation_classes : 0;
  run.rig_sectors = s->rig ? s->rig->config->mi_orientation_classes : 0;
  return run;
}

}  // namespace

void RegisterImagesByMi(JointState* s, MiStage stage) {
  // The rig's result files first (the photos' are read with the photo block).
  if (stage == MiStage::kRigFrames && s->rig && !s->rig->config->mi_results.empty()) ReadRigMiResults(s);
  MiRun run = PrepareRun(s, stage);
  if (run.tasks.empty()) return;
  Timer timer;
  std::vector<size_t> fixed, moving;
  for (size_t i = 0; i < run.tasks.size(); ++i) (run.tasks[i].mobile ? moving : fixed).push_back(i);
  if (!fixed.empty()) RegisterToStaticLidar(s, &run, fixed);
  if (!moving.empty()) CalibrateRigOnMobileLidar(s, &run, moving);
  const size_t n = run.tasks.size();
  s->log.push_back("MI registration: " + std::to_string(run.ok) + " of " + std::to_string(n) +
                   " images ok, used as pose priors (" + std::to_string(static_cast<int>(timer.ElapsedSeconds())) + " s)");
  if (run.ok < n) {
    s->warnings.push_back("MI registration: " + std::to_string(n - run.ok) + " of " + std::to_string(n) +
                          " images not registered (status failed; see report.json mi_registration): no prior from them");
  }
}

}  // namespace mmba::adjust::internal
