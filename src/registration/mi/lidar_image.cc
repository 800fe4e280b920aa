#include "mmba/registration/mi/lidar_image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <glog/logging.h>

#include "mmba/core/error.h"
#include "mmba/core/parallel_for.h"
#include "registration/mi/camera_dispatch.h"
#include "registration/mi/pinhole_block.h"

namespace mmba::registration::mi {

std::string RepresentationName(Representation representation) {
  switch (representation) {
    case Representation::kIntensity: return "intensity";
    case Representation::kPoints: return "points";
    case Representation::kDepth: return "depth";
  }
  return "";
}

bool ParseRepresentation(const std::string& name, Representation* representation) {
  for (Representation r : {Representation::kIntensity, Representation::kPoints,
                           Representation::kDepth}) {
    if (name == RepresentationName(r)) {
      *representation = r;
      return true;
    }
  }
  return false;
}

bool RenderOptions::Check(std::string* error) const {
  if (!(point_radius_m >= 0)) {
    *error = "point_radius_m " + std::to_string(point_radius_m) + " must be >= 0";
    return false;
  }
  if (max_point_radius_px < 0 || max_point_radius_px > 16) {
    *error = "max_point_radius_px " + std::to_string(max_point_radius_px) +
             " must be in 0..16";
    return false;
  }
  if (!(min_range_m > 0) || !(max_range_m > min_range_m)) {
    *error = "ranges must satisfy 0 < min_range_m < max_range_m (found " +
             std::to_string(min_range_m) + ", " + std::to_string(max_range_m) + ")";
    return false;
  }
  return true;
}

namespace {

constexpr uint64_t kEmptyKey = kEmptyZBufferKey;

inline uint32_t FloatBits(float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof(bits));
  return bits;
}

// Widest footprint row written as one fixed window (kZBufferPadding entries): radius ≤ 3.
constexpr int kWindow = static_cast<int>(kZBufferPadding);

// Pass 1 of the z-buffer: each point is projected once and its footprint keeps, per pixel,
// the smallest key (range << 32 | index). Positive IEEE floats order as their bit patterns,
// so one 64-bit comparison resolves depth (ties: lower index) without touching the outputs.
template <typename Model>
[[gnu::always_inline]] inline void SplatWithModel(const LidarPoints& points, const View& view,
                                                  const Rigid3d& cam_from_lidar,
                                                  const RenderOptions& options,
                                                  size_t point_begin, size_t point_end,
                                                  uint64_t* zbuffer, LidarImage* out) {
  const int width = out->width;
  const int height = out->height;
  const ViewTransform view_from_lidar = MakeTransform(view, cam_from_lidar);
  const Eigen::Matrix3f& rotation = view_from_lidar.rotation;
  const Eigen::Vector3f& translation = view_from_lidar.translation;
  const double* params = view.camera.params.data();
  const double focal = view.camera.MeanFocalLength();
  const float min_range2 = static_cast<float>(options.min_range_m * options.min_range_m);
  const float max_range2 = static_cast<float>(options.max_range_m * options.max_range_m);
  const float radius_factor = static_cast<float>(options.point_radius_m * focal);
  const int max_radius = options.max_point_radius_px;
  constexpr bool kPerspective = Model::kModelId != sensors::CameraModelId::kEquirectangular;
  const double period = 2.0 * M_PI * params[0];  // panorama columns per turn (f = W/2π)
  Eigen::Vector2f* projected = out->projected.data();
  const bool ranked = !points.tie_rank.empty();
  // One point that passed the projection: its footprint into the z-buffer. (Inlined: as a
  // call it would be compiled for the default instruction set, not the clone's.)
  // `range` = √range2, `radius_px` = radius_factor / range.
  auto draw = [&](size_t i, float range, float radius_px,
                  const double* xy) __attribute__((always_inline)) {
    const int col = static_cast<int>(xy[0]);
    const int row = static_cast<int>(xy[1]);
    const int radius = std::min(max_radius, static_cast<int>(radius_px));
    projected[i] = Eigen::Vector2f(static_cast<float>(xy[0]), static_cast<float>(xy[1]));
    const uint32_t rank = ranked ? points.tie_rank[i] : static_cast<uint32_t>(i);
    const uint64_t key = (static_cast<uint64_t>(FloatBits(range)) << 32) | rank;
    const int r0 = std::max(0, row - radius), r1 = std::min(height - 1, row + radius);
    const int c0 = std::max(0, col - radius), c1 = std::min(width - 1, col + radius);
    if (c1 - c0 < kWindow) {
      // A fixed window per row, the empty key past the footprint (a pixel keeps its key;
      // the buffer is padded for the last row): no branch on the footprint's width, and
      // a loop the compiler vectorises. The same minimum per pixel as the loop below.
      const int n = c1 - c0 + 1;
      for (int r = r0; r <= r1; ++r) {
        uint64_t* cell = zbuffer + static_cast<size_t>(r) * width + c0;
        for (int j = 0; j < kWindow; ++j) cell[j] = std::min(cell[j], j < n ? key : kEmptyKey);
      }
      return;
    }
    for (int r = r0; r <= r1; ++r) {
      uint64_t* line = zbuffer + static_cast<size_t>(r) * width;
      for (int c = c0; c <= c1; ++c) line[c] = std::min(line[c], key);
    }
  };
  if constexpr (std::is_same_v<Model, sensors::PinholeModel>) {
    // The pinhole camera (perspective cuts, KITTI): the points transformed and projected a
    // block at a time in loops without branches, which the compiler vectorises (the
    // divisions in double are most of a point's cost), then the checks and footprints one by
    // one. The same arithmetic as the loop below — Eigen's 3×3 product is r₀x + (r₁y + r₂z)
    // per row, the squared norm x² + (y² + z²) (test ProjectionBlocksEqualTheEigenExpressions),
    // PinholeModel::ImgFromCam is f·(x/z + 0) + c.
    const internal::PinholeBlockProjection projection(rotation, translation, params);
    internal::ForEachPinholePoint(
        projection, points.points_in_lidar, point_begin, point_end, min_range2, max_range2, width,
        height, [&](size_t i, const double* xy, float range2) __attribute__((always_inline)) {
          // (The square root stays here, out of the projection's block loop: std::sqrt may
          // set errno, which keeps GCC from vectorising that loop — measured: it then ran
          // scalar, slower.)
          const float range = std::sqrt(range2);
          draw(i, range, radius_factor / range, xy);
        });
    return;
  }
  for (size_t i = point_begin; i < point_end; ++i) {
    const Eigen::Vector3f p = rotation * points.points_in_lidar[i] + translation;
    if (kPerspective && !(p.z() > 0.f)) continue;
    const float range2 = p.squaredNorm();
    if (range2 < min_range2 || range2 > max_range2) continue;
    const double point_in_view[3] = {p.x(), p.y(), p.z()};
    double xy[2];
    if (!Model::ImgFromCam(params, point_in_view, xy)) continue;
    if (!kPerspective) {  // the ±180° seam: wrap the column into the panorama
      if (xy[0] >= width) xy[0] -= period;
      if (xy[0] < 0) xy[0] += period;
    }
    if (!(xy[0] >= 0 && xy[1] >= 0 && xy[0] < width && xy[1] < height)) continue;
    const float range = std::sqrt(range2);
    draw(i, range, radius_factor / range, xy);
  }
}

// Points [begin, end) of one view into `zbuffer`; one function per instruction set (AVX2
// where the CPU has it: the footprint windows as vectors; no FMA, so the same arithmetic).
__attribute__((target_clones("avx2", "default"))) void Splat(
    const LidarPoints& points, const View& view, const Rigid3d& cam_from_lidar,
    const RenderOptions& options, size_t begin, size_t end, uint64_t* zbuffer,
    LidarImage* out) {
  internal::WithCameraModel(view.camera.model_id, [&](auto model) __attribute__((always_inline)) {
    SplatWithModel<decltype(model)>(points, view, cam_from_lidar, options, begin, end, zbuffer, out);
  });
}

}  // namespace

