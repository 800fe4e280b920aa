// Fast Point Feature Histograms without PCL's per-query allocations: the same descriptor as
// pcl::FPFHEstimation (PCL 1.13, 11 + 11 + 11 bins), on the nanoflann point index, with the
// SPFH of the points around the keypoints computed in parallel (OpenMP, 2 threads).
//
// Rusu, Blodow & Beetz, "Fast Point Feature Histograms (FPFH) for 3D Registration",
// ICRA 2009: for a pair (p_s, n_s), (p_t, n_t) with d = p_t − p_s the Darboux frame is
// u = n_s, v = d × u / ‖d × u‖, w = u × v (Eq. 1), and the features are
//   α = v·n_t,  φ = u·d / ‖d‖,  θ = atan2(w·n_t, u·n_t)                       (Eq. 1)
// with source and target chosen so that the source normal makes the smaller angle with d.
// SPFH(p) bins them over the neighbours within r; FPFH(p) = Σ_k SPFH(p_k) / ω_k (Eq. 3) over
// the neighbours p_k ≠ p within r, ω_k the squared distance (PCL's choice; PCL also leaves
// out the SPFH of p itself), each of the three sub-histograms normalised to sum 100.

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "registration/cloud/pcl_backend.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace mmba::registration::internal {
namespace {

constexpr int kBins = 11;  // per feature (PCL's FPFHSignature33)
constexpr int kDim = 3 * kBins;
constexpr int kThreads = 2;

int Bin(float value01) {
  const int b = static_cast<int>(std::floor(kBins * value01));
  return b < 0 ? 0 : (b >= kBins ? kBins - 1 : b);
}

// The "diamond angle" of a direction (x, y) ≠ 0: in [0, 4), strictly increasing with its
// angle in [0, 2π) (1 at π/2, 2 at π, 3 at 3π/2), without a trigonometric call.
float DiamondAngle(float x, float y) {
  if (y >= 0.0f) return x >= 0.0f ? y / (x + y) : 1.0f - x / (y - x);
  return x < 0.0f ? 2.0f - y / (-x - y) : 3.0f + x / (x - y);
}

// The θ bin Bin((θ + π) / 2π) of θ = atan2(y, x), without atan2 (it took a third of the
// descriptor's time): θ + π is the angle of (−x, −y), and the bins' edges at k · 2π/11 are
// compared as diamond angles. Only a pair within float rounding of an edge (or exactly on
// the negative x axis) can fall into the neighbouring bin.
int ThetaBin(float x, float y) {
  static const std::array<float, kBins - 1> edges = [] {
    std::array<float, kBins - 1> e{};
    for (int k = 1; k < kBins; ++k) {
      const double a = 2.0 * M_PI * k / kBins;
      e[k - 1] = DiamondAngle(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)));
    }
    return e;
  }();
  if (x == 0.0f && y == 0.0f) return Bin(0.5f);  // atan2(0, 0) = 0
  const float d = DiamondAngle(-x, -y);
  int bin = 0;
  while (bin < kBins - 1 && edges[bin] <= d) ++bin;
  return bin;
}

// Pair features (α, φ, θ) = (f2, f3, f1) of pcl::computePairFeatures, θ as its bin
// (ThetaBin); all zero for coincident points or a degenerate frame (PCL's FPFH bins those
// zeros too).
void PairFeatures(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1, const Eigen::Vector3f& p2,
                  const Eigen::Vector3f& n2, int* f1_bin, float* f2, float* f3) {
  Eigen::Vector3f d = p2 - p1;
  const float dist = d.norm();
  *f1_bin = Bin(0.5f);  // θ = 0
  *f2 = *f3 = 0.0f;
  if (dist == 0.0f) return;
  const float angle1 = n1.dot(d) / dist;
  const float angle2 = n2.dot(d) / dist;
  const Eigen::Vector3f* u = &n1;
  const Eigen::Vector3f* other = &n2;
  float phi = angle1;
  // PCL swaps when acos|angle1| > acos|angle2|, i.e. |angle1| < |angle2| (acos decreases).
  if (std::fabs(angle1) < std::fabs(angle2)) {
    u = &n2;
    other = &n1;
    d = -d;
    phi = -angle2;
  }
  Eigen::Vector3f v = d.cross(*u);
  const float v_norm = v.norm();
  if (v_norm == 0.0f) return;
  v /= v_norm;
  const Eigen::Vector3f w = u->cross(v);
  *f3 = phi;
  *f2 = v.dot(*other);
  *f1_bin = ThetaBin(u->dot(*other), w.dot(*other));
}

}  // namespace

