#include "mmba/registration/mi/metric.h"

#include <algorithm>
#include <cmath>

namespace mmba::registration::mi {

std::string MetricName(MetricKind kind) {
  switch (kind) {
    case MetricKind::kMi: return "mi";
    case MetricKind::kNmi: return "nmi";
    case MetricKind::kNid: return "nid";
  }
  return "";
}

bool ParseMetric(const std::string& name, MetricKind* kind) {
  for (MetricKind k : {MetricKind::kMi, MetricKind::kNmi, MetricKind::kNid}) {
    if (name == MetricName(k)) {
      *kind = k;
      return true;
    }
  }
  return false;
}

std::string SmoothingName(Smoothing smoothing) {
  switch (smoothing) {
    case Smoothing::kNone: return "none";
    case Smoothing::kParzen: return "parzen";
    case Smoothing::kBSpline: return "bspline";
  }
  return "";
}

bool ParseSmoothing(const std::string& name, Smoothing* smoothing) {
  for (Smoothing s : {Smoothing::kNone, Smoothing::kParzen, Smoothing::kBSpline}) {
    if (name == SmoothingName(s)) {
      *smoothing = s;
      return true;
    }
  }
  return false;
}

std::string RegionName(Region region) {
  return region == Region::kWholeImage ? "whole" : "overlap";
}

bool ParseRegion(const std::string& name, Region* region) {
  if (name == "whole") {
    *region = Region::kWholeImage;
  } else if (name == "overlap") {
    *region = Region::kOverlap;
  } else {
    return false;
  }
  return true;
}

bool MetricOptions::Check(std::string* error) const {
  if (bins < 4 || bins > 1024) {
    *error = "bins " + std::to_string(bins) + " must be in 4..1024";
    return false;
  }
  if (smoothing == Smoothing::kParzen && !(parzen_sigma_bins > 0 && parzen_sigma_bins < 32)) {
    *error = "parzen_sigma_bins " + std::to_string(parzen_sigma_bins) + " must be in (0, 32)";
    return false;
  }
  return true;
}

JointHistogram::JointHistogram(const MetricOptions& options)
    : options_(options),
      lidar_bins_(options.region == Region::kWholeImage ? options.bins + 1 : options.bins),
      counts_(static_cast<size_t>(lidar_bins_) * options.bins, 0.0) {}

void JointHistogram::Clear() {
  std::fill(counts_.begin(), counts_.end(), 0.0);
  total_ = 0;
  lidar_total_ = 0;
}

namespace {

// Cubic B-spline weights of the four bins base−1 .. base+2 for a fractional position t
// (Mattes et al. 2003, Eq. (4); Thévenaz & Unser 2000).
inline void CubicBSplineWeights(double t, double w[4]) {
  const double t2 = t * t, t3 = t2 * t;
  const double u = 1.0 - t;
  w[0] = u * u * u / 6.0;
  w[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
  w[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
  w[3] = t3 / 6.0;
}

double Entropy(const std::vector<double>& p, double total) {
  double h = 0;
  for (double c : p) {
    if (c > 0) {
      const double q = c / total;
      h -= q * std::log2(q);
    }
  }
  return h;
}

}  // namespace

void JointHistogram::AddSample(double lidar_pos, double photo_pos, bool lidar_empty) {
  const int bins = options_.bins;
  const int first_lidar = options_.region == Region::kWholeImage ? 1 : 0;
  total_ += 1;
  if (!lidar_empty) lidar_total_ += 1;
  if (options_.smoothing != Smoothing::kBSpline) {
    const int py = std::clamp(static_cast<int>(photo_pos + 0.5), 0, bins - 1);
    const int lx = lidar_empty ? 0
                               : first_lidar + std::clamp(static_cast<int>(lidar_pos + 0.5), 0,
                                                          bins - 1);
    counts_[static_cast<size_t>(lx) * bins + py] += 1;
    return;
  }
  double wy[4], wx[4] = {0, 1, 0, 0};
  const int by = static_cast<int>(std::floor(photo_pos));
  CubicBSplineWeights(photo_pos - by, wy);
  int bx = 0;
  if (!lidar_empty) {
    bx = static_cast<int>(std::floor(lidar_pos));
    CubicBSplineWeights(lidar_pos - bx, wx);
  }
  for (int i = 0; i < 4; ++i) {
    if (wx[i] == 0) continue;
    const int lx = lidar_empty ? 0 : first_lidar + std::clamp(bx - 1 + i, 0, bins - 1);
    double* row = &counts_[static_cast<size_t>(lx) * bins];
    for (int j = 0; j < 4; ++j) {
      row[std::clamp(by - 1 + j, 0, bins - 1)] += wx[i] * wy[j];
    }
  }
}

void JointHistogram::Add(const LidarImage& lidar, const GrayImage& photo) {
  const int bins = options_.bins;
  const bool whole = options_.region == Region::kWholeImage;
  const bool spline = options_.smoothing == Smoothing::kBSpline;
  // Continuous bin coordinates: value 0..1 (LiDAR) and 0..255 (photo) onto 0..bins−1.
  const double lidar_scale = bins - 1;
  const double photo_scale = (bins - 1) / 255.0;
  for (int r = 0; r < lidar.height; ++r) {
    for (int c = 0; c < lidar.width; ++c) {
      const size_t k = static_cast<size_t>(r) * lidar.width + c;
      const bool empty = lidar.point_index[k] < 0;
      if (empty && !whole) continue;
      float photo_value = photo.at(c, r);
      if (spline && !empty) {
        // Sample the photo where the point really falls: smooth in the pose.
        photo.Sample(c + 0.5 + lidar.offset_x[k], r + 0.5 + lidar.offset_y[k], &photo_value);
      }
      AddSample(empty ? 0.0 : lidar.value[k] * lidar_scale, photo_value * photo_scale, empty);
    }
  }
}

MetricValue JointHistogram::Evaluate() const {
  MetricValue result;
  result.samples = total_;
  result.lidar_samples = lidar_total_;
  if (total_ <= 0) return result;
  const int bins = options_.bins;
  std::vector<double> joint = counts_;
  if (options_.smoothing == Smoothing::kParzen) {
    // Separable Gaussian Parzen window over the bins (not across the empty LiDAR bin).
    const double sigma = options_.parzen_sigma_bins;
    const int radius = static_cast<int>(std::ceil(3 * sigma));
    std::vector<double> kernel(2 * radius + 1);
    double sum = 0;
    for (int i = -radius; i <= radius; ++i) {
      kernel[i + radius] = std::exp(-0.5 * i * i / (sigma * sigma));
      sum += kernel[i + radius];
    }
    for (double& w : kernel) w /= sum;
    const int first = options_.region == Region::kWholeImage ? 1 : 0;
    std::vector<double> tmp(joint.size(), 0.0);
    for (int x = 0; x < lidar_bins_; ++x) {  // along the photo axis
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
    for (int x = first; x < lidar_bins_; ++x) {  // along the LiDAR axis
      for (int y = 0; y < bins; ++y) {
        double v = 0;
        for (int i = -radius; i <= radius; ++i) {
          const int xx = std::clamp(x + i, first, lidar_bins_ - 1);
          v += kernel[i + radius] * tmp[static_cast<size_t>(xx) * bins + y];
        }
        joint[static_cast<size_t>(x) * bins + y] = v;
      }
    }
  }
  std::vector<double> lidar_marginal(lidar_bins_, 0.0), photo_marginal(bins, 0.0);
  double total = 0;
  for (int x = 0; x < lidar_bins_; ++x) {
    for (int y = 0; y < bins; ++y) {
      const double c = joint[static_cast<size_t>(x) * bins + y];
      lidar_marginal[x] += c;
      photo_marginal[y] += c;
      total += c;
    }
  }
  // Eq. (1)–(3), Wang et al. 2012: MI = H(X) + H(Y) − H(X,Y).
  const double hx = Entropy(lidar_marginal, total);
  const double hy = Entropy(photo_marginal, total);
  const double hxy = Entropy(joint, total);
  result.joint_entropy = hxy;
  result.mi = hx + hy - hxy;
  result.nmi = hxy > 0 ? (hx + hy) / hxy : 1.0;
  result.nid = hxy > 0 ? 1.0 - result.mi / hxy : 1.0;
  switch (options_.kind) {
    case MetricKind::kMi: result.value = result.mi; break;
    case MetricKind::kNmi: result.value = result.nmi; break;
    case MetricKind::kNid: result.value = -result.nid; break;
  }
  return result;
}

}  // namespace mmba::registration::mi
