// The PCL-free FPFH of the cloud registration's backend (src/registration/cloud/fpfh.cc)
// against PCL's FPFHEstimationOMP, which it replaces (same pair features, weights,
// normalisation).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "registration/cloud/normal_orientation.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration::internal {
namespace {

// A wavy surface z = 0.3 sin(3x) cos(2y) sampled on a jittered grid, with exact normals.
void WavySurface(std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector3d>* normals) {
  uint32_t state = 12345;
  auto jitter = [&state]() {
    state = state * 1664525u + 1013904223u;
    return (static_cast<double>(state >> 8) / (1 << 24) - 0.5) * 0.01;
  };
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 60; ++j) {
      const double x = -1.5 + 0.05 * i + jitter(), y = -1.5 + 0.05 * j + jitter();
      const double z = 0.3 * std::sin(3 * x) * std::cos(2 * y);
      points->emplace_back(x, y, z);
      const Eigen::Vector3d n(-0.9 * std::cos(3 * x) * std::cos(2 * y),
                              0.6 * std::sin(3 * x) * std::sin(2 * y), 1.0);
      normals->push_back(n.normalized());
    }
  }
}

TEST(CloudFpfh, MatchesPcl) {
  std::vector<Eigen::Vector3d> points, normals;
  WavySurface(&points, &normals);
  std::vector<int> keypoints;
  for (int k = 0; k < static_cast<int>(points.size()); k += 97) keypoints.push_back(k);
  const double radius = 0.3;
  const Descriptors ours = ComputeFpfh(points, normals, keypoints, radius);
  const Descriptors pcl = ComputeFpfhPcl(points, normals, keypoints, radius);
  ASSERT_EQ(ours.dim, 33);
  ASSERT_EQ(pcl.dim, 33);
  ASSERT_EQ(ours.valid.size(), keypoints.size());
  double max_diff = 0.0, sum_diff = 0.0;
  for (size_t k = 0; k < keypoints.size(); ++k) {
    ASSERT_EQ(ours.valid[k], pcl.valid[k]) << "keypoint " << k;
    ASSERT_TRUE(ours.valid[k]);
    for (int b = 0; b < 33; ++b) {
      const double d = std::abs(ours.data[k * 33 + b] - pcl.data[k * 33 + b]);
      max_diff = std::max(max_diff, d);
      sum_diff += d;
    }
  }
  // Each sub-histogram sums to 100; only the order of float sums (and a pair exactly on a
  // bin edge) may differ.
  EXPECT_LT(max_diff, 0.05);
  EXPECT_LT(sum_diff / (keypoints.size() * 33), 1e-3);
}

TEST(CloudFpfh, IsolatedKeypointIsInvalid) {
  std::vector<Eigen::Vector3d> points, normals;
  WavySurface(&points, &normals);
  points.emplace_back(10.0, 10.0, 10.0);  // nothing within the radius
  normals.emplace_back(0.0, 0.0, 1.0);
  const std::vector<int> keypoints = {0, 1800, static_cast<int>(points.size()) - 1};
  const Descriptors ours = ComputeFpfh(points, normals, keypoints, 0.3);
  ASSERT_EQ(ours.valid.size(), 3u);
  EXPECT_TRUE(ours.valid[0]);
  EXPECT_TRUE(ours.valid[1]);
  EXPECT_FALSE(ours.valid[2]);
  // Sub-histograms of a valid descriptor sum to 100.
  for (int f = 0; f < 3; ++f) {
    double sum = 0.0;
    for (int b = 0; b < 11; ++b) sum += ours.data[33 + f * 11 + b];
    EXPECT_NEAR(sum, 100.0, 1e-3);
  }
}

