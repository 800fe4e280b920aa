#include "mmba/registration/cloud/robust_estimators.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>
#include <Eigen/SVD>

namespace mmba::registration {

Eigen::Matrix4d EstimateRigid(const std::vector<Eigen::Vector3d>& src,
                              const std::vector<Eigen::Vector3d>& dst,
                              const Eigen::Vector3d* up) {
  const size_t n = std::min(src.size(), dst.size());
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  if (n == 0) return target_from_source;
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero(), mean_dst = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_src += src[i];
    mean_dst += dst[i];
  }
  mean_src /= static_cast<double>(n);
  mean_dst /= static_cast<double>(n);
  Eigen::Matrix3d rotation;
  if (up != nullptr) {
    // Rotation about `up` only: 2-D Procrustes in the plane orthogonal to up.
    const Eigen::Vector3d u = up->normalized();
    Eigen::Vector3d e1 = u.unitOrthogonal();
    Eigen::Vector3d e2 = u.cross(e1);
    double sin_sum = 0.0, cos_sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d a = src[i] - mean_src, b = dst[i] - mean_dst;
      const double ax = a.dot(e1), ay = a.dot(e2), bx = b.dot(e1), by = b.dot(e2);
      cos_sum += ax * bx + ay * by;
      sin_sum += ax * by - ay * bx;
    }
    const double yaw = std::atan2(sin_sum, cos_sum);
    rotation = Eigen::AngleAxisd(yaw, u).toRotationMatrix();
  } else {
    // Umeyama 1991, Eq. (38)–(40) without scale.
    Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < n; ++i) {
      sigma += (dst[i] - mean_dst) * (src[i] - mean_src).transpose();
    }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
    if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) s(2, 2) = -1.0;
    rotation = svd.matrixU() * s * svd.matrixV().transpose();
  }
  target_from_source.topLeftCorner<3, 3>() = rotation;
  target_from_source.topRightCorner<3, 1>() = mean_dst - rotation * mean_src;
  return target_from_source;
}

double RotationAngleDeg(const Eigen::Matrix3d& rotation) {
  const double c = std::clamp((rotation.trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

namespace {

// Branch and bound maximum clique (MCQ, Tomita & Seki 2003) on adjacency lists as bitsets.
class MaxCliqueSolver {
 public:
  MaxCliqueSolver(int n, std::vector<std::vector<uint64_t>> adjacency, int64_t budget)
      : n_(n), words_((n + 63) / 64), adjacency_(std::move(adjacency)), budget_(budget) {}

  bool Adjacent(int a, int b) const { return (adjacency_[a][b >> 6] >> (b & 63)) & 1ULL; }

  std::vector<int> Solve(const std::vector<int>& initial_order, std::vector<int> lower_bound,
                         bool* exact) {
    best_ = std::move(lower_bound);
    std::vector<int> clique;
    Expand(initial_order, &clique);
    if (exact != nullptr) *exact = expanded_ <= budget_;
    return best_;
  }

 private:
  // Greedy colouring of `candidates`; returns them ordered by colour with the colour bound.
  void ColourSort(const std::vector<int>& candidates, std::vector<int>* order,
                  std::vector<int>* colours) const {
    std::vector<std::vector<int>> classes;
    for (int v : candidates) {
      size_t k = 0;
      for (; k < classes.size(); ++k) {
        bool conflict = false;
        for (int w : classes[k]) {
          if (Adjacent(v, w)) {
            conflict = true;
            break;
          }
        }
        if (!conflict) break;
      }
      if (k == classes.size()) classes.emplace_back();
      classes[k].push_back(v);
    }
    order->clear();
    colours->clear();
    for (size_t k = 0; k < classes.size(); ++k) {
      for (int v : classes[k]) {
        order->push_back(v);
        colours->push_back(static_cast<int>(k) + 1);
      }
    }
  }

  void Expand(std::vector<int> candidates, std::vector<int>* clique) {
    if (++expanded_ > budget_) return;
    std::vector<int> order, colours;
    ColourSort(candidates, &order, &colours);
    for (int i = static_cast<int>(order.size()) - 1; i >= 0; --i) {
      if (clique->size() + colours[i] <= best_.size()) return;
      if (expanded_ > budget_) return;
      const int v = order[i];
      clique->push_back(v);
      std::vector<int> next;
      for (int j = 0; j < i; ++j) {
        if (Adjacent(v, order[j])) next.push_back(order[j]);
      }
      if (next.empty()) {
        if (clique->size() > best_.size()) best_ = *clique;
      } else {
        Expand(next, clique);
      }
      clique->pop_back();
    }
  }

  int n_;
  int words_;
  std::vector<std::vector<uint64_t>> adjacency_;
  int64_t budget_;
  int64_t expanded_ = 0;
  std::vector<int> best_;
};

}  // namespace

std::vector<int> MaxConsistentClique(const std::vector<Eigen::Vector3d>& src,
                                     const std::vector<Eigen::Vector3d>& dst,
                                     const CliqueOptions& options, bool* exact) {
  const int n = static_cast<int>(std::min(src.size(), dst.size()));
  if (exact != nullptr) *exact = true;
  if (n == 0) return {};
  const int words = (n + 63) / 64;
  std::vector<std::vector<uint64_t>> adjacency(n, std::vector<uint64_t>(words, 0));
  std::vector<int> degree(n, 0);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const double ls = (src[i] - src[j]).norm();
      const double ld = (dst[i] - dst[j]).norm();
      if (ls < options.min_length_m) continue;
      if (std::abs(ls - ld) < options.tolerance_m) {
        adjacency[i][j >> 6] |= 1ULL << (j & 63);
        adjacency[j][i >> 6] |= 1ULL << (i & 63);
        ++degree[i];
        ++degree[j];
      }
    }
  }
  // Greedy lower bound: grow from each of the highest-degree vertices.
  std::vector<int> by_degree(n);
  std::iota(by_degree.begin(), by_degree.end(), 0);
  std::stable_sort(by_degree.begin(), by_degree.end(),
                   [&](int a, int b) { return degree[a] > degree[b]; });
  auto adjacent = [&](int a, int b) { return (adjacency[a][b >> 6] >> (b & 63)) & 1ULL; };
  std::vector<int> best;
  for (int s = 0; s < std::min(n, 20); ++s) {
    std::vector<int> clique = {by_degree[s]};
    for (int v : by_degree) {
      if (v == by_degree[s]) continue;
      bool ok = true;
      for (int w : clique) {
        if (!adjacent(v, w)) {
          ok = false;
          break;
        }
      }
      if (ok) clique.push_back(v);
    }
    if (clique.size() > best.size()) best = clique;
  }
  // Vertices that cannot beat the greedy clique are dropped (degree + 1 <= |best|).
  std::vector<int> candidates;
  for (int v : by_degree) {
    if (degree[v] + 1 > static_cast<int>(best.size())) candidates.push_back(v);
  }
  // Lowest degree first so that the colour sort puts high-degree vertices last (tried first).
  std::reverse(candidates.begin(), candidates.end());
  MaxCliqueSolver solver(n, std::move(adjacency), options.max_nodes_expanded);
  std::vector<int> result = solver.Solve(candidates, best, exact);
  std::sort(result.begin(), result.end());
  return result;
}

}  // namespace mmba::registration
