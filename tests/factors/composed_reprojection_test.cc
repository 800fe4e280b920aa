#include "mmba/factors/composed_reprojection.h"

#include <memory>

#include <gtest/gtest.h>

#include "gradient_check.h"
#include "mmba/factors/reprojection_error.h"
#include "mmba/geometry/rigid3d.h"

namespace mmba::factors {
namespace {

using sensors::OpenCVModel;
using sensors::PinholeModel;

// The pinhole case of reprojection_error_test.cc: identity pose, X = (1, −0.5, 4) projects to
// (445, 176.25); observed (444, 177.25) with σ = 0.5 px → r = (2, −2).
const double kPinhole[4] = {500, 510, 320, 240};
ceres::CostFunction* PinholeCost() {
  return ReprojectionError<PinholeModel>::Create(Eigen::Vector2d(444, 177.25), 0.5);
}

TEST(NetworkPointReprojectionCost, HandComputedOnEastNorthAndUp) {
  const NetworkPointReprojectionCost cost(PinholeCost());
  ASSERT_EQ(cost.parameter_block_sizes(), std::vector<int32_t>({4, 3, 2, 1, 4}));
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 0}, en[2] = {1, -0.5}, up[1] = {4};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(cost, {q, t, en, up, kPinhole}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
  EXPECT_NEAR(r[1], -2.0, 1e-12);
}

TEST(NetworkPointReprojectionCost, GradientCheck) {
  const NetworkPointReprojectionCost cost(ReprojectionError<OpenCVModel>::Create(Eigen::Vector2d(300, 200), 1.5));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const double t[3] = {0.3, -0.2, 1.0}, en[2] = {0.5, 0.7}, up[1] = {6.0};
  const double params[8] = {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002};
  ExpectGradientsMatch(cost, {q.coeffs().data(), t, en, up, params}, {0});
}

TEST(BaselineReprojectionCost, BaselineSubtractedFromTheTranslation) {
  // t − b = 0: the identity pose of the pinhole case.
  const BaselineReprojectionCost cost(PinholeCost());
  ASSERT_EQ(cost.parameter_block_sizes(), std::vector<int32_t>({4, 3, 3, 3, 4}));
  const double q[4] = {0, 0, 0, 1}, t[3] = {0.3, 0.2, -1.1}, b[3] = {0.3, 0.2, -1.1}, x[3] = {1, -0.5, 4};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(cost, {q, t, b, x, kPinhole}, &r));
  EXPECT_NEAR(r[0], 2.0, 1e-12);
  EXPECT_NEAR(r[1], -2.0, 1e-12);
}

TEST(BaselineReprojectionCost, GradientCheck) {
  const BaselineReprojectionCost cost(ReprojectionError<OpenCVModel>::Create(Eigen::Vector2d(300, 200), 1.5));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const double t[3] = {0.3, -0.2, 1.0}, b[3] = {0.1, 0.05, 0.6}, x[3] = {0.5, 0.7, 6.0};
  const double params[8] = {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002};
  ExpectGradientsMatch(cost, {q.coeffs().data(), t, b, x, params}, {0});
}

TEST(ComposePoses, CamFromRigAfterRigFromWorld) {
  const Rigid3d rig_from_world(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(1, -2, 0.5));
  const Rigid3d cam_from_rig(Eigen::Quaterniond(0.7, -0.1, 0.4, 0.2), Eigen::Vector3d(0.1, 0.2, -0.3));
  const Rigid3d expected = cam_from_rig * rig_from_world;
  double out[7];
  ASSERT_TRUE(ComposePoses()(rig_from_world.rotation.coeffs().data(), rig_from_world.translation.data(),
                             cam_from_rig.rotation.coeffs().data(), cam_from_rig.translation.data(), out));
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(out[k], expected.rotation.coeffs()[k], 1e-12) << k;
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(out[4 + k], expected.translation[k], 1e-12) << k;
}

TEST(RigReprojectionCost, HandComputedThroughTheRig) {
  // cam_from_rig = rig_from_world⁻¹: the composed cam_from_world is the identity pose of the
  // pinhole case.
  const RigReprojectionCost cost(PinholeCost());
  ASSERT_EQ(cost.parameter_block_sizes(), std::vector<int32_t>({4, 3, 4, 3, 3, 4}));
  const Rigid3d rig_from_world(Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3), Eigen::Vector3d(1, -2, 0.5));
  const Rigid3d cam_from_rig = rig_from_world.Inverse();
  const double x[3] = {1, -0.5, 4};
  std::vector<double> r;
  ASSERT_TRUE(EvaluateCost(cost,
                           {rig_from_world.rotation.coeffs().data(), rig_from_world.translation.data(),
                            cam_from_rig.rotation.coeffs().data(), cam_from_rig.translation.data(), x, kPinhole},
                           &r));
  EXPECT_NEAR(r[0], 2.0, 1e-9);
  EXPECT_NEAR(r[1], -2.0, 1e-9);
}

TEST(RigReprojectionCost, GradientCheck) {
  const RigReprojectionCost cost(ReprojectionError<OpenCVModel>::Create(Eigen::Vector2d(300, 200), 1.5));
  const Eigen::Quaterniond q_rw = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const Eigen::Quaterniond q_cr = Eigen::Quaterniond(0.99, -0.03, 0.08, 0.05).normalized();
  const double t_rw[3] = {0.3, -0.2, 1.0}, t_cr[3] = {0.1, 0.05, -0.2}, x[3] = {0.5, 0.7, 6.0};
  const double params[8] = {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002};
  ExpectGradientsMatch(cost, {q_rw.coeffs().data(), t_rw, q_cr.coeffs().data(), t_cr, x, params}, {0, 2});
}

}  // namespace
}  // namespace mmba::factors
