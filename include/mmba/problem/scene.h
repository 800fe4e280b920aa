#pragma once

#include <map>
#include <unordered_map>
#include <utility>
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

/// A node of the smooth correction of a trajectory (a GNSS/INS solution): rotation vector ω
/// (world axes) and translation δ [m], applied as world_from_body = (Exp(ω)·R_ins, p_ins + δ)
/// so that a rotation correction turns the vehicle about its own position. Between nodes ω and
/// δ are interpolated linearly (corrections are small).
struct TrajectoryNode {
  double time_s = 0.0;
  double correction[6] = {0, 0, 0, 0, 0, 0};  ///< ωx ωy ωz [rad], δx δy δz [m]
};

/// The parameter store of an adjustment: every estimated quantity, keyed by typed ids.
/// Addresses of stored values are stable (node-based maps; the trajectory nodes are set once,
/// before the problem is built, and not resized after), so factor groups hand them to Ceres as
/// parameter blocks:
///   camera intrinsics  -> `Camera::params.data()` (model's parameter count)
///   image pose         -> `cam_from_world.rotation.coeffs().data()` (4, Eigen order x,y,z,w)
///                         and `cam_from_world.translation.data()` (3)
///   3-D point          -> `Eigen::Vector3d::data()` (3, world frame)
///   rig frame          -> `rig_from_world` of one epoch of a camera rig, by FrameId: rotation
///                         (4, x,y,z,w) and translation (3) blocks as an image pose
///   rig camera         -> `cam_from_rig` of a camera of a rig, by the camera's CameraId: 4 + 3
///   scan               -> `scan_from_world` of a static LiDAR scan, by ScanId: 4 + 3
///   sensor mount       -> `platform_from_sensor` of a sensor on a platform (e.g. a mobile
///                         LiDAR's vehicle_from_lidar), by MountId: 4 + 3
///   trajectory node    -> `TrajectoryNode::correction` (6: ωx ωy ωz [rad], δx δy δz [m]);
///                         the nodes in time order, TrajectoryNodeId = the index
/// ProblemBuilder sets the manifolds (quaternion for every rotation block) and constant blocks.
class Scene {
 public:
  /// Inserts or replaces. The camera's params must match its model.
  sensors::Camera& AddCamera(const sensors::Camera& camera);
  ImagePose& AddImage(ImageId image_id, CameraId camera_id, const Rigid3d& cam_from_world);
  Eigen::Vector3d& AddPoint(Point3DId point3D_id, const Eigen::Vector3d& point_in_world);
  Rigid3d& AddRigFrame(FrameId frame_id, const Rigid3d& rig_from_world);
  Rigid3d& AddCamFromRig(CameraId camera_id, const Rigid3d& cam_from_rig);
  Rigid3d& AddScan(ScanId scan_id, const Rigid3d& scan_from_world);
  Rigid3d& AddMount(MountId mount_id, const Rigid3d& platform_from_sensor);
  /// The trajectory nodes, sorted by time (replaces any set before).
  void SetTrajectoryNodes(std::vector<TrajectoryNode> nodes) { trajectory_nodes_ = std::move(nodes); }

  bool HasCamera(CameraId id) const { return cameras_.count(id) > 0; }
  bool HasImage(ImageId id) const { return images_.count(id) > 0; }
  bool HasPoint(Point3DId id) const { return points_.count(id) > 0; }
  bool HasRigFrame(FrameId id) const { return rig_frames_.count(id) > 0; }
  bool HasCamFromRig(CameraId id) const { return cams_from_rig_.count(id) > 0; }
  bool HasScan(ScanId id) const { return scans_.count(id) > 0; }
  bool HasMount(MountId id) const { return mounts_.count(id) > 0; }

  sensors::Camera& Camera(CameraId id) { return cameras_.at(id); }
  const sensors::Camera& Camera(CameraId id) const { return cameras_.at(id); }
  ImagePose& Image(ImageId id) { return images_.at(id); }
  const ImagePose& Image(ImageId id) const { return images_.at(id); }
  Eigen::Vector3d& Point(Point3DId id) { return points_.at(id); }
  const Eigen::Vector3d& Point(Point3DId id) const { return points_.at(id); }
  Rigid3d& RigFrame(FrameId id) { return rig_frames_.at(id); }
  const Rigid3d& RigFrame(FrameId id) const { return rig_frames_.at(id); }
  Rigid3d& CamFromRig(CameraId id) { return cams_from_rig_.at(id); }
  const Rigid3d& CamFromRig(CameraId id) const { return cams_from_rig_.at(id); }
  Rigid3d& Scan(ScanId id) { return scans_.at(id); }
  const Rigid3d& Scan(ScanId id) const { return scans_.at(id); }
  Rigid3d& Mount(MountId id) { return mounts_.at(id); }
  const Rigid3d& Mount(MountId id) const { return mounts_.at(id); }

  const std::unordered_map<CameraId, sensors::Camera>& cameras() const { return cameras_; }
  std::unordered_map<CameraId, sensors::Camera>& cameras() { return cameras_; }
  const std::unordered_map<ImageId, ImagePose>& images() const { return images_; }
  std::unordered_map<ImageId, ImagePose>& images() { return images_; }
  const std::unordered_map<Point3DId, Eigen::Vector3d>& points() const { return points_; }
  std::unordered_map<Point3DId, Eigen::Vector3d>& points() { return points_; }
  const std::map<FrameId, Rigid3d>& rig_frames() const { return rig_frames_; }
  std::map<FrameId, Rigid3d>& rig_frames() { return rig_frames_; }
  const std::map<CameraId, Rigid3d>& cams_from_rig() const { return cams_from_rig_; }
  std::map<CameraId, Rigid3d>& cams_from_rig() { return cams_from_rig_; }
  const std::map<ScanId, Rigid3d>& scans() const { return scans_; }
  std::map<ScanId, Rigid3d>& scans() { return scans_; }
  const std::map<MountId, Rigid3d>& mounts() const { return mounts_; }
  std::map<MountId, Rigid3d>& mounts() { return mounts_; }
  const std::vector<TrajectoryNode>& trajectory_nodes() const { return trajectory_nodes_; }
  std::vector<TrajectoryNode>& trajectory_nodes() { return trajectory_nodes_; }

  /// Image ids in increasing order.
  std::vector<ImageId> SortedImageIds() const;

  /// Moves the whole scene into a new world frame: points p' = new_from_old · p, poses
  /// cam_from_new = cam_from_old · old_from_new (a similarity scales camera translations,
  /// so images are unchanged); rig frames and scans as image poses. Poses between sensors
  /// (cam_from_rig, mounts) do not depend on the world frame; trajectory nodes correct a
  /// trajectory the Scene does not hold and are left as they are.
  void Transform(const Sim3d& new_from_old);

 private:
  std::unordered_map<CameraId, sensors::Camera> cameras_;
  std::unordered_map<ImageId, ImagePose> images_;
  std::unordered_map<Point3DId, Eigen::Vector3d> points_;
  std::map<FrameId, Rigid3d> rig_frames_;
  std::map<CameraId, Rigid3d> cams_from_rig_;
  std::map<ScanId, Rigid3d> scans_;
  std::map<MountId, Rigid3d> mounts_;
  std::vector<TrajectoryNode> trajectory_nodes_;
};

}  // namespace mmba
