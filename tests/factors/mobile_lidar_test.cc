#include "mmba/factors/mobile_lidar.h"

#include <memory>

#include <gtest/gtest.h>

#include "gradient_check.h"
#include "mmba/factors/pose_prior.h"

namespace mmba::factors {
namespace {

const double kZeroNode[6] = {0, 0, 0, 0, 0, 0};
const double kIdentity[4] = {0, 0, 0, 1};
const double kZero[3] = {0, 0, 0};

// A generic point of the parameter space for the gradient checks.
const double kNodeA[6] = {0.01, -0.02, 0.015, 0.3, -0.1, 0.2};
const double kNodeB[6] = {0.012, -0.01, 0.02, 0.25, -0.2, 0.3};
const Rigid3d kIns(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(100, -50, 20));
const Rigid3d kBodyFromVehicle(Eigen::Quaterniond(0.99, 0.02, -0.03, 0.1), Eigen::Vector3d(0.5, 0, 1.2));

MobilePointCost PointOnPlaneZ3(const Rigid3d& ins) {
  // p = (1, 2, 3) in the LiDAR, plane z = 3 with σ = 0.5 m, body_from_vehicle = (I, (0, 0, 1)).
  return MobilePointCost(Eigen::Vector3d(1, 2, 3), 0.3, ins, Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0, 0, 3), 0.5,
                         Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 1)));
}

TEST(MobilePointCost, HandComputedDistance) {
  // Zero correction, GNSS/INS (I, (10, 0, 0)): p is (11, 2, 4) in the world, 1 m above the
  // plane z = 3, σ = 0.5 m → r = 2.
  std::unique_ptr<ceres::CostFunction> cost(
      new ceres::AutoDiffCostFunction<MobilePointCost, 1, 6, 6, 4, 3>(
          new MobilePointCost(PointOnPlaneZ3(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(10, 0, 0))))));
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {kZeroNode, kZeroNode, kIdentity, kZero}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
}

TEST(MobilePointCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(MobilePointCost::Create(
      Eigen::Vector3d(5, -3, 1), 0.3, kIns, Eigen::Vector3d(0, 0.6, 0.8), Eigen::Vector3d(100, -50, 18), 0.01,
      kBodyFromVehicle));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const double t[3] = {0.3, -0.2, 1.0};
  ExpectGradientsMatch(*cost, {kNodeA, kNodeB, q.coeffs().data(), t}, {2});
}

TEST(MobileScanPointCost, HandComputedDistanceInTheScanFrame) {
  // The point of the test above, (11, 2, 4) in the world, is (11, 2, 3) in a scan at
  // (I, (0, 0, −1)): on the scan's plane z = 3, r = 0. In a scan at (I, (0, 0, −1.5)) it is
  // 0.5 m below the plane: r = −0.5/0.5 = −1.
  const MobilePointCost point = PointOnPlaneZ3(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(10, 0, 0)));
  std::unique_ptr<ceres::CostFunction> cost(MobileScanPointCost::Create(point));
  std::vector<double> r;
  const double t_on[3] = {0, 0, -1}, t_below[3] = {0, 0, -1.5};
  ASSERT_TRUE(EvaluateCost(*cost, {kZeroNode, kZeroNode, kIdentity, kZero, kIdentity, t_on}, &r));
  EXPECT_NEAR(r[0], 0.0, 1e-12);
  ASSERT_TRUE(EvaluateCost(*cost, {kZeroNode, kZeroNode, kIdentity, kZero, kIdentity, t_below}, &r));
  EXPECT_NEAR(r[0], -1.0, 1e-12);
}

TEST(MobileScanPointCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(MobileScanPointCost::Create(MobilePointCost(
      Eigen::Vector3d(5, -3, 1), 0.7, kIns, Eigen::Vector3d(0, 0.6, 0.8), Eigen::Vector3d(1, 2, -1), 0.01,
      kBodyFromVehicle)));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const Eigen::Quaterniond q_sw = Eigen::Quaterniond(0.7, 0.1, 0.05, -0.7).normalized();
  const double t[3] = {0.3, -0.2, 1.0}, t_sw[3] = {-90, 40, -15};
  ExpectGradientsMatch(*cost, {kNodeA, kNodeB, q.coeffs().data(), t, q_sw.coeffs().data(), t_sw}, {2, 4});
}

