#include "mmba/factors/point_to_plane.h"

#include <memory>

#include <gtest/gtest.h>

#include "gradient_check.h"

namespace mmba::factors {
namespace {

TEST(PointToPlaneCost, HandComputedDistance) {
  // Plane z = 1; X = (3, 4, 1.5): 0.5 m above it, σ = 0.25 m → r = 2.
  const PointToPlaneCost cost(Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0, 0, 1), 0.25);
  const double x[3] = {3, 4, 1.5};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(cost, {x}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
}

TEST(PointToPlaneCost, GradientCheck) {
  const PointToPlaneCost cost(Eigen::Vector3d(0.6, 0, 0.8), Eigen::Vector3d(1, 2, 3), 0.01);
  const double x[3] = {1.2, 2.5, 2.9};
  ExpectGradientsMatch(cost, {x});
}

TEST(ScanPointToPlaneCost, HandComputedDistanceInTheScanFrame) {
  // scan_from_world = (I, (0, 0, −1)): X = (3, 4, 2.5) is (3, 4, 1.5) in the scan, 0.5 m
  // above the scan's plane z = 1; σ = 0.25 m → r = 2.
  std::unique_ptr<ceres::CostFunction> cost(
      ScanPointToPlaneCost::Create(Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0, 0, 1), 0.25));
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, -1}, x[3] = {3, 4, 2.5};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {q, t, x}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
}

TEST(ScanPointToPlaneCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(
      ScanPointToPlaneCost::Create(Eigen::Vector3d(0, 0.6, 0.8), Eigen::Vector3d(1, 2, 3), 0.02));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized();
  const double t[3] = {0.5, -1, 2}, x[3] = {4, -3, 7};
  ExpectGradientsMatch(*cost, {q.coeffs().data(), t, x}, {0});
}

TEST(ScanToScanCost, HandComputedDistance) {
  // S_from = (I, (1, 0, 0)): p = (2, 0, 3) is (1, 0, 3) in the world and in the `to` scan
  // (S_to = I), 0.5 m in front of the plane x = 0.5; σ = 0.1 m → r = 5.
  std::unique_ptr<ceres::CostFunction> cost(ScanToScanCost::Create(
      Eigen::Vector3d(2, 0, 3), Eigen::Vector3d::UnitX(), Eigen::Vector3d(0.5, 0, 0), 0.1));
  const double q[4] = {0, 0, 0, 1}, t_from[3] = {1, 0, 0}, t_to[3] = {0, 0, 0};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {q, t_from, q, t_to}, &r));
  EXPECT_NEAR(r[0], 5.0, 1e-12);
}

TEST(ScanToScanCost, GradientCheck) {
  std::unique_ptr<ceres::CostFunction> cost(ScanToScanCost::Create(
      Eigen::Vector3d(2, -1, 3), Eigen::Vector3d(0.48, 0.6, 0.64), Eigen::Vector3d(0.5, 0.2, 0.1), 0.01));
  const Eigen::Quaterniond q_from = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized();
  const Eigen::Quaterniond q_to = Eigen::Quaterniond(0.8, -0.1, 0.25, 0.1).normalized();
  const double t_from[3] = {1, 0.5, -0.3}, t_to[3] = {-0.2, 0.4, 0.9};
  ExpectGradientsMatch(*cost, {q_from.coeffs().data(), t_from, q_to.coeffs().data(), t_to}, {0, 2});
}

}  // namespace
}  // namespace mmba::factors