void RenderLidarZBuffer(const LidarPoints& points, const View& view,
                        const Rigid3d& cam_from_lidar, const RenderOptions& options,
                        LidarImage* out, bool two_threads) {
  CHECK(options.representation != Representation::kIntensity || points.has_intensity() ||
        points.size() == 0)
      << "intensity representation of a cloud without intensity";
  CHECK_LT(points.size(), size_t{1} << 32) << "at most 2^32 points per render";
  CHECK(points.tie_rank.empty() || (points.tie_rank.size() == points.size() &&
                                    points.index_of_rank.size() == points.size()))
      << "tie_rank and index_of_rank must both be empty or both have one entry per point";
  out->width = static_cast<int>(view.camera.width);
  out->height = static_cast<int>(view.camera.height);
  const size_t pixels = static_cast<size_t>(out->width) * out->height;
  out->zbuffer.assign(pixels + kZBufferPadding, kEmptyKey);
  if (out->projected.size() < points.size()) out->projected.resize(points.size());
  if (two_threads && points.size() >= 2) {
    out->zbuffer_second.assign(pixels + kZBufferPadding, kEmptyKey);
    const size_t half = points.size() / 2;
    // `projected` is written per point: the two ranges are disjoint.
    OnThreads(2, [&](int t, int) {
      if (t == 0) {
        Splat(points, view, cam_from_lidar, options, 0, half, out->zbuffer.data(), out);
      } else {
        Splat(points, view, cam_from_lidar, options, half, points.size(), out->zbuffer_second.data(), out);
      }
    });
    // The minimum is order-independent: the same key per pixel as one thread's render.
    for (size_t k = 0; k < pixels; ++k) {
      out->zbuffer[k] = std::min(out->zbuffer[k], out->zbuffer_second[k]);
    }
  } else {
    Splat(points, view, cam_from_lidar, options, 0, points.size(), out->zbuffer.data(), out);
  }
}

