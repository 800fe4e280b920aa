#include "mmba/sim/render.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace mmba::sim {
namespace {

Material Flat(const std::string& name, double albedo) {
  Material m;
  m.name = name;
  m.base_albedo = albedo;
  m.contrast = 0.0;
  return m;
}

// A bright square marker of side `size_m` centred on `point`, facing `eye`.
void AddMarker(SimScene* scene, const Eigen::Vector3d& point, const Eigen::Vector3d& eye,
               double size_m, int material) {
  const Eigen::Vector3d n = (eye - point).normalized();
  Eigen::Vector3d a = n.cross(Eigen::Vector3d::UnitZ());
  if (a.norm() < 1e-3) a = n.cross(Eigen::Vector3d::UnitX());
  a.normalize();
  const Eigen::Vector3d b = n.cross(a);
  const double h = 0.5 * size_m;
  scene->mesh.AddQuad(point - h * a - h * b, point + h * a - h * b, point + h * a + h * b,
                      point - h * a + h * b, material);
}

// Intensity-weighted centroid of the pixels brighter than `threshold` within `radius` of
// `guess` (pixel centres at +0.5).
Eigen::Vector2d Centroid(const GrayImage& image, const Eigen::Vector2d& guess, int radius,
                         int threshold) {
  double sw = 0, sx = 0, sy = 0;
  for (int y = std::max(0, int(guess.y()) - radius); y < std::min(image.height, int(guess.y()) + radius); ++y) {
    for (int x = std::max(0, int(guess.x()) - radius); x < std::min(image.width, int(guess.x()) + radius); ++x) {
      const double w = image.at(x, y) - threshold;
      if (w <= 0) continue;
      sw += w;
      sx += w * (x + 0.5);
      sy += w * (y + 0.5);
    }
  }
  return sw > 0 ? Eigen::Vector2d(sx / sw, sy / sw) : Eigen::Vector2d(-1, -1);
}

struct ModelCase {
  sensors::CameraModelId model;
  int width, height;
  std::vector<double> params;
};

class RenderProjection : public ::testing::TestWithParam<ModelCase> {};

TEST_P(RenderProjection, KnownPointRendersWhereTheModelProjectsIt) {
  const ModelCase c = GetParam();
  sensors::Camera camera;
  camera.model_id = c.model;
  camera.width = c.width;
  camera.height = c.height;
  camera.params = c.params;
  // Camera at (0, -6, 1.5) looking north (+y); world up = −y of the camera.
  Eigen::Matrix3d world_from_cam_rotation;
  world_from_cam_rotation.col(0) = Eigen::Vector3d::UnitX();
  world_from_cam_rotation.col(1) = -Eigen::Vector3d::UnitZ();
  world_from_cam_rotation.col(2) = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d eye(0, -6, 1.5);
  const Rigid3d cam_from_world =
      Rigid3d(Eigen::Quaterniond(world_from_cam_rotation), eye).Inverse();
  const std::vector<Eigen::Vector3d> points = {
      {0.3, 0, 1.7}, {-2.5, 0.0, 3.0}, {3.1, 0.0, 0.4}, {-2.0, -3.0, 2.8}, {4.0, -4.0, 2.0}};
  SimScene scene;
  const int dark = scene.mesh.AddMaterial(Flat("dark", 0.05));
  const int bright = scene.mesh.AddMaterial(Flat("bright", 0.95));
  scene.mesh.AddQuad({-30, 0.5, -10}, {30, 0.5, -10}, {30, 0.5, 20}, {-30, 0.5, 20}, dark);
  for (const auto& p : points) AddMarker(&scene, p, eye, 0.03 * (p - eye).norm(), bright);
  RayCaster caster(scene.mesh);
  RenderOptions options;
  options.ambient = 1.0;
  options.sky = 0.0;
  options.noise_sigma_dn = 0.0;
  options.samples_per_axis = 3;
  const GrayImage image = RenderImage(caster, scene, camera, cam_from_world, options, 1, 1, 2);
  int checked = 0;
  for (const auto& p : points) {
    const auto expected = camera.ImgFromCam(cam_from_world * p);
    if (!expected || expected->x() < 10 || expected->y() < 10 || expected->x() > c.width - 10 ||
        expected->y() > c.height - 10) {
      continue;
    }
    const Eigen::Vector2d found = Centroid(image, *expected, 12, 128);
    EXPECT_LT((found - *expected).norm(), 0.5)
        << camera.ModelName() << " point " << p.transpose() << " expected "
        << expected->transpose() << " found " << found.transpose();
    ++checked;
  }
  EXPECT_GE(checked, 3) << camera.ModelName();
}

INSTANTIATE_TEST_SUITE_P(
    Models, RenderProjection,
    ::testing::Values(
        ModelCase{sensors::CameraModelId::kPinhole, 320, 240, {260, 262, 161.3, 118.9}},
        ModelCase{sensors::CameraModelId::kOpenCV, 320, 240, {260, 262, 158.2, 121.7, -0.12, 0.03, 0.001, -0.0008}},
        ModelCase{sensors::CameraModelId::kOpenCVFisheye, 320, 320, {110, 110, 161, 158, 0.02, -0.01, 0.002, 0.0}},
        ModelCase{sensors::CameraModelId::kEquirectangular, 720, 360, {720 / (2 * M_PI), 362.5, 178.0}}));

TEST(Render, DeterministicAndWritesPng) {
  const SimScene scene = MakeGateScene(GateOptions(), 2);
  RayCaster caster(scene.mesh);
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kPinhole;
  camera.width = 160;
  camera.height = 120;
  camera.params = {120, 120, 80, 60};
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d::UnitX();
  r.col(1) = -Eigen::Vector3d::UnitZ();
  r.col(2) = Eigen::Vector3d::UnitY();
  const Rigid3d cam_from_world = Rigid3d(Eigen::Quaterniond(r), Eigen::Vector3d(0, -8, 2)).Inverse();
  const GrayImage a = RenderImage(caster, scene, camera, cam_from_world, RenderOptions(), 5, 1, 1);
  const GrayImage b = RenderImage(caster, scene, camera, cam_from_world, RenderOptions(), 5, 1, 2);
  EXPECT_EQ(a.pixels, b.pixels);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("mmba_render_" + std::to_string(::getpid()) + ".png")).string();
  WritePng(a, path);
  const GrayImage back = ReadGray(path);
  EXPECT_EQ(back.pixels, a.pixels);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace mmba::sim
