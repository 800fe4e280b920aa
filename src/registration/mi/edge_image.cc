// The image side of the geometric term: Levinson & Thrun's (RSS 2013, Sec. IV-A) edge image and
// its inverse distance transform.

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "mmba/registration/mi/edges.h"

namespace mmba::registration::mi {

namespace {

// E: each pixel's largest absolute difference to its 8 neighbours (Levinson & Thrun).
std::vector<float> NeighbourEdges(const cv::Mat& image) {
  const int w = image.cols, h = image.rows;
  std::vector<float> edges(static_cast<size_t>(w) * h, 0.f);
  for (int y = 1; y + 1 < h; ++y) {
    const float* up = image.ptr<float>(y - 1);
    const float* row = image.ptr<float>(y);
    const float* down = image.ptr<float>(y + 1);
    float* out = &edges[static_cast<size_t>(y) * w];
    for (int x = 1; x + 1 < w; ++x) {
      const float v = row[x];
      float m = std::max({std::abs(up[x - 1] - v), std::abs(up[x] - v), std::abs(up[x + 1] - v),
                          std::abs(row[x - 1] - v), std::abs(row[x + 1] - v)});
      m = std::max({m, std::abs(down[x - 1] - v), std::abs(down[x] - v), std::abs(down[x + 1] - v)});
      out[x] = m;
    }
  }
  return edges;
}

// M_{i,j} = max_{x,y} E_{x,y} γ^{max(|x−i|,|y−j|)}: a forward raster pass over the four
// neighbours already visited, then a backward pass over the other four — the two-pass
// chamfer scheme of the Chebyshev distance transform (Rosenfeld & Pfaltz 1966) in max-product
// form (γ^d = exp(d ln γ), a distance transform of −ln E).
void SpreadMax(std::vector<float>* values, int w, int h, float gamma) {
  std::vector<float>& m = *values;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t k = static_cast<size_t>(y) * w + x;
      float best = m[k];
      if (x > 0) best = std::max(best, gamma * m[k - 1]);
      if (y > 0) {
        const size_t up = k - w;
        best = std::max(best, gamma * m[up]);
        if (x > 0) best = std::max(best, gamma * m[up - 1]);
        if (x + 1 < w) best = std::max(best, gamma * m[up + 1]);
      }
      m[k] = best;
    }
  }
  for (int y = h - 1; y >= 0; --y) {
    for (int x = w - 1; x >= 0; --x) {
      const size_t k = static_cast<size_t>(y) * w + x;
      float best = m[k];
      if (x + 1 < w) best = std::max(best, gamma * m[k + 1]);
      if (y + 1 < h) {
        const size_t down = k + w;
        best = std::max(best, gamma * m[down]);
        if (x > 0) best = std::max(best, gamma * m[down - 1]);
        if (x + 1 < w) best = std::max(best, gamma * m[down + 1]);
      }
      m[k] = best;
    }
  }
}

}  // namespace

GrayImage EdgeDistanceImage(const GrayImage& photo, double blur_px, double alpha, double gamma,
                            double smooth_px) {
  GrayImage out(photo.width, photo.height, 0.f);
  if (photo.width < 3 || photo.height < 3) return out;
  cv::Mat image(photo.height, photo.width, CV_32F, const_cast<float*>(photo.pixels.data()));
  cv::Mat blurred;
  if (blur_px > 0) {
    cv::GaussianBlur(image, blurred, cv::Size(0, 0), blur_px, blur_px, cv::BORDER_REPLICATE);
  } else {
    blurred = image;
  }
  std::vector<float> edges = NeighbourEdges(blurred);
  // No edges within a border of 2σ + 2 px: the blur's replicated border and a lens's dark
  // rim are not scene edges.
  const int border = static_cast<int>(std::ceil(2 * blur_px)) + 2;
  for (int y = 0; y < photo.height; ++y) {
    for (int x = 0; x < photo.width; ++x) {
      if (x < border || y < border || x >= photo.width - border || y >= photo.height - border) {
        edges[static_cast<size_t>(y) * photo.width + x] = 0.f;
      }
    }
  }
  std::vector<float> spread = edges;
  SpreadMax(&spread, photo.width, photo.height, static_cast<float>(gamma));
  // D = α E + (1 − α) M (Levinson & Thrun 2013, Sec. IV-A), then divided by its mean.
  double sum = 0;
  for (size_t k = 0; k < edges.size(); ++k) {
    out.pixels[k] = static_cast<float>(alpha * edges[k] + (1 - alpha) * spread[k]);
    sum += out.pixels[k];
  }
  if (smooth_px > 0) {
    // A coarse level: D itself blurred, so that its maximum widens without losing the edges
    // (blurring the photo instead would wash them out).
    cv::Mat d(photo.height, photo.width, CV_32F, out.pixels.data());
    cv::GaussianBlur(d, d, cv::Size(0, 0), smooth_px, smooth_px, cv::BORDER_REPLICATE);
    sum = cv::sum(d)[0];
  }
  const double mean = sum / static_cast<double>(out.pixels.size());
  if (mean > 0) {
    const float scale = static_cast<float>(1.0 / mean);
    for (float& v : out.pixels) v *= scale;
  }
  return out;
}

GrayImage EdgeLevelImage(const GrayImage& photo, const EdgeOptions& options, int level) {
  const double s = std::pow(options.level_blur_factor, level);
  return EdgeDistanceImage(photo, options.blur_px, options.alpha, std::pow(options.gamma, 1.0 / s),
                           level > 0 ? options.blur_px * s : 0.0);
}

}  // namespace mmba::registration::mi