TEST(CloudNormals, OrientedTowardsTheNearestSensor) {
  // Ground 20 m × 20 m at z = 0 in a frame whose origin lies on it (a merged model): the
  // normals estimated towards the origin point up or down at random; turned towards the
  // nearest of two scanners 1.5 m above the ground, all point up. And a wall at x = 3 seen
  // from a scanner at x = 1 (the nearer one for the wall) faces it, towards −x.
  std::vector<Eigen::Vector3d> points;
  uint32_t state = 7;
  auto noise = [&state]() {
    state = state * 1664525u + 1013904223u;
    return (static_cast<double>(state >> 8) / (1 << 24) - 0.5) * 0.004;
  };
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 100; ++j) points.emplace_back(-10 + 0.2 * i, -10 + 0.2 * j, noise());
  }
  const size_t ground = points.size();
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 15; ++j) points.emplace_back(3.0 + noise(), -2 + 0.2 * i, 0.1 + 0.2 * j);
  }
  std::vector<Eigen::Vector3d> normals = EstimateNormals(points, 0.5, Eigen::Vector3d::Zero());
  auto share_up = [&]() {
    int up = 0;
    for (size_t i = 0; i < ground; ++i) up += normals[i].z() > 0 ? 1 : 0;
    return static_cast<double>(up) / static_cast<double>(ground);
  };
  const double before = share_up();
  EXPECT_GT(before, 0.05);  // the failure it is for: signs at random on the ground
  EXPECT_LT(before, 0.95);
  const std::vector<Eigen::Vector3d> sensors = {{-5, 0, 1.5}, {1, 0, 1.5}};
  normals[5] = Eigen::Vector3d::Constant(std::nan(""));
  OrientTowardsNearest(points, sensors, &normals);
  EXPECT_EQ(share_up(), 1.0 - 1.0 / static_cast<double>(ground));  // all but the NaN one
  EXPECT_FALSE(normals[5].allFinite());
  for (size_t i = ground; i < points.size(); ++i) {
    if (normals[i].allFinite() && std::abs(normals[i].x()) > 0.9) {
      EXPECT_LT(normals[i].x(), 0.0) << i;
    }
  }
  // No sensors: the normals as they were.
  const std::vector<Eigen::Vector3d> kept = normals;
  OrientTowardsNearest(points, {}, &normals);
  for (size_t i = 0; i < normals.size(); ++i) {
    if (i != 5) {
      EXPECT_EQ(normals[i], kept[i]) << i;
    }
  }
}

TEST(CloudNormals, OrientedConsistentlyOverTheNeighbourGraph) {
  // Two parts far apart: a sphere of radius 1 whose normals point out at 70 % of its points
  // and in at the rest, and a plane 10 m away whose normals point down at 60 % of its
  // points. Each part ends with the sign most of its normals had: the sphere out, the plane
  // down; a NaN normal stays NaN.
  std::vector<Eigen::Vector3d> points, normals;
  uint32_t state = 99;
  auto uniform = [&state]() {
    state = state * 1664525u + 1013904223u;
    return static_cast<double>(state >> 8) / (1 << 24);
  };
  const int sphere = 2000;
  for (int i = 0; i < sphere; ++i) {  // a Fibonacci sphere: even spacing
    const double z = 1.0 - 2.0 * (i + 0.5) / sphere, r = std::sqrt(1.0 - z * z);
    const double phi = i * M_PI * (3.0 - std::sqrt(5.0));
    const Eigen::Vector3d p(r * std::cos(phi), r * std::sin(phi), z);
    points.push_back(p);
    normals.push_back(uniform() < 0.7 ? p : Eigen::Vector3d(-p));
  }
  for (int i = 0; i < 40; ++i) {
    for (int j = 0; j < 40; ++j) {
      points.emplace_back(10.0 + 0.05 * i, 0.05 * j, 0.0);
      normals.push_back(Eigen::Vector3d(0.0, 0.0, uniform() < 0.6 ? -1.0 : 1.0));
    }
  }
  normals[17] = Eigen::Vector3d::Constant(std::nan(""));
  std::vector<Eigen::Vector3d> before = normals;
  size_t changed = 0;
  const size_t turned = OrientConsistently(points, 10, &normals);
  for (size_t i = 0; i < points.size(); ++i) {
    if (i == 17) {
      EXPECT_FALSE(normals[i].allFinite());
      continue;
    }
    changed += normals[i] != before[i] ? 1 : 0;
    if (i < static_cast<size_t>(sphere)) {
      EXPECT_GT(normals[i].dot(points[i]), 0.99) << i;
    } else {
      EXPECT_EQ(normals[i], -Eigen::Vector3d::UnitZ()) << i;
    }
  }
  EXPECT_EQ(turned, changed);
  EXPECT_GT(turned, 0.25 * sphere);
}

}  // namespace
}  // namespace mmba::registration::internal
