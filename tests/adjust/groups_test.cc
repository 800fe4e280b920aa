// Factor groups of the joint adjustment, unit by unit: the Gauss–Markov GNSS/INS priors and the
// LiDAR surface's plane association.
#include "mmba/adjust/groups.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "mmba/io_cloud/point_cloud.h"
#include "mmba/problem/scene.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;

/// 2·(Ceres cost) of the group's residuals over a copy of `scene`.
double Cost(FactorGroup& group, Scene scene = Scene()) {
  ceres::Problem problem;
  group.AddResiduals(scene, problem);
  double cost = 0.0;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  return 2.0 * cost;  // Ceres' cost is ½‖r‖²
}

// A photo's GNSS antenna: the camera centre plus the lever arm turned into the world. At the
// true antenna the residual is zero; 6 cm east is 3 σ on the east axis only.
TEST(GnssCameraGroup, TheLeverArmTurnsWithTheCamera) {
  const Rigid3d cam_from_world(Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, 3).normalized())),
                               Eigen::Vector3d(0.4, -2.0, 5.0));
  const Eigen::Vector3d lever(0.05, -0.12, 0.02);  // antenna in the camera frame
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  const Eigen::Vector3d antenna = world_from_cam.translation + world_from_cam.rotation * lever;
  const auto cost = [&](const Eigen::Vector3d& enu) {
    GnssCamera c;
    c.image_id = ImageId(1);
    c.enu = enu;
    c.sigma = Eigen::Vector3d(0.02, 0.02, 0.03);
    c.lever_arm = lever;
    GnssCameraGroup group({c}, LossOptions(), "gnss cameras");
    Scene scene;
    scene.AddImage(ImageId(1), CameraId(1), cam_from_world);
    ceres::Problem problem;
    group.AddResiduals(scene, problem);
    double value = 0.0;
    problem.Evaluate(ceres::Problem::EvaluateOptions(), &value, nullptr, nullptr, nullptr);
    return 2.0 * value;
  };
  EXPECT_NEAR(cost(antenna), 0.0, 1e-18);
  EXPECT_NEAR(cost(antenna + Eigen::Vector3d(0.06, 0, 0)), 9.0, 1e-9);
  // Without the lever arm the camera centre would be 0.13 m off: the arm is not ignored.
  EXPECT_GT(cost(world_from_cam.translation), 10.0);
}

TEST(GaussMarkovFactor, IsTheExponentialCorrelationAndZeroWithoutACorrelationTime) {
  EXPECT_NEAR(GaussMarkovFactor(1.0, 30.0), std::exp(-1.0 / 30.0), 1e-15);
  EXPECT_NEAR(GaussMarkovFactor(-2.0, 10.0), std::exp(-0.2), 1e-15);
  EXPECT_EQ(GaussMarkovFactor(1.0, 0.0), 0.0);
}

// A constant correction c on all N nodes: independent priors weigh it N times; a Gauss–Markov
// process once plus (N−1)·(1−φ)/(1+φ) — the drift's common offset is one observation.
TEST(TrajectoryPriorGroup, ACommonOffsetCountsOnceWhenTheErrorsAreCorrelated) {
  const int n = 13;
  const double sigma_m = 0.1, sigma_rad = 1.0 * M_PI / 180.0, offset = 0.05, tau = 30.0, dt = 1.0;
  std::vector<TrajectoryNode> nodes(n);
  for (int i = 0; i < n; ++i) {
    nodes[i].time_s = i * dt;
    nodes[i].correction[3] = offset;  // δx
  }
  TrajectoryPriorGroup independent(&nodes, sigma_m, sigma_rad, 0.0, LossOptions(), "independent");
  TrajectoryPriorGroup correlated(&nodes, sigma_m, sigma_rad, tau, LossOptions(), "correlated");
  const double z2 = offset * offset / (sigma_m * sigma_m);
  EXPECT_NEAR(Cost(independent), n * z2, 1e-12);
  const double phi = std::exp(-dt / tau);
  EXPECT_NEAR(Cost(correlated), z2 * (1 + (n - 1) * (1 - phi) / (1 + phi)), 1e-12);
  EXPECT_LT(Cost(correlated), 1.3 * z2);
}

// A pure random walk step between two nodes costs (Δ)²/(σ²(1−φ²)): the innovation.
TEST(TrajectoryPriorGroup, ResidualsAreTheWhitenedInnovations) {
  std::vector<TrajectoryNode> nodes(2);
  nodes[1].time_s = 5.0;
  nodes[1].correction[2] = 0.01;  // ωz
  const double sigma_rad = 0.02, tau = 20.0, phi = std::exp(-5.0 / 20.0);
  TrajectoryPriorGroup group(&nodes, 0.1, sigma_rad, tau, LossOptions(), "prior");
  EXPECT_NEAR(Cost(group), 0.01 * 0.01 / (sigma_rad * sigma_rad * (1 - phi * phi)), 1e-12);
}

