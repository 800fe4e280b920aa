#include "mmba/sim/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "mmba/core/parallel_for.h"
#include "mmba/sim/texture.h"
#include "sim/random_internal.h"

namespace mmba::sim {

bool GrayImage::Sample(double x, double y, double* value) const {
  const double fx = x - 0.5, fy = y - 0.5;
  if (!(fx >= 0 && fy >= 0 && fx <= width - 1 && fy <= height - 1)) return false;
  const int x0 = std::min(static_cast<int>(fx), width - 2 < 0 ? 0 : width - 2);
  const int y0 = std::min(static_cast<int>(fy), height - 2 < 0 ? 0 : height - 2);
  const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  const double tx = fx - x0, ty = fy - y0;
  *value = (1 - ty) * ((1 - tx) * at(x0, y0) + tx * at(x1, y0)) +
           ty * ((1 - tx) * at(x0, y1) + tx * at(x1, y1));
  return true;
}

bool RenderOptions::Check(std::string* error) const {
  std::ostringstream e;
  if (samples_per_axis < 1 || samples_per_axis > 8) e << "render samples_per_axis " << samples_per_axis << " must be in [1, 8]";
  else if (!(sun_direction.norm() > 0)) e << "render sun_direction must be non-zero";
  else if (!(ambient >= 0 && ambient <= 1)) e << "render ambient " << ambient << " must be in [0, 1]";
  else if (!(exposure > 0)) e << "render exposure " << exposure << " must be > 0";
  else if (!(noise_sigma_dn >= 0)) e << "render noise_sigma_dn " << noise_sigma_dn << " must be >= 0";
  if (e.str().empty()) return true;
  if (error) *error = e.str();
  return false;
}

namespace {

// Radiance (0..~1) seen along a ray.
double Shade(const RayCaster& caster, const SimScene& scene, const Eigen::Vector3d& origin,
             const Eigen::Vector3d& direction, const RenderOptions& options,
             const Eigen::Vector3d& sun, uint64_t seed, int depth) {
  const RayHit hit = caster.Intersect(origin, direction, 1e-3);
  if (!hit.hit) return options.sky;
  const TriangleMesh& mesh = scene.mesh;
  const Material& material = mesh.materials[mesh.triangle_material[hit.triangle]];
  const double albedo = Albedo(material, hit.point, hit.normal, seed);
  const double lambert = std::max(0.0, hit.normal.dot(sun));
  double radiance = albedo * (options.ambient + (1.0 - options.ambient) * lambert);
  if (material.material_class != MaterialClass::kDiffuse && depth < 1) {
    // One mirror bounce: glass reflects ~20 %, polished metal ~60 %.
    const Eigen::Vector3d reflected = direction - 2.0 * direction.dot(hit.normal) * hit.normal;
    const double k = material.material_class == MaterialClass::kGlass ? 0.2 : 0.6;
    radiance = (1 - k) * radiance +
               k * Shade(caster, scene, hit.point, reflected, options, sun, seed, depth + 1);
  }
  return radiance;
}

uint8_t ToByte(double radiance, double exposure, double noise) {
  // sRGB-like gamma 1/2.2.
  const double v = 255.0 * std::pow(std::clamp(radiance * exposure, 0.0, 1.0), 1.0 / 2.2) + noise;
  return static_cast<uint8_t>(std::clamp(std::lround(v), 0l, 255l));
}

}  // namespace

RayTable MakeRayTable(const sensors::Camera& camera, int samples_per_axis, int threads) {
  RayTable table;
  const int n = samples_per_axis;
  table.samples_per_axis = n;
  const int width = static_cast<int>(camera.width), height = static_cast<int>(camera.height);
  table.rays.assign(static_cast<size_t>(width) * height * n * n,
                    Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  ParallelChunks(static_cast<size_t>(height), threads, [&](size_t begin, size_t end) {
    for (size_t y = begin; y < end; ++y) {
      for (int x = 0; x < width; ++x) {
        for (int sy = 0; sy < n; ++sy) {
          for (int sx = 0; sx < n; ++sx) {
            const Eigen::Vector2d xy(x + (sx + 0.5) / n, static_cast<double>(y) + (sy + 0.5) / n);
            // NaN outside the model's domain (a fisheye's corners beyond 90°): no ray, black.
            const Eigen::Vector3d ray = camera.CamFromImg(xy);
            if (!ray.allFinite()) continue;
            table.rays[((y * width + x) * n + sy) * n + sx] = ray.normalized();
          }
        }
      }
    }
  });
  return table;
}

GrayImage RenderImage(const RayCaster& caster, const SimScene& scene,
                      const sensors::Camera& camera, const Rigid3d& cam_from_world,
                      const RenderOptions& options, uint64_t seed, uint64_t stream, int threads,
                      const RayTable* rays) {
  RayTable own;
  if (rays == nullptr || rays->samples_per_axis != options.samples_per_axis ||
      rays->rays.size() != camera.width * camera.height * options.samples_per_axis *
                               options.samples_per_axis) {
    own = MakeRayTable(camera, options.samples_per_axis, threads);
    rays = &own;
  }
  GrayImage image;
  image.width = static_cast<int>(camera.width);
  image.height = static_cast<int>(camera.height);
  image.pixels.assign(static_cast<size_t>(image.width) * image.height, 0);
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  const Eigen::Vector3d origin = world_from_cam.translation;
  const Eigen::Vector3d sun = options.sun_direction.normalized();
  const int n2 = options.samples_per_axis * options.samples_per_axis;
  ParallelChunks(static_cast<size_t>(image.height), threads, [&](size_t begin, size_t end) {
    for (size_t y = begin; y < end; ++y) {
      for (int x = 0; x < image.width; ++x) {
        double sum = 0;
        int count = 0;
        const size_t base = (y * image.width + x) * n2;
        for (int k = 0; k < n2; ++k) {
          const Eigen::Vector3d& ray = rays->rays[base + k];
          if (!ray.allFinite()) continue;
          sum += Shade(caster, scene, origin, world_from_cam.rotation * ray, options, sun, seed, 0);
          ++count;
        }
        if (count == 0) continue;
        internal::Rng rng(seed, stream, y * image.width + x);
        image.pixels[y * image.width + x] =
            ToByte(sum / count, options.exposure, rng.Normal(options.noise_sigma_dn));
      }
    }
  });
  return image;
}

GrayImage StitchPanorama(const std::vector<GrayImage>& images,
                         const std::vector<sensors::Camera>& cameras,
                         const std::vector<Rigid3d>& cam_from_rig,
                         const sensors::Camera& pano_camera, double stitch_distance_m,
                         int threads) {
  GrayImage pano;
  pano.width = static_cast<int>(pano_camera.width);
  pano.height = static_cast<int>(pano_camera.height);
  pano.pixels.assign(static_cast<size_t>(pano.width) * pano.height, 0);
  ParallelChunks(static_cast<size_t>(pano.height), threads, [&](size_t begin, size_t end) {
    for (size_t y = begin; y < end; ++y) {
      for (int x = 0; x < pano.width; ++x) {
        const Eigen::Vector3d bearing =
            pano_camera.CamFromImg(Eigen::Vector2d(x + 0.5, y + 0.5)).normalized();
        const Eigen::Vector3d point_in_rig = stitch_distance_m * bearing;
        double best_margin = 0, best_value = 0;
        bool found = false;
        for (size_t c = 0; c < cameras.size(); ++c) {
          const Eigen::Vector3d p = cam_from_rig[c] * point_in_rig;
          if (p.z() <= 0) continue;
          const auto xy = cameras[c].ImgFromCam(p);
          if (!xy) continue;
          const double margin = std::min(std::min(xy->x(), cameras[c].width - xy->x()),
                                         std::min(xy->y(), cameras[c].height - xy->y()));
          double value;
          if (margin > best_margin && images[c].Sample(xy->x(), xy->y(), &value) &&
              (value > 0 || !found)) {
            best_margin = margin;
            best_value = value;
            found = true;
          }
        }
        if (found) pano.pixels[y * pano.width + x] = static_cast<uint8_t>(std::lround(best_value));
      }
    }
  });
  return pano;
}

}  // namespace mmba::sim
