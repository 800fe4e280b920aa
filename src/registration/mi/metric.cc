#include "mmba/registration/mi/metric.h"

#include <algorithm>
#include <cmath>

#include <immintrin.h>

#include <glog/logging.h>

#include "registration/mi/bilinear_avx2.h"

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
  if (lidar_classes < 1 || lidar_classes > kMaxLidarClasses) {
    *error = "lidar_classes " + std::to_string(lidar_classes) + " must be in 1.." +
             std::to_string(kMaxLidarClasses);
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
      bins_(options.bins),
      classes_(std::clamp(options.lidar_classes, 1, kMaxLidarClasses)),
      counts_(static_cast<size_t>(classes_) * (options.bins + 3) * (options.bins + 3), 0.0),
      empty_counts_(options.bins + 3, 0.0),
      background_(options.bins + 3, 0.0),
      photo_scale_(static_cast<float>((options.bins - 1) / 255.0)) {}

void JointHistogram::Clear() {
  std::fill(counts_.begin(), counts_.end(), 0.0);
  std::fill(empty_counts_.begin(), empty_counts_.end(), 0.0);
  std::fill(background_.begin(), background_.end(), 0.0);
  total_ = 0;
  lidar_total_ = 0;
  background_pixels_ = 0;
}

void JointHistogram::AddBackgroundComplement(const double* padded, double pixels) {
  CHECK(options_.region == Region::kWholeImage)
      << "a background complement belongs to the whole-image histogram";
  for (size_t q = 0; q < background_.size(); ++q) background_[q] += padded[q];
  background_pixels_ += pixels;
}

std::vector<double> JointHistogram::PaddedCoveredPhoto() const {
  const size_t stride = static_cast<size_t>(bins_) + 3;
  std::vector<double> columns(stride, 0.0);
  for (size_t row = 0; row < counts_.size() / stride; ++row) {
    const double* line = &counts_[row * stride];
    for (size_t q = 0; q < stride; ++q) columns[q] += line[q];
  }
  return columns;
}

// One sample's bins; the caller counts it (total_, lidar_total_): counts are integers, so
// adding them once per call instead of once per sample gives the same sums without a
// dependency through memory per sample.
[[gnu::always_inline]] inline void JointHistogram::AddSample(int lidar_row, float lidar_pos,
                                                             float photo_pos, bool lidar_empty) {
  const int bins = bins_;
  const int stride = bins + 3;
  if (lidar_empty) {
    if (options_.smoothing != Smoothing::kBSpline) {
      empty_counts_[1 + std::clamp(static_cast<int>(photo_pos + 0.5f), 0, bins - 1)] += 1;
      return;
    }
    float wy[4];
    const int by = std::clamp(static_cast<int>(photo_pos), 0, bins - 1);
    JointHistogram::CubicBSplineWeights(photo_pos - by, wy);
    for (int j = 0; j < 4; ++j) empty_counts_[by + j] += wy[j];
    return;
  }
  if (options_.smoothing != Smoothing::kBSpline) {
    const int py = std::clamp(static_cast<int>(photo_pos + 0.5f), 0, bins - 1);
    const int lx = std::clamp(static_cast<int>(lidar_pos + 0.5f), 0, bins - 1);
    counts_[static_cast<size_t>(lidar_row + lx + 1) * stride + py + 1] += 1;
    return;
  }
  float wx[4], wy[4];
  // Positions are within [0, bins − 1]; the clamp only guards rounding.
  const int bx = std::clamp(static_cast<int>(lidar_pos), 0, bins - 1);
  const int by = std::clamp(static_cast<int>(photo_pos), 0, bins - 1);
  JointHistogram::CubicBSplineWeights(lidar_pos - bx, wx);
  JointHistogram::CubicBSplineWeights(photo_pos - by, wy);
  // Padded index of bin (bx − 1 + i, by − 1 + j) is (bx + i) · stride + by + j.
  double* base = &counts_[static_cast<size_t>(lidar_row + bx) * stride + by];
  for (int i = 0; i < 4; ++i) {
    double* row = base + static_cast<size_t>(i) * stride;
    row[0] += wx[i] * wy[0];
    row[1] += wx[i] * wy[1];
    row[2] += wx[i] * wy[2];
    row[3] += wx[i] * wy[3];
  }
}

namespace {

// The covered pixels of a LiDAR image for the chunked B-spline histogram, read either from
// a rendered image (RenderLidarImage's per-pixel arrays) or straight from its z-buffer
// (RenderLidarZBuffer), with the same arithmetic: the same values bit for bit.
struct RenderedPixels {
  const LidarImage& lidar;
  [[gnu::always_inline]] int GetBatch(const int*, int, int, const GrayImage&, float, float,
                                      float*, float*) const {
    return 0;
  }
  [[gnu::always_inline]] bool Covered(size_t k) const { return lidar.point_index[k] >= 0; }
  /// Pixel k at (c, r): its LiDAR value and where its point falls in the photo.
  [[gnu::always_inline]] void Get(size_t k, int c, int r, float* value, float* x,
                                  float* y) const {
    *value = lidar.value[k];
    *x = c + 0.5f + lidar.offset_x[k];
    *y = r + 0.5f + lidar.offset_y[k];
  }
};

// AVX2: Get() and the photo sample of the covered pixels cols[0 .. m) of row r, 8 at a time
// with gathers, for the intensity and points representations: the same float operations in
// the same order as the scalar code (no FMA), so the same values bit for bit. Returns how
// many it did (a multiple of 8); the caller does the rest.
__attribute__((target("avx2"))) int ZBufferSamplesAvx2(const LidarImage& lidar,
                                                       const LidarPoints& points,
                                                       bool intensity, const int* cols, int m,
                                                       int r, const GrayImage& photo,
                                                       float lidar_scale, float photo_scale,
                                                       float* lidar_pos, float* photo_pos) {
  const uint64_t* zrow = lidar.zbuffer.data() + static_cast<size_t>(r) * lidar.width;
  const float* projected = lidar.projected.data()->data();
  const bool ranked = !points.tie_rank.empty();
  const int* index_of_rank = reinterpret_cast<const int*>(points.index_of_rank.data());
  const float* intensity01 = points.intensity01.data();
  const internal::BilinearAvx2 bilinear(photo);
  const __m256 half = bilinear.half, one = bilinear.one;
  const __m256 row_centre = _mm256_set1_ps(r + 0.5f);
  const __m256i low_dwords = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
  const __m256 lscale = _mm256_set1_ps(lidar_scale), pscale = _mm256_set1_ps(photo_scale);
  int j = 0;
  for (; j + 8 <= m; j += 8) {
    const __m256i col = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cols + j));
    // The keys' low 32 bits (the tie ranks) of the 8 pixels.
    const __m256i k0 = _mm256_i32gather_epi64(reinterpret_cast<const long long*>(zrow),
                                              _mm256_castsi256_si128(col), 8);
    const __m256i k1 = _mm256_i32gather_epi64(reinterpret_cast<const long long*>(zrow),
                                              _mm256_extracti128_si256(col, 1), 8);
    const __m256i l0 = _mm256_permutevar8x32_epi32(k0, low_dwords);
    const __m256i l1 = _mm256_permutevar8x32_epi32(k1, low_dwords);
    __m256i index = _mm256_permute2x128_si256(l0, l1, 0x20);
    if (ranked) index = _mm256_i32gather_epi32(index_of_rank, index, 4);
    const __m256 value = intensity ? _mm256_i32gather_ps(intensity01, index, 4) : one;
    // projected[i] = (x, y): 8 bytes apart.
    const __m256 px = _mm256_i32gather_ps(projected, index, 8);
    const __m256 py = _mm256_i32gather_ps(projected + 1, index, 8);
    const __m256 offset_x = _mm256_sub_ps(px, _mm256_add_ps(_mm256_floor_ps(px), half));
    const __m256 offset_y = _mm256_sub_ps(py, _mm256_add_ps(_mm256_floor_ps(py), half));
    const __m256 x = _mm256_add_ps(_mm256_add_ps(_mm256_cvtepi32_ps(col), half), offset_x);
    const __m256 y = _mm256_add_ps(row_centre, offset_y);
    const __m256 sample = bilinear.Sample(x, y);
    _mm256_storeu_ps(lidar_pos + j, _mm256_mul_ps(value, lscale));
    _mm256_storeu_ps(photo_pos + j, _mm256_mul_ps(sample, pscale));
  }
  return j;
}

