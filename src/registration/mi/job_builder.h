#pragma once

// PrepareJob's steps (job.h): job.cc holds the request's policy and checks, the frames'
// files, the images and camera (or rig), the views and the start pose; job_clouds.cc the
// clouds' preparation.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "mmba/io/camera_yaml.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/lidar_image.h"

namespace mmba::registration::mi::internal {

/// Where the scanner of a cloud's points was (JobBuilder::FindScanner): a fixed origin, or a
/// trajectory and mounting (the request's or a sidecar's, held here) at each point's time.
struct ScannerSource {
  std::optional<Eigen::Vector3d> origin;  ///< in the cloud's own frame
  const std::vector<std::pair<double, Rigid3d>>* trajectory = nullptr;
  const Rigid3d* mount = nullptr;
  std::string trajectory_named;  ///< the trajectory as error messages name it
  std::string from;              ///< what gave the position (empty: nothing)
  std::vector<std::pair<double, Rigid3d>> sidecar_trajectory;
  Rigid3d sidecar_mount;

  ScannerSource() = default;
  ScannerSource(const ScannerSource&) = delete;  ///< `trajectory` may point into it
  ScannerSource& operator=(const ScannerSource&) = delete;
};

// PrepareJob's steps, in order: the policy and checks of the request, the frames' files, the
// images and camera (or rig), the views' kind, the start pose, the clouds, the frames.
class JobBuilder {
 public:
  explicit JobBuilder(const JobRequest& request)
      : request(request), view_options(request.view), view_name(request.view_name) {
    job.options = request.options;
  }
  void ApplyPolicy(bool log);
  void CheckScannerOptions() const;
  void CheckCameraOptions() const;
  std::vector<std::pair<std::string, std::string>> ListPairs() const;
  void ReadImagesAndCamera();
  void ResolveViews();
  void StartPose();
  void PrepareClouds();
  void PrepareCloud(const std::string& lidar_path);
  io::PointCloud ReadCloud(const std::string& lidar_path);
  void GeometricTermAlone(io::PointCloud* cloud, const std::string& lidar_path);
  void CheckIntensity(const io::PointCloud& cloud, const std::string& lidar_path) const;
  void FindScanner(const std::string& lidar_path, ScannerSource* source) const;
  IncidenceCorrection ScannerCorrection(const io::PointCloud& cloud, const std::string& lidar_path,
                                        ScannerSource* source) const;
  std::vector<Eigen::Vector3f> CorrectIncidence(const io::PointCloud& cloud, const std::string& lidar_path,
                                                const IncidenceCorrection& correction,
                                                const std::string& scanner_from);
  void EncodeClasses(const std::string& lidar_path, const std::vector<Eigen::Vector3f>& normals);
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

}  // namespace mmba::registration::mi::internal
