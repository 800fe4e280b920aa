#include "registration/cloud/intensity_test.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {
namespace {

using Moments = IntensityBlocks::Moments;

void Add(Moments* m, const Moments& o, double sign) {
  m->n += sign * o.n;
  m->sx += sign * o.sx;
  m->sy += sign * o.sy;
  m->sxx += sign * o.sxx;
  m->syy += sign * o.syy;
  m->sxy += sign * o.sxy;
}

double AbsCorrelationOf(const Moments& m) {
  if (m.n < 30) return 0.0;
  const double cov = m.sxy / m.n - (m.sx / m.n) * (m.sy / m.n);
  const double vx = m.sxx / m.n - (m.sx / m.n) * (m.sx / m.n);
  const double vy = m.syy / m.n - (m.sy / m.n) * (m.sy / m.n);
  if (!(vx > 1e-12) || !(vy > 1e-12)) return 0.0;
  return std::abs(cov) / std::sqrt(vx * vy);
}

Moments Total(const IntensityBlocks& b) {
  Moments t;
  for (const Moments& m : b.moments) Add(&t, m, 1.0);
  return t;
}

// Block key of a source point (blocks of `block` metres; 21 bits per axis).
int64_t BlockKey(const Eigen::Vector3d& p, double block) {
  auto c = [block](double v) {
    return static_cast<int64_t>(std::floor(v / block)) & ((int64_t{1} << 21) - 1);
  };
  return (c(p.x()) << 42) | (c(p.y()) << 21) | c(p.z());
}

}  // namespace

std::vector<float> BrightnessRanks(const io::PointCloud& cloud, const std::vector<size_t>& at) {
  std::vector<float> v;
  if (cloud.has_intensity()) {
    v = cloud.intensity;
  } else if (cloud.has_colors()) {
    v.reserve(cloud.colors.size());
    for (const auto& c : cloud.colors) {
      v.push_back(0.299f * c[0] + 0.587f * c[1] + 0.114f * c[2]);  // ITU-R BT.601 luma
    }
  }
  if (v.empty() || v.size() != cloud.size()) return {};
  for (float x : v) {
    if (!std::isfinite(x)) return {};
  }
  std::vector<float> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  if (sorted.front() == sorted.back()) return {};
  // Mid-ranks: ties (quantised intensities) share the mean of their ranks, (k + ½)/n, i.e.
  // ½ (#values < x + #values ≤ x) / n.
  const double n = static_cast<double>(v.size());
  std::vector<float> rank;
  rank.reserve(at.size());
  for (size_t i : at) {
    const auto [lo, hi] = std::equal_range(sorted.begin(), sorted.end(), v[i]);
    rank.push_back(static_cast<float>(
        0.5 * static_cast<double>((lo - sorted.begin()) + (hi - sorted.begin())) / n));
  }
  return rank;
}

std::vector<float> BrightnessRanks(const io::PointCloud& cloud) {
  std::vector<size_t> all(cloud.size());
  std::iota(all.begin(), all.end(), size_t{0});
  return BrightnessRanks(cloud, all);
}

double IntensityBlocks::AbsCorrelation() const { return AbsCorrelationOf(Total(*this)); }

IntensityAgreement::IntensityAgreement(const io::PointCloud& source,
                                       const io::PointCloud& target,
                                       const std::vector<Eigen::Vector3d>& fine_src, double block,
                                       size_t max_points)
    : fine_src_(fine_src), block_(block > 0 ? block : 1.0) {
  // Ranks among all points of each cloud, needed only at the sampled points.
  const std::vector<size_t> src_pick = StrideSample(source.size(), max_points);
  const std::vector<size_t> tgt_pick = StrideSample(target.size(), max_points);
  const std::vector<float> src_rank = BrightnessRanks(source, src_pick);
  const std::vector<float> tgt_rank = BrightnessRanks(target, tgt_pick);
  if (src_rank.empty() || tgt_rank.empty() || fine_src.empty()) return;
  // The source's brightness at each fine point: that of its nearest source point.
  std::vector<Eigen::Vector3d> src_points;
  src_points.reserve(src_pick.size());
  for (size_t i : src_pick) src_points.push_back(source.points[i]);
  const PointIndex src_index(src_points);
  fine_src_rank_.resize(fine_src.size());
  for (size_t i = 0; i < fine_src.size(); ++i) {
    int k = -1;
    double d2 = 0.0;
    if (!src_index.Nearest(fine_src[i], &k, &d2) || k < 0) return;
    fine_src_rank_[i] = src_rank[static_cast<size_t>(k)];
  }
  std::vector<Eigen::Vector3d> tgt_points;
  tgt_points.reserve(tgt_pick.size());
  for (size_t i : tgt_pick) tgt_points.push_back(target.points[i]);
  tgt_rank_ = tgt_rank;
  tgt_index_ = std::make_unique<PointIndex>(tgt_points);
  available_ = true;
}

