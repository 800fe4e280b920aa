#include "registration/mi/evaluator_cull.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <immintrin.h>

#include "registration/mi/pinhole_block.h"

namespace mmba::registration::mi {

namespace {

// Key of a point that falls on no view (after every pixel's).
constexpr uint64_t kNowhere = std::numeric_limits<uint64_t>::max();

// RenderOrder's keys for one pinhole view (perspective cuts, KITTI), a block of points at a
// time: the transform, squared norm and projection in loops without branches as in
// CullPinholeBlocks (the arithmetic of the general path: Eigen's product and squared norm,
// ImgFromCam), then the general path's tests; only keys still kNowhere are set.
__attribute__((target_clones("avx2", "default"))) void PinholeKeys(
    const std::vector<Eigen::Vector3f>& points, const Eigen::Matrix3f& rotation,
    const Eigen::Vector3f& translation, const sensors::Camera& camera, double min_range2,
    double max_range2, uint64_t view_bits, uint64_t* key) {
  constexpr int kBlock = 64;
  alignas(64) float bx[kBlock], by[kBlock], gz[kBlock], bz[kBlock], b2[kBlock];
  alignas(64) double bu[kBlock], bv[kBlock];
  const internal::PinholeBlockProjection projection(rotation, translation,
                                                   camera.params.data());
  const double width = camera.width, height = camera.height;
  constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
  for (size_t block = 0; block < points.size(); block += kBlock) {
    const int n = static_cast<int>(std::min<size_t>(kBlock, points.size() - block));
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3f& q = points[block + j];
      bx[j] = q.x();
      by[j] = q.y();
      gz[j] = q.z();
    }
    projection.Project<1>(bx, by, gz, n, bz, b2, bu, bv);
    for (int j = 0; j < n; ++j) {
      uint64_t& k = key[block + j];
      if (k != kNowhere || !(bz[j] > 0.f)) continue;
      const double range2 = b2[j];
      if (range2 < min_range2 || range2 > max_range2) continue;
      if (!(static_cast<double>(bz[j]) > kEpsilon)) continue;
      const double x = bu[j], y = bv[j];
      if (!(x >= 0 && y >= 0 && x < width && y < height)) continue;
      k = view_bits | (static_cast<uint64_t>(y) << 24) | static_cast<uint64_t>(x);
    }
  }
}

}  // namespace

namespace internal {

// The positions 0 .. points.size() − 1 in the order of the pixel each point falls on at
// `cam_from_lidar` (the first view it projects into; view, row, column), the points that fall
// on no view last; ties in the points' order (a stable sort: deterministic). Sorted by counting
// the points per pixel (the keys are pixels: the order of a stable sort by key).
std::vector<uint32_t> RenderOrder(const std::vector<Eigen::Vector3f>& points,
                                  const std::vector<View>& views, const Rigid3d& cam_from_lidar,
                                  const RenderOptions& render) {
  std::vector<uint64_t> key(points.size(), kNowhere);
  const double min_range2 = render.min_range_m * render.min_range_m;
  const double max_range2 = render.max_range_m * render.max_range_m;
  for (size_t v = 0; v < views.size(); ++v) {
    const View& view = views[v];
    const auto [rotation, translation] = MakeTransform(view, cam_from_lidar);
    if (view.camera.model_id == sensors::CameraModelId::kPinhole) {
      PinholeKeys(points, rotation, translation, view.camera, min_range2, max_range2,
                  static_cast<uint64_t>(v) << 48, key.data());
      continue;
    }
    const bool spherical = view.camera.IsSpherical();
    const double period = 2.0 * M_PI * view.camera.params[0];
    for (size_t k = 0; k < points.size(); ++k) {
      if (key[k] != kNowhere) continue;
      const Eigen::Vector3f p = rotation * points[k] + translation;
      if (!spherical && !(p.z() > 0.f)) continue;
      const double range2 = p.squaredNorm();
      if (range2 < min_range2 || range2 > max_range2) continue;
      const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p.cast<double>());
      if (!xy) continue;
      double x = (*xy)[0];
      if (spherical) x -= period * std::floor(x / period);
      if (!(x >= 0 && (*xy)[1] >= 0 && x < view.camera.width && (*xy)[1] < view.camera.height)) {
        continue;
      }
      key[k] = (static_cast<uint64_t>(v) << 48) | (static_cast<uint64_t>((*xy)[1]) << 24) |
               static_cast<uint64_t>(x);
    }
  }
  std::vector<uint32_t> order(points.size());
  // A key's pixel (view, row, column) numbered in key order: view-major, then row-major;
  // kNowhere after them all. (Columns and rows below 2^24, as the keys need.)
  std::vector<size_t> first_pixel(views.size() + 1, 0);
  bool countable = views.size() < (size_t{1} << 16);
  for (size_t v = 0; v < views.size(); ++v) {
    const sensors::Camera& camera = views[v].camera;
    countable = countable && camera.width < (1 << 24) && camera.height < (1 << 24);
    first_pixel[v + 1] = first_pixel[v] + static_cast<size_t>(camera.width) * camera.height;
  }
  if (!countable) {
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&key](uint32_t a, uint32_t b) { return key[a] < key[b]; });
    return order;
  }
  const size_t nowhere = first_pixel.back();
  auto pixel = [&](uint64_t k) {
    if (k == kNowhere) return nowhere;
    const size_t v = static_cast<size_t>(k >> 48);
    const size_t row = static_cast<size_t>((k >> 24) & 0xFFFFFF);
    const size_t column = static_cast<size_t>(k & 0xFFFFFF);
    return first_pixel[v] + row * views[v].camera.width + column;
  };
  std::vector<uint32_t> start(nowhere + 2, 0);  // points before each pixel, then its fill
  for (uint64_t k : key) ++start[pixel(k) + 1];
  for (size_t p = 1; p < start.size(); ++p) start[p] += start[p - 1];
  for (size_t k = 0; k < key.size(); ++k) order[start[pixel(key[k])]++] = static_cast<uint32_t>(k);
  return order;
}

