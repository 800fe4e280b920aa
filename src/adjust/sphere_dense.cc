// The only translation unit of mmba_adjust that includes OpenCV (semi-global matching).
#include "sphere_dense.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "mmba/core/error.h"
#include "mmba/registration/mi/image.h"

namespace mmba::adjust::internal {
namespace {

/// The panorama as 8-bit grey (read by the MI module's reader: its errors name the file), of
/// the calibrated size.
cv::Mat ReadGray(const std::string& path, const sensors::Camera& camera) {
  registration::mi::GrayImage gray = registration::mi::ReadGrayImage(path);
  if (static_cast<uint64_t>(gray.width) != camera.width || static_cast<uint64_t>(gray.height) != camera.height) {
    throw InputError::Message(path, "found a " + std::to_string(gray.width) + "x" + std::to_string(gray.height) +
                                        " panorama, expected the calibrated " + std::to_string(camera.width) + "x" +
                                        std::to_string(camera.height));
  }
  cv::Mat image;
  cv::Mat(gray.height, gray.width, CV_32F, gray.pixels.data()).convertTo(image, CV_8U);
  return image;
}

}  // namespace

bool TriangulateMidpoint(const Eigen::Vector3d& a, const Eigen::Vector3d& c, const Eigen::Vector3d& b,
                         Eigen::Vector3d* point) {
  // min |s·a − (c + t·b)|²: the normal equations of [a, −b]·(s, t)ᵀ = c.
  const double ab = a.dot(b);
  const double det = 1.0 - ab * ab;
  if (det < 1e-12) return false;
  const double ac = a.dot(c), bc = b.dot(c);
  const double s = (ac - ab * bc) / det;
  const double t = (ab * ac - bc) / det;
  if (!(s > 0) || !(t > 0)) return false;
  *point = 0.5 * (s * a + c + t * b);
  return true;
}

DenseStereoCloud DenseSphericalStereo(const std::string& lower_path, const std::string& upper_path,
                                      const sensors::Camera& lower, const sensors::Camera& upper,
                                      const Eigen::Vector3d& baseline, const DenseStereoOptions& options) {
  const cv::Mat lower_full = ReadGray(lower_path, lower);
  const cv::Mat upper_full = ReadGray(upper_path, upper);
  DenseStereoCloud out;
  const double scale = std::min(1.0, static_cast<double>(options.max_width) / lower.width);
  const int width = static_cast<int>(std::lround(static_cast<double>(lower.width) * scale));
  const int height = static_cast<int>(std::lround(static_cast<double>(lower.height) * scale));
  out.match_width = width;
  // The upper panorama resampled onto the lower's intrinsics at the matching scale: the same
  // bearing lands on the same pixel in both (the pair shares its orientation), so a point
  // moves only along its column, by the parallax of the vertical baseline.
  cv::Mat lower_scaled = lower_full, upper_scaled = upper_full;
  if (scale < 1.0) {
    cv::resize(lower_full, lower_scaled, cv::Size(width, height), 0, 0, cv::INTER_AREA);
    cv::resize(upper_full, upper_scaled, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  }
  // Pixel centres: full-resolution x = (x_scaled + 0.5) / scale − 0.5.
  const auto full = [&](double x) { return (x + 0.5) / scale - 0.5; };
  const auto scaled = [&](double x) { return (x + 0.5) * scale - 0.5; };
  cv::Mat map_x(height, width, CV_32F), map_y(height, width, CV_32F);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d ray = lower.CamFromImg(Eigen::Vector2d(full(u), full(v)));
      const std::optional<Eigen::Vector2d> xy = upper.ImgFromCam(ray);
      map_x.at<float>(v, u) = xy ? static_cast<float>(scaled(xy->x())) : -1.0f;
      map_y.at<float>(v, u) = xy ? static_cast<float>(scaled(xy->y())) : -1.0f;
    }
  }
  cv::Mat upper_resampled;
  cv::remap(upper_scaled, upper_resampled, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  // Columns become rows. The upper sphere sees a point further down (larger y), so the upper
  // panorama is the "left" image: x_lower = x_upper − d with d >= 0.
  cv::Mat left, right;
  cv::transpose(upper_resampled, left);
  cv::transpose(lower_scaled, right);
  const double f = lower.params[0] * scale;  // px per radian at the matching scale
  const int max_disparity = std::clamp(static_cast<int>(std::ceil(f * baseline.norm() / options.min_range_m / 16.0)) * 16, 16, 512);
  const int block = 5;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0, max_disparity, block, 8 * block * block, 32 * block * block,
                                                        1, 0, 10, 100, 2, cv::StereoSGBM::MODE_SGBM);
  cv::Mat disparity16;
  sgbm->compute(left, right, disparity16);  // fixed point, 4 fractional bits
  // Texture along the matching direction, averaged over the block: where there is none (sky,
  // blank walls) semi-global matching only spreads the disparity of the nearest edge.
  cv::Mat gradient, texture;
  cv::Sobel(left, gradient, CV_32F, 1, 0, 3);
  cv::boxFilter(cv::abs(gradient), texture, CV_32F, cv::Size(block, block));

  for (int u = 0; u < width; ++u) {          // rows of the transposed images
    for (int v = 0; v < height; ++v) {       // columns: the upper panorama's y
      const short raw = disparity16.at<short>(u, v);
      if (raw <= 0 || texture.at<float>(u, v) < options.min_texture) continue;
      ++out.matched_pixels;
      const double d = raw / 16.0;
      const auto ray = [&](double column, double row) {
        return lower.CamFromImg(Eigen::Vector2d(full(column), full(row))).normalized();
      };
      // Both bearings through the lower intrinsics (the upper image was resampled onto them).
      const Eigen::Vector3d upper_ray = ray(u, v);
      Eigen::Vector3d point, shifted;
      if (!TriangulateMidpoint(ray(u, v - d), baseline, upper_ray, &point)) continue;
      const double range = point.norm();
      if (range < options.min_range_m || range > options.max_range_m) continue;
      // σ of the range from the disparity's: the same triangulation one σ further.
      if (!TriangulateMidpoint(ray(u, v - d - options.disparity_sigma_px), baseline, upper_ray, &shifted)) continue;
      const double sigma = std::abs(shifted.norm() - range);
      if (!(sigma <= options.max_relative_sigma * range)) continue;
      out.cloud.points.push_back(point);
      const int row = std::clamp(static_cast<int>(std::lround(v - d)), 0, height - 1);
      out.cloud.intensity.push_back(lower_scaled.at<uint8_t>(row, u) / 255.0f);
      out.range_sigma_m.push_back(sigma);
    }
  }
  return out;
}

}  // namespace mmba::adjust::internal
