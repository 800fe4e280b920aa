#include "mmba/sim/lidar.h"

#include <gtest/gtest.h>

namespace mmba::sim {
namespace {

// A room-like diffuse scene: floor, a wall at y = 5 and a box.
SimScene DiffuseScene(MaterialClass wall_class) {
  SimScene scene;
  Material diffuse;
  diffuse.name = "diffuse";
  Material wall = diffuse;
  wall.name = "wall";
  wall.material_class = wall_class;
  const int d = scene.mesh.AddMaterial(diffuse);
  const int w = scene.mesh.AddMaterial(wall);
  scene.mesh.AddQuad({-20, -20, 0}, {20, -20, 0}, {20, 20, 0}, {-20, 20, 0}, d);
  scene.mesh.AddQuad({-20, 5, 0}, {20, 5, 0}, {20, 5, 6}, {-20, 5, 6}, w);
  scene.mesh.AddQuad({-20, 9, 0}, {20, 9, 0}, {20, 9, 6}, {-20, 9, 6}, d);
  scene.mesh.AddBox({1, 1, 0}, {2, 2, 1.5}, d, true);
  return scene;
}

TEST(Lidar, StaticScanPointsLieOnTheMeshWithinTheNoise) {
  const SimScene scene = DiffuseScene(MaterialClass::kDiffuse);
  RayCaster caster(scene.mesh);
  StaticScanOptions options;
  options.azimuth_step_deg = 2.0;
  options.elevation_step_deg = 2.0;
  const Rigid3d world_from_scan(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())),
                                Eigen::Vector3d(0.5, -1.0, 1.6));
  const LidarScan scan = SimulateStaticScan(caster, scene, world_from_scan, options, "s1", 4, 2);
  ASSERT_GT(scan.cloud.size(), 1000u);
  EXPECT_EQ(scan.num_ghosts, 0u);
  EXPECT_EQ(scan.cloud.size() + scan.num_dropouts, scan.num_rays);
  double sum2 = 0;
  for (size_t i = 0; i < scan.cloud.size(); ++i) {
    const Eigen::Vector3d p = world_from_scan * scan.cloud.points[i];
    const Eigen::Vector3d ray = p - world_from_scan.translation;
    const RayHit hit = caster.Intersect(world_from_scan.translation, ray.normalized());
    ASSERT_TRUE(hit.hit);
    const double error = ray.norm() - hit.distance_m;
    const double sigma = options.noise.range_sigma_m + options.noise.range_sigma_ppm * 1e-6 * hit.distance_m;
    ASSERT_LT(std::abs(error), 6 * sigma) << i;
    sum2 += error * error / (sigma * sigma);
    EXPECT_GE(scan.cloud.intensity[i], 0.0f);
    EXPECT_LE(scan.cloud.intensity[i], 1.0f);
  }
  // The normalised errors have unit variance.
  EXPECT_NEAR(std::sqrt(sum2 / scan.cloud.size()), 1.0, 0.1);
}

TEST(Lidar, SameSeedSamePointsAnyThreadCount) {
  const SimScene scene = DiffuseScene(MaterialClass::kGlass);
  RayCaster caster(scene.mesh);
  StaticScanOptions options;
  options.azimuth_step_deg = 3.0;
  options.elevation_step_deg = 3.0;
  const Rigid3d world_from_scan(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1.5));
  const LidarScan a = SimulateStaticScan(caster, scene, world_from_scan, options, "s", 9, 1);
  const LidarScan b = SimulateStaticScan(caster, scene, world_from_scan, options, "s", 9, 2);
  ASSERT_EQ(a.cloud.size(), b.cloud.size());
  for (size_t i = 0; i < a.cloud.size(); ++i) ASSERT_EQ(a.cloud.points[i], b.cloud.points[i]);
}

TEST(Lidar, GlassPassesPulsesAndMirrorsMakeGhosts) {
  const SimScene scene = DiffuseScene(MaterialClass::kReflective);
  RayCaster caster(scene.mesh);
  StaticScanOptions options;
  options.azimuth_step_deg = 1.0;
  options.elevation_step_deg = 1.0;
  options.noise.ghost_probability = 0.5;
  const Rigid3d world_from_scan(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1.5));
  const LidarScan scan = SimulateStaticScan(caster, scene, world_from_scan, options, "s", 2, 2);
  ASSERT_GT(scan.num_ghosts, 100u);
  // Ghosts of the mirror wall y = 5 lie behind it (y > 5), where nothing was hit directly.
  for (size_t i = 0; i < scan.cloud.size(); ++i) {
    if (!scan.spurious[i]) continue;
    EXPECT_GT(scan.cloud.points[i].y(), 5.0 - 0.05);
  }
  const SimScene glass = DiffuseScene(MaterialClass::kGlass);
  RayCaster glass_caster(glass.mesh);
  const LidarScan through = SimulateStaticScan(glass_caster, glass, world_from_scan, options, "s", 2, 2);
  EXPECT_GT(through.num_glass_pass, 100u);
  size_t behind = 0;
  for (const auto& p : through.cloud.points) behind += p.y() > 8.9;
  EXPECT_GT(behind, 100u);  // the wall at y = 9 is seen through the pane at y = 5
}

TEST(Lidar, MobileScanOnTheMeshWithTrueTrajectoryAndOffWithIns) {
  const SimScene scene = DiffuseScene(MaterialClass::kDiffuse);
  RayCaster caster(scene.mesh);
  const Trajectory trajectory(-5, 5, -2, 2.0, 0.1, 1.0, 3);
  MobileScanOptions options;
  options.azimuth_step_deg = 2.0;
  options.noise.range_sigma_m = 0.0;
  options.noise.range_sigma_ppm = 0.0;
  const Rigid3d body_from_lidar(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 0, 1.9));
  const LidarScan scan =
      SimulateMobileScan(caster, scene, trajectory, body_from_lidar, options, 5, "mobile", 1, 2);
  ASSERT_GT(scan.cloud.size(), 1000u);
  ASSERT_EQ(scan.time_s.size(), scan.cloud.size());
  const io::PointCloud truth = GeoreferenceMobileScan(scan, trajectory, body_from_lidar, false);
  const io::PointCloud ins = GeoreferenceMobileScan(scan, trajectory, body_from_lidar, true);
  double max_truth = 0, max_ins = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    const Rigid3d world_from_lidar = trajectory.WorldFromBodyTrue(scan.time_s[i]) * body_from_lidar;
    const Eigen::Vector3d o = world_from_lidar.translation;
    const RayHit hit = caster.Intersect(o, (truth.points[i] - o).normalized());
    ASSERT_TRUE(hit.hit);
    max_truth = std::max(max_truth, (hit.point - truth.points[i]).norm());
    max_ins = std::max(max_ins, (ins.points[i] - truth.points[i]).norm());
  }
  EXPECT_LT(max_truth, 1e-6);
  EXPECT_GT(max_ins, 0.02);  // the GNSS/INS errors show
  EXPECT_LT(max_ins, 0.1 + 0.02 * 25);  // ≤ 0.1 m + ~1° at ≤ 25 m
}

TEST(Lidar, OptionsCheckNamesTheField) {
  StaticScanOptions options;
  options.azimuth_step_deg = 0;
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("azimuth_step_deg"), std::string::npos);
  options = StaticScanOptions();
  options.noise.max_range_m = -1;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("max_range_m"), std::string::npos);
}

}  // namespace
}  // namespace mmba::sim
