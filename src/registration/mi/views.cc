// The views of a frame (lidar_image.h): the image itself, a panorama's perspective cuts or
// cube faces, a rig camera's view, the headings that see the most LiDAR, and the pyramid.
#include "mmba/registration/mi/lidar_image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <thread>
#include <type_traits>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <glog/logging.h>

#include "mmba/core/error.h"
#include "registration/mi/pinhole_block.h"

namespace mmba::registration::mi {

std::string ViewKindName(ViewKind kind) {
  switch (kind) {
    case ViewKind::kImage: return "image";
    case ViewKind::kPerspective: return "perspective";
    case ViewKind::kCube: return "cube";
  }
  return "";
}

bool ParseViewKind(const std::string& name, ViewKind* kind) {
  if (name == "image" || name == "equirect") {
    *kind = ViewKind::kImage;
  } else if (name == "perspective") {
    *kind = ViewKind::kPerspective;
  } else if (name == "cube") {
    *kind = ViewKind::kCube;
  } else {
    return false;
  }
  return true;
}

bool ViewOptions::Check(std::string* error) const {
  if (perspective_width < 8 || perspective_height < 8) {
    *error = "perspective view size " + std::to_string(perspective_width) + "x" +
             std::to_string(perspective_height) + " must be at least 8x8";
    return false;
  }
  if (!(perspective_hfov_deg > 1 && perspective_hfov_deg < 170)) {
    *error = "perspective_hfov_deg " + std::to_string(perspective_hfov_deg) +
             " must be in (1, 170)";
    return false;
  }
  if (perspective_yaw_deg.empty()) {
    *error = "perspective_yaw_deg must list at least one heading";
    return false;
  }
  if (cube_face_size < 8) {
    *error = "cube_face_size " + std::to_string(cube_face_size) + " must be >= 8";
    return false;
  }
  return true;
}


namespace {

Eigen::Matrix3d RotationAboutY(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

// Perspective cut of an equirectangular panorama looking `yaw_deg` right of its centre.
View CutPerspective(const GrayImage& pano, const sensors::Camera& pano_camera, int width,
                    int height, double hfov_deg, double yaw_deg, const std::string& name) {
  View view;
  view.name = name;
  const double f = 0.5 * width / std::tan(0.5 * hfov_deg * M_PI / 180.0);
  view.camera.model_id = sensors::CameraModelId::kPinhole;
  view.camera.width = width;
  view.camera.height = height;
  view.camera.params = {f, f, 0.5 * width, 0.5 * height};
  const Eigen::Matrix3d cam_from_view = RotationAboutY(yaw_deg * M_PI / 180.0);
  view.view_from_cam = cam_from_view.transpose();
  view.image_pixels_per_pixel = pano_camera.params[0] / f;  // equirect f = columns per radian
  view.image_camera = pano_camera;
  view.image = GrayImage(width, height);
  const double* params = pano_camera.params.data();
  const double period = 2.0 * M_PI * params[0];
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const Eigen::Vector3d ray_in_view((c + 0.5 - 0.5 * width) / f,
                                        (r + 0.5 - 0.5 * height) / f, 1.0);
      const Eigen::Vector3d ray_in_cam = cam_from_view * ray_in_view;
      double xy[2] = {0.0, 0.0};
      sensors::EquirectangularModel::ImgFromCam(params, ray_in_cam.data(), xy);
      if (xy[0] < 0.5) xy[0] += period;
      if (xy[0] > pano.width - 0.5) xy[0] -= period;
      xy[0] = std::clamp(xy[0], 0.5, pano.width - 0.5);
      xy[1] = std::clamp(xy[1], 0.5, pano.height - 0.5);
      float value = 0;
      pano.Sample(xy[0], xy[1], &value);
      view.image.at(c, r) = value;
    }
  }
  return view;
}

}  // namespace

View MakeRigCameraView(const GrayImage& image, const sensors::Camera& camera,
                       const Rigid3d& cam_from_rig, const std::string& source) {
  View view = MakeViews(image, camera, ViewOptions(), source)[0];
  view.view_from_cam = cam_from_rig.rotation.toRotationMatrix();
  view.view_from_cam_t = cam_from_rig.translation;
  return view;
}

size_t CountPointsInView(const LidarPoints& points, const View& view,
                         const Rigid3d& cam_from_lidar, const RenderOptions& render,
                         size_t limit) {
  const ViewTransform transform = MakeTransform(view, cam_from_lidar);
  const Eigen::Matrix3d rotation = transform.rotation.cast<double>();
  const Eigen::Vector3d translation = transform.translation.cast<double>();
  size_t seen = 0;
  for (size_t i = 0; i < points.size() && seen < limit; ++i) {
    const Eigen::Vector3d p = rotation * points.points_in_lidar[i].cast<double>() + translation;
    const double range = p.norm();
    if (range < render.min_range_m || range > render.max_range_m) continue;
    const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p);
    seen += xy && (*xy)[0] >= 0 && (*xy)[1] >= 0 && (*xy)[0] < view.camera.width &&
            (*xy)[1] < view.camera.height;
  }
  return seen;
}

