#include "mmba/problem/colmap_scene.h"

namespace mmba {

std::vector<ReprojectionObservation> SceneFromColmap(const io::ColmapModel& model,
                                                     double sigma_px, Scene* scene) {
  for (const auto& [id, camera] : model.cameras) scene->AddCamera(camera);
  for (const auto& [id, image] : model.images) {
    Rigid3d cam_from_world = image.cam_from_world;
    cam_from_world.rotation.normalize();
    scene->AddImage(id, image.camera_id, cam_from_world);
  }
  std::vector<ReprojectionObservation> observations;
  observations.reserve(model.NumObservations());
  for (const auto& [id, point] : model.points3D) {
    scene->AddPoint(id, point.xyz);
    for (const io::ColmapTrackElement& element : point.track) {
      const io::ColmapImage& image = model.images.at(element.image_id);
      observations.push_back(
          {element.image_id, id, image.points2D.at(element.point2D_idx), sigma_px});
    }
  }
  return observations;
}

void UpdateColmapFromScene(const Scene& scene, io::ColmapModel* model) {
  for (auto& [id, camera] : model->cameras) {
    if (scene.HasCamera(id)) camera.params = scene.Camera(id).params;
  }
  for (auto& [id, image] : model->images) {
    if (scene.HasImage(id)) image.cam_from_world = scene.Image(id).cam_from_world;
  }
  for (auto& [id, point] : model->points3D) {
    if (!scene.HasPoint(id)) continue;
    point.xyz = scene.Point(id);
    double sum = 0.0;
    int count = 0;
    for (const io::ColmapTrackElement& element : point.track) {
      const io::ColmapImage& image = model->images.at(element.image_id);
      const sensors::Camera& camera = model->cameras.at(image.camera_id);
      const auto xy = camera.ImgFromCam(image.cam_from_world * point.xyz);
      if (!xy) continue;
      sum += (*xy - image.points2D[element.point2D_idx]).norm();
      ++count;
    }
    point.error = count > 0 ? sum / count : -1.0;
  }
}

}  // namespace mmba
