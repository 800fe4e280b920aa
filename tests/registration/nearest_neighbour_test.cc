// The exact nearest-neighbour indices of the cloud registration (nanoflann kd-tree for 3-D
// points, brute force for descriptors) against a plain scan.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/geometry/point_index.h"
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

TEST(AreaSpacing, EvenGridGivesItsSpacing) {
  std::vector<Eigen::Vector3d> p;  // a gently curved sheet, 2 cm grid: ‖n‖₁ ≈ 1, 0.82 × 2 cm
  for (int i = 0; i < 400; ++i) {
    for (int j = 0; j < 400; ++j) p.emplace_back(0.02 * i, 0.02 * j, 0.3 * std::sin(0.01 * i));
  }
  EXPECT_NEAR(AreaSpacing(p, 0.4), 0.02, 0.004);
  EXPECT_EQ(AreaSpacing({}, 0.5), 0.0);
}

TEST(AreaSpacing, ScanLinesGiveTheGeometricMeanNotTheAlongLineSpacing) {
  // Lines 0.1 m apart sampled every 5 mm, on a tilted plane: 1/√ρ = √(0.005 × 0.1) = 2.24 cm.
  std::vector<Eigen::Vector3d> p;
  for (int line = 0; line < 100; ++line) {
    for (int k = 0; k < 2000; ++k) p.emplace_back(0.005 * k, 0.1 * line * std::cos(0.3), 0.1 * line * std::sin(0.3));
  }
  const double s = AreaSpacing(p, 0.5);
  EXPECT_NEAR(s, std::sqrt(0.005 * 0.1), 0.2 * std::sqrt(0.005 * 0.1));
  EXPECT_GT(s, 3.0 * 0.005);
}

// Normals of a scan's lines: estimated wider where the radius spans one line only.
TEST(SurfaceNormals, ScanLinesGetTheirSurfacesNormal) {
  // Lines 0.1 m apart sampled every 5 mm on a plane tilted 0.3 rad about x, with 1 mm noise
  // across it: within 0.03 m a point sees its own line only.
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.001);
  const Eigen::Vector3d u(1, 0, 0), v(0, std::cos(0.3), std::sin(0.3)), truth = u.cross(v);
  std::vector<Eigen::Vector3d> p;
  for (int line = 0; line < 40; ++line) {
    for (int k = 0; k < 400; ++k) p.push_back(0.005 * k * u + 0.1 * line * v + noise(rng) * truth);
  }
  const Eigen::Vector3d viewpoint = 10.0 * truth;
  const PointIndex index(p);
  auto agreeing = [&](const std::vector<Eigen::Vector3d>& normals) {
    int count = 0;
    for (const Eigen::Vector3d& x : normals) count += x.allFinite() && x.dot(truth) > 0.95 ? 1 : 0;
    return static_cast<double>(count) / static_cast<double>(normals.size());
  };
  EXPECT_LT(agreeing(EstimateNormals(p, 0.03, viewpoint)), 0.5);  // the failure it is for
  std::vector<Eigen::Vector3d> n;
  const size_t widened = SurfaceNormals(p, index, 0.03, 0.4, viewpoint, &n);
  ASSERT_EQ(n.size(), p.size());
  EXPECT_GT(widened, p.size() * 9 / 10);
  EXPECT_GT(agreeing(n), 0.99);

  // An even sample of the same plane: no normal widened, each the same as PCL's (the same
  // PCA; PCL's is in float), NaN where PCL's is.
  std::vector<Eigen::Vector3d> q;
  for (int i = 0; i < 200; ++i) {
    for (int j = 0; j < 200; ++j) q.push_back(0.01 * i * u + 0.01 * j * v + noise(rng) * truth);
  }
  const PointIndex q_index(q);
  const std::vector<Eigen::Vector3d> pcl_normals = EstimateNormals(q, 0.04, viewpoint);
  std::vector<Eigen::Vector3d> m;
  EXPECT_EQ(SurfaceNormals(q, q_index, 0.04, 0.4, viewpoint, &m), 0u);
  for (size_t i = 0; i < m.size(); ++i) {
    ASSERT_EQ(m[i].allFinite(), pcl_normals[i].allFinite()) << i;
    if (m[i].allFinite()) {
      ASSERT_GT(m[i].dot(pcl_normals[i]), std::cos(1e-3)) << i;
    }
  }
  // Fewer than 3 neighbours: NaN.
  const std::vector<Eigen::Vector3d> pair = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0.01, 0, 0)};
  std::vector<Eigen::Vector3d> none;
  SurfaceNormals(pair, PointIndex(pair), 0.04, 0.4, viewpoint, &none);
  EXPECT_FALSE(none[0].allFinite());
  EXPECT_FALSE(none[1].allFinite());
}

}  // namespace
}  // namespace mmba::registration::internal
