#pragma once

// One MI registration job as `mmba register-mi` sets it up, shared by every caller (the
// command, `mmba adjust`, the benches): the frames (image + cloud pairs, a list file, a rig's
// image patterns), the camera and start pose, the views (a panorama's perspective cuts at the
// headings that see the most LiDAR, a rig's cameras that see the cloud), the clouds prepared
// (points beyond range dropped, a map-grid cloud moved to a local origin, the intensity
// corrected for the angle of incidence, orientation classes) and the options with the
// job's policy applied (the region of a points image, the metric's classes).

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {

/// Voxel of the local planes of the surface and orientation classes and of the incidence
/// fit, m (register-mi --surface-voxel-m).
constexpr double kDefaultSurfaceVoxelM = 0.5;
/// A rig camera is a view of a frame when at least this many LiDAR points project into it at
/// the start (a Ladybug's upward camera sees none).
constexpr size_t kMinRigViewPoints = 1000;
/// Perspective cuts chosen by SelectPerspectiveHeadings for a panorama ("--headings auto").
constexpr int kAutoHeadings = 2;

/// What a caller asks for: the inputs and the user's choices. Error messages name the
/// register-mi option of a field (`--view`, `--headings`, …).
struct JobRequest {
  std::vector<std::string> lidar;  ///< clouds, paired with `image`
  std::vector<std::string> image;  ///< images (with `rig`: patterns with {camera})
  std::string list;                ///< text file of frames, IMAGE LIDAR per line
  std::string camera;              ///< camera YAML (calib/README.md)
  std::string kitti_calib;         ///< KITTI calibration file
  int kitti_camera = 2;            ///< 0..3
  std::string rig;                 ///< rig YAML: each image a pattern, the pose rig_from_lidar
  std::string initial;             ///< POSE.json with the start (else the calibration's)
  std::vector<double> perturb;     ///< empty or 6: tx,ty,tz [m], roll,pitch,yaw [deg]
  /// The options from the user's settings; PrepareJob applies the job's policy to them.
  RegistrationOptions options;
  bool region_given = false;          ///< options.metric.region chosen by the user
  bool representation_given = false;  ///< options.render.representation chosen by the user
  bool view_auto = true;              ///< a panorama: perspective cuts; any other image: itself
  ViewOptions view;                   ///< when not view_auto
  std::string view_name = "auto";
  bool headings_auto = true;          ///< the kAutoHeadings cuts that see the most LiDAR
  bool surface_classes = false;       ///< ground against the rest (intensity)
  int orientation_classes = -1;       ///< sectors; -1: kDefaultOrientationSectors with intensity
  double surface_voxel_m = kDefaultSurfaceVoxelM;
  std::string incidence_correction = "auto";  ///< auto | on | off
  std::vector<double> scanner_origin;         ///< empty or x,y,z in the cloud's frame
  std::string trajectory;                     ///< with lidar_mount: the scanner of each point
  std::string lidar_mount;
};

/// One frame's files: the image (or pattern) and the cloud.
struct FramePaths {
  std::string image;
  std::string lidar;
};

/// A prepared job. Frames point into `clouds`: a Job is moved, never copied.
struct Job {
  RegistrationOptions options;  ///< the request's with the policy applied
  std::vector<FramePaths> paths;
  std::vector<LidarPoints> clouds;  ///< in the local frame (minus `origin`)
  std::vector<Frame> frames;
  bool rig_mode = false;
  io::RigYaml rig;                  ///< rig_mode: the cameras
  sensors::Camera camera;           ///< not rig_mode
  std::string view_name;            ///< the views' kind as resolved (auto → perspective/image)
  std::string region_note;          ///< why the region is not the asked one (empty: it is)
  int orientation_sectors = 0;
  /// Map-grid clouds are registered about this origin (io::LocalOrigin of the first cloud).
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Rigid3d start_given;         ///< the start in the clouds' own frame (perturbed)
  Rigid3d start;               ///< the same about `origin`
  Rigid3d reference;           ///< the unperturbed start about `origin`
  bool have_calibration_pose = false;
  Rigid3d calibration;         ///< the calibration file's pose about `origin`
  nlohmann::json clouds_json = nlohmann::json::array();     ///< per cloud: points read, dropped
  nlohmann::json incidence_json = nlohmann::json::array();  ///< per cloud: the fit or null

  Job() = default;
  Job(Job&&) = default;
  Job& operator=(Job&&) = default;
  Job(const Job&) = delete;
  Job& operator=(const Job&) = delete;
  /// A pose about `origin` in the clouds' own frame.
  Rigid3d ToGiven(Rigid3d cam_from_local) const {
    cam_from_local.translation -= cam_from_local.rotation * origin;
    return cam_from_local;
  }
  Rigid3d ToLocal(Rigid3d cam_from_lidar) const {
    cam_from_lidar.translation += cam_from_lidar.rotation * origin;
    return cam_from_lidar;
  }
};

/// Checks the request (throws InputError naming the option) and lists its frames: the
/// image/lidar pairs, then the list file's (relative paths relative to the list's folder).
/// Nothing but the list file is read.
std::vector<FramePaths> ListFrames(const JobRequest& request);

/// Reads the frames' images, camera or rig, start pose and clouds and prepares the job
/// (`paths` from ListFrames). Throws InputError on bad input.
Job PrepareJob(const JobRequest& request, std::vector<FramePaths> paths);

/// Registers a prepared job: one frame (its views) by RegisterFrames, several frames (a shared
/// calibration or a rig) by RegisterRig. The result's poses are in the clouds' own frame;
/// `cam_from_local` receives the result's pose about the job's origin (for rendering `clouds`).
RegistrationResult RegisterJob(const Job& job, Rigid3d* cam_from_local);

/// The views of a panorama's image: perspective cuts at the kAutoHeadings headings that see
/// the most of `points` at `start` (`headings` receives them, degrees), as register-mi
/// --view perspective --headings auto.
std::vector<View> AutoPerspectiveViews(const GrayImage& image, const sensors::Camera& camera,
                                       const LidarPoints& points, const Rigid3d& start,
                                       const ViewOptions& views, const RenderOptions& render,
                                       const std::string& name, std::vector<double>* headings);

/// The orientation classes' sectors of a job (register-mi --orientation-classes): `asked`
/// when ≥ 0, else kDefaultOrientationSectors where the intensity is compared and no surface
/// classes were asked for, else 0 (no orientation classes).
int OrientationSectors(int asked, Representation representation, bool surface_classes);
/// The metric's LiDAR classes (MetricOptions::lidar_classes) of `sectors` > 0 orientation
/// sectors: facing up, facing down, the sectors, no plane.
int OrientationClassCount(int sectors);

/// A rig camera's view of a frame if at least kMinRigViewPoints of `points` project into it
/// at `rig_from_lidar`.
bool RigCameraSeesCloud(const View& view, const LidarPoints& points, const Rigid3d& rig_from_lidar,
                        const RenderOptions& render);

}  // namespace mmba::registration::mi
