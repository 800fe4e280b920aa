// The cloud registration's paired block statistic (src/registration/cloud/score_significance.h).
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "registration/cloud/score_significance.h"

namespace mmba::registration::internal {
namespace {

// Points of block k (blocks of 1 m along x) and the residual giving a score term of 1 − d
// (term = 1 − r²/τ² with τ = 1).
struct Pair {
  std::vector<Eigen::Vector3d> src;
  std::vector<double> ra, rb;
  std::vector<bool> aa, ab;
  void Add(int block, double term_a, double term_b) {
    src.emplace_back(block + 0.5, 0.5, 0.5);
    ra.push_back(std::sqrt(1.0 - term_a));
    rb.push_back(std::sqrt(1.0 - term_b));
    aa.push_back(true);
    ab.push_back(true);
  }
  double T() const { return ScoreSignificance(src, ra, aa, rb, ab, 1.0, 1.0); }
};

TEST(ScoreSignificance, PointsNotRaggedEdgeBlocksCarryTheEvidence) {
  // 40 blocks of 200 points where A is better by 0.02 per point (noise 0.1), and 10 blocks of
  // 2 points at the edge where either may be far better. The mean of the 50 block means is
  // dominated by the 10 edge blocks (t about 0.5); per point the advantage is plain.
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Pair p;
  for (int b = 0; b < 40; ++b) {
    for (int i = 0; i < 200; ++i) {
      const double d = 0.02 + noise(rng);
      p.Add(b, 0.5 + d / 2, 0.5 - d / 2);
    }
  }
  for (int b = 40; b < 50; ++b) {
    const double d = b % 2 == 0 ? 0.9 : -0.9;
    for (int i = 0; i < 2; ++i) p.Add(b, 0.5 + d / 2 * u(rng), 0.5 - d / 2 * u(rng));
  }
  EXPECT_GT(p.T(), 5.0);
  // The plain block-mean t, for the record of why the statistic changed.
  std::vector<double> means(50, 0.0);
  for (size_t i = 0; i < p.src.size(); ++i) {
    const int b = static_cast<int>(p.src[i].x());
    means[b] += ((1 - p.ra[i] * p.ra[i]) - (1 - p.rb[i] * p.rb[i])) / (b < 40 ? 200.0 : 2.0);
  }
  double mean = 0, var = 0;
  for (double m : means) mean += m / 50;
  for (double m : means) var += (m - mean) * (m - mean) / 49;
  EXPECT_LT(mean / std::sqrt(var / 50), 3.0);
}

TEST(ScoreSignificance, AntisymmetricAndCalibratedUnderNoDifference) {
  // Two equally good poses: per-point terms drawn alike for A and B, with a block effect shared
  // by the points of a block (correlated errors) and blocks of 1–300 points. t > 3 must be
  // rare (normal tail 0.13 %; allowed 2 % of 400 draws), and swapping A and B negates t.
  std::mt19937 rng(11);
  std::normal_distribution<double> z(0.0, 1.0);
  std::uniform_int_distribution<int> size(1, 300);
  int above = 0;
  for (int draw = 0; draw < 400; ++draw) {
    Pair p;
    for (int b = 0; b < 60; ++b) {
      const double effect = 0.05 * z(rng);
      const int n = size(rng);
      for (int i = 0; i < n; ++i) {
        const double ta = std::clamp(0.5 + effect + 0.1 * z(rng), 0.0, 0.99);
        const double tb = std::clamp(0.5 - effect + 0.1 * z(rng), 0.0, 0.99);
        p.Add(b, ta, tb);
      }
    }
    const double t = p.T();
    above += t > 3.0 ? 1 : 0;
    if (draw < 5) {
      Pair swapped = p;
      std::swap(swapped.ra, swapped.rb);
      EXPECT_NEAR(swapped.T(), -t, 1e-9);
    }
  }
  EXPECT_LE(above, 8);
}

TEST(ScoreSignificance, FewBlocksAndNoSpread) {
  Pair two;
  two.Add(0, 0.9, 0.1);
  two.Add(1, 0.9, 0.1);
  EXPECT_EQ(two.T(), 0.0);  // fewer than 3 blocks
  Pair same;
  for (int b = 0; b < 5; ++b) same.Add(b, 0.9, 0.1);
  EXPECT_TRUE(std::isinf(same.T()));  // the same advantage everywhere
  Pair none;
  for (int b = 0; b < 5; ++b) none.Add(b, 0.5, 0.5);
  EXPECT_EQ(none.T(), 0.0);
}

}  // namespace
}  // namespace mmba::registration::internal
