#include "mmba/problem/scene.h"

#include <algorithm>

namespace mmba {

sensors::Camera& Scene::AddCamera(const sensors::Camera& camera) {
  return cameras_[camera.camera_id] = camera;
}

ImagePose& Scene::AddImage(ImageId image_id, CameraId camera_id,
                           const Rigid3d& cam_from_world) {
  return images_[image_id] = ImagePose{camera_id, cam_from_world};
}

Eigen::Vector3d& Scene::AddPoint(Point3DId point3D_id, const Eigen::Vector3d& point_in_world) {
  return points_[point3D_id] = point_in_world;
}

Rigid3d& Scene::AddRigFrame(FrameId frame_id, const Rigid3d& rig_from_world) {
  return rig_frames_[frame_id] = rig_from_world;
}

Rigid3d& Scene::AddCamFromRig(CameraId camera_id, const Rigid3d& cam_from_rig) {
  return cams_from_rig_[camera_id] = cam_from_rig;
}

Rigid3d& Scene::AddScan(ScanId scan_id, const Rigid3d& scan_from_world) {
  return scans_[scan_id] = scan_from_world;
}

Rigid3d& Scene::AddMount(MountId mount_id, const Rigid3d& platform_from_sensor) {
  return mounts_[mount_id] = platform_from_sensor;
}

std::vector<ImageId> Scene::SortedImageIds() const {
  std::vector<ImageId> ids;
  ids.reserve(images_.size());
  for (const auto& [id, image] : images_) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

void Scene::Transform(const Sim3d& new_from_old) {
  for (auto& [id, point] : points_) point = new_from_old * point;
  for (auto& [id, image] : images_) {
    image.cam_from_world = new_from_old.TransformCamFromSource(image.cam_from_world);
  }
  for (auto& [id, rig_from_world] : rig_frames_) rig_from_world = new_from_old.TransformCamFromSource(rig_from_world);
  for (auto& [id, scan_from_world] : scans_) scan_from_world = new_from_old.TransformCamFromSource(scan_from_world);
}

}  // namespace mmba
