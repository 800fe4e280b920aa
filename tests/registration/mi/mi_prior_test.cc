#include "mmba/registration/mi/mi_prior.h"

#include <cmath>
#include <memory>
#include <vector>

#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <gtest/gtest.h>

#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

Rigid3d SomePose() {
  return Rigid3d(Eigen::Quaterniond(0.9, -0.2, 0.3, 0.1).normalized(),
                 Eigen::Vector3d(0.3, -1.2, 0.5));
}

Matrix6d Diagonal(double sigma_m, double sigma_deg) {
  Vector6d d;
  d << sigma_m, sigma_m, sigma_m, sigma_deg, sigma_deg, sigma_deg;
  return d.cwiseAbs2().asDiagonal();
}

Vector6d Residual(ceres::CostFunction* cost, const Rigid3d& pose) {
  const double* blocks[2] = {pose.rotation.coeffs().data(), pose.translation.data()};
  Vector6d r;
  EXPECT_TRUE(cost->Evaluate(blocks, r.data(), nullptr));
  return r;
}

TEST(MiPosePrior, ZeroAtTheMiPoseAndWhitenedOffsets) {
  const Rigid3d mi = SomePose();
  std::unique_ptr<ceres::CostFunction> cost(MiPosePrior::Create(mi, Diagonal(0.05, 0.5)));
  ASSERT_NE(cost, nullptr);
  EXPECT_LT(Residual(cost.get(), mi).norm(), 1e-12);
  // 0.1 m along the LiDAR x axis at σ 0.05 m: r = (2, 0, 0, 0, 0, 0).
  Vector6d c = Vector6d::Zero();
  c[0] = 0.1;
  Vector6d expected = Vector6d::Zero();
  expected[0] = 2.0;
  EXPECT_LT((Residual(cost.get(), ApplyCorrection(mi, c)) - expected).norm(), 1e-9);
  // 1° of yaw (about the LiDAR z axis, camera centre fixed) at σ 0.5°: r = (0, …, 0, 2).
  c.setZero();
  c[5] = 1.0;
  expected.setZero();
  expected[5] = 2.0;
  EXPECT_LT((Residual(cost.get(), ApplyCorrection(mi, c)) - expected).norm(), 1e-9);
}

TEST(MiPosePrior, SquaredNormIsTheMahalanobisDistance) {
  Matrix6d a = Matrix6d::Random();
  const Matrix6d covariance = 1e-3 * (a * a.transpose() + Matrix6d::Identity());
  const Rigid3d mi = SomePose();
  std::unique_ptr<ceres::CostFunction> cost(MiPosePrior::Create(mi, covariance));
  ASSERT_NE(cost, nullptr);
  Vector6d e;
  e << 0.03, -0.02, 0.01, 0.0, 0.0, 0.0;  // translation only: exact in both conventions
  const Vector6d r = Residual(cost.get(), ApplyCorrection(mi, e));
  EXPECT_NEAR(r.squaredNorm(), e.dot(covariance.inverse() * e), 1e-9 * r.squaredNorm());
}

TEST(MiPosePrior, GradientCheck) {
  Matrix6d a = Matrix6d::Random();
  const Matrix6d covariance = 1e-2 * (a * a.transpose() + Matrix6d::Identity());
  std::unique_ptr<ceres::CostFunction> cost(MiPosePrior::Create(SomePose(), covariance));
  ASSERT_NE(cost, nullptr);
  Vector6d c;
  c << 0.05, -0.1, 0.02, 1.0, -2.0, 0.5;
  const Rigid3d at = ApplyCorrection(SomePose(), c);
  ceres::EigenQuaternionManifold quaternion;
  std::vector<const ceres::Manifold*> manifolds = {&quaternion, nullptr};
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(cost.get(), &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  const double* blocks[2] = {at.rotation.coeffs().data(), at.translation.data()};
  EXPECT_TRUE(checker.Probe(blocks, 1e-6, &results)) << results.error_log;
}

TEST(MiPosePrior, CovarianceNotPositiveDefiniteGivesNoCostFunction) {
  Matrix6d singular = Diagonal(0.05, 0.5);
  singular(2, 2) = 0.0;
  EXPECT_EQ(MiPosePrior::Create(SomePose(), singular), nullptr);
  Matrix6d asymmetric = Diagonal(0.05, 0.5);
  asymmetric(0, 1) = 1e-4;
  EXPECT_EQ(MiPosePrior::Create(SomePose(), asymmetric), nullptr);
  Matrix6d nan = Diagonal(0.05, 0.5);
  nan(3, 3) = std::nan("");
  EXPECT_EQ(MiPosePrior::Create(SomePose(), nan), nullptr);
}

TEST(MiPosePrior, TwoPriorsGiveTheInverseVarianceWeightedPose) {
  // Two MI results 0.1 m apart along x, σ 0.1 m and 0.05 m: the adjusted centre lies at
  // 0.1 · 400 / (100 + 400) = 0.08 m from the first; rotations equal.
  const Rigid3d first = SomePose();
  Vector6d c = Vector6d::Zero();
  c[0] = 0.1;
  const Rigid3d second = ApplyCorrection(first, c);
  Rigid3d pose = first;
  ceres::Problem problem;
  problem.AddResidualBlock(MiPosePrior::Create(first, Diagonal(0.1, 1.0)), nullptr,
                           pose.rotation.coeffs().data(), pose.translation.data());
  problem.AddResidualBlock(MiPosePrior::Create(second, Diagonal(0.05, 1.0)), nullptr,
                           pose.rotation.coeffs().data(), pose.translation.data());
  problem.SetManifold(pose.rotation.coeffs().data(), new ceres::EigenQuaternionManifold);
  ceres::Solver::Options options;
  options.function_tolerance = 1e-14;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();
  const Vector6d adjusted = CorrectionBetween(first, pose);
  EXPECT_NEAR(adjusted[0], 0.08, 1e-7);
  EXPECT_LT(adjusted.segment<2>(1).norm(), 1e-7);
  EXPECT_LT(adjusted.tail<3>().norm(), 1e-6);
}

}  // namespace
}  // namespace mmba::registration::mi
