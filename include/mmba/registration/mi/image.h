#pragma once

// Grey images for MI registration (library mmba_registration_mi). Plain float buffers so that
// OpenCV stays inside two .cc files (image_io.cc, probe_plot.cc).

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace mmba::registration::mi {

/// A grey image, row-major, values 0..255 (8-bit range even when stored as float).
/// Pixel (c, r) covers [c, c+1) × [r, r+1); its centre is (c + 0.5, r + 0.5) (COLMAP).
struct GrayImage {
  int width = 0;
  int height = 0;
  std::vector<float> pixels;  ///< width·height, row-major

  GrayImage() = default;
  GrayImage(int w, int h, float fill = 0.f) : width(w), height(h), pixels(size_t(w) * h, fill) {}
  bool empty() const { return pixels.empty(); }
  float& at(int c, int r) { return pixels[size_t(r) * width + c]; }
  float at(int c, int r) const { return pixels[size_t(r) * width + c]; }
  /// Bilinear value at continuous pixel coordinates (COLMAP convention); false outside.
  bool Sample(double x, double y, float* value) const;
};

/// Bilinear value at continuous pixel coordinates (x, y), clamped to the image: the same as
/// GrayImage::Sample inside, the nearest edge value outside (a point's sub-pixel offset can
/// reach half a pixel past the border). The photo sampler of the B-spline histogram (always
/// inlined: it is the inner loop of every evaluation).
[[gnu::always_inline]] inline float SampleClamped(const GrayImage& photo, float x, float y) {
  const float u = std::clamp(x - 0.5f, 0.f, static_cast<float>(photo.width - 1));
  const float v = std::clamp(y - 0.5f, 0.f, static_cast<float>(photo.height - 1));
  const int c0 = std::min(static_cast<int>(u), std::max(0, photo.width - 2));
  const int r0 = std::min(static_cast<int>(v), std::max(0, photo.height - 2));
  const int c1 = std::min(c0 + 1, photo.width - 1);
  const int r1 = std::min(r0 + 1, photo.height - 1);
  const float a = u - c0, b = v - r0;
  const float* row0 = &photo.pixels[static_cast<size_t>(r0) * photo.width];
  const float* row1 = &photo.pixels[static_cast<size_t>(r1) * photo.width];
  return (1 - b) * ((1 - a) * row0[c0] + a * row0[c1]) + b * ((1 - a) * row1[c0] + a * row1[c1]);
}

/// Reads an image file (PNG, JPEG, TIFF, PGM, ... through OpenCV) as grey on 0..255 (colour
/// converted with the usual luma weights). 8-bit images as they are; deeper ones by the
/// sensor's range, as fractions: integers against the fewest of 8, 10, 12, 14, 16 bits that
/// hold the largest value (a 12-bit camera's 0..4095 onto 0..255), floating point against 1
/// (or its largest value when above 1); NaN is black. Throws InputError naming the file when it
/// is missing, not an image, or holds negative values.
GrayImage ReadGrayImage(const std::string& path);

/// Writes an 8-bit grey PNG atomically (values clamped to 0..255).
void WriteGrayPng(const GrayImage& image, const std::string& path);

/// Half resolution by 2×2 box averaging (odd last row/column dropped).
GrayImage Downsample2(const GrayImage& image);

/// Statistics used to refuse images the paper's method cannot register (overexposed/black).
struct ImageContrast {
  double mean = 0;
  double stdev = 0;
  double fraction_dark = 0;       ///< value <= 5
  double fraction_saturated = 0;  ///< value >= 250
};
ImageContrast MeasureContrast(const GrayImage& image);

}  // namespace mmba::registration::mi
