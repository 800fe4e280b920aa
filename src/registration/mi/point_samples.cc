#include "mmba/registration/mi/point_samples.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

#include <immintrin.h>

#include <glog/logging.h>

#include "mmba/registration/mi/image.h"
#include "registration/mi/bilinear_avx2.h"
#include "registration/mi/camera_dispatch.h"
#include "registration/mi/pinhole_block.h"

namespace mmba::registration::mi {
namespace {

// The renderer's projection (lidar_image.cc, SplatWithModel): in front of a perspective
// camera, within the range limits, inside the image; the panorama's column wrapped at the
// seam. Returns false where the renderer draws nothing.
template <typename Model>
inline bool ProjectLikeRenderer(const double* params, const Eigen::Vector3f& p, int width,
                                int height, double period, float min_range2, float max_range2,
                                double xy[2], float* range2) {
  constexpr bool kPerspective = Model::kModelId != sensors::CameraModelId::kEquirectangular;
  if (kPerspective && !(p.z() > 0.f)) return false;
  *range2 = p.squaredNorm();
  if (*range2 < min_range2 || *range2 > max_range2) return false;
  const double point_in_view[3] = {p.x(), p.y(), p.z()};
  if (!Model::ImgFromCam(params, point_in_view, xy)) return false;
  if (!kPerspective) {
    if (xy[0] >= width) xy[0] -= period;
    if (xy[0] < 0) xy[0] += period;
  }
  return xy[0] >= 0 && xy[1] >= 0 && xy[0] < width && xy[1] < height;
}

// AVX2: SampleClamped(photo, x[k], y[k]) for k < count, 8 at a time (BilinearAvx2: the same
// values bit for bit). Returns how many it did (a multiple of 8); the caller samples the rest.
__attribute__((target("avx2"))) int SampleClampedAvx2(const GrayImage& photo, const float* x,
                                                      const float* y, int count, float* out) {
  const internal::BilinearAvx2 bilinear(photo);
  int k = 0;
  for (; k + 8 <= count; k += 8) {
    _mm256_storeu_ps(out + k, bilinear.Sample(_mm256_loadu_ps(x + k), _mm256_loadu_ps(y + k)));
  }
  return k;
}

// AccumulateWithModel for the pinhole camera when every point has one sample (per-point
// sets, and per-pixel ones whose points each won a single pixel) and its LiDAR value is
// fixed (intensity, points): the whole block's tests in one loop without branches, the
// samples that pass packed into the batch without a branch, and the LiDAR bin weights of a
// batch in one loop — the same values as the general loop's (the same projection,
// comparisons and float operations; test
// PointSamplesTest.PinholeBlocksAccumulateAsTheGenericModel), added in the same order.
[[gnu::always_inline]] inline void AccumulatePinholeOnePerPoint(
    const ViewSamples& samples, const View& view, const ViewTransform& t,
    const RenderOptions& options, size_t point_begin, size_t point_end,
    JointHistogram* histogram) {
  const int width = static_cast<int>(view.camera.width);
  const int height = static_cast<int>(view.camera.height);
  const double* params = view.camera.params.data();
  const float min_range2 = static_cast<float>(options.min_range_m * options.min_range_m);
  const float max_range2 = static_cast<float>(options.max_range_m * options.max_range_m);
  constexpr int kBatch = JointHistogram::kBatch;
  constexpr int kBlock = 64;
  static_assert(kBatch >= kBlock, "a block fits a batch");
  alignas(64) int batch_bx[kBatch];
  alignas(64) float batch_wx[4][kBatch];
  alignas(64) float batch_photo[kBatch], batch_weight[kBatch], batch_value[kBatch];
  alignas(64) float batch_x[kBatch], batch_y[kBatch];
  int n = 0;
  // The total weight, summed per sample in the same order as the general loop.
  double count = 0;
  // JointHistogram::LidarWeights with the bins held here (its last bin is that of value 1),
  // the clamp as min/max (the same bin for every value that is not NaN), so that the batch's
  // loop has no branch.
  int last_bin = 0;
  {
    float unused[4];
    histogram->LidarWeights(1.f, &last_bin, unused);
  }
  const float lidar_scale = static_cast<float>(last_bin);
  const int classes = histogram->lidar_classes();
  const float last_class = static_cast<float>(classes - 1);
  const float class_scale = static_cast<float>(histogram->bins() - 1);
  const int class_stride = histogram->bins() + 3;
  const bool gather = internal::CpuHasAvx2() && view.image.pixels.size() < (size_t{1} << 31);
  auto flush = [&]() __attribute__((always_inline)) {
    const int done = gather ? SampleClampedAvx2(view.image, batch_x, batch_y, n, batch_photo) : 0;
    for (int k = done; k < n; ++k) batch_photo[k] = SampleClamped(view.image, batch_x[k], batch_y[k]);
    if (classes > 1) {
      // Several classes: each value's class block, as JointHistogram::LidarWeights (the same
      // operations; the clamps as min/max, so that the loop has no branch).
      for (int k = 0; k < n; ++k) {
        const float value = batch_value[k];
        // (Truncation instead of floor: the same class after the clamp to 0.)
        const float c = std::min(std::max(static_cast<float>(static_cast<int>(value)), 0.f), last_class);
        const float pos = (value - c) * class_scale;
        const int local = static_cast<int>(std::min(std::max(pos, 0.f), class_scale));
        float w[4];
        JointHistogram::CubicBSplineWeights(pos - local, w);
        batch_bx[k] = static_cast<int>(c) * class_stride + local;
        for (int i = 0; i < 4; ++i) batch_wx[i][k] = w[i];
      }
    } else {
      for (int k = 0; k < n; ++k) {
        const float pos = batch_value[k] * lidar_scale;
        const int bx = static_cast<int>(std::min(std::max(pos, 0.f), lidar_scale));
        float w[4];
        JointHistogram::CubicBSplineWeights(pos - bx, w);
        batch_bx[k] = bx;
        for (int i = 0; i < 4; ++i) batch_wx[i][k] = w[i];
      }
    }
    for (int k = 0; k < n; ++k) count += batch_weight[k];
    histogram->AddCoveredBatch(n, batch_bx, batch_wx, batch_photo, batch_weight);
    n = 0;
  };
  alignas(64) float bz[kBlock], b2[kBlock], bsx[kBlock], bsy[kBlock];
  alignas(64) double bu[kBlock], bv[kBlock];
  alignas(64) int ok[kBlock];
  const internal::PinholeBlockProjection projection(t.rotation, t.translation, params);
  constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
  const std::array<int8_t, 2>* offset = samples.sample_offset.data();
  const float* value01 = samples.value01.data();
  const float* weight = samples.sample_weight.data();
  for (size_t begin = point_begin; begin < point_end; begin += kBlock) {
    const int m = static_cast<int>(std::min<size_t>(kBlock, point_end - begin));
    const float* xyz = samples.points_in_lidar[begin].data();
    projection.Project<3>(xyz, xyz + 1, xyz + 2, m, bz, b2, bu, bv);
    for (int j = 0; j < m; ++j) {
      // The general loop's tests: in front, within the ranges, projected inside the image;
      // then the sample inside it.
      const float range2 = b2[j];
      const bool seen = (bz[j] > 0.f) & !(range2 < min_range2) & !(range2 > max_range2) &
                        (static_cast<double>(bz[j]) > kEpsilon) & (bu[j] >= 0) & (bv[j] >= 0) &
                        (bu[j] < width) & (bv[j] < height);
      const float sx = static_cast<float>(bu[j]) + offset[begin + j][0];
      const float sy = static_cast<float>(bv[j]) + offset[begin + j][1];
      bsx[j] = sx;
      bsy[j] = sy;
      ok[j] = seen & (sx >= 0.f) & (sy >= 0.f) & (sx < width) & (sy < height);
    }
    if (n > kBatch - kBlock) flush();
    for (int j = 0; j < m; ++j) {
      batch_x[n] = bsx[j];
      batch_y[n] = bsy[j];
      batch_value[n] = value01[begin + j];
      batch_weight[n] = weight[begin + j];
      n += ok[j];
    }
  }
  flush();
  histogram->AddCoveredCount(count);
}

template <typename Model>
[[gnu::always_inline]] inline void AccumulateWithModel(const ViewSamples& samples,
                                                       const View& view, const ViewTransform& t,
                                                       const RenderOptions& options,
                                                       size_t point_begin, size_t point_end,
                                                       JointHistogram* histogram) {
  const int width = static_cast<int>(view.camera.width);
  const int height = static_cast<int>(view.camera.height);
  const double* params = view.camera.params.data();
  const double period = 2.0 * M_PI * params[0];
  const float min_range2 = static_cast<float>(options.min_range_m * options.min_range_m);
  const float max_range2 = static_cast<float>(options.max_range_m * options.max_range_m);
  const bool depth = options.representation == Representation::kDepth;
  const float log_min = static_cast<float>(std::log(options.min_range_m));
  const float inv_log_span =
      static_cast<float>(1.0 / (std::log(options.max_range_m) - std::log(options.min_range_m)));
  double count = 0;
  // Samples gathered in batches (JointHistogram::AddCoveredBatch: the same sums as one by one).
  constexpr int kBatch = JointHistogram::kBatch;
  int batch_bx[kBatch];
  float batch_wx[4][kBatch];
  float batch_photo[kBatch];
  float batch_weight[kBatch];
  float batch_x[kBatch], batch_y[kBatch];
  int n = 0;
  // The pinhole camera samples the photo of a whole batch at once (AVX2 gathers where the
  // CPU has them; the photo's pixel count below 2^31 for the 32-bit gather indices); the
  // other models one sample at a time. The same values either way.
  constexpr bool kPinhole = std::is_same_v<Model, sensors::PinholeModel>;
  if constexpr (kPinhole) {
    if (!depth && samples.samples() == samples.points()) {
      AccumulatePinholeOnePerPoint(samples, view, t, options, point_begin, point_end, histogram);
      return;
    }
  }
  const bool gather = kPinhole && internal::CpuHasAvx2() && view.image.pixels.size() < (size_t{1} << 31);
  auto flush = [&]() __attribute__((always_inline)) {
    if constexpr (kPinhole) {
      const int done = gather ? SampleClampedAvx2(view.image, batch_x, batch_y, n, batch_photo) : 0;
      for (int k = done; k < n; ++k) batch_photo[k] = SampleClamped(view.image, batch_x[k], batch_y[k]);
    }
    histogram->AddCoveredBatch(n, batch_bx, batch_wx, batch_photo, batch_weight);
    n = 0;
  };
  // One point that projects to (xy[0], xy[1]) at squared range range2: its samples.
  auto add_point = [&](size_t j, const double* xy, float range2) __attribute__((always_inline)) {
    // The renderer's depth value: 1/range on a log scale (near bright).
    const float value =
        depth ? std::clamp(1.f - (0.5f * std::log(range2) - log_min) * inv_log_span, 0.f, 1.f)
              : samples.value01[j];
    int bx;
    float wx[4];
    histogram->LidarWeights(value, &bx, wx);
    const float x = static_cast<float>(xy[0]), y = static_cast<float>(xy[1]);
    for (uint32_t s = samples.sample_begin[j]; s < samples.sample_begin[j + 1]; ++s) {
      const float sx = x + samples.sample_offset[s][0];
      const float sy = y + samples.sample_offset[s][1];
      if (!(sx >= 0.f && sy >= 0.f && sx < width && sy < height)) continue;
      // The rendered path's photo sampler (clamped bilinear), so both fill the same histogram.
      if constexpr (kPinhole) {
        batch_x[n] = sx;
        batch_y[n] = sy;
      } else {
        batch_photo[n] = SampleClamped(view.image, sx, sy);
      }
      batch_weight[n] = samples.sample_weight[s];
      batch_bx[n] = bx;
      for (int i = 0; i < 4; ++i) batch_wx[i][n] = wx[i];
      count += samples.sample_weight[s];
      if (++n == kBatch) flush();
    }
  };
  if constexpr (kPinhole) {
    // The renderer's pinhole blocks (lidar_image.cc, SplatWithModel): the points transformed
    // and projected a block at a time in loops without branches, which the compiler
    // vectorises; the same arithmetic as ProjectLikeRenderer (Eigen's 3×3 product is
    // r₀x + (r₁y + r₂z) per row, the squared norm x² + (y² + z²), PinholeModel::ImgFromCam
    // f·(x/z + 0) + c; test PointSamplesTest.PinholeBlocksAccumulateAsTheGenericModel).
    const internal::PinholeBlockProjection projection(t.rotation, t.translation, params);
    internal::ForEachPinholePoint(projection, samples.points_in_lidar, point_begin, point_end, min_range2,
                                  max_range2, width, height, add_point);
  } else {
    for (size_t j = point_begin; j < point_end; ++j) {
      const Eigen::Vector3f p = t.rotation * samples.points_in_lidar[j] + t.translation;
      double xy[2];
      float range2 = 0.f;
      if (!ProjectLikeRenderer<Model>(params, p, width, height, period, min_range2, max_range2,
                                      xy, &range2)) {
        continue;
      }
      add_point(j, xy, range2);
    }
  }
  flush();
  histogram->AddCoveredCount(count);
}

// One function per instruction set (AVX2 where the CPU has it: the projection blocks as
// wider vectors; no FMA, so the same arithmetic).
__attribute__((target_clones("avx2", "default"))) void Accumulate(
    const ViewSamples& samples, const View& view, const ViewTransform& t,
    const RenderOptions& options, size_t point_begin, size_t point_end,
    JointHistogram* histogram) {
  internal::WithCameraModel(view.camera.model_id, [&](auto model) __attribute__((always_inline)) {
    AccumulateWithModel<decltype(model)>(samples, view, t, options, point_begin, point_end, histogram);
  });
}

}  // namespace

ViewSamples MakeViewSamples(const LidarPoints& points, const LidarImage& rendered,
                            const RenderOptions& options, bool per_point,
                            const PerPointPlacement& placement, int max_probes) {
  ViewSamples samples;
  const size_t pixels = rendered.point_index.size();
  // Compact index of each winning point, in order of first appearance (row-major).
  std::vector<int> compact(points.size(), -1);
  std::vector<uint32_t> count;
  std::vector<int> original;  // compact → index in `points`
  std::vector<size_t> first_pixel;  // compact → the first pixel it won
  for (size_t k = 0; k < pixels; ++k) {
    const int i = rendered.point_index[k];
    if (i < 0) continue;
    if (compact[i] < 0) {
      compact[i] = static_cast<int>(samples.points_in_lidar.size());
      samples.points_in_lidar.push_back(points.points_in_lidar[i]);
      samples.value01.push_back(options.representation == Representation::kIntensity
                                    ? points.intensity01[i]
                                    : 1.f);
      count.push_back(0);
      original.push_back(i);
      first_pixel.push_back(k);
    }
    ++count[compact[i]];
  }
  const size_t n = samples.points_in_lidar.size();
  const int width = rendered.width;
  if (per_point && placement.block_px > 0) {
    // The footprint decides visibility only: each point in front at the pixel of its own
    // projection is sampled there, with its share of its block's covered pixels.
    const int block = placement.block_px;
    const int blocks_x = (width + block - 1) / block;
    const int blocks_y = (rendered.height + block - 1) / block;
    std::vector<float> block_pixels(static_cast<size_t>(blocks_x) * blocks_y, 0.f);
    std::vector<float> block_samples(block_pixels.size(), 0.f);
    for (size_t k = 0; k < pixels; ++k) {
      if (rendered.point_index[k] < 0) continue;
      const int c = static_cast<int>(k % width), r = static_cast<int>(k / width);
      block_pixels[static_cast<size_t>(r / block) * blocks_x + c / block] += 1.f;
    }
    ViewSamples kept;
    std::vector<size_t> block_of;
    std::vector<int> kept_original;
    for (size_t j = 0; j < n; ++j) {
      const int i = original[j];
      const Eigen::Vector2f& xy = rendered.projected[i];
      // The renderer keeps only projections inside the image (tested in double); the clamp
      // guards the float copy rounding up to the edge.
      const int c = std::min(width - 1, static_cast<int>(std::floor(xy.x())));
      const int r = std::min(rendered.height - 1, static_cast<int>(std::floor(xy.y())));
      // The point's range is the depth of every pixel it won (one key per footprint).
      const float range = rendered.depth[first_pixel[j]];
      const float front = rendered.depth[static_cast<size_t>(r) * width + c];
      if (!(range <= front + placement.depth_tolerance_m +
                         placement.depth_tolerance_fraction * front)) {
        continue;
      }
      kept.points_in_lidar.push_back(samples.points_in_lidar[j]);
      kept.value01.push_back(samples.value01[j]);
      const size_t b = static_cast<size_t>(r / block) * blocks_x + c / block;
      block_of.push_back(b);
      block_samples[b] += 1.f;
      kept_original.push_back(i);
    }
    const size_t m = kept.points_in_lidar.size();
    kept.sample_begin.resize(m + 1);
    for (size_t j = 0; j <= m; ++j) kept.sample_begin[j] = static_cast<uint32_t>(j);
    kept.sample_offset.assign(m, {0, 0});
    kept.sample_weight.resize(m);
    for (size_t j = 0; j < m; ++j) {
      kept.sample_weight[j] = block_pixels[block_of[j]] / block_samples[block_of[j]];
    }
    const size_t probes = std::min<size_t>(m, static_cast<size_t>(std::max(0, max_probes)));
    for (size_t q = 0; q < probes; ++q) {
      const size_t j = (2 * q + 1) * m / (2 * probes);  // spread over the visible set
      kept.probe_points.push_back(kept.points_in_lidar[j]);
      kept.probe_pixels.push_back(rendered.projected[kept_original[j]]);
    }
    return kept;
  }
  samples.sample_begin.assign(n + 1, 0);
  for (size_t j = 0; j < n; ++j) samples.sample_begin[j + 1] = samples.sample_begin[j] + count[j];
  samples.sample_offset.resize(samples.sample_begin[n]);
  std::vector<uint32_t> fill(samples.sample_begin.begin(), samples.sample_begin.end() - 1);
  for (size_t k = 0; k < pixels; ++k) {
    const int i = rendered.point_index[k];
    if (i < 0) continue;
    const int c = static_cast<int>(k % rendered.width);
    const int r = static_cast<int>(k / rendered.width);
    const Eigen::Vector2f& xy = rendered.projected[i];
    const int dc = c - static_cast<int>(std::floor(xy.x()));
    const int dr = r - static_cast<int>(std::floor(xy.y()));
    CHECK(std::abs(dc) <= 127 && std::abs(dr) <= 127) << "footprint wider than 127 pixels";
    samples.sample_offset[fill[compact[i]]++] = {static_cast<int8_t>(dc), static_cast<int8_t>(dr)};
  }
  samples.sample_weight.assign(samples.sample_offset.size(), 1.f);
  if (per_point) {
    // One sample per point: its won pixel nearest the projection, weighted by the count.
    std::vector<std::array<int8_t, 2>> offsets(n);
    for (size_t j = 0; j < n; ++j) {
      int best = -1, best_d2 = 0;
      for (uint32_t s = samples.sample_begin[j]; s < samples.sample_begin[j + 1]; ++s) {
        const int d2 = samples.sample_offset[s][0] * samples.sample_offset[s][0] +
                       samples.sample_offset[s][1] * samples.sample_offset[s][1];
        if (best < 0 || d2 < best_d2) {
          best = static_cast<int>(s);
          best_d2 = d2;
        }
      }
      offsets[j] = samples.sample_offset[best];
    }
    samples.sample_weight.assign(n, 0.f);
    for (size_t j = 0; j < n; ++j) samples.sample_weight[j] = static_cast<float>(count[j]);
    samples.sample_offset = std::move(offsets);
    for (size_t j = 0; j <= n; ++j) samples.sample_begin[j] = static_cast<uint32_t>(j);
  }
  const size_t probes = std::min<size_t>(n, static_cast<size_t>(std::max(0, max_probes)));
  for (size_t q = 0; q < probes; ++q) {
    const size_t j = (2 * q + 1) * n / (2 * probes);  // spread over the visible set
    samples.probe_points.push_back(samples.points_in_lidar[j]);
    samples.probe_pixels.push_back(rendered.projected[original[j]]);  // the renderer's pixel
  }
  return samples;
}

void AccumulateViewSamples(const ViewSamples& samples, const View& view,
                           const Rigid3d& cam_from_lidar, const RenderOptions& options,
                           size_t point_begin, size_t point_end, JointHistogram* histogram) {
  CHECK_LE(point_end, samples.points());
  const ViewTransform t = MakeTransform(view, cam_from_lidar);
  Accumulate(samples, view, t, options, point_begin, point_end, histogram);
}

double ProbeDisplacementPx(const ViewSamples& samples, const View& view,
                           const Rigid3d& cam_from_lidar) {
  const ViewTransform t = MakeTransform(view, cam_from_lidar);
  const bool spherical = view.camera.IsSpherical();
  const double period = 2.0 * M_PI * view.camera.params[0];
  double largest = 0;
  for (size_t q = 0; q < samples.probe_points.size(); ++q) {
    const Eigen::Vector3f p = t.rotation * samples.probe_points[q] + t.translation;
    if (!spherical && !(p.z() > 0.f)) return std::numeric_limits<double>::infinity();
    const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p.cast<double>());
    if (!xy) return std::numeric_limits<double>::infinity();
    Eigen::Vector2d d = *xy - samples.probe_pixels[q].cast<double>();
    if (spherical) d.x() -= period * std::round(d.x() / period);
    largest = std::max(largest, d.norm());
  }
  return largest;
}

}  // namespace mmba::registration::mi
