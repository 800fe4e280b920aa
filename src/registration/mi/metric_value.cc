// The metric's value from a joint histogram (JointHistogram::Evaluate): the marginal and
// joint entropies, MI = H(X) + H(Y) − H(X,Y), NMI = (H(X) + H(Y)) / H(X,Y) and
// NID = 1 − MI / H(X,Y), per LiDAR class and combined.
#include "mmba/registration/mi/metric.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <glog/logging.h>

namespace mmba::registration::mi {
namespace {

// Rows [begin, end) of the folded histogram evaluated as one histogram.
using Block = std::pair<int, int>;

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

// LiDAR rows evaluated as one histogram each: all of them, or with several classes the
// rows of each class and, in whole-image mode, the empty row; the result is then the
// metric conditioned on the class, Σ_c p(c)·metric_c.
std::vector<Block> ClassBlocks(int classes, int bins, bool whole) {
  const int first = whole ? 1 : 0;
  if (classes == 1) return {{0, first + bins}};
  std::vector<Block> blocks;
  for (int c = 0; c < classes; ++c) blocks.push_back({first + c * bins, first + (c + 1) * bins});
  if (whole) blocks.push_back({0, 1});
  return blocks;
}

// Each block's weight p(c) from its counts before any Parzen window (whose clamped edges
// do not keep a block's sum).
std::vector<double> BlockWeights(const std::vector<double>& joint, const std::vector<Block>& blocks,
                                 int bins) {
  std::vector<double> block_weight;
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
  return block_weight;
}

// Separable Gaussian Parzen window of `sigma` bins over the histogram's `lidar_bins` rows
// (not across the empty LiDAR row, the first when `first` is 1, nor across classes).
void ParzenSmooth(double sigma, int bins, int first, int lidar_bins, std::vector<double>* joint) {
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> kernel(2 * radius + 1);
  double sum = 0;
  for (int i = -radius; i <= radius; ++i) {
    kernel[i + radius] = std::exp(-0.5 * i * i / (sigma * sigma));
    sum += kernel[i + radius];
  }
  for (double& w : kernel) w /= sum;
  std::vector<double> tmp(joint->size(), 0.0);
  for (int x = 0; x < lidar_bins; ++x) {  // along the photo axis
    for (int y = 0; y < bins; ++y) {
      double v = 0;
      for (int i = -radius; i <= radius; ++i) {
        const int yy = std::clamp(y + i, 0, bins - 1);
        v += kernel[i + radius] * (*joint)[static_cast<size_t>(x) * bins + yy];
      }
      tmp[static_cast<size_t>(x) * bins + y] = v;
    }
  }
  *joint = tmp;
  for (int x = first; x < lidar_bins; ++x) {  // along the LiDAR axis, within the class
    const int class_first = first + (x - first) / bins * bins;
    for (int y = 0; y < bins; ++y) {
      double v = 0;
      for (int i = -radius; i <= radius; ++i) {
        const int xx = std::clamp(x + i, class_first, class_first + bins - 1);
        v += kernel[i + radius] * tmp[static_cast<size_t>(xx) * bins + y];
      }
      (*joint)[static_cast<size_t>(x) * bins + y] = v;
    }
  }
}

// Adds `weight` times one block's entropies and metrics (`rows` LiDAR rows of `bins` photo
// bins at `block`) to `result`; an empty block adds nothing.
void AddBlockMetrics(const double* block, int rows, int bins, double weight, MetricValue* result) {
  std::vector<double> lidar_marginal(rows, 0.0), photo_marginal(bins, 0.0);
  double total = 0;
  for (int x = 0; x < rows; ++x) {
    for (int y = 0; y < bins; ++y) {
      const double c = block[static_cast<size_t>(x) * bins + y];
      lidar_marginal[x] += c;
      photo_marginal[y] += c;
      total += c;
    }
  }
  if (!(total > 0)) return;
  // Eq. (1)–(3), Wang et al. 2012: MI = H(X) + H(Y) − H(X,Y).
  const double hx = Entropy(lidar_marginal.data(), lidar_marginal.size(), total);
  const double hy = Entropy(photo_marginal.data(), photo_marginal.size(), total);
  const double hxy = Entropy(block, static_cast<size_t>(rows) * bins, total);
  const double mi = hx + hy - hxy;
  result->joint_entropy += weight * hxy;
  result->mi += weight * mi;
  // NMI = (H(X) + H(Y)) / H(X,Y) (Studholme et al. 1999); NID = 1 − MI / H(X,Y) (Li et al.
  // 2004); both 1 for a block of one bin.
  result->nmi += weight * (hxy > 0 ? (hx + hy) / hxy : 1.0);
  result->nid += weight * (hxy > 0 ? 1.0 - mi / hxy : 1.0);
}

}  // namespace

std::vector<double> JointHistogram::FoldedJoint() const {
  const int bins = bins_;
  const int stride = bins + 3;
  const bool whole = options_.region == Region::kWholeImage;
  const int first = whole ? 1 : 0;
  const int lidar_bins = first + classes_ * bins;
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
  for (int c = 0; c < classes_; ++c) {
    for (int p = 0; p < stride; ++p) {
      double* row = &joint[static_cast<size_t>(first + c * bins + fold(p)) * bins];
      const double* padded = &counts_[static_cast<size_t>(c * stride + p) * stride];
      for (int q = 0; q < stride; ++q) row[fold(q)] += padded[q];
    }
  }
  return joint;
}

MetricValue JointHistogram::Evaluate() const {
  MetricValue result;
  // With a background complement the sample count is the views' pixels (the covered
  // samples' weights are part of them).
  const double sample_count = total_ + std::max(0.0, background_pixels_ - lidar_total_);
  result.samples = sample_count;
  result.lidar_samples = lidar_total_;
  if (sample_count <= 0) return result;
  const bool whole = options_.region == Region::kWholeImage;
  const int first = whole ? 1 : 0;
  const int lidar_bins = first + classes_ * bins_;
  std::vector<double> joint = FoldedJoint();
  const std::vector<Block> blocks = ClassBlocks(classes_, bins_, whole);
  const std::vector<double> block_weight = BlockWeights(joint, blocks, bins_);
  if (options_.smoothing == Smoothing::kParzen) {
    ParzenSmooth(options_.parzen_sigma_bins, bins_, first, lidar_bins, &joint);
  }
  double all = 0;
  for (double c : joint) all += c;
  if (!(all > 0)) return result;
  result.nid = 0;  // a sum over the blocks below
  for (size_t b = 0; b < blocks.size(); ++b) {
    const auto& [begin, end] = blocks[b];
    // block_weight is exactly 1 for the single block.
    AddBlockMetrics(&joint[static_cast<size_t>(begin) * bins_], end - begin, bins_, block_weight[b],
                    &result);
  }
  switch (options_.kind) {
    case MetricKind::kMi: result.value = result.mi; break;
    case MetricKind::kNmi: result.value = result.nmi; break;
    case MetricKind::kNid: result.value = -result.nid; break;
  }
  return result;
}

}  // namespace mmba::registration::mi
