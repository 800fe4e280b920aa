// Hypothesis verification of the cloud registration.

#include "registration/cloud/verification.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>

#include "registration/cloud/score_significance.h"

namespace mmba::registration::internal {

void Verify(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& src_n,
            const std::vector<Eigen::Vector3d>& tgt_n, const PointIndex& tgt_index,
            const Eigen::Matrix4d& t, double tau, Hypothesis* h) {
  size_t inliers = 0, agree = 0;
  double sum_sq = 0.0;
  int index;
  double sq;
  const double cos30 = std::cos(30.0 * M_PI / 180.0);
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  for (size_t i = 0; i < src.size(); ++i) {
    if (!tgt_index.NearestWithin(Apply(t, src[i]), tau * tau, &index, &sq)) continue;
    ++inliers;
    sum_sq += sq;
    if (!src_n.empty() && !tgt_n.empty() && src_n[i].allFinite() && tgt_n[index].allFinite() &&
        std::abs((r * src_n[i]).dot(tgt_n[index])) > cos30) {
      ++agree;
    }
  }
  h->inliers = inliers;
  h->fitness = src.empty() ? 0.0 : static_cast<double>(inliers) / src.size();
  h->rmse = inliers > 0 ? std::sqrt(sum_sq / inliers) : 0.0;
  h->normal_agreement = inliers > 0 ? static_cast<double>(agree) / inliers : 0.0;
  h->score = h->fitness * h->normal_agreement;
}

std::vector<size_t> CropIndices(const io::PointCloud& target,
                                const std::vector<Eigen::Vector3d>& src, const Eigen::Matrix4d& t,
                                double margin) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : src) {
    const Eigen::Vector3d q = Apply(t, p);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  lo.array() -= margin;
  hi.array() += margin;
  std::vector<size_t> inside;
  for (size_t i = 0; i < target.size(); ++i) {
    const Eigen::Vector3d& p = target.points[i];
    if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
    inside.push_back(i);
  }
  return inside;
}

uint64_t HashIndices(const std::vector<size_t>& indices) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i : indices) {
    h ^= static_cast<uint64_t>(i);
    h *= 1099511628211ull;
  }
  return h;
}

TargetCrop CropTarget(const io::PointCloud& target, bool use_normals,
                      const std::vector<size_t>& inside, size_t budget, double min_voxel) {
  io::PointCloud crop;
  crop.points.reserve(inside.size());
  for (size_t i : inside) crop.points.push_back(target.points[i]);
  if (use_normals) {
    crop.normals.reserve(inside.size());
    for (size_t i : inside) crop.normals.push_back(target.normals[i]);
  }
  TargetCrop out;
  const double voxel = crop.size() > budget ? VoxelForBudget(crop, min_voxel, budget) : min_voxel;
  out.level = VoxelDownsample(crop.points, crop.normals, voxel);
  out.index = std::make_unique<PointIndex>(out.level.points);
  out.level.spacing = MedianSpacing(*out.index, out.level.points, 20000);
  return out;
}

void FineResiduals(const std::vector<Eigen::Vector3d>& src,
                   const std::vector<Eigen::Vector3d>& src_n, const TargetCrop& target,
                   const Eigen::Matrix4d& t, double reach, std::vector<double>* residuals,
                   std::vector<bool>* agree) {
  residuals->assign(src.size(), std::nan(""));
  agree->assign(src.size(), false);
  const double cos30 = std::cos(30.0 * M_PI / 180.0);
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  int index;
  double sq;
  for (size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d q = Apply(t, src[i]);
    if (!target.index->NearestWithin(q, reach * reach, &index, &sq)) continue;
    const Eigen::Vector3d& n = target.level.normals[index];
    if (!n.allFinite()) continue;
    (*residuals)[i] = (q - target.level.points[index]).dot(n);
    (*agree)[i] = src_n.empty() || !src_n[i].allFinite() || std::abs((r * src_n[i]).dot(n)) > cos30;
  }
}

