// The intensity test of the cloud registration (src/registration/cloud/intensity_test.h).
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "registration/cloud/intensity_test.h"

namespace mmba::registration {
namespace {

TEST(BrightnessRanks, MidRanksTiesAndFallbacks) {
  io::PointCloud c;
  c.points.assign(5, Eigen::Vector3d::Zero());
  c.intensity = {3.0f, 1.0f, 3.0f, 7.0f, 1.0f};
  // Sorted: 1 1 3 3 7 → ranks (k + ½)/5, ties sharing their mean: 0.2 0.2 0.6 0.6 0.9.
  const std::vector<float> r = internal::BrightnessRanks(c);
  ASSERT_EQ(r.size(), 5u);
  EXPECT_FLOAT_EQ(r[0], 0.6f);
  EXPECT_FLOAT_EQ(r[1], 0.2f);
  EXPECT_FLOAT_EQ(r[2], 0.6f);
  EXPECT_FLOAT_EQ(r[3], 0.9f);
  EXPECT_FLOAT_EQ(r[4], 0.2f);

  c.intensity.assign(5, 0.4f);  // constant: no information
  EXPECT_TRUE(internal::BrightnessRanks(c).empty());
  c.intensity = {0.1f, NAN, 0.3f, 0.2f, 0.5f};
  EXPECT_TRUE(internal::BrightnessRanks(c).empty());

  // Without intensity the colours' luma is used: green is brighter than red than blue.
  c.intensity.clear();
  c.colors = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {0, 0, 0}, {255, 255, 255}};
  const std::vector<float> g = internal::BrightnessRanks(c);
  ASSERT_EQ(g.size(), 5u);
  EXPECT_LT(g[3], g[2]);
  EXPECT_LT(g[2], g[0]);
  EXPECT_LT(g[0], g[1]);
  EXPECT_LT(g[1], g[4]);
  c.colors.clear();
  EXPECT_TRUE(internal::BrightnessRanks(c).empty());
}

// The ranks at chosen points are those of the whole cloud there (the registration ranks
// millions of intensities but only needs them at its samples): quantised values with many
// ties, indices out of order and repeated.
TEST(BrightnessRanks, AtChosenPointsEqualTheWholeCloudsRanks) {
  io::PointCloud c;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(0, 40);
  for (int i = 0; i < 5000; ++i) {
    c.points.emplace_back(i, 0, 0);
    c.intensity.push_back(static_cast<float>(level(rng)) * 0.25f);
  }
  const std::vector<float> all = internal::BrightnessRanks(c);
  ASSERT_EQ(all.size(), c.size());
  const std::vector<size_t> at = {4999, 0, 17, 17, 2500, 1, 3333};
  const std::vector<float> some = internal::BrightnessRanks(c, at);
  ASSERT_EQ(some.size(), at.size());
  for (size_t k = 0; k < at.size(); ++k) EXPECT_EQ(some[k], all[at[k]]) << "point " << at[k];
  // A point's rank: its mid-rank among all 5000 values.
  size_t below = 0, equal = 0;
  for (float v : c.intensity) {
    below += v < c.intensity[17] ? 1 : 0;
    equal += v == c.intensity[17] ? 1 : 0;
  }
  EXPECT_FLOAT_EQ(some[2], static_cast<float>((below + 0.5 * equal) / 5000.0));
  c.intensity.assign(c.size(), 1.0f);
  EXPECT_TRUE(internal::BrightnessRanks(c, at).empty());
}

// A textured wall sampled twice (source and target, independent samples of one texture):
// the right pose correlates the two brightnesses, the wall shifted by 1.5 m does not, and the
// jackknifed t says so; the pose against itself gives no evidence either way.
TEST(IntensityAgreement, RightPoseAgreesShiftedPoseDoesNot) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<Eigen::Vector2d> bumps;
  for (int k = 0; k < 40; ++k) bumps.emplace_back(8.0 * u(rng), 4.0 * u(rng));
  auto texture = [&](double x, double z) {
    double v = 0.0;
    for (const Eigen::Vector2d& b : bumps) {
      v += std::exp(-((x - b.x()) * (x - b.x()) + (z - b.y()) * (z - b.y())) / (2 * 0.3 * 0.3));
    }
    return v;
  };
  auto wall = [&](int n) {
    io::PointCloud c;
    for (int i = 0; i < n; ++i) {
      const double x = 8.0 * u(rng), z = 4.0 * u(rng);
      c.points.emplace_back(x, 0.0, z);
      c.intensity.push_back(static_cast<float>(texture(x, z) + noise(rng)));
    }
    return c;
  };
  const io::PointCloud source = wall(20000), target = wall(40000);
  std::vector<Eigen::Vector3d> fine;
  for (size_t i = 0; i < source.size(); i += 4) fine.push_back(source.points[i]);
  const internal::IntensityAgreement agreement(source, target, fine, 1.0);
  ASSERT_TRUE(agreement.available());
  Eigen::Matrix4d shifted = Eigen::Matrix4d::Identity();
  shifted(0, 3) = 1.5;
  std::vector<bool> all(fine.size(), true), on_target(fine.size(), false);
  for (size_t i = 0; i < fine.size(); ++i) on_target[i] = fine[i].x() + 1.5 <= 8.0;
  const internal::IntensityBlocks right = agreement.Measure(Eigen::Matrix4d::Identity(), all);
  const internal::IntensityBlocks wrong = agreement.Measure(shifted, on_target);
  EXPECT_GT(right.AbsCorrelation(), 0.8);
  EXPECT_LT(wrong.AbsCorrelation(), 0.3);
  EXPECT_GT(internal::IntensityAgreement::Significance(right, wrong), 5.0);
  EXPECT_LT(internal::IntensityAgreement::Significance(wrong, right), -5.0);
  EXPECT_EQ(internal::IntensityAgreement::Significance(right, right), 0.0);