IntensityAgreement::~IntensityAgreement() = default;

IntensityBlocks IntensityAgreement::Measure(const Eigen::Matrix4d& target_from_source,
                                            const std::vector<bool>& inlier) const {
  IntensityBlocks out;
  if (!available_) return out;
  std::vector<std::pair<int64_t, Moments>> entries;
  const Eigen::Matrix3d r = target_from_source.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = target_from_source.topRightCorner<3, 1>();
  for (size_t i = 0; i < fine_src_.size() && i < inlier.size(); ++i) {
    if (!inlier[i]) continue;
    int k = -1;
    double d2 = 0.0;
    if (!tgt_index_->Nearest(r * fine_src_[i] + t, &k, &d2) || k < 0) continue;
    const double x = fine_src_rank_[i], y = tgt_rank_[static_cast<size_t>(k)];
    entries.push_back({BlockKey(fine_src_[i], block_), Moments{1, x, y, x * x, y * y, x * y}});
  }
  std::sort(entries.begin(), entries.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [key, m] : entries) {
    if (out.keys.empty() || out.keys.back() != key) {
      out.keys.push_back(key);
      out.moments.emplace_back();
    }
    Add(&out.moments.back(), m, 1.0);
  }
  return out;
}

double IntensityAgreement::Significance(const IntensityBlocks& a, const IntensityBlocks& b) {
  // Union of the blocks (both sorted by key); a block missing from one pose is empty there.
  std::vector<std::pair<Moments, Moments>> blocks;
  size_t i = 0, j = 0;
  while (i < a.keys.size() || j < b.keys.size()) {
    if (j >= b.keys.size() || (i < a.keys.size() && a.keys[i] < b.keys[j])) {
      blocks.push_back({a.moments[i++], Moments{}});
    } else if (i >= a.keys.size() || b.keys[j] < a.keys[i]) {
      blocks.push_back({Moments{}, b.moments[j++]});
    } else {
      blocks.push_back({a.moments[i++], b.moments[j++]});
    }
  }
  const size_t k = blocks.size();
  if (k < 3) return 0.0;
  const Moments ta = Total(a), tb = Total(b);
  const double d = AbsCorrelationOf(ta) - AbsCorrelationOf(tb);
  // Delete-one-block jackknife of d (Efron & Stein 1981): var = (K−1)/K Σ (d_(k) − d̄)².
  std::vector<double> dk(k);
  for (size_t m = 0; m < k; ++m) {
    Moments xa = ta, xb = tb;
    Add(&xa, blocks[m].first, -1.0);
    Add(&xb, blocks[m].second, -1.0);
    dk[m] = AbsCorrelationOf(xa) - AbsCorrelationOf(xb);
  }
  const double mean = std::accumulate(dk.begin(), dk.end(), 0.0) / static_cast<double>(k);
  double ss = 0.0;
  for (double x : dk) ss += (x - mean) * (x - mean);
  const double se = std::sqrt(static_cast<double>(k - 1) / static_cast<double>(k) * ss);
  if (!(se > 0)) return 0.0;
  // The ratio is Student-t-like with K − 1 degrees of freedom; it joins a normal z statistic
  // (Stouffer), so it is mapped to its normal equivalent z = t (1 − 1/(4ν)) / √(1 + t²/(2ν))
  // (a normal approximation to Student's t, Abramowitz & Stegun 1964, §26.7; slightly
  // conservative: t = 3.25 at ν = 9, the 99.5 % point, gives 2.51 against 2.58).
  const double t = d / se, nu = static_cast<double>(k - 1);
  return t * (1.0 - 1.0 / (4.0 * nu)) / std::sqrt(1.0 + t * t / (2.0 * nu));
}

double CombinedSignificance(double t_geometric, double t_intensity) {
  return std::max(t_geometric, (t_geometric + t_intensity) / std::sqrt(2.0));
}

}  // namespace mmba::registration::internal