TEST(FrameOnTrajectoryCost, HandComputedCentreAndAngle) {
  // Zero correction, GNSS/INS (I, (10, 0, 0)), body_from_rig = (I, (0, 1, 0)): the predicted
  // world_from_rig is (I, (10, 1, 0)). The estimated rig_from_world = (Rz(0.1), −Rz(0.1)·c) with
  // the centre c = (10, 1, 0.5): r_z = 0.5/σ_m (σ_m = 0.25 → 2), rotation Rz(−0.1): r_yaw =
  // −0.1/σ_rad (σ_rad = 0.05 → −2).
  std::unique_ptr<ceres::CostFunction> cost(FrameOnTrajectoryCost::Create(
      0.4, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(10, 0, 0)),
      Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 1, 0)), 0.25, 0.05));
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d t = -(q * Eigen::Vector3d(10, 1, 0.5));
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {kZeroNode, kZeroNode, q.coeffs().data(), t.data()}, &r));
  const double expected[6] = {0, 0, 2, 0, 0, -2};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(r[k], expected[k], 1e-12) << k;
}

// The gradient checks probe within ~0.4 rad of the predicted rotation: Ceres' Ridders
// differences of the angle-axis residual go wrong near 180° of rotation difference.
const Eigen::Quaterniond kSmallTurn = Eigen::Quaterniond(0.98, 0.1, -0.1, 0.15).normalized();

TEST(FrameOnTrajectoryCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(FrameOnTrajectoryCost::Create(0.3, kIns, kBodyFromVehicle, 0.02, 0.001));
  const Eigen::Quaterniond q = (kSmallTurn * kIns.rotation * kBodyFromVehicle.rotation).conjugate();
  const double t[3] = {-50, 80, 10};
  ExpectGradientsMatch(*cost, {kNodeA, kNodeB, q.coeffs().data(), t}, {2});
}

TEST(MobileMiFrameCost, HandComputedWithAPosePrior) {
  // Every transform the identity: the delivered cloud is the world and rig_from_delivered is
  // rig_from_world. A pose prior at the identity with σ_m = 0.5 sees the rig centre 1 m up:
  // r_z = 2.
  using Cost = MobileMiFrameCost<PosePriorCost>;
  std::unique_ptr<ceres::CostFunction> cost(
      Cost::Create(0.5, Rigid3d(), Rigid3d(), Rigid3d(), PosePriorCost(Rigid3d(), 0.5, 0.01)));
  const double t[3] = {0, 0, -1};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {kZeroNode, kZeroNode, kIdentity, kZero, kIdentity, t}, &r));
  const double expected[6] = {0, 0, 2, 0, 0, 0};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(r[k], expected[k], 1e-12) << k;
}

TEST(MobileMiFrameCost, GradientCheck) {
  using Cost = MobileMiFrameCost<PosePriorCost>;
  const Rigid3d body_from_lidar_nominal(Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5), Eigen::Vector3d(0.2, 0.1, 1.5));
  const Rigid3d vehicle_from_lidar(Eigen::Quaterniond(0.49, 0.51, -0.5, 0.5), Eigen::Vector3d(-0.3, 0.1, 0.3));
  const Rigid3d rig_from_world(Eigen::Quaterniond(0.3, -0.6, 0.2, 0.7), Eigen::Vector3d(-50, 80, 10));
  // The prior: the uncorrected rig_from_delivered, turned and shifted a little.
  const Rigid3d rig_from_delivered = rig_from_world * kIns * kBodyFromVehicle * vehicle_from_lidar *
                                     (kIns * body_from_lidar_nominal).Inverse();
  const Rigid3d prior(kSmallTurn * rig_from_delivered.rotation,
                      rig_from_delivered.translation + Eigen::Vector3d(0.1, -0.2, 0.05));
  std::unique_ptr<ceres::CostFunction> cost(
      Cost::Create(0.3, kIns, kBodyFromVehicle, body_from_lidar_nominal, PosePriorCost(prior, 0.05, 0.002)));
  ExpectGradientsMatch(*cost,
                       {kNodeA, kNodeB, vehicle_from_lidar.rotation.coeffs().data(),
                        vehicle_from_lidar.translation.data(), rig_from_world.rotation.coeffs().data(),
                        rig_from_world.translation.data()},
                       {2, 4});
}

}  // namespace
}  // namespace mmba::factors
