#pragma once

// The pinhole projection of a block of LiDAR points, shared by the renderer (lidar_image.cc),
// the point-sample evaluations (point_samples.cc) and the evaluator's cull and render order
// (mi_registration.cc). The float operations run in the general path's order — Eigen's 3×3
// product r₀x + (r₁y + r₂z) + t per row, the squared norm x² + (y² + z²), and
// PinholeModel::ImgFromCam f·(x/z + 0) + c in double — so every path gives the same bits
// (tests ProjectionBlocksEqualTheEigenExpressions, PinholeBlocksAccumulateAsTheGenericModel,
// PinholeCullEqualsTheGenericModel). No branch, so the loop vectorises; always inlined, so it
// is compiled for each caller's target (the callers' target_clones: AVX2 and the default, no
// FMA in either: the same roundings).

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

namespace mmba::registration::mi::internal {

struct PinholeBlockProjection {
  float m00, m01, m02, m10, m11, m12, m20, m21, m22, t0, t1, t2;
  double fx, fy, cx, cy;

  /// `rotation`, `translation`: the view from the LiDAR; `params`: fx fy cx cy.
  PinholeBlockProjection(const Eigen::Matrix3f& rotation, const Eigen::Vector3f& translation,
                         const double* params)
      : m00(rotation(0, 0)), m01(rotation(0, 1)), m02(rotation(0, 2)),
        m10(rotation(1, 0)), m11(rotation(1, 1)), m12(rotation(1, 2)),
        m20(rotation(2, 0)), m21(rotation(2, 1)), m22(rotation(2, 2)),
        t0(translation.x()), t1(translation.y()), t2(translation.z()),
        fx(params[0]), fy(params[1]), cx(params[2]), cy(params[3]) {}

  /// n points, point j at (x[S·j], y[S·j], z[S·j]) (S = 3: packed x y z triplets, x, x + 1,
  /// x + 2; S = 1: gathered arrays): camera-frame depth bz[j], squared range b2[j], pixel
  /// (bu[j], bv[j]).
  template <int S>
  [[gnu::always_inline]] inline void Project(const float* __restrict x,
                                             const float* __restrict y,
                                             const float* __restrict z, int n,
                                             float* __restrict bz, float* __restrict b2,
                                             double* __restrict bu,
                                             double* __restrict bv) const {
    for (int j = 0; j < n; ++j) {
      const float px = m00 * x[S * j] + (m01 * y[S * j] + m02 * z[S * j]) + t0;
      const float py = m10 * x[S * j] + (m11 * y[S * j] + m12 * z[S * j]) + t1;
      const float pz = m20 * x[S * j] + (m21 * y[S * j] + m22 * z[S * j]) + t2;
      bz[j] = pz;
      b2[j] = px * px + (py * py + pz * pz);
      bu[j] = fx * (static_cast<double>(px) / static_cast<double>(pz) + 0.0) + cx;
      bv[j] = fy * (static_cast<double>(py) / static_cast<double>(pz) + 0.0) + cy;
    }
  }
};

/// Projects points[point_begin, point_end) with `projection` a block of 64 at a time and calls
/// `body(index, xy, range2)` (xy: double[2], the pixel; range2: the squared range) for each
/// point, in order, that is in front of the camera (depth > 0 and, in double, above its
/// epsilon), whose squared range is within [min_range2, max_range2] and whose pixel is in the
/// width × height image. The renderer's and the point samples' pinhole path.
template <typename Body>
[[gnu::always_inline]] inline void ForEachPinholePoint(const PinholeBlockProjection& projection,
                                                       const std::vector<Eigen::Vector3f>& points,
                                                       size_t point_begin, size_t point_end,
                                                       float min_range2, float max_range2, int width,
                                                       int height, Body&& body) {
  constexpr int kBlock = 64;
  alignas(64) float bz[kBlock], b2[kBlock];
  alignas(64) double bu[kBlock], bv[kBlock];
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "packed points");
  for (size_t begin = point_begin; begin < point_end; begin += kBlock) {
    const int n = static_cast<int>(std::min<size_t>(kBlock, point_end - begin));
    const float* xyz = points[begin].data();
    projection.Project<3>(xyz, xyz + 1, xyz + 2, n, bz, b2, bu, bv);
    for (int j = 0; j < n; ++j) {
      if (!(bz[j] > 0.f)) continue;
      const float range2 = b2[j];
      if (range2 < min_range2 || range2 > max_range2) continue;
      if (!(static_cast<double>(bz[j]) > std::numeric_limits<double>::epsilon())) continue;
      const double xy[2] = {bu[j], bv[j]};
      if (!(xy[0] >= 0 && xy[1] >= 0 && xy[0] < width && xy[1] < height)) continue;
      body(begin + j, xy, range2);
    }
  }
}

}  // namespace mmba::registration::mi::internal
