#pragma once

// A small synthetic street for MI registration tests and benchmarks: textured axis-aligned
// rectangles (ground, two façades, an end wall, boxes). The LiDAR cloud samples the surfaces
// with a reflectance = texture; the photo is ray cast independently (not from the points) and
// maps the texture through a non-linear, partly inverted response plus noise, so that MI, not
// correlation, is needed.

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/mi/image.h"
#include "mmba/sensors/camera.h"

namespace mmba::registration::mi::testing {

/// A rectangle: origin + s·u + t·v, s in [0, su], t in [0, tv] (u, v unit, orthogonal).
struct Rectangle {
  Eigen::Vector3d origin, u, v;
  double su, tv;
  int texture;  ///< texture variant
};

/// World frame of the scene ("lidar" frame): x forward along the street, y left, z up.
inline std::vector<Rectangle> StreetScene() {
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  std::vector<Rectangle> r;
  r.push_back({{-2, -8, -1.8}, x, y, 32, 16, 0});       // ground
  r.push_back({{-2, 6, -1.8}, x, z, 32, 7, 1});         // left façade (y = 6)
  r.push_back({{-2, -6, -1.8}, x, z, 32, 7, 2});        // right façade (y = −6)
  r.push_back({{28, -8, -1.8}, y, z, 16, 9, 3});        // end wall (x = 28)
  r.push_back({{8, 1.5, -1.8}, -y, z, 3, 1.6, 4});      // box front (x = 8)
  r.push_back({{14, -2, -1.8}, y, z, 2, 2.5, 5});       // pillar front (x = 14)
  return r;
}

inline double Texture(int variant, double s, double t) {
  // Blocks, stripes and blobs of several sizes (a few decimetres to metres).
  const double blocks = (static_cast<int>(std::floor(s / 1.3) + std::floor(t / 0.9)) & 1) ? 0.8 : 0.25;
  const double stripes = 0.5 + 0.5 * std::sin(2.1 * s + 0.7 * variant) * std::cos(1.7 * t);
  const double blob = std::exp(-std::pow(std::fmod(s + 3 * variant, 4.0) - 2.0, 2) -
                               std::pow(std::fmod(t + variant, 3.0) - 1.5, 2) * 2.0);
  const double mix = 0.45 * blocks + 0.35 * stripes + 0.2 * blob;
  return std::clamp(variant % 2 ? 1.0 - mix : mix, 0.0, 1.0);
}

/// Cloud sampling every rectangle at `spacing_m`, intensity = texture (+ noise).
inline io::PointCloud StreetCloud(double spacing_m, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  io::PointCloud cloud;
  for (const Rectangle& rect : StreetScene()) {
    for (double s = 0; s <= rect.su; s += spacing_m) {
      for (double t = 0; t <= rect.tv; t += spacing_m) {
        cloud.points.push_back(rect.origin + s * rect.u + t * rect.v +
                               Eigen::Vector3d(noise(rng), noise(rng), noise(rng)) * 0.3);
        cloud.intensity.push_back(static_cast<float>(
            std::clamp(Texture(rect.texture, s, t) + noise(rng), 0.0, 1.0)));
      }
    }
  }
  return cloud;
}

/// A pinhole camera looking along +x of the scene from `position`, heading `yaw_deg`.
inline Rigid3d StreetCamFromLidar(const Eigen::Vector3d& position, double yaw_deg) {
  // cam axes in scene coordinates: z_cam = forward, x_cam = right, y_cam = down.
  const double a = yaw_deg * M_PI / 180.0;
  const Eigen::Vector3d forward(std::cos(a), std::sin(a), 0);
  const Eigen::Vector3d right(std::sin(a), -std::cos(a), 0);
  const Eigen::Vector3d down(0, 0, -1);
  Eigen::Matrix3d lidar_from_cam_r;
  lidar_from_cam_r << right, down, forward;
  const Rigid3d lidar_from_cam(Eigen::Quaterniond(lidar_from_cam_r), position);
  return lidar_from_cam.Inverse();
}

/// Ray-cast photo of the scene through `camera` from `cam_from_lidar`: grey =
/// response(texture) with noise; background (no hit) is sky grey 230.
inline GrayImage StreetPhoto(const sensors::Camera& camera, const Rigid3d& cam_from_lidar,
                             uint32_t seed = 11, double noise_sigma = 3.0) {
  const std::vector<Rectangle> scene = StreetScene();
  const Rigid3d lidar_from_cam = cam_from_lidar.Inverse();
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_sigma);
  GrayImage image(static_cast<int>(camera.width), static_cast<int>(camera.height));
  for (int r = 0; r < image.height; ++r) {
    for (int c = 0; c < image.width; ++c) {
      const Eigen::Vector3d ray_in_cam = camera.CamFromImg(Eigen::Vector2d(c + 0.5, r + 0.5));
      const Eigen::Vector3d dir = (lidar_from_cam.rotation * ray_in_cam).normalized();
      const Eigen::Vector3d o = lidar_from_cam.translation;
      double best = 1e30, value = 230.0;
      for (const Rectangle& rect : scene) {
        const Eigen::Vector3d n = rect.u.cross(rect.v);
        const double denom = n.dot(dir);
        if (std::abs(denom) < 1e-12) continue;
        const double t = n.dot(rect.origin - o) / denom;
        if (t <= 0.05 || t >= best) continue;
        const Eigen::Vector3d hit = o + t * dir - rect.origin;
        const double s = hit.dot(rect.u), q = hit.dot(rect.v);
        if (s < 0 || s > rect.su || q < 0 || q > rect.tv) continue;
        best = t;
        const double tex = Texture(rect.texture, s, q);
        // Non-linear, non-monotonic response: MI handles it, correlation would not.
        value = 20.0 + 200.0 * std::pow(tex, 1.6) + 30.0 * std::sin(3.0 * tex);
      }
      image.at(c, r) = static_cast<float>(std::clamp(value + noise(rng), 0.0, 255.0));
    }
  }
  return image;
}

inline sensors::Camera StreetCamera(int width = 320, int height = 240, double focal = 260.0) {
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kPinhole;
  camera.width = width;
  camera.height = height;
  camera.params = {focal, focal, width / 2.0, height / 2.0};
  return camera;
}

}  // namespace mmba::registration::mi::testing
