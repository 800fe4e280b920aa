#include "mmba/registration/mi/edges.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/registration_settings.h"

namespace mmba::registration::mi {
namespace {

// One bright pixel on black: E is 255 at it and its 8 neighbours (their difference to it), and
// D decays as γ^(Chebyshev distance) from that 3×3 block (Levinson & Thrun 2013).
TEST(EdgeDistanceImage, DecaysByGammaPerChebyshevStep) {
  GrayImage photo(41, 41, 0.f);
  photo.at(20, 20) = 255.f;
  const double alpha = 1.0 / 3.0, gamma = 0.9;
  const GrayImage d = EdgeDistanceImage(photo, 0.0, alpha, gamma);
  // Outside the block D = (1 − α) · 255 · γ^(k) / mean, k the distance to the block: the ratio
  // of two points k and k + 1 apart is γ, along a row and along a diagonal alike.
  EXPECT_NEAR(d.at(25, 20) / d.at(24, 20), gamma, 1e-5);
  EXPECT_NEAR(d.at(25, 25) / d.at(24, 24), gamma, 1e-5);
  EXPECT_NEAR(d.at(25, 23) / d.at(24, 20), gamma, 1e-5);  // Chebyshev: (25,23) is 5 steps off
  // Divided by its mean.
  double sum = 0;
  for (float v : d.pixels) sum += v;
  EXPECT_NEAR(sum / d.pixels.size(), 1.0, 1e-4);
  // The bright pixel and its neighbours all have E = 255 (each differs from the next by 255).
  float largest = 0;
  for (float v : d.pixels) largest = std::max(largest, v);
  EXPECT_FLOAT_EQ(d.at(20, 20), largest);
}

// A scan of a near box (4 m) in front of a far wall (10 m), in one ring: the box's two ends are
// depth edges; the wall's points beside the box are not (they are the far side: occlusion).
TEST(DetectLidarEdges, NearSideOfADiscontinuityOnly) {
  LidarPoints points;
  for (int k = -40; k <= 40; ++k) {
    const double azimuth = k * 0.25 * M_PI / 180.0;
    const double range = std::abs(k) <= 10 ? 4.0 : 10.0;
    points.points_in_lidar.emplace_back(range * std::cos(azimuth), range * std::sin(azimuth), 0.f);
  }
  EdgeOptions options;
  options.intensity_quantile = 1;  // no intensity
  const std::vector<EdgePoint> edges = DetectLidarEdges(points, Eigen::Vector3f::Zero(), options);
  ASSERT_EQ(edges.size(), 2u);
  for (const EdgePoint& edge : edges) {
    EXPECT_NEAR(edge.point_in_lidar.norm(), 4.0, 1e-4);  // on the box, not on the wall
    EXPECT_NEAR(std::abs(std::atan2(edge.point_in_lidar.y(), edge.point_in_lidar.x())) * 180 / M_PI, 2.5, 1e-3);
    EXPECT_NEAR(edge.weight, std::sqrt(6.0), 1e-4);  // X = (jump)^½ (Levinson & Thrun)
    EXPECT_EQ(edge.kind, 0);
  }
}

// Foliage: ranges that jump at every step have no surface ends, so no depth edges.
TEST(DetectLidarEdges, NoEdgesWhereEveryStepJumps) {
  LidarPoints points;
  for (int k = -40; k <= 40; ++k) {
    const double azimuth = k * 0.25 * M_PI / 180.0;
    const double range = (k % 2 == 0) ? 4.0 : 9.0;
    points.points_in_lidar.emplace_back(range * std::cos(azimuth), range * std::sin(azimuth), 0.f);
  }
  EdgeOptions options;
  options.intensity_quantile = 1;
  EXPECT_TRUE(DetectLidarEdges(points, Eigen::Vector3f::Zero(), options).empty());
}

TEST(EdgeSettings, ReachedByNameAndChecked) {
  RegistrationOptions options;
  std::string problem;
  ASSERT_TRUE(RegistrationSettingsTable().Apply({"edges=on", "edge_gamma=0.95", "edge_cell_deg=0.1"}, &options,
                                                &problem))
      << problem;
  EXPECT_EQ(options.edges, "on");
  EXPECT_DOUBLE_EQ(options.edge.gamma, 0.95);
  EXPECT_DOUBLE_EQ(options.edge.cell_deg, 0.1);
  EXPECT_FALSE(RegistrationSettingsTable().Apply({"edge_gamma=1.5"}, &options, &problem));
  EXPECT_NE(problem.find("edge_gamma"), std::string::npos) << problem;
  EXPECT_FALSE(RegistrationSettingsTable().Apply({"edges=maybe"}, &options, &problem));
  ASSERT_TRUE(RegistrationSettingsTable().Apply({"edge_mi_level=2"}, &options, &problem)) << problem;
  EXPECT_EQ(options.edge_mi_level, 2);
  EXPECT_FALSE(RegistrationSettingsTable().Apply({"edge_mi_level=6"}, &options, &problem));
  EXPECT_NE(problem.find("edge_mi_level"), std::string::npos) << problem;
}

}  // namespace
}  // namespace mmba::registration::mi
