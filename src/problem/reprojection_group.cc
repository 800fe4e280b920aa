#include "mmba/problem/reprojection_group.h"

#include "mmba/factors/reprojection_error.h"

namespace mmba {

ReprojectionGroup::ReprojectionGroup(std::vector<ReprojectionObservation> observations,
                                     LossOptions loss, std::string name)
    : FactorGroup(std::move(name), "px", loss), observations_(std::move(observations)) {}

void ReprojectionGroup::AddResiduals(Scene& scene, ceres::Problem& problem) {
  for (size_t i = 0; i < observations_.size(); ++i) {
    const ReprojectionObservation& obs = observations_[i];
    if (!scene.HasImage(obs.image_id) || !scene.HasPoint(obs.point3D_id)) {
      ++skipped_missing_;
      Skip();
      continue;
    }
    ImagePose& image = scene.Image(obs.image_id);
    if (!scene.HasCamera(image.camera_id)) {
      ++skipped_missing_;
      Skip();
      continue;
    }
    sensors::Camera& camera = scene.Camera(image.camera_id);
    Eigen::Vector3d& point = scene.Point(obs.point3D_id);
    if (!camera.ImgFromCam(image.cam_from_world * point)) {
      ++skipped_behind_;
      Skip();
      continue;
    }
    ceres::CostFunction* cost = factors::CreateReprojectionCost(
        camera.model_id, obs.xy, obs.sigma_px, camera.params.data());
    AddBlock(problem, cost,
             {image.cam_from_world.rotation.coeffs().data(),
              image.cam_from_world.translation.data(), point.data(), camera.params.data()},
             obs.sigma_px, i);
  }
}

}  // namespace mmba