LidarValueMap::LidarValueMap(const RenderOptions& options)
    : representation_(options.representation),
      log_min_(static_cast<float>(std::log(options.min_range_m))),
      inv_log_span_(static_cast<float>(
          1.0 / (std::log(options.max_range_m) - std::log(options.min_range_m)))) {}

void RenderLidarImage(const LidarPoints& points, const View& view, const Rigid3d& cam_from_lidar,
                      const RenderOptions& options, LidarImage* out, bool two_threads) {
  RenderLidarZBuffer(points, view, cam_from_lidar, options, out, two_threads);
  const size_t pixels = static_cast<size_t>(out->width) * out->height;
  // Pass 2: the winner of each pixel gives its value, depth and sub-pixel offset.
  out->value.resize(pixels);
  out->depth.resize(pixels);
  out->offset_x.resize(pixels);
  out->offset_y.resize(pixels);
  out->point_index.resize(pixels);
  const LidarValueMap value_of(options);
  size_t covered = 0;
  for (size_t k = 0; k < pixels; ++k) {
    const uint64_t key = out->zbuffer[k];
    if (key == kEmptyKey) {
      out->value[k] = -1.f;
      out->depth[k] = std::numeric_limits<float>::infinity();
      out->offset_x[k] = 0.f;
      out->offset_y[k] = 0.f;
      out->point_index[k] = -1;
      continue;
    }
    ++covered;
    const uint32_t i = ZBufferPointIndex(points, key);
    const float range = ZBufferRange(key);
    const Eigen::Vector2f& xy = out->projected[i];
    out->value[k] = value_of(points, i, range);
    out->depth[k] = range;
    // Offset of the point from the centre of ITS pixel, shared by its whole footprint.
    out->offset_x[k] = xy.x() - (std::floor(xy.x()) + 0.5f);
    out->offset_y[k] = xy.y() - (std::floor(xy.y()) + 0.5f);
    out->point_index[k] = static_cast<int>(i);
  }
  out->covered_pixels = covered;
}

size_t CountVisiblePoints(const LidarImage& image) {
  std::vector<int> winners;
  winners.reserve(image.covered_pixels);
  for (int index : image.point_index) {
    if (index >= 0) winners.push_back(index);
  }
  std::sort(winners.begin(), winners.end());
  return static_cast<size_t>(std::unique(winners.begin(), winners.end()) - winners.begin());
}

GrayImage LidarImageToGray(const LidarImage& image) {
  GrayImage gray(image.width, image.height);
  for (size_t k = 0; k < image.value.size(); ++k) {
    // (Values of several surface classes are class + fraction: the fraction is shown.)
    const float v = image.value[k];
    gray.pixels[k] = v < 0 ? 0.f : 255.f * (v > 1.f ? v - std::floor(v) : v);
  }
  return gray;
}

}  // namespace mmba::registration::mi