// The rig's frame priors: same process over frames in time order (given in any order).
TEST(PosePriorGroup, CorrelatedFramePriorsFollowTimeOrder) {
  const double sigma_m = 0.1, sigma_rad = 0.02, tau = 30.0;
  std::vector<Rigid3d> priors(3), poses(3);
  const std::vector<double> times = {8.0, 0.0, 4.0};  // not sorted
  for (int i = 0; i < 3; ++i) {
    priors[i] = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i, 0, 0));
    // pose = X_from_world: a centre 0.03 m east of the prior's centre.
    poses[i] = Rigid3d(Eigen::Quaterniond::Identity(), priors[i].translation - Eigen::Vector3d(0.03, 0, 0));
  }
  std::vector<Rigid3d*> pointers = {&poses[0], &poses[1], &poses[2]};
  PosePriorGroup independent(pointers, priors, sigma_m, sigma_rad, LossOptions(), "independent");
  PosePriorGroup correlated(pointers, priors, sigma_m, sigma_rad, LossOptions(), "correlated", times, tau);
  const double z2 = 0.03 * 0.03 / (sigma_m * sigma_m);
  EXPECT_NEAR(Cost(independent), 3 * z2, 1e-12);
  const double phi = std::exp(-4.0 / tau);  // both gaps are 4 s once sorted
  EXPECT_NEAR(Cost(correlated), z2 * (1 + 2 * (1 - phi) / (1 + phi)), 1e-12);
}

// A rig frame's MI pose against the mobile LiDAR's delivered cloud (georeferenced with the
// GNSS/INS pose and the nominal mounting): the map to the adjusted world is that of the
// points themselves, and one frame's pose recovers the camera–LiDAR extrinsic.
TEST(MobileMiPriorGroup, OneFramesMiPoseRecoversTheCameraLidarExtrinsic) {
  const auto pose = [](double rx, double ry, double rz, double tx, double ty, double tz) {
    const Eigen::Quaterniond q = Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX());
    return Rigid3d(q, Eigen::Vector3d(tx, ty, tz));
  };
  std::vector<TrajectoryNode> nodes(2);
  nodes[1].time_s = 1.0;
  const double correction_a[6] = {0.002, -0.001, 0.01, 0.05, -0.03, 0.02}, correction_b[6] = {0.001, 0.0, 0.012, 0.06, -0.02, 0.01};
  std::copy(correction_a, correction_a + 6, nodes[0].correction);
  std::copy(correction_b, correction_b + 6, nodes[1].correction);
  const NodeWeight w = WeightAt(nodes, 0.25);
  const Rigid3d ins = pose(0.01, -0.02, 1.2, 105.0, -40.0, 2.0);
  const Rigid3d body_from_vehicle = pose(0.0, 0.0, M_PI / 2, 0.3, 0.0, 1.5);
  const Rigid3d body_from_lidar_nominal = pose(0.0, 0.0, M_PI / 2, 0.1, 0.2, 1.9);
  const Rigid3d vehicle_from_lidar_true = pose(0.004, -0.003, 0.007, -0.2, 0.12, 0.43);
  // A LiDAR point at the frame's time: where the delivered cloud put it and where it is.
  const Eigen::Vector3d x_lidar(7.0, -3.0, 1.0);
  const Eigen::Vector3d delivered = ins * (body_from_lidar_nominal * x_lidar);
  const Eigen::Vector3d world = CorrectedPose(nodes, w, ins) * (body_from_vehicle * (vehicle_from_lidar_true * x_lidar));
  const Rigid3d world_from_delivered =
      WorldFromDelivered(nodes, w, ins, body_from_vehicle, vehicle_from_lidar_true, body_from_lidar_nominal);
  EXPECT_LT((world_from_delivered * delivered - world).norm(), 1e-9);
  // With the nominal extrinsic and no correction the delivered cloud is the world.
  const std::vector<TrajectoryNode> zero(2, TrajectoryNode{});
  const Rigid3d identity = WorldFromDelivered(zero, w, ins, body_from_vehicle, body_from_vehicle.Inverse() * body_from_lidar_nominal,
                                              body_from_lidar_nominal);
  EXPECT_LT(identity.translation.norm() + identity.rotation.angularDistance(Eigen::Quaterniond::Identity()), 1e-9);

  // The MI pose a perfect registration finds, then the extrinsic from a start 3 cm / 0.5° off.
  Scene scene;
  Rigid3d& rig_from_world = scene.AddRigFrame(FrameId(0), pose(0.0, 0.01, -0.4, 3.0, 80.0, -2.0));
  MobileMiFrame frame;
  frame.frame = 0;
  frame.weight = w;
  frame.ins = ins;
  frame.rig_from_delivered = rig_from_world * world_from_delivered;
  frame.covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-4;  // 1 cm, 0.01°
  Rigid3d vehicle_from_lidar = pose(0.004 + 0.005, -0.003, 0.007 - 0.006, -0.2 + 0.02, 0.12 - 0.02, 0.43 + 0.01);
  MobileMiPriorGroup group({frame}, &nodes, &vehicle_from_lidar, body_from_vehicle, body_from_lidar_nominal, 1.0,
                           LossOptions(), "mi");
  EXPECT_GT(Cost(group, scene), 100.0);
  ceres::Problem problem;
  group.AddResiduals(scene, problem);
  problem.SetManifold(vehicle_from_lidar.rotation.coeffs().data(), new ceres::EigenQuaternionManifold);
  for (double* block : {nodes[0].correction, nodes[1].correction, rig_from_world.rotation.coeffs().data(),
                        rig_from_world.translation.data()}) {
    problem.SetParameterBlockConstant(block);
  }
  ceres::Solver::Options options;
  options.function_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  EXPECT_LT((vehicle_from_lidar.translation - vehicle_from_lidar_true.translation).norm(), 1e-6);
  EXPECT_LT(vehicle_from_lidar.rotation.angularDistance(vehicle_from_lidar_true.rotation), 1e-8);
  EXPECT_LT(Cost(group, scene), 1e-10);
}