  // A cloud without brightness: the test is not available.
  io::PointCloud plain = target;
  plain.intensity.clear();
  EXPECT_FALSE(internal::IntensityAgreement(source, plain, fine, 1.0).available());
}

// Blocks of a pose whose brightness ranks follow y = slope·x + noise over `blocks` blocks.
internal::IntensityBlocks Blocks(double slope, double noise, int blocks, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, noise);
  internal::IntensityBlocks out;
  for (int b = 0; b < blocks; ++b) {
    out.keys.push_back(b);
    internal::IntensityBlocks::Moments m;
    for (int i = 0; i < 40; ++i) {
      const double x = u(rng), y = slope * x + n(rng);
      m.n += 1;
      m.sx += x;
      m.sy += y;
      m.sxx += x * x;
      m.syy += y * y;
      m.sxy += x * y;
    }
    out.moments.push_back(m);
  }
  return out;
}

TEST(IntensityAgreement, BrightnessSettlesATieOnlyForTheBetterPose) {
  // Two poses the geometry cannot tell apart (t 0.4); the brightness agrees on the first only.
  const internal::IntensityBlocks textured = Blocks(1.0, 0.1, 30, 1);
  const internal::IntensityBlocks unrelated = Blocks(0.0, 0.3, 30, 2);
  const double ti = internal::IntensityAgreement::Significance(textured, unrelated);
  EXPECT_GT(ti, 5.0);
  EXPECT_GE(internal::CombinedSignificance(0.4, ti), 3.0);  // settled
  // The reverse comparison gives no support; the geometric t stands.
  EXPECT_DOUBLE_EQ(internal::CombinedSignificance(0.4, -ti), 0.4);
  // Both textured alike: the tie stays.
  const double alike = internal::IntensityAgreement::Significance(textured, Blocks(1.0, 0.1, 30, 3));
  EXPECT_LT(internal::CombinedSignificance(0.4, alike), 2.0);
  // A pose the geometry resolved (t 6) is not unsettled by a brightness against it.
  EXPECT_DOUBLE_EQ(internal::CombinedSignificance(6.0, -20.0), 6.0);
  EXPECT_DOUBLE_EQ(internal::CombinedSignificance(1.0, 3.0), 4.0 / std::sqrt(2.0));
}

}  // namespace
}  // namespace mmba::registration
