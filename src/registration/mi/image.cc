#include "mmba/registration/mi/image.h"

#include <cmath>

namespace mmba::registration::mi {

bool GrayImage::Sample(double x, double y, float* value) const {
  // Pixel centres at +0.5: convert to index space.
  const double u = x - 0.5;
  const double v = y - 0.5;
  if (!(u >= 0) || !(v >= 0) || u > width - 1 || v > height - 1) return false;
  const int c0 = std::min(static_cast<int>(u), width - 2 < 0 ? 0 : width - 2);
  const int r0 = std::min(static_cast<int>(v), height - 2 < 0 ? 0 : height - 2);
  const int c1 = std::min(c0 + 1, width - 1);
  const int r1 = std::min(r0 + 1, height - 1);
  const float a = static_cast<float>(u - c0);
  const float b = static_cast<float>(v - r0);
  *value = (1 - a) * (1 - b) * at(c0, r0) + a * (1 - b) * at(c1, r0) + (1 - a) * b * at(c0, r1) +
           a * b * at(c1, r1);
  return true;
}

GrayImage Downsample2(const GrayImage& image) {
  GrayImage half(image.width / 2, image.height / 2);
  for (int r = 0; r < half.height; ++r) {
    for (int c = 0; c < half.width; ++c) {
      half.at(c, r) = 0.25f * (image.at(2 * c, 2 * r) + image.at(2 * c + 1, 2 * r) +
                               image.at(2 * c, 2 * r + 1) + image.at(2 * c + 1, 2 * r + 1));
    }
  }
  return half;
}

ImageContrast MeasureContrast(const GrayImage& image) {
  ImageContrast contrast;
  if (image.empty()) return contrast;
  double sum = 0, sum2 = 0;
  size_t dark = 0, saturated = 0;
  for (float v : image.pixels) {
    sum += v;
    sum2 += double(v) * v;
    dark += v <= 5.f;
    saturated += v >= 250.f;
  }
  const double n = static_cast<double>(image.pixels.size());
  contrast.mean = sum / n;
  contrast.stdev = std::sqrt(std::max(0.0, sum2 / n - contrast.mean * contrast.mean));
  contrast.fraction_dark = dark / n;
  contrast.fraction_saturated = saturated / n;
  return contrast;
}

}  // namespace mmba::registration::mi
