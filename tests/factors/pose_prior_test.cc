#include "mmba/factors/pose_prior.h"

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "gradient_check.h"

namespace mmba::factors {
namespace {

Eigen::Quaterniond RotationZ(double angle_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()));
}

TEST(PosePriorCost, HandComputedCentreAndAngle) {
  // Prior Rz(0.2) at the origin; pose X_from_world = (Rz(0.5), (1, 0, 0)): centre −Rᵀt =
  // (−cos 0.5, sin 0.5, 0), rotation difference Rz(0.3). σ_m = 0.5 m, σ_rad = 0.1 rad.
  std::unique_ptr<ceres::CostFunction> cost(
      PosePriorCost::Create(Rigid3d(RotationZ(0.2), Eigen::Vector3d::Zero()), 0.5, 0.1));
  const Eigen::Quaterniond q = RotationZ(0.5);
  const double t[3] = {1, 0, 0};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {q.coeffs().data(), t}, &r));
  EXPECT_NEAR(r[0], -std::cos(0.5) / 0.5, 1e-12);
  EXPECT_NEAR(r[1], std::sin(0.5) / 0.5, 1e-12);
  EXPECT_NEAR(r[2], 0.0, 1e-12);
  EXPECT_NEAR(r[3], 0.0, 1e-12);
  EXPECT_NEAR(r[4], 0.0, 1e-12);
  EXPECT_NEAR(r[5], 3.0, 1e-12);
}

TEST(PosePriorCost, GradientCheck) {
  const Rigid3d prior(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(1, -2, 0.5));
  std::unique_ptr<ceres::CostFunction> cost(PosePriorCost::Create(prior, 0.05, 0.01));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.85, 0.15, -0.25, 0.3).normalized();
  const double t[3] = {0.9, -2.2, 0.4};
  ExpectGradientsMatch(*cost, {q.coeffs().data(), t}, {0});
}

TEST(GaussMarkovPosePriorCost, HandComputedInnovation) {
  // Unit priors at the origin; the previous centre is 2 m up, this one 3 m up:
  // r_z = (3 − φ·2)/(σ_m·√(1 − φ²)) with φ = 0.6 (√0.64 = 0.8), σ_m = 0.5 → 1.8/0.4 = 4.5.
  std::unique_ptr<ceres::CostFunction> cost(
      GaussMarkovPosePriorCost::Create(Rigid3d(), Rigid3d(), 0.6, 0.5, 0.01));
  const double q[4] = {0, 0, 0, 1}, t_previous[3] = {0, 0, -2}, t[3] = {0, 0, -3};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(*cost, {q, t_previous, q, t}, &r));
  EXPECT_NEAR(r[2], 4.5, 1e-12);
  for (int k : {0, 1, 3, 4, 5}) EXPECT_NEAR(r[k], 0.0, 1e-12) << k;
}

TEST(GaussMarkovPosePriorCost, GradientCheck) {
  const Rigid3d previous(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(1, -2, 0.5));
  const Rigid3d current(Eigen::Quaterniond(0.8, 0.2, -0.1, 0.3), Eigen::Vector3d(1.5, -2, 0.7));
  std::unique_ptr<ceres::CostFunction> cost(GaussMarkovPosePriorCost::Create(previous, current, 0.7, 0.1, 0.02));
  const Eigen::Quaterniond q_previous = Eigen::Quaterniond(0.88, 0.12, -0.22, 0.31).normalized();
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.79, 0.21, -0.12, 0.33).normalized();
  const double t_previous[3] = {0.9, -1.8, 0.45}, t[3] = {1.4, -2.1, 0.75};
  ExpectGradientsMatch(*cost, {q_previous.coeffs().data(), t_previous, q.coeffs().data(), t}, {0, 2});
}

}  // namespace
}  // namespace mmba::factors
