// The dense cloud of a vertical-baseline spherical stereo pair, on panoramas rendered here
// of a known scene: a textured ground 1.5 m below the lower sphere and a textured cylindrical
// wall 8 m around it.
#include "../../src/adjust/sphere_dense.h"

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/sensors/camera_models.h"

namespace mmba::adjust::internal {
namespace {

namespace fs = std::filesystem;

constexpr double kGround = 1.5;  // y (down) of the ground in the lower sphere's frame
constexpr double kWall = 8.0;    // horizontal radius of the wall

double Hash(int64_t a, int64_t b) {
  uint64_t h = static_cast<uint64_t>(a) * 0x9E3779B97F4A7C15ULL ^ static_cast<uint64_t>(b) * 0xC2B2AE3D27D4EB4FULL;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 32;
  return (h % 1000) / 1000.0;
}

/// Grey value seen along `ray` from `centre`; 0 when the ray meets nothing (sky).
double Shade(const Eigen::Vector3d& centre, const Eigen::Vector3d& ray) {
  double best = 1e300;
  double value = 0.0;
  if (ray.y() > 1e-9) {  // the ground
    const double t = (kGround - centre.y()) / ray.y();
    const Eigen::Vector3d p = centre + t * ray;
    if (t > 0 && std::hypot(p.x(), p.z()) < kWall) {
      best = t;
      value = 0.2 + 0.6 * Hash(static_cast<int64_t>(std::floor(p.x() / 0.25)), static_cast<int64_t>(std::floor(p.z() / 0.25)));
    }
  }
  // The wall: |(c + t·r)_xz| = R.
  const double a = ray.x() * ray.x() + ray.z() * ray.z();
  const double b = 2 * (centre.x() * ray.x() + centre.z() * ray.z());
  const double c = centre.x() * centre.x() + centre.z() * centre.z() - kWall * kWall;
  if (a > 1e-12) {
    const double t = (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
    const Eigen::Vector3d p = centre + t * ray;
    if (t > 0 && t < best && p.y() < kGround && p.y() > -6.0) {
      const double azimuth = std::atan2(p.x(), p.z());
      value = 0.2 + 0.6 * Hash(static_cast<int64_t>(std::floor(azimuth * kWall / 0.3)) + 7,
                               static_cast<int64_t>(std::floor(p.y() / 0.3)));
    }
  }
  return value;
}

/// A binary PGM of the panorama seen from `centre` (OpenCV reads PGM).
void Render(const fs::path& path, const sensors::Camera& camera, const Eigen::Vector3d& centre) {
  std::ofstream out(path, std::ios::binary);
  out << "P5\n" << camera.width << " " << camera.height << "\n255\n";
  for (uint64_t v = 0; v < camera.height; ++v) {
    for (uint64_t u = 0; u < camera.width; ++u) {
      // 2×2 supersampling: the panorama is an area sample, as a camera's is.
      double sum = 0.0;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d xy(u - 0.25 + 0.5 * (k % 2), v - 0.25 + 0.5 * (k / 2));
        sum += Shade(centre, camera.CamFromImg(xy).normalized());
      }
      out.put(static_cast<char>(std::lround(255 * sum / 4)));
    }
  }
}

sensors::Camera Sphere(double cx, double cy) {
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kEquirectangular;
  camera.width = 1024;
  camera.height = 512;
  camera.params = {1024 / (2 * M_PI), cx, cy};
  return camera;
}

/// Distance of a lower-frame point from the scene's surfaces.
double SurfaceDistance(const Eigen::Vector3d& p) {
  return std::min(std::abs(p.y() - kGround), std::abs(std::hypot(p.x(), p.z()) - kWall));
}

TEST(DenseSphericalStereo, PointsLieOnTheRenderedSurfacesWithinTheirSigma) {
  const fs::path dir = fs::path(testing::TempDir()) / "mmba_sphere_dense";
  fs::create_directories(dir);
  // Different principal points, as a line-scan pair has: the upper panorama is resampled.
  const sensors::Camera lower = Sphere(512.0, 256.0), upper = Sphere(513.7, 255.2);
  const Eigen::Vector3d baseline(0, -0.6, 0);
  Render(dir / "lower.pgm", lower, Eigen::Vector3d::Zero());
  Render(dir / "upper.pgm", upper, baseline);
  const DenseStereoCloud dense =
      DenseSphericalStereo((dir / "lower.pgm").string(), (dir / "upper.pgm").string(), lower, upper, baseline);
  ASSERT_GT(dense.cloud.size(), 20000u);
  ASSERT_EQ(dense.range_sigma_m.size(), dense.cloud.size());
  ASSERT_EQ(dense.cloud.intensity.size(), dense.cloud.size());
  std::vector<double> normalised, wall;
  for (size_t i = 0; i < dense.cloud.size(); ++i) {
    const Eigen::Vector3d& p = dense.cloud.points[i];
    normalised.push_back(SurfaceDistance(p) / dense.range_sigma_m[i]);
    if (std::abs(std::hypot(p.x(), p.z()) - kWall) < 1.0) wall.push_back(p.y());
  }
  std::sort(normalised.begin(), normalised.end());
  // Within their σ (that of a 0.5 px disparity error; ~0.2σ at the median here, where the
  // rendering is noise-free); the wall seen over its height.
  EXPECT_LT(normalised[normalised.size() / 2], 0.6);
  EXPECT_LT(normalised[normalised.size() * 9 / 10], 1.5);
  ASSERT_GT(wall.size(), 5000u);
  EXPECT_LT(*std::min_element(wall.begin(), wall.end()), -3.0);
  // A sign error in the disparity would put the points above the upper sphere or behind it.
  size_t behind = 0;
  for (const Eigen::Vector3d& p : dense.cloud.points) behind += SurfaceDistance(p) > 2.0 ? 1 : 0;
  EXPECT_LT(behind, dense.cloud.size() / 100);
}

TEST(DenseSphericalStereo, AWrongSizedPanoramaNamesTheFile) {
  const fs::path dir = fs::path(testing::TempDir()) / "mmba_sphere_dense_bad";
  fs::create_directories(dir);
  sensors::Camera small = Sphere(256.0, 128.0);
  small.width = 512;
  small.height = 256;
  Render(dir / "lower.pgm", small, Eigen::Vector3d::Zero());
  Render(dir / "upper.pgm", small, Eigen::Vector3d(0, -0.6, 0));
  const sensors::Camera calibrated = Sphere(512.0, 256.0);
  try {
    DenseSphericalStereo((dir / "lower.pgm").string(), (dir / "upper.pgm").string(), calibrated, calibrated,
                         Eigen::Vector3d(0, -0.6, 0));
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lower.pgm"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("512x256"), std::string::npos) << e.what();
  }
}

TEST(TriangulateMidpoint, IntersectingRaysMeetAtThePointAndParallelOnesFail) {
  const Eigen::Vector3d x(3, 1, 7), c(0, -0.6, 0);
  Eigen::Vector3d p;
  ASSERT_TRUE(TriangulateMidpoint(x.normalized(), c, (x - c).normalized(), &p));
  EXPECT_LT((p - x).norm(), 1e-9);
  EXPECT_FALSE(TriangulateMidpoint(Eigen::Vector3d::UnitZ(), c, Eigen::Vector3d::UnitZ(), &p));
  EXPECT_FALSE(TriangulateMidpoint(x.normalized(), c, -(x - c).normalized(), &p));  // behind the upper centre
}

}  // namespace
}  // namespace mmba::adjust::internal
