// The visibility (free-space) test of the cloud registration's hypothesis verification.
#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "mmba/registration/cloud/feature_registration.h"
#include "registration/cloud/free_space.h"

namespace mmba::registration {
namespace {

TEST(FreeSpace, PointsInFrontOfTheFirstSurfaceAreInFreeSpace) {
  // A wall at x = 5 seen from the origin.
  std::vector<Eigen::Vector3d> wall;
  for (double y = -3; y <= 3; y += 0.05) {
    for (double z = -3; z <= 3; z += 0.05) wall.emplace_back(5.0, y, z);
  }
  const internal::FreeSpace space(wall, {Eigen::Vector3d::Zero()}, 0.05);
  ASSERT_FALSE(space.empty());
  int surface = -1;
  EXPECT_TRUE(space.Violates({3.0, 0.5, 0.2}, 0.1, &surface));  // the sensor saw through it
  ASSERT_GE(surface, 0);
  EXPECT_NEAR(wall[static_cast<size_t>(surface)].x(), 5.0, 1e-12);
  EXPECT_NEAR(wall[static_cast<size_t>(surface)].y(), 0.5 * 5.0 / 3.0, 0.3);  // on the same ray
  EXPECT_FALSE(space.Violates({4.95, 0.5, 0.2}, 0.1));  // on the surface within the margin
  EXPECT_FALSE(space.Violates({7.0, 0.5, 0.2}, 0.1));   // behind it: occluded, not evidence
  EXPECT_FALSE(space.Violates({-3.0, 0.5, 0.2}, 0.1));  // a ray that saw nothing
  EXPECT_FALSE(space.Violates({3.0, 4.5, 0.2}, 0.1));   // beside the wall: unobserved
  // Without sensors there is no free space.
  EXPECT_TRUE(internal::FreeSpace(wall, {}, 0.05).empty());
  EXPECT_FALSE(internal::FreeSpace(wall, {}, 0.05).Violates({3.0, 0.5, 0.2}, 0.1));
}

// A thin wall in the plane y = 0 (x in [-10, 10], z in [0, 4]) with buttresses 0.6 m deep
// on its south face (y < 0) at x = -7, -3, 1, 5 (so no 180° turn about z maps them onto
// themselves), their fronts and sides sampled; `ground` adds the ground z = 0 for |y| <= 3.
io::PointCloud ButtressedWall(double step, bool ground = false) {
  io::PointCloud c;
  if (ground) {
    for (double x = -10; x <= 10 + 1e-9; x += step) {
      for (double y = -3; y <= 3 + 1e-9; y += step) c.points.emplace_back(x, y, 0.0);
    }
  }
  for (double x = -10; x <= 10 + 1e-9; x += step) {
    for (double z = 0; z <= 4 + 1e-9; z += step) c.points.emplace_back(x, 0.0, z);
  }
  for (double bx : {-7.0, -3.0, 1.0, 5.0}) {
    for (double z = 0; z <= 4 + 1e-9; z += step) {
      for (double x = bx - 0.5; x <= bx + 0.5 + 1e-9; x += step) c.points.emplace_back(x, -0.6, z);
      for (double y = -0.6; y < -1e-9; y += step) {
        c.points.emplace_back(bx - 0.5, y, z);
        c.points.emplace_back(bx + 0.5, y, z);
      }
    }
  }
  return c;
}

TEST(FreeSpace, TheTurnedTwinOfAButtressedWallPutsItsButtressesInObservedFreeSpace) {
  // Target: the wall scanned from both sides; source: the same wall seen from the south only.
  // Turned by 180° about z, the wall plane maps onto itself and the source's buttresses land
  // on the north face, where the target's northern scanner saw the plain wall through them.
  const io::PointCloud wall = ButtressedWall(0.1);
  const std::vector<Eigen::Vector3d> target_sensors = {{0, -15, 2}, {0, 15, 2}};
  const std::vector<Eigen::Vector3d> source_sensors = {{2, -12, 1.5}};
  const Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d twin = Eigen::Matrix4d::Identity();
  twin.topLeftCorner<3, 3>() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const double margin = 0.1;
  const double at_truth =
      FreeSpaceViolation(wall, wall, source_sensors, target_sensors, truth, margin);
  const double at_twin = FreeSpaceViolation(wall, wall, source_sensors, target_sensors, twin, margin);
  EXPECT_EQ(at_truth, 0.0);
  // The buttress points more than the margin off the wall plane: most of the fronts and sides.
  EXPECT_GT(at_twin, 0.1) << "truth " << at_truth;
  // Seen from the south only (the northern scanner removed), the twin's buttresses lie behind
  // the wall: occluded, no evidence either way.
  EXPECT_LT(FreeSpaceViolation(wall, wall, source_sensors, {{0, -15, 2}}, twin, margin), 0.01);
  // No sensors: no test.
  EXPECT_EQ(FreeSpaceViolation(wall, wall, {}, {}, twin, margin), 0.0);
}

TEST(FreeSpace, SourceSensorsChargeTheTargetPointsTheySawThrough) {
  // The other direction: the target's buttresses, taken into the source frame by the twin,
  // stand in front of the plain north face that the source's northern sensor saw. Only target
  // points inside the source's bounding box count (a part says nothing beyond its extent):
  // the ground takes the box to both sides of the wall.
  const io::PointCloud wall = ButtressedWall(0.1, true);
  Eigen::Matrix4d twin = Eigen::Matrix4d::Identity();
  twin.topLeftCorner<3, 3>() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_GT(FreeSpaceViolation(wall, wall, {{0, 15, 2}}, {}, twin, 0.1), 0.01);
  EXPECT_EQ(FreeSpaceViolation(wall, wall, {{0, 15, 2}}, {}, Eigen::Matrix4d::Identity(), 0.1),
            0.0);
}

TEST(FreeSpace, RegistrationWithSensorsIsRightOrFails) {
  // The whole pipeline with sensors on the buttressed wall: the visibility test enters the
  // score; an "ok" must be the true pose (never the twin).
  const io::PointCloud target = ButtressedWall(0.1);
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();  // target_from_source
  truth.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()).toRotationMatrix();
  truth.topRightCorner<3, 1>() = Eigen::Vector3d(1.0, -2.0, 0.5);
  const Eigen::Matrix4d source_from_target = truth.inverse();
  io::PointCloud source;
  for (const auto& p : ButtressedWall(0.1).points) {
    if (p.x() < 6.0) {  // a part of the wall
      source.points.push_back(source_from_target.topLeftCorner<3, 3>() * p +
                              source_from_target.topRightCorner<3, 1>());
    }
  }
  CloudRegistrationOptions options;
  options.target_viewpoints = {{0, -15, 2}, {0, 15, 2}};
  const Eigen::Vector3d south(2, -12, 1.5);
  options.source_viewpoints = {source_from_target.topLeftCorner<3, 3>() * south +
                               source_from_target.topRightCorner<3, 1>()};
  const CloudRegistrationResult r = RegisterClouds(source, target, options);
  EXPECT_TRUE(r.visibility_tested);
  if (r.ok()) {
    EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, truth), 0.05) << r.BriefReport();
    EXPECT_LT(r.violation, 0.01);
  } else {
    EXPECT_FALSE(r.reason.empty());
  }
}

}  // namespace
}  // namespace mmba::registration
