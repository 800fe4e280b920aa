// The exact nearest-neighbour indices of the cloud registration (nanoflann kd-tree for 3-D
// points, brute force for descriptors) against a plain scan.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {
namespace {

std::vector<Eigen::Vector3d> RandomPoints(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> p(n);
  for (auto& x : p) x = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

// Squared distances as the index computes them (float coordinates).
std::vector<float> ScanSquared(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& q) {
  std::vector<float> d;
  for (const auto& p : points) {
    const Eigen::Vector3f a = p.cast<float>(), b = q.cast<float>();
    d.push_back((a - b).squaredNorm());
  }
  return d;
}

TEST(NearestNeighbour, PointIndexIsExact) {
  const std::vector<Eigen::Vector3d> points = RandomPoints(3000, 1);
  const std::vector<Eigen::Vector3d> queries = RandomPoints(300, 2);
  const PointIndex index(points);
  std::vector<int> idx;
  std::vector<float> sq;
  for (const auto& q : queries) {
    std::vector<float> d = ScanSquared(points, q);
    std::vector<float> sorted = d;
    std::sort(sorted.begin(), sorted.end());
    int nearest = -1;
    double nearest_sq = 0.0;
    ASSERT_TRUE(index.Nearest(q, &nearest, &nearest_sq));
    EXPECT_NEAR(nearest_sq, sorted[0], 1e-6);
    EXPECT_FLOAT_EQ(d[nearest], sorted[0]);
    index.KNearest(q, 5, &idx, &sq);
    ASSERT_EQ(idx.size(), 5u);
    for (int k = 0; k < 5; ++k) EXPECT_NEAR(sq[k], sorted[k], 1e-6) << k;
    const double r = 0.2;
    index.Radius(q, r, &idx);
    const long inside = std::count_if(d.begin(), d.end(), [r](float x) { return x <= r * r; });
    EXPECT_NEAR(static_cast<double>(idx.size()), static_cast<double>(inside), 1.0);
    for (int i : idx) EXPECT_LE(d[i], r * r * (1 + 1e-5));
  }
  // An empty index answers nothing.
  const PointIndex empty(std::vector<Eigen::Vector3d>{});
  int i = 0;
  double s = 0.0;
  EXPECT_FALSE(empty.Nearest(Eigen::Vector3d::Zero(), &i, &s));
}

TEST(NearestNeighbour, FeatureIndexIsExactAndBreaksTiesByIndex) {
  constexpr int kDim = 33;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  std::vector<float> data(400 * kDim);
  for (float& x : data) x = u(rng);
  // Rows 10 and 250 are identical: a query equal to them must give 10 first, then 250.
  std::copy(data.begin() + 10 * kDim, data.begin() + 11 * kDim, data.begin() + 250 * kDim);
  const FeatureIndex index(data, kDim);
  ASSERT_EQ(index.rows(), 400u);
  std::vector<int> idx;
  std::vector<float> sq;
  index.KNearest(&data[10 * kDim], 3, &idx, &sq);
  ASSERT_EQ(idx.size(), 3u);
  EXPECT_EQ(idx[0], 10);
  EXPECT_EQ(idx[1], 250);
  EXPECT_NEAR(sq[0], 0.0f, 1e-2);
  // Against a scan, for random queries; two indices over the same data agree exactly.
  const FeatureIndex again(data, kDim);
  std::vector<int> idx2;
  std::vector<float> sq2;
  for (int t = 0; t < 50; ++t) {
    std::vector<float> q(kDim);
    for (float& x : q) x = u(rng);
    index.KNearest(q.data(), 4, &idx, &sq);
    again.KNearest(q.data(), 4, &idx2, &sq2);
    EXPECT_EQ(idx, idx2);
    std::vector<std::pair<double, int>> scan;
    for (int r = 0; r < 400; ++r) {
      double d = 0.0;
      for (int k = 0; k < kDim; ++k) d += std::pow(data[r * kDim + k] - q[k], 2);
      scan.emplace_back(d, r);
    }
    std::sort(scan.begin(), scan.end());
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(idx[k], scan[k].second) << k;
      EXPECT_NEAR(sq[k], scan[k].first, 1e-2 * std::max(1.0, scan[k].first)) << k;
    }
  }
}

}  // namespace
}  // namespace mmba::registration::internal