std::vector<bool> FreeSpaceViolations(const std::vector<Eigen::Vector3d>& src,
                                      const PointIndex& src_index,
                                      const internal::FreeSpace* src_free,
                                      const Eigen::AlignedBox3d& src_box,
                                      const TargetCrop& crop,
                                      const internal::FreeSpace* tgt_free,
                                      const Eigen::Matrix4d& t, double near, double margin) {
  std::vector<bool> out(src.size(), false);
  int index;
  double sq;
  if (tgt_free != nullptr && !tgt_free->empty()) {
    for (size_t i = 0; i < src.size(); ++i) {
      const Eigen::Vector3d q = Apply(t, src[i]);
      if (crop.index->NearestWithin(q, near * near, &index, &sq)) continue;
      if (tgt_free->Violates(q, margin)) out[i] = true;
    }
  }
  if (src_free != nullptr && !src_free->empty()) {
    const Eigen::Matrix3d rt = t.topLeftCorner<3, 3>().transpose();
    const Eigen::Vector3d tt = t.topRightCorner<3, 1>();
    for (const Eigen::Vector3d& c : crop.level.points) {
      const Eigen::Vector3d p = rt * (c - tt);
      if (!src_box.contains(p)) continue;
      if (src_index.NearestWithin(p, near * near, &index, &sq)) continue;
      Eigen::Vector3d hit;
      if (src_free->Violates(p, margin, nullptr, &hit) && src_index.Nearest(hit, &index, &sq)) {
        out[static_cast<size_t>(index)] = true;
      }
    }
  }
  return out;
}

double RobustScale(const std::vector<double>& residuals) {
  std::vector<double> a;
  a.reserve(residuals.size());
  for (double r : residuals) {
    if (std::isfinite(r)) a.push_back(std::abs(r));
  }
  if (a.size() < 10) return std::numeric_limits<double>::infinity();
  std::nth_element(a.begin(), a.begin() + a.size() / 2, a.end());
  return 1.4826 * a[a.size() / 2];
}

void ScoreFine(const std::vector<double>& residuals, const std::vector<bool>& agree, double tau,
               const std::vector<bool>& violates, Hypothesis* h) {
  size_t inliers = 0, agreeing = 0, near = 0, violating = 0;
  for (size_t i = 0; i < violates.size(); ++i) violating += violates[i] ? 1 : 0;
  double sum_sq = 0.0, score = 0.0;
  for (size_t i = 0; i < residuals.size(); ++i) {
    const double r = residuals[i];
    if (!std::isfinite(r)) continue;
    ++near;
    if (std::abs(r) >= tau) continue;
    ++inliers;
    sum_sq += r * r;
    if (agree[i]) {
      ++agreeing;
      score += 1.0 - (r * r) / (tau * tau);
    }
  }
  const double n = static_cast<double>(std::max<size_t>(1, residuals.size()));
  h->inliers = inliers;
  h->fitness = static_cast<double>(inliers) / n;
  h->rmse = inliers > 0 ? std::sqrt(sum_sq / inliers) : 0.0;
  h->normal_agreement = inliers > 0 ? static_cast<double>(agreeing) / inliers : 0.0;
  // A point in observed free space is evidence against the pose: −1 (the opposite of a
  // perfect inlier), so a turn that puts asymmetric detail where a sensor saw through loses.
  h->violation = static_cast<double>(violating) / n;
  h->score = (score - static_cast<double>(violating)) / n;
  h->conflict = near > 0 ? 1.0 - static_cast<double>(agreeing) / near : 1.0;
}

// The per-point terms of ScoreFine, summed per block; the mean per-point difference over its
// cluster-robust standard error (score_significance.h).
double ScoreSignificance(const std::vector<Eigen::Vector3d>& src, const std::vector<double>& ra,
                         const std::vector<bool>& aa, const std::vector<double>& rb,
                         const std::vector<bool>& ab, double tau, double block) {
  auto term = [tau](double r, bool agree) {
    return std::isfinite(r) && std::abs(r) < tau && agree ? 1.0 - (r * r) / (tau * tau) : 0.0;
  };
  std::unordered_map<VoxelKey, std::pair<double, int>, VoxelKeyHash> blocks;
  for (size_t i = 0; i < src.size(); ++i) {
    const VoxelKey key{static_cast<int64_t>(std::floor(src[i].x() / block)),
                       static_cast<int64_t>(std::floor(src[i].y() / block)),
                       static_cast<int64_t>(std::floor(src[i].z() / block))};
    auto& b = blocks[key];
    b.first += term(ra[i], aa[i]) - term(rb[i], ab[i]);
    ++b.second;
  }
  if (blocks.size() < 3) return 0.0;
  double sum = 0.0, n = 0.0;
  for (const auto& [key, b] : blocks) {
    sum += b.first;
    n += b.second;
  }
  const double mean = sum / n;
  double ss = 0.0;
  for (const auto& [key, b] : blocks) ss += (b.first - b.second * mean) * (b.first - b.second * mean);
  const double k = static_cast<double>(blocks.size());
  const double se = std::sqrt(ss * k / (k - 1.0)) / n;
  return se > 0 ? mean / se : (mean > 0 ? std::numeric_limits<double>::infinity() : 0.0);
}

}  // namespace mmba::registration::internal