// A cloud that misses the block: a units or frame mistake is named when one explains it.
TEST(CoordinateHint, NamesTheUnitOrFrameThatWouldMakeTheCloudOverlap) {
  const Eigen::Vector3d block_min(-20, -15, 0), block_max(25, 30, 12);
  const Eigen::Vector3d cloud_min(-30, -25, -2), cloud_max(35, 40, 20);
  EXPECT_EQ(CoordinateHint(cloud_min, cloud_max, block_min, block_max), "");
  EXPECT_NE(CoordinateHint(1000 * cloud_min, 1000 * cloud_max, block_min, block_max).find("millimetres"), std::string::npos);
  EXPECT_NE(CoordinateHint(cloud_min / 0.3048, cloud_max / 0.3048, block_min, block_max).find("feet"),
            std::string::npos);
  const Eigen::Vector3d utm(611000, 5041000, 0);
  EXPECT_NE(CoordinateHint(utm + cloud_min, utm + cloud_max, block_min, block_max).find("projected"), std::string::npos);
  // Elsewhere in the same frame: no guess.
  EXPECT_EQ(CoordinateHint(cloud_min + Eigen::Vector3d(500, 0, 0), cloud_max + Eigen::Vector3d(500, 0, 0), block_min, block_max),
            "");
}

class LidarSurfaceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (fs::path(testing::TempDir()) / ("mmba_surface_" + std::to_string(::getpid()) + ".ply")).string();
    // A 2 m × 2 m patch of the plane z = 0, sampled every 0.1 m, with ±2 mm of relief.
    io::PointCloud cloud;
    for (int i = 0; i <= 20; ++i) {
      for (int j = 0; j <= 20; ++j) {
        cloud.points.emplace_back(0.1 * i, 0.1 * j, ((i + j) % 2 ? 0.002 : -0.002));
      }
    }
    io::WritePly(cloud, path_);
  }
  void TearDown() override { fs::remove(path_); }
  std::string path_;
};

TEST_F(LidarSurfaceTest, GatesOnTheDistanceToThePlaneNotToTheNearestSample) {
  const LidarSurface surface(path_, Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(3, 3, 1), 0.0);
  Eigen::Vector3d n, c;
  double roughness = -1;
  // 2 cm above the plane between samples (7 cm from the nearest): associated at a 3 cm gate.
  ASSERT_TRUE(surface.FitPlane(Eigen::Vector3d(1.05, 1.05, 0.02), 0.03, 12, &n, &c, &roughness));
  EXPECT_NEAR(std::abs(n.z()), 1.0, 1e-6);
  EXPECT_NEAR(roughness, 0.002, 2e-4);
  // 4 cm above: outside the gate.
  EXPECT_FALSE(surface.FitPlane(Eigen::Vector3d(1.05, 1.05, 0.04), 0.03, 12, &n, &c));
  // On the plane's extension but 0.5 m beyond the patch's edge: not extrapolated.
  EXPECT_FALSE(surface.FitPlane(Eigen::Vector3d(2.5, 1.0, 0.0), 0.03, 12, &n, &c));
}

}  // namespace
}  // namespace mmba::adjust
