#pragma once

// Counter-based random numbers for the simulator: every ray draws from its own stream seeded by
// (seed, stream, index), so with mmba::ParallelChunks the output is the same bytes whatever the
// number of threads.

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace mmba::sim::internal {

inline uint64_t SplitMix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// A small random stream (SplitMix64 sequence).
class Rng {
 public:
  Rng(uint64_t seed, uint64_t stream, uint64_t index = 0)
      : state_(SplitMix(SplitMix(seed ^ 0x5851F42D4C957F2Dull) ^ SplitMix(stream + 1)) ^
               SplitMix(index * 0x632BE59BD9B4E019ull + 7)) {}
  uint64_t Next() {
    state_ += 0x9E3779B97F4A7C15ull;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0); }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  /// Standard normal (Box–Muller).
  double Normal() {
    const double u1 = std::max(Uniform(), 1e-300), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  double Normal(double sigma) { return sigma * Normal(); }

 private:
  uint64_t state_;
};

}  // namespace mmba::sim::internal