std::vector<View> MakeViews(const GrayImage& image, const sensors::Camera& camera,
                            const ViewOptions& options, const std::string& source) {
  std::string error;
  if (!options.Check(&error)) throw InputError::Message(source, error);
  if (image.width != static_cast<int>(camera.width) ||
      image.height != static_cast<int>(camera.height)) {
    throw InputError::Message(
        source, "image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                    " but the camera is " + std::to_string(camera.width) + "x" +
                    std::to_string(camera.height));
  }
  std::vector<View> views;
  if (options.kind == ViewKind::kImage) {
    View view;
    view.camera = camera;
    view.image = image;
    view.name = "image";
    views.push_back(std::move(view));
    return views;
  }
  if (camera.model_id != sensors::CameraModelId::kEquirectangular) {
    throw InputError::Message(source, "view '" + ViewKindName(options.kind) +
                                          "' needs an EQUIRECTANGULAR camera, found " +
                                          camera.ModelName());
  }
  if (options.kind == ViewKind::kPerspective) {
    for (double yaw : options.perspective_yaw_deg) {
      views.push_back(CutPerspective(image, camera, options.perspective_width,
                                     options.perspective_height, options.perspective_hfov_deg,
                                     yaw, "perspective_" + std::to_string(int(std::lround(yaw)))));
    }
  } else {
    for (double yaw : {0.0, 90.0, 180.0, 270.0}) {
      views.push_back(CutPerspective(image, camera, options.cube_face_size,
                                     options.cube_face_size, 90.0, yaw,
                                     "cube_" + std::to_string(int(yaw))));
    }
  }
  return views;
}

std::vector<double> SelectPerspectiveHeadings(const LidarPoints& points,
                                              const sensors::Camera& panorama_camera,
                                              const Rigid3d& cam_from_lidar,
                                              const ViewOptions& options,
                                              const RenderOptions& render, int count,
                                              int candidates) {
  CHECK(panorama_camera.IsSpherical()) << "heading selection needs an equirectangular camera";
  CHECK_GT(candidates, 0);
  const int width = std::max(8, options.perspective_width / 4);
  const int height = std::max(8, options.perspective_height / 4);
  const double f = 0.5 * width / std::tan(0.5 * options.perspective_hfov_deg * M_PI / 180.0);
  std::vector<std::pair<double, double>> scored;  // (covered fraction, heading)
  LidarImage lidar;
  for (int k = 0; k < candidates; ++k) {
    const double yaw = -180.0 + 360.0 * k / candidates;
    View view;
    view.camera.model_id = sensors::CameraModelId::kPinhole;
    view.camera.width = width;
    view.camera.height = height;
    view.camera.params = {f, f, 0.5 * width, 0.5 * height};
    view.view_from_cam = RotationAboutY(yaw * M_PI / 180.0).transpose();
    RenderLidarImage(points, view, cam_from_lidar, render, &lidar);
    scored.emplace_back(static_cast<double>(lidar.covered_pixels) / (width * height), yaw);
  }
  std::stable_sort(scored.begin(), scored.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<double> chosen;
  for (const auto& [fraction, yaw] : scored) {
    if (static_cast<int>(chosen.size()) >= count) break;
    bool apart = true;
    for (double c : chosen) {
      const double d = std::abs(std::remainder(yaw - c, 360.0));
      apart = apart && d >= options.perspective_hfov_deg - 1e-9;
    }
    if (apart) chosen.push_back(yaw);
  }
  return chosen;
}

View DownsampleView(const View& view) {
  View half;
  half.name = view.name;
  half.view_from_cam = view.view_from_cam;
  half.view_from_cam_t = view.view_from_cam_t;
  half.image_pixels_per_pixel = 2.0 * view.image_pixels_per_pixel;
  half.image_camera = view.image_camera;
  half.image = Downsample2(view.image);
  half.camera = view.camera;
  half.camera.width = half.image.width;
  half.camera.height = half.image.height;
  // Pixel coordinates scale with the image when the top-left corner is the origin (COLMAP).
  const double sx = static_cast<double>(half.image.width) / view.image.width;
  const double sy = static_cast<double>(half.image.height) / view.image.height;
  const double s = 0.5 * (sx + sy);
  for (int i : sensors::CameraModelFocalIdxs(view.camera.model_id)) half.camera.params[i] *= s;
  const std::vector<int> principal = sensors::CameraModelPrincipalIdxs(view.camera.model_id);
  if (principal.size() == 2) {
    half.camera.params[principal[0]] *= sx;
    half.camera.params[principal[1]] *= sy;
  }
  return half;
}

}  // namespace mmba::registration::mi