struct ZBufferPixels {
  const LidarImage& lidar;
  const LidarPoints& points;
  const LidarValueMap& value_of;
  /// The first covered pixels of a chunk at once (AVX2); how many were done.
  [[gnu::always_inline]] int GetBatch(const int* cols, int m, int r, const GrayImage& photo,
                                      float lidar_scale, float photo_scale, float* lidar_pos,
                                      float* photo_pos) const {
    const Representation representation = value_of.representation();
    // (The gathers take signed 32-bit indices: points and photo pixels below 2^31.)
    constexpr size_t kIndexLimit = size_t{1} << 31;
    if (representation == Representation::kDepth || !internal::CpuHasAvx2() ||
        points.size() >= kIndexLimit || photo.pixels.size() >= kIndexLimit) {
      return 0;
    }
    return ZBufferSamplesAvx2(lidar, points, representation == Representation::kIntensity, cols,
                              m, r, photo, lidar_scale, photo_scale, lidar_pos, photo_pos);
  }
  [[gnu::always_inline]] bool Covered(size_t k) const {
    return lidar.zbuffer[k] != kEmptyZBufferKey;
  }
  [[gnu::always_inline]] void Get(size_t k, int c, int r, float* value, float* x,
                                  float* y) const {
    const uint64_t key = lidar.zbuffer[k];
    const uint32_t i = ZBufferPointIndex(points, key);
    *value = value_of(points, i, ZBufferRange(key));
    // Offset of the point from the centre of ITS pixel (as RenderLidarImage's pass 2).
    const Eigen::Vector2f& xy = lidar.projected[i];
    const float offset_x = xy.x() - (std::floor(xy.x()) + 0.5f);
    const float offset_y = xy.y() - (std::floor(xy.y()) + 0.5f);
    *x = c + 0.5f + offset_x;
    *y = r + 0.5f + offset_y;
  }
};

}  // namespace

