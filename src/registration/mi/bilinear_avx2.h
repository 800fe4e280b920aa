#pragma once

// The photo's bilinear sample at 8 positions at once (AVX2 gathers), shared by the z-buffer
// histogram (metric.cc, ZBufferSamplesAvx2) and the point samples (point_samples.cc,
// SampleClampedAvx2). The same float operations in the same order as the scalar
// SampleClamped (no FMA; std::clamp(v, lo, hi) as min(hi, max(lo, v)) operand for operand),
// so the same values bit for bit (tests Metric.ZBufferHistogramEqualsTheRenderedImages and
// PointSamplesTest.PinholeBlocksAccumulateAsTheGenericModel). Every member is compiled for
// AVX2 and always inlined into its AVX2 caller; call it only where CpuHasAvx2() and the photo
// has fewer than 2^31 pixels (the gathers take signed 32-bit indices).

#include <algorithm>

#include <immintrin.h>

#include "mmba/registration/mi/image.h"

namespace mmba::registration::mi::internal {

/// True when this CPU runs AVX2 (checked once).
inline bool CpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

struct BilinearAvx2 {
  const float* pixels;
  __m256 half, one, zero, u_max, v_max;
  __m256i c_last, r_last, c_max, r_max, width, ones;

  __attribute__((target("avx2"))) [[gnu::always_inline]] inline explicit BilinearAvx2(
      const GrayImage& photo)
      : pixels(photo.pixels.data()),
        half(_mm256_set1_ps(0.5f)),
        one(_mm256_set1_ps(1.f)),
        zero(_mm256_setzero_ps()),
        u_max(_mm256_set1_ps(static_cast<float>(photo.width - 1))),
        v_max(_mm256_set1_ps(static_cast<float>(photo.height - 1))),
        c_last(_mm256_set1_epi32(std::max(0, photo.width - 2))),
        r_last(_mm256_set1_epi32(std::max(0, photo.height - 2))),
        c_max(_mm256_set1_epi32(photo.width - 1)),
        r_max(_mm256_set1_epi32(photo.height - 1)),
        width(_mm256_set1_epi32(photo.width)),
        ones(_mm256_set1_epi32(1)) {}

  /// SampleClamped(photo, x, y) for the 8 lanes (pixel centres at +0.5).
  __attribute__((target("avx2"))) [[gnu::always_inline]] inline __m256 Sample(__m256 x,
                                                                           __m256 y) const {
    const __m256 u = _mm256_min_ps(u_max, _mm256_max_ps(zero, _mm256_sub_ps(x, half)));
    const __m256 v = _mm256_min_ps(v_max, _mm256_max_ps(zero, _mm256_sub_ps(y, half)));
    const __m256i c0 = _mm256_min_epi32(_mm256_cvttps_epi32(u), c_last);
    const __m256i r0 = _mm256_min_epi32(_mm256_cvttps_epi32(v), r_last);
    const __m256i c1 = _mm256_min_epi32(_mm256_add_epi32(c0, ones), c_max);
    const __m256i r1 = _mm256_min_epi32(_mm256_add_epi32(r0, ones), r_max);
    const __m256 a = _mm256_sub_ps(u, _mm256_cvtepi32_ps(c0));
    const __m256 b = _mm256_sub_ps(v, _mm256_cvtepi32_ps(r0));
    const __m256i row0 = _mm256_mullo_epi32(r0, width);
    const __m256i row1 = _mm256_mullo_epi32(r1, width);
    const __m256 p00 = _mm256_i32gather_ps(pixels, _mm256_add_epi32(row0, c0), 4);
    const __m256 p01 = _mm256_i32gather_ps(pixels, _mm256_add_epi32(row0, c1), 4);
    const __m256 p10 = _mm256_i32gather_ps(pixels, _mm256_add_epi32(row1, c0), 4);
    const __m256 p11 = _mm256_i32gather_ps(pixels, _mm256_add_epi32(row1, c1), 4);
    const __m256 one_a = _mm256_sub_ps(one, a), one_b = _mm256_sub_ps(one, b);
    const __m256 top = _mm256_add_ps(_mm256_mul_ps(one_a, p00), _mm256_mul_ps(a, p01));
    const __m256 bottom = _mm256_add_ps(_mm256_mul_ps(one_a, p10), _mm256_mul_ps(a, p11));
    return _mm256_add_ps(_mm256_mul_ps(one_b, top), _mm256_mul_ps(b, bottom));
  }
};

}  // namespace mmba::registration::mi::internal
