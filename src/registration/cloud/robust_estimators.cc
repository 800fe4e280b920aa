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

// Bit-parallel branch and bound maximum clique (BBMC: San Segundo, Rodríguez-Losada & Jiménez,
// "An exact bit-parallel algorithm for the maximum clique problem", Computers & OR 2011),
// the MCQ scheme of Tomita & Seki 2003 with the candidate sets and the greedy colouring done
// on bitsets: a colour class is grown by taking the lowest remaining vertex and removing its
// neighbours (one AND-NOT over the adjacency words), so colouring a node costs
// O(|candidates| × words) however many classes there are. Vertices are numbered in the
// initial order (highest degree first); only vertices whose colour can still beat the best
// clique are branched on (BBMC's k_min).
class MaxCliqueSolver {
 public:
  MaxCliqueSolver(int n, std::vector<uint64_t> adjacency, int64_t budget)
      : n_(n), words_((n + 63) / 64), adjacency_(std::move(adjacency)), budget_(budget) {}

  /// The largest clique with more than `known_size` vertices (a clique of that size is known
  /// already); empty if there is none (or the budget ran out before one was found).
  std::vector<int> Solve(size_t known_size, bool* exact) {
    known_size_ = known_size;
    best_.clear();
    std::vector<uint64_t> all(static_cast<size_t>(words_), 0ULL);
    for (int v = 0; v < n_; ++v) all[v >> 6] |= 1ULL << (v & 63);
    std::vector<int> clique;
    Expand(all, &clique);
    if (exact != nullptr) *exact = expanded_ <= budget_;
    return best_;
  }

 private:
  size_t BestSize() const { return std::max(best_.size(), known_size_); }
  const uint64_t* Row(int v) const { return &adjacency_[static_cast<size_t>(v) * words_]; }

  void Expand(std::vector<uint64_t> candidates, std::vector<int>* clique) {
    if (++expanded_ > budget_) return;
    // Greedy colouring in vertex order; order/colours keep the vertices with colour > k_min.
    const int k_min = static_cast<int>(BestSize()) - static_cast<int>(clique->size());
    std::vector<int> order, colours;
    std::vector<uint64_t> remaining = candidates, uncoloured(static_cast<size_t>(words_));
    int colour = 0;
    for (;;) {
      bool any = false;
      for (int w = 0; w < words_ && !any; ++w) any = remaining[w] != 0;
      if (!any) break;
      ++colour;
      uncoloured = remaining;
      for (int w = 0; w < words_; ++w) {
        while (uncoloured[w] != 0) {
          const int bit = __builtin_ctzll(uncoloured[w]);
          const int v = w * 64 + bit;
          remaining[w] &= ~(1ULL << bit);
          uncoloured[w] &= ~(1ULL << bit);
          const uint64_t* row = Row(v);
          for (int x = w; x < words_; ++x) uncoloured[x] &= ~row[x];
          if (colour > k_min) {
            order.push_back(v);
            colours.push_back(colour);
          }
        }
      }
    }
    std::vector<uint64_t> next(static_cast<size_t>(words_));
    for (int i = static_cast<int>(order.size()) - 1; i >= 0; --i) {
      if (clique->size() + colours[i] <= BestSize()) return;
      if (expanded_ > budget_) return;
      const int v = order[i];
      clique->push_back(v);
      const uint64_t* row = Row(v);
      bool any = false;
      for (int w = 0; w < words_; ++w) {
        next[w] = candidates[w] & row[w];
        any = any || next[w] != 0;
      }
      if (!any) {
        if (clique->size() > BestSize()) best_ = *clique;
      } else {
        Expand(next, clique);
      }
      clique->pop_back();
      candidates[v >> 6] &= ~(1ULL << (v & 63));
    }
  }

  int n_;
  int words_;
  std::vector<uint64_t> adjacency_;  // n_ rows of words_ words
  int64_t budget_;
  int64_t expanded_ = 0;
  std::vector<int> best_;
  size_t known_size_ = 0;
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
  // Vertices that cannot beat the greedy clique are dropped (degree + 1 <= |best|); the rest
  // are renumbered highest degree first for the bit-parallel search.
  std::vector<int> candidates;
  for (int v : by_degree) {
    if (degree[v] + 1 > static_cast<int>(best.size())) candidates.push_back(v);
  }
  const int m = static_cast<int>(candidates.size());
  const int m_words = (m + 63) / 64;
  std::vector<uint64_t> sub(static_cast<size_t>(m) * m_words, 0ULL);
  for (int a = 0; a < m; ++a) {
    for (int b = a + 1; b < m; ++b) {
      if (adjacent(candidates[a], candidates[b])) {
        sub[static_cast<size_t>(a) * m_words + (b >> 6)] |= 1ULL << (b & 63);
        sub[static_cast<size_t>(b) * m_words + (a >> 6)] |= 1ULL << (a & 63);
      }
    }
  }
  MaxCliqueSolver solver(m, std::move(sub), options.max_nodes_expanded);
  const std::vector<int> found = solver.Solve(best.size(), exact);
  std::vector<int> result = best;
  if (found.size() > best.size()) {
    result.clear();
    for (int v : found) result.push_back(candidates[v]);
  }
  std::sort(result.begin(), result.end());
  return result;
}

}  // namespace mmba::registration