// The B-spline histogram of one view, in chunks of a row: the covered pixels' bin positions
// first (a loop the compiler vectorises), then their weights, then the 4×4 adds — the same
// operations on the same values in the same order as AddSample, so the same sums, bit for bit.
template <typename Pixels>
[[gnu::always_inline]] inline void JointHistogram::AddBSplineChunks(const Pixels& pixels,
                                                                     int width, int height,
                                                                     const GrayImage& photo) {
  constexpr int kChunk = 256;
  const bool whole = options_.region == Region::kWholeImage;
  const int bins = bins_;
  const int stride = bins + 3;
  const float lidar_scale = static_cast<float>(bins - 1);
  const float photo_scale = static_cast<float>((bins - 1) / 255.0);
  size_t samples = 0, lidar_samples = 0;
  int cols[kChunk];
  float lidar_pos[kChunk], photo_pos[kChunk];
  int bx[kChunk], by[kChunk], class_row[kChunk];
  float wx[4][kChunk], wy[4][kChunk];
  for (int r = 0; r < height; ++r) {
    const size_t row = static_cast<size_t>(r) * width;
    for (int c0 = 0; c0 < width; c0 += kChunk) {
      const int c1 = std::min(width, c0 + kChunk);
      int m = 0;
      for (int c = c0; c < c1; ++c) {
        cols[m] = c;
        m += pixels.Covered(row + c);
      }
      // (Several classes: one value at a time, for each value's class row.)
      const int batched = classes_ == 1 ? pixels.GetBatch(cols, m, r, photo, lidar_scale,
                                                          photo_scale, lidar_pos, photo_pos)
                                        : 0;
      for (int j = batched; j < m; ++j) {
        float value, x, y;
        pixels.Get(row + cols[j], cols[j], r, &value, &x, &y);
        // Sample the photo where the point really falls: smooth in the pose.
        const float photo_value = SampleClamped(photo, x, y);
        lidar_pos[j] = classes_ == 1 ? value * lidar_scale : LidarPosition(value, &class_row[j]);
        photo_pos[j] = photo_value * photo_scale;
      }
      for (int j = 0; j < m; ++j) {
        // Positions are within [0, bins − 1]; the clamp only guards rounding.
        bx[j] = std::clamp(static_cast<int>(lidar_pos[j]), 0, bins - 1);
        by[j] = std::clamp(static_cast<int>(photo_pos[j]), 0, bins - 1);
      }
      for (int j = 0; j < m; ++j) {
        float w[4];
        CubicBSplineWeights(lidar_pos[j] - bx[j], w);
        for (int i = 0; i < 4; ++i) wx[i][j] = w[i];
        CubicBSplineWeights(photo_pos[j] - by[j], w);
        for (int i = 0; i < 4; ++i) wy[i][j] = w[i];
      }
      for (int j = 0; j < m; ++j) {
        // Padded index of bin (bx − 1 + i, by − 1 + q) is (bx + i) · stride + by + q (in the
        // block of the sample's class).
        const int first_row = classes_ == 1 ? 0 : class_row[j];
        double* base = &counts_[static_cast<size_t>(first_row + bx[j]) * stride + by[j]];
        for (int i = 0; i < 4; ++i) {
          double* line = base + static_cast<size_t>(i) * stride;
          line[0] += wx[i][j] * wy[0][j];
          line[1] += wx[i][j] * wy[1][j];
          line[2] += wx[i][j] * wy[2][j];
          line[3] += wx[i][j] * wy[3][j];
        }
      }
      samples += static_cast<size_t>(m);
      lidar_samples += static_cast<size_t>(m);
      if (!whole) continue;
      // Whole image: the pixels without LiDAR, in their own row of the histogram (their own
      // array: the order of the adds within each array is that of AddSample's pixel loop).
      const float* photo_row = &photo.pixels[static_cast<size_t>(r) * photo.width];
      int e = 0;
      for (int c = c0; c < c1; ++c) {
        cols[e] = c;
        e += !pixels.Covered(row + c);
      }
      for (int j = 0; j < e; ++j) {
        const float photo_value = photo_row[cols[j]] * photo_scale;
        const int b = std::clamp(static_cast<int>(photo_value), 0, bins - 1);
        float w[4];
        CubicBSplineWeights(photo_value - b, w);
        for (int q = 0; q < 4; ++q) empty_counts_[b + q] += w[q];
      }
      samples += static_cast<size_t>(e);
    }
  }
  total_ += static_cast<double>(samples);
  lidar_total_ += static_cast<double>(lidar_samples);
}