Descriptors ComputeFpfh(const std::vector<Eigen::Vector3d>& points,
                        const std::vector<Eigen::Vector3d>& normals,
                        const std::vector<int>& keypoints, double radius) {
  Descriptors out;
  out.dim = kDim;
  out.data.assign(keypoints.size() * kDim, 0.0f);
  out.valid.assign(keypoints.size(), false);
  if (points.empty() || keypoints.empty()) return out;
  const PointIndex index(points);
  std::vector<Eigen::Vector3f> p(points.size()), n(points.size());
  const Eigen::Vector3d origin = io::LocalOrigin(points);  // as PointIndex and PCL's copy
  for (size_t i = 0; i < points.size(); ++i) {
    p[i] = (points[i] - origin).cast<float>();
    n[i] = normals[i].cast<float>();
  }
  // Neighbourhoods of the keypoints; their members need an SPFH.
  const long num_kp = static_cast<long>(keypoints.size());
  std::vector<std::vector<int>> kp_nn(keypoints.size());
  std::vector<std::vector<float>> kp_sq(keypoints.size());
#pragma omp parallel for num_threads(kThreads) schedule(dynamic, 16)
  for (long k = 0; k < num_kp; ++k) {
    index.RadiusWithDistances(points[keypoints[k]], radius, &kp_nn[k], &kp_sq[k]);
  }
  std::vector<int> row(points.size(), -1);
  std::vector<int> spfh_points;
  for (const std::vector<int>& nn : kp_nn) {
    for (int j : nn) {
      if (row[j] < 0) {
        row[j] = static_cast<int>(spfh_points.size());
        spfh_points.push_back(j);
      }
    }
  }
  // SPFH of each of them (Eq. 2: the pair features of the point with its neighbours). The
  // pair features are symmetric (the source of a pair is the point whose normal makes the
  // smaller angle with the line, whichever is queried), so each pair of two SPFH points is
  // computed once and binned into both; bins are counted per thread and scaled at the end.
  const long num_spfh = static_cast<long>(spfh_points.size());
  std::vector<int> num_neighbours(spfh_points.size(), 0);
  std::vector<std::vector<int32_t>> counts(kThreads);
#pragma omp parallel num_threads(kThreads)
  {
#ifdef _OPENMP
    const int thread = omp_get_thread_num();
#else
    const int thread = 0;
#endif
    std::vector<int32_t>& c = counts[thread];
    c.assign(spfh_points.size() * kDim, 0);
    std::vector<int> nn;
    std::vector<float> sq;
    auto add = [&c](int r, int f1_bin, float f2, float f3) {
      int32_t* h = &c[static_cast<size_t>(r) * kDim];
      ++h[f1_bin];
      ++h[kBins + Bin((f2 + 1.0f) * 0.5f)];
      ++h[2 * kBins + Bin((f3 + 1.0f) * 0.5f)];
    };
#pragma omp for schedule(dynamic, 64)
    for (long r = 0; r < num_spfh; ++r) {
      const int i = spfh_points[r];
      // Unsorted: the order of the pairs does not matter.
      index.RadiusWithDistances(points[i], radius, &nn, &sq, /*sorted=*/false);
      num_neighbours[r] = static_cast<int>(nn.size());
      for (int j : nn) {
        if (j == i) continue;
        const int rj = row[j];
        if (rj >= 0 && rj < r) continue;  // done from j's side
        int f1;
        float f2, f3;
        PairFeatures(p[i], n[i], p[j], n[j], &f1, &f2, &f3);
        add(static_cast<int>(r), f1, f2, f3);
        if (rj >= 0) add(rj, f1, f2, f3);
      }
    }
  }
  std::vector<float> spfh(spfh_points.size() * kDim, 0.0f);
  for (long r = 0; r < num_spfh; ++r) {
    if (num_neighbours[r] < 2) continue;
    const float increment = 100.0f / static_cast<float>(num_neighbours[r] - 1);
    for (int b = 0; b < kDim; ++b) {
      int32_t total = 0;
      for (const std::vector<int32_t>& c : counts) total += c[static_cast<size_t>(r) * kDim + b];
      spfh[static_cast<size_t>(r) * kDim + b] = static_cast<float>(total) * increment;
    }
  }
  // FPFH of the keypoints (Eq. 3). Validity is collected per keypoint in bytes: out.valid is a
  // std::vector<bool>, whose bits share words, and must not be written from two threads.
  std::vector<char> valid(keypoints.size(), 0);
#pragma omp parallel for num_threads(kThreads) schedule(dynamic, 16)
  for (long k = 0; k < num_kp; ++k) {
    const std::vector<int>& nn = kp_nn[k];
    const std::vector<float>& sq = kp_sq[k];
    double sum[3] = {0.0, 0.0, 0.0};
    float hist[kDim] = {};
    for (size_t m = 0; m < nn.size(); ++m) {
      if (sq[m] == 0.0f) continue;
      const float weight = 1.0f / sq[m];
      const float* h = &spfh[static_cast<size_t>(row[nn[m]]) * kDim];
      for (int b = 0; b < kDim; ++b) {
        const float value = h[b] * weight;
        sum[b / kBins] += value;
        hist[b] += value;
      }
    }
    bool nonzero = false, finite = true;
    float* dst = &out.data[static_cast<size_t>(k) * kDim];
    for (int b = 0; b < kDim; ++b) {
      const double s = sum[b / kBins];
      dst[b] = s != 0.0 ? static_cast<float>(hist[b] * (100.0 / s)) : hist[b];
      nonzero = nonzero || dst[b] != 0.0f;
      finite = finite && std::isfinite(dst[b]);
    }
    valid[k] = nonzero && finite;
    if (!valid[k]) std::fill(dst, dst + kDim, 0.0f);
  }
  for (size_t k = 0; k < keypoints.size(); ++k) out.valid[k] = valid[k] != 0;
  return out;
}

}  // namespace mmba::registration::internal
