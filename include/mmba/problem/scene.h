#pragma once

#include <map>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/ids.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/geometry/sim3d.h"
#include "mmba/sensors/camera.h"

namespace mmba {

/// The pose of one image: which intrinsics it uses and its `cam_from_world`.
struct ImagePose {
  CameraId camera_id;
  Rigid3d cam_from_world;
};

/// The parameter store of an adjustment: every estimated quantity, keyed by typed ids.
/// Addresses of stored values are stable (node-based maps), so factor groups hand them to
/// Ceres as parameter blocks:
///   camera intrinsics  -> `Camera::params.data()` (model's parameter count)
///   image pose         -> `cam_from_world.rotation.coeffs().data()` (4, Eigen order x,y,z,w)
///                         and `cam_from_world.translation.data()` (3)
///   3-D point          -> `Eigen::Vector3d::data()` (3, world frame)
/// Later sensors (rigs, scans, stations) add their own maps here.
class Scene {
 public:
  /// Inserts or replaces. The camera's params must match its model.
  sensors::Camera& AddCamera(const sensors::Camera& camera);
  ImagePose& AddImage(ImageId image_id, CameraId camera_id, const Rigid3d& cam_from_world);
  Eigen::Vector3d& AddPoint(Point3DId point3D_id, const Eigen::Vector3d& point_in_world);

  bool HasCamera(CameraId id) const { return cameras_.count(id) > 0; }
  bool HasImage(ImageId id) const { return images_.count(id) > 0; }
  bool HasPoint(Point3DId id) const { return points_.count(id) > 0; }

  sensors::Camera& Camera(CameraId id) { return cameras_.at(id); }
  const sensors::Camera& Camera(CameraId id) const { return cameras_.at(id); }
  ImagePose& Image(ImageId id) { return images_.at(id); }
  const ImagePose& Image(ImageId id) const { return images_.at(id); }
  Eigen::Vector3d& Point(Point3DId id) { return points_.at(id); }
  const Eigen::Vector3d& Point(Point3DId id) const { return points_.at(id); }

  const std::unordered_map<CameraId, sensors::Camera>& cameras() const { return cameras_; }
  std::unordered_map<CameraId, sensors::Camera>& cameras() { return cameras_; }
  const std::unordered_map<ImageId, ImagePose>& images() const { return images_; }
  std::unordered_map<ImageId, ImagePose>& images() { return images_; }
  const std::unordered_map<Point3DId, Eigen::Vector3d>& points() const { return points_; }
  std::unordered_map<Point3DId, Eigen::Vector3d>& points() { return points_; }

  /// Image ids in increasing order.
  std::vector<ImageId> SortedImageIds() const;

  /// Moves the whole scene into a new world frame: points p' = new_from_old · p, poses
  /// cam_from_new = cam_from_old · old_from_new (a similarity scales camera translations,
  /// so images are unchanged).
  void Transform(const Sim3d& new_from_old);

 private:
  std::unordered_map<CameraId, sensors::Camera> cameras_;
  std::unordered_map<ImageId, ImagePose> images_;
  std::unordered_map<Point3DId, Eigen::Vector3d> points_;
};

}  // namespace mmba