// The cull of candidates [begin, end) (indices into `all`, or the points themselves when
// `candidates` is null) against one pinhole view (perspective cuts, KITTI): keep[k] |= the
// test of candidate k. A block of points at a time in loops without branches, which the
// compiler vectorises: the transform, squared norm and projection with the arithmetic of the
// general path (Eigen's 3×3 product r₀x + (r₁y + r₂z) per row, the squared norm
// x² + (y² + z²), ImgFromCam f·(x/z + 0) + c), then the general path's test written as one
// expression of comparisons — kept iff not beyond the range, and nearer than the near range
// or in front of the camera and inside the view's margin (test
// StreetTest.PinholeCullEqualsTheGenericModel). No FMA in either clone: the same roundings.
__attribute__((target_clones("avx2", "default"))) void CullPinholeBlocks(
    const PinholeCull& cull, const LidarPoints& all, const std::vector<uint32_t>* candidates,
    size_t begin, size_t end, char* keep) {
  constexpr int kBlock = 64;
  alignas(64) float bx[kBlock], by[kBlock], gz[kBlock], bz[kBlock], b2[kBlock];
  alignas(64) float br[kBlock];
  alignas(64) double bu[kBlock], bv[kBlock];
  alignas(64) char flag[kBlock];
  const internal::PinholeBlockProjection projection(cull.rotation, cull.translation,
                                                   cull.camera.params.data());
  const double width = cull.camera.width, height = cull.camera.height;
  const double focal = cull.focal, rot_margin = cull.rot_margin;
  const double bound_m = cull.bound_translation_m;
  const double max_range = cull.max_range, near_range = cull.near_range;
  constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
  const Eigen::Vector3f* points = all.points_in_lidar.data();
  const uint32_t* index = candidates != nullptr ? candidates->data() : nullptr;
  for (size_t block = begin; block < end; block += kBlock) {
    const int n = static_cast<int>(std::min<size_t>(kBlock, end - block));
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3f& q = points[index != nullptr ? index[block + j] : block + j];
      bx[j] = q.x();
      by[j] = q.y();
      gz[j] = q.z();
    }
    projection.Project<1>(bx, by, gz, n, bz, b2, bu, bv);
    // p.norm(): the float root (SSE's, correctly rounded as std::sqrt; without errno, so the
    // loop below has no branch), four at a time over the block (the tail set to 0).
    for (int j = n; j < kBlock; ++j) b2[j] = 0.f;
    for (int j = 0; j < n; j += 4) _mm_store_ps(br + j, _mm_sqrt_ps(_mm_load_ps(b2 + j)));
    for (int j = 0; j < n; ++j) {
      const double range = br[j];
      const double margin = focal * (rot_margin + bound_m / range) + 8.0;
      const bool inside = (bu[j] >= -margin) & (bv[j] >= -margin) & (bu[j] <= width + margin) &
                          (bv[j] <= height + margin);
      const bool front = !(bz[j] <= 0.f) & (static_cast<double>(bz[j]) > kEpsilon);
      flag[j] = (!(range > max_range)) & ((range < near_range) | (front & inside));
    }
    for (int j = 0; j < n; ++j) keep[block + j] |= flag[j];
  }
}

}  // namespace internal

}  // namespace mmba::registration::mi