// One function per instruction set (AVX2 where the CPU has it: wider vectors for the bin
// positions and weights; no FMA, so the same arithmetic and the same sums).
__attribute__((target_clones("avx2", "default"))) void JointHistogram::AddBSpline(
    const LidarImage& lidar, const GrayImage& photo) {
  AddBSplineChunks(RenderedPixels{lidar}, lidar.width, lidar.height, photo);
}

__attribute__((target_clones("avx2", "default"))) void JointHistogram::AddBSplineZBuffer(
    const LidarImage& lidar, const LidarPoints& points, const LidarValueMap& value_of,
    const GrayImage& photo) {
  AddBSplineChunks(ZBufferPixels{lidar, points, value_of}, lidar.width, lidar.height, photo);
}

void JointHistogram::AddZBuffer(const LidarImage& lidar, const LidarPoints& points,
                                const RenderOptions& render, const GrayImage& photo) {
  CHECK(options_.smoothing == Smoothing::kBSpline)
      << "AddZBuffer is the B-spline histogram's (use RenderLidarImage and Add otherwise)";
  CHECK_GE(lidar.zbuffer.size(), static_cast<size_t>(lidar.width) * lidar.height);
  AddBSplineZBuffer(lidar, points, LidarValueMap(render), photo);
}

void JointHistogram::Add(const LidarImage& lidar, const GrayImage& photo) {
  const int bins = bins_;
  const bool whole = options_.region == Region::kWholeImage;
  const bool spline = options_.smoothing == Smoothing::kBSpline;
  if (spline) {
    AddBSpline(lidar, photo);
    return;
  }
  // Continuous bin coordinates: LiDAR value (LidarPosition) and 0..255 (photo) onto 0..bins−1.
  const float photo_scale = static_cast<float>((bins - 1) / 255.0);
  size_t samples = 0, lidar_samples = 0;
  for (int r = 0; r < lidar.height; ++r) {
    const size_t row = static_cast<size_t>(r) * lidar.width;
    const float* photo_row = &photo.pixels[static_cast<size_t>(r) * photo.width];
    for (int c = 0; c < lidar.width; ++c) {
      const size_t k = row + c;
      const bool empty = lidar.point_index[k] < 0;
      if (empty && !whole) continue;
      float photo_value = photo_row[c];
      if (spline && !empty) {
        // Sample the photo where the point really falls: smooth in the pose.
        photo_value = SampleClamped(photo, c + 0.5f + lidar.offset_x[k], r + 0.5f + lidar.offset_y[k]);
      }
      int lidar_row = 0;
      const float lidar_pos = empty ? 0.f : LidarPosition(lidar.value[k], &lidar_row);
      AddSample(lidar_row, lidar_pos, photo_value * photo_scale, empty);
      ++samples;
      if (!empty) ++lidar_samples;
    }
  }
  total_ += static_cast<double>(samples);
  lidar_total_ += static_cast<double>(lidar_samples);
}

