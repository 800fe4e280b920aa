// The metric's value from a joint histogram (JointHistogram::Evaluate): the marginal and
// joint entropies, MI = H(X) + H(Y) − H(X,Y), NMI = (H(X) + H(Y)) / H(X,Y) and
// NID = 1 − MI / H(X,Y), per LiDAR class and combined.
#include "mmba/registration/mi/metric.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glog/logging.h>

namespace mmba::registration::mi {
namespace {

double Entropy(const double* p, size_t count, double total) {
  double h = 0;
  for (size_t i = 0; i < count; ++i) {
    const double c = p[i];
    if (c > 0) {
      const double q = c / total;
      h -= q * std::log2(q);
    }
  }
  return h;
}

}  // namespace

MetricValue JointHistogram::Evaluate() const {
  MetricValue result;
  // With a background complement the sample count is the views' pixels (the covered
  // samples' weights are part of them).
  const double sample_count = total_ + std::max(0.0, background_pixels_ - lidar_total_);
  result.samples = sample_count;
  result.lidar_samples = lidar_total_;
  if (sample_count <= 0) return result;
  const int bins = bins_;
  const int stride = bins + 3;
  const bool whole = options_.region == Region::kWholeImage;
  // Rows: the empty-LiDAR bin first in whole-image mode, then the LiDAR bins of each class.
  const int classes = classes_;
  const int lidar_bins = (whole ? 1 : 0) + classes * bins;
  const int first = whole ? 1 : 0;
  // Fold the padding onto the edge bins (padded index p ↦ bin clamp(p − 1, 0, bins − 1)).
  auto fold = [bins](int p) { return std::clamp(p - 1, 0, bins - 1); };
  std::vector<double> joint(static_cast<size_t>(lidar_bins) * bins, 0.0);
  if (whole) {
    for (int q = 0; q < stride; ++q) joint[fold(q)] += empty_counts_[q];
    if (background_pixels_ > 0) {
      // The background as the complement of the covered samples' photo values.
      const std::vector<double> covered = PaddedCoveredPhoto();
      for (int q = 0; q < stride; ++q) joint[fold(q)] += background_[q] - covered[q];
      for (int y = 0; y < bins; ++y) joint[y] = std::max(0.0, joint[y]);
    }
  }
  for (int c = 0; c < classes; ++c) {
    for (int p = 0; p < stride; ++p) {
      double* row = &joint[static_cast<size_t>(first + c * bins + fold(p)) * bins];
      const double* padded = &counts_[static_cast<size_t>(c * stride + p) * stride];
      for (int q = 0; q < stride; ++q) row[fold(q)] += padded[q];
    }
  }
  // LiDAR rows evaluated as one histogram each: all of them, or with several classes the
  // rows of each class and, in whole-image mode, the empty row; the result is then the
  // metric conditioned on the class, Σ_c p(c)·metric_c.
  std::vector<std::pair<int, int>> blocks = {{0, lidar_bins}};
  if (classes > 1) {
    blocks.clear();
    for (int c = 0; c < classes; ++c) blocks.push_back({first + c * bins, first + (c + 1) * bins});
    if (whole) blocks.push_back({0, 1});
  }
  // Each block's weight p(c) from its counts before any Parzen window (whose clamped edges
  // do not keep a block's sum).
  std::vector<double> block_weight;
  {
    double raw_all = 0;
    for (const auto& [begin, end] : blocks) {
      double sum = 0;
      for (size_t k = static_cast<size_t>(begin) * bins; k < static_cast<size_t>(end) * bins; ++k) {
        sum += joint[k];
      }
      block_weight.push_back(sum);
      raw_all += sum;
    }
    for (double& w : block_weight) w = raw_all > 0 ? w / raw_all : 0.0;
  }
  if (options_.smoothing == Smoothing::kParzen) {
    // Separable Gaussian Parzen window over the bins (not across the empty LiDAR bin nor
    // across classes).
    const double sigma = options_.parzen_sigma_bins;
    const int radius = static_cast<int>(std::ceil(3 * sigma));
    std::vector<double> kernel(2 * radius + 1);
    double sum = 0;
    for (int i = -radius; i <= radius; ++i) {
      kernel[i + radius] = std::exp(-0.5 * i * i / (sigma * sigma));
      sum += kernel[i + radius];
    }
    for (double& w : kernel) w /= sum;
    std::vector<double> tmp(joint.size(), 0.0);
    for (int x = 0; x < lidar_bins; ++x) {  // along the photo axis
      for (int y = 0; y < bins; ++y) {
        double v = 0;
        for (int i = -radius; i <= radius; ++i) {
          const int yy = std::clamp(y + i, 0, bins - 1);
          v += kernel[i + radius] * joint[static_cast<size_t>(x) * bins + yy];
        }
        tmp[static_cast<size_t>(x) * bins + y] = v;
      }
    }
    joint = tmp;
    for (int x = first; x < lidar_bins; ++x) {  // along the LiDAR axis, within the class
      const int class_first = first + (x - first) / bins * bins;
      for (int y = 0; y < bins; ++y) {
        double v = 0;
        for (int i = -radius; i <= radius; ++i) {
          const int xx = std::clamp(x + i, class_first, class_first + bins - 1);
          v += kernel[i + radius] * tmp[static_cast<size_t>(xx) * bins + y];
        }
        joint[static_cast<size_t>(x) * bins + y] = v;
      }
    }
  }
  double all = 0;
  for (double c : joint) all += c;
  if (!(all > 0)) return result;
  result.nid = 0;  // a sum over the blocks below
  std::vector<double> lidar_marginal, photo_marginal;
  for (size_t b = 0; b < blocks.size(); ++b) {
    const auto& [begin, end] = blocks[b];
    const double* block = &joint[static_cast<size_t>(begin) * bins];
    const size_t size = static_cast<size_t>(end - begin) * bins;
    lidar_marginal.assign(end - begin, 0.0);
    photo_marginal.assign(bins, 0.0);
    double total = 0;
    for (int x = 0; x < end - begin; ++x) {
      for (int y = 0; y < bins; ++y) {
        const double c = block[static_cast<size_t>(x) * bins + y];
        lidar_marginal[x] += c;
        photo_marginal[y] += c;
        total += c;
      }
    }
    if (!(total > 0)) continue;
    const double weight = block_weight[b];  // exactly 1 for the single block
    // Eq. (1)–(3), Wang et al. 2012: MI = H(X) + H(Y) − H(X,Y).
    const double hx = Entropy(lidar_marginal.data(), lidar_marginal.size(), total);
    const double hy = Entropy(photo_marginal.data(), photo_marginal.size(), total);
    const double hxy = Entropy(block, size, total);
    const double mi = hx + hy - hxy;
    result.joint_entropy += weight * hxy;
    result.mi += weight * mi;
    result.nmi += weight * (hxy > 0 ? (hx + hy) / hxy : 1.0);
    result.nid += weight * (hxy > 0 ? 1.0 - mi / hxy : 1.0);
  }
  switch (options_.kind) {
    case MetricKind::kMi: result.value = result.mi; break;
    case MetricKind::kNmi: result.value = result.nmi; break;
    case MetricKind::kNid: result.value = -result.nid; break;
  }
  return result;
}

}  // namespace mmba::registration::mi
