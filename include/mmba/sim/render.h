#pragma once

// Rendering by ray casting: one ray per pixel sample through the camera model's CamFromImg
// (so distortion, fisheye and equirectangular projections are exact by construction), shaded
// with the procedural albedo, a sun (Lambert) and ambient light; glass is dark, reflective
// surfaces mirror one bounce. Grey 8-bit images.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"
#include "mmba/sim/ray_caster.h"
#include "mmba/sim/scenes.h"

namespace mmba::sim {

/// An 8-bit grey image, row-major.
struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;
  uint8_t at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
  /// Bilinear sample at continuous pixel coordinates (COLMAP convention: centre of the
  /// top-left pixel at (0.5, 0.5)); returns false outside the image.
  bool Sample(double x, double y, double* value) const;
};

struct RenderOptions {
  int samples_per_axis = 1;         ///< supersampling: n×n rays per pixel
  Eigen::Vector3d sun_direction = Eigen::Vector3d(0.4, -0.6, 0.7);  ///< towards the sun
  double ambient = 0.35;
  double sky = 0.85;                ///< radiance of rays that hit nothing
  double exposure = 1.0;
  double noise_sigma_dn = 1.0;      ///< Gaussian sensor noise, digital numbers
  bool Check(std::string* error) const;
};

/// The unit viewing rays (camera frame) of every pixel sample of a camera, computed once and
/// reused for every pose (undistortion is iterative, so this saves most of the work for
/// OPENCV and OPENCV_FISHEYE). Rays the model cannot form are NaN.
struct RayTable {
  int samples_per_axis = 1;
  std::vector<Eigen::Vector3d> rays;  ///< (y·W + x)·n² + sy·n + sx
};
RayTable MakeRayTable(const sensors::Camera& camera, int samples_per_axis, int threads);

/// Renders what `camera` at `cam_from_world` sees. Pixels whose ray the model cannot form
/// (outside a fisheye's domain) are black. Deterministic for `seed` and `stream`. `rays`
/// (optional) must come from MakeRayTable(camera, options.samples_per_axis).
GrayImage RenderImage(const RayCaster& caster, const SimScene& scene,
                      const sensors::Camera& camera, const Rigid3d& cam_from_world,
                      const RenderOptions& options, uint64_t seed, uint64_t stream, int threads,
                      const RayTable* rays = nullptr);

/// Stitches the images of a rig into an equirectangular panorama (`pano_camera`, in the rig
/// frame): every panorama pixel's bearing is placed at `stitch_distance_m` from the rig
/// centre, projected into each camera, and sampled (bilinear) from the camera whose image
/// point lies farthest inside its image border. Uncovered pixels are black.
GrayImage StitchPanorama(const std::vector<GrayImage>& images,
                         const std::vector<sensors::Camera>& cameras,
                         const std::vector<Rigid3d>& cam_from_rig,
                         const sensors::Camera& pano_camera, double stitch_distance_m,
                         int threads);

/// Writes a PNG (OpenCV imwrite), atomically.
void WritePng(const GrayImage& image, const std::string& path);
/// Reads a grey PNG/JPEG (for tests); throws InputError.
GrayImage ReadGray(const std::string& path);

}  // namespace mmba::sim