namespace {

// AVX2: the 4×4 adds of AddCoveredBatch, one bin row of a sample as four doubles: the same
// float products (wx·wy) converted to double and added to the same bins in the same order as
// the scalar loop (no FMA), so the same sums bit for bit.
__attribute__((target("avx2"))) void AddBatchRowsAvx2(double* counts, int stride, int count,
                                                      const int* bx, const int* by,
                                                      const float (*wx)[JointHistogram::kBatch],
                                                      const float (*wy)[4]) {
  for (int k = 0; k < count; ++k) {
    double* base = counts + static_cast<size_t>(bx[k]) * stride + by[k];
    const __m128 w = _mm_loadu_ps(wy[k]);
    for (int i = 0; i < 4; ++i) {
      double* row = base + static_cast<size_t>(i) * stride;
      const __m256d add = _mm256_cvtps_pd(_mm_mul_ps(_mm_set1_ps(wx[i][k]), w));
      _mm256_storeu_pd(row, _mm256_add_pd(_mm256_loadu_pd(row), add));
    }
  }
}

// AddCoveredBatch's body, one function per instruction set (AVX2 where the CPU has it: the
// photo bins and weights as wider vectors, the adds four doubles at a time; no FMA). The
// photo bin clamped as min/max, the same bin as AddCoveredBins' comparisons for every
// position that is not NaN, so that the loop has no branch.
__attribute__((target_clones("avx2", "default"))) void AddCoveredBatchTo(
    double* counts, int bins, float photo_scale, int count, const int* bx,
    const float (*wx)[JointHistogram::kBatch], const float* photo255, const float* weight) {
  constexpr int kBatch = JointHistogram::kBatch;
  const int stride = bins + 3;
  const float last = static_cast<float>(bins - 1);
  int by[kBatch];
  float pos[kBatch];
  for (int k = 0; k < count; ++k) {
    pos[k] = photo255[k] * photo_scale;
    by[k] = static_cast<int>(std::min(std::max(pos[k], 0.f), last));
  }
  float wy[kBatch][4];  // per sample, its four photo weights times its weight
  for (int k = 0; k < count; ++k) {
    float w[4];
    JointHistogram::CubicBSplineWeights(pos[k] - by[k], w);
    for (int q = 0; q < 4; ++q) wy[k][q] = w[q] * weight[k];
  }
  if (internal::CpuHasAvx2()) {
    AddBatchRowsAvx2(counts, stride, count, bx, by, wx, wy);
    return;
  }
  for (int k = 0; k < count; ++k) {
    double* base = counts + static_cast<size_t>(bx[k]) * stride + by[k];
    for (int i = 0; i < 4; ++i) {
      double* row = base + static_cast<size_t>(i) * stride;
      row[0] += wx[i][k] * wy[k][0];
      row[1] += wx[i][k] * wy[k][1];
      row[2] += wx[i][k] * wy[k][2];
      row[3] += wx[i][k] * wy[k][3];
    }
  }
}

}  // namespace

void JointHistogram::AddCoveredBatch(int count, const int* bx, const float (*wx)[kBatch],
                                     const float* photo255, const float* weight) {
  CHECK_LE(count, kBatch);
  AddCoveredBatchTo(counts_.data(), bins_, photo_scale_, count, bx, wx, photo255, weight);
}

void JointHistogram::AddPairs(const std::vector<float>& lidar01,
                              const std::vector<float>& photo255) {
  AddPairs(lidar01.data(), photo255.data(), std::min(lidar01.size(), photo255.size()));
}

void JointHistogram::AddPairs(const float* lidar01, const float* photo255, size_t count) {
  const bool whole = options_.region == Region::kWholeImage;
  const float lidar_scale = static_cast<float>(bins_ - 1);
  const float photo_scale = static_cast<float>((bins_ - 1) / 255.0);
  size_t samples = 0, lidar_samples = 0;
  for (size_t k = 0; k < count; ++k) {
    const bool empty = lidar01[k] < 0;
    if (empty && !whole) continue;
    int lidar_row = 0;
    const float lidar_pos = empty ? 0.f
                            : classes_ == 1 ? std::min(lidar01[k], 1.f) * lidar_scale
                                            : LidarPosition(lidar01[k], &lidar_row);
    AddSample(lidar_row, lidar_pos, std::clamp(photo255[k], 0.f, 255.f) * photo_scale, empty);
    ++samples;
    if (!empty) ++lidar_samples;
  }
  total_ += static_cast<double>(samples);
  lidar_total_ += static_cast<double>(lidar_samples);
}

void JointHistogram::Merge(const JointHistogram& other) {
  CHECK_EQ(counts_.size(), other.counts_.size()) << "histograms of different bins";
  for (size_t k = 0; k < counts_.size(); ++k) counts_[k] += other.counts_[k];
  for (size_t k = 0; k < empty_counts_.size(); ++k) empty_counts_[k] += other.empty_counts_[k];
  for (size_t k = 0; k < background_.size(); ++k) background_[k] += other.background_[k];
  total_ += other.total_;
  lidar_total_ += other.lidar_total_;
  background_pixels_ += other.background_pixels_;
}

}  // namespace mmba::registration::mi
