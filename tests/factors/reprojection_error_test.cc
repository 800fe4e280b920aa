#include "mmba/factors/reprojection_error.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <gtest/gtest.h>

namespace mmba::factors {
namespace {

using sensors::CameraModelId;
using sensors::EquirectangularModel;
using sensors::OpenCVModel;
using sensors::PhotogrammetricModel;
using sensors::PinholeModel;

TEST(ReprojectionError, HandComputedPinholeResidual) {
  // Identity pose, point (1, -0.5, 4): pixel (500·0.25 + 320, 510·(-0.125) + 240) =
  // (445, 176.25). Observed (444, 177.25), σ = 0.5 px -> r = (2, -2).
  std::unique_ptr<ceres::CostFunction> cost(
      ReprojectionError<PinholeModel>::Create(Eigen::Vector2d(444, 177.25), 0.5));
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 0}, x[3] = {1, -0.5, 4};
  const double params[4] = {500, 510, 320, 240};
  const double* blocks[4] = {q, t, x, params};
  double residuals[2];
  ASSERT_TRUE(cost->Evaluate(blocks, residuals, nullptr));
  EXPECT_NEAR(residuals[0], 2.0, 1e-12);
  EXPECT_NEAR(residuals[1], -2.0, 1e-12);
}

TEST(ReprojectionError, PointBehindTheCameraFailsTheEvaluation) {
  std::unique_ptr<ceres::CostFunction> cost(
      ReprojectionError<PinholeModel>::Create(Eigen::Vector2d(0, 0), 1.0));
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 0}, x[3] = {1, 1, -4};
  const double params[4] = {500, 510, 320, 240};
  const double* blocks[4] = {q, t, x, params};
  double residuals[2];
  EXPECT_FALSE(cost->Evaluate(blocks, residuals, nullptr));
}

template <typename CostPtr>
void CheckGradients(CostPtr& cost, const std::vector<const double*>& blocks) {
  ceres::EigenQuaternionManifold quaternion;
  std::vector<const ceres::Manifold*> manifolds(blocks.size(), nullptr);
  manifolds[0] = &quaternion;
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(cost.get(), &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(blocks.data(), 1e-6, &results)) << results.error_log;
}

TEST(ReprojectionError, GradientCheckOpenCV) {
  std::unique_ptr<ceres::CostFunction> cost(
      ReprojectionError<OpenCVModel>::Create(Eigen::Vector2d(300, 200), 1.5));
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const double t[3] = {0.3, -0.2, 1.0}, x[3] = {0.5, 0.7, 6.0};
  const double params[8] = {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002};
  CheckGradients(cost, {q.coeffs().data(), t, x, params});
}

TEST(ReprojectionError, GradientCheckPhotogrammetric) {
  // The C4040Z of DBAT's camcaldemo: c, xp, yp in mm, K1–K3, P1, P2, b1, b2, pixel pitch (mm).
  const double params[12] = {7.457, 3.615, 2.613, 3e-3, -1e-4, 2e-6, 1e-4, -2e-4, 1e-4, 0.0,
                             0.0031913, 0.0031913};
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.98, 0.05, -0.1, 0.02).normalized();
  const double t[3] = {0.3, -0.2, 1.0}, x[3] = {0.5, 0.7, 6.0};
  std::unique_ptr<ceres::CostFunction> cost(
      ReprojectionError<PhotogrammetricModel>::Create(Eigen::Vector2d(1500, 1100), 0.5));
  // The pitch is held (a property of the sensor), as ProblemBuilder holds it. Ridders' first
  // step is a fraction of the whole block's scale: 1e-2 of c would make P1 (1e-4 mm⁻¹) 0.3,
  // where the Newton inverse of the correction has no solution, so the steps start smaller.
  ceres::EigenQuaternionManifold quaternion;
  ceres::SubsetManifold pitch_held(12, {10, 11});
  const std::vector<const ceres::Manifold*> manifolds{&quaternion, nullptr, nullptr, &pitch_held};
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-4;
  ceres::GradientChecker checker(cost.get(), &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  const double* blocks[4] = {q.coeffs().data(), t, x, params};
  EXPECT_TRUE(checker.Probe(blocks, 1e-6, &results)) << results.error_log;
}

/// The chain-rule cost (Create) against autodiff of the functor over all parameters
/// (CreateAutoDiff): the same residual and Jacobians, with the camera's Jacobian requested and
/// without it (a held camera).
template <typename Model>
void ExpectChainRuleEqualsAutoDiff(const double* params) {
  const Eigen::Vector2d observed(300, 200);
  std::unique_ptr<ceres::CostFunction> chained(ReprojectionError<Model>::Create(observed, 1.5));
  std::unique_ptr<ceres::CostFunction> autodiff(ReprojectionError<Model>::CreateAutoDiff(observed, 1.5));
  // Not of unit norm: the functor rotates by Eigen's formula, the chain rule must follow it.
  const double q[4] = {0.05, -0.1, 0.02, 0.99}, t[3] = {0.3, -0.2, 1.0}, x[3] = {0.5, 0.7, 6.0};
  const double* blocks[4] = {q, t, x, params};
  const int n = Model::kNumParams;
  for (bool with_camera : {true, false}) {
    std::vector<std::vector<double>> ja{std::vector<double>(8), std::vector<double>(6), std::vector<double>(6),
                                        std::vector<double>(2 * n)};
    std::vector<std::vector<double>> jb = ja;
    double* pa[4] = {ja[0].data(), ja[1].data(), ja[2].data(), with_camera ? ja[3].data() : nullptr};
    double* pb[4] = {jb[0].data(), jb[1].data(), jb[2].data(), with_camera ? jb[3].data() : nullptr};
    double ra[2], rb[2];
    ASSERT_TRUE(chained->Evaluate(blocks, ra, pa));
    ASSERT_TRUE(autodiff->Evaluate(blocks, rb, pb));
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(ra[i], rb[i], 1e-12 * std::max(1.0, std::abs(rb[i]))) << Model::kName;
    for (int b = 0; b < (with_camera ? 4 : 3); ++b) {
      for (size_t k = 0; k < ja[b].size(); ++k) {
        EXPECT_NEAR(ja[b][k], jb[b][k], 1e-9 * std::max(1.0, std::abs(jb[b][k])))
            << Model::kName << " block " << b << " entry " << k;
      }
    }
  }
}

TEST(ReprojectionError, ChainRuleEqualsAutoDiffForEveryPerspectiveModel) {
  const double generic[12] = {500, 510, 320, 240, -0.05, 0.01, 0.001, -0.002, 0.001, 0.0005, 0.0002, -0.0001};
  const double one_focal[5] = {500, 320, 240, -0.05, 0.01};  // f, cx, cy, k1, k2
  ExpectChainRuleEqualsAutoDiff<sensors::SimplePinholeModel>(one_focal);
  ExpectChainRuleEqualsAutoDiff<sensors::PinholeModel>(generic);
  ExpectChainRuleEqualsAutoDiff<sensors::SimpleRadialModel>(one_focal);
  ExpectChainRuleEqualsAutoDiff<sensors::RadialModel>(one_focal);
  ExpectChainRuleEqualsAutoDiff<OpenCVModel>(generic);
  ExpectChainRuleEqualsAutoDiff<sensors::OpenCVFisheyeModel>(generic);
  ExpectChainRuleEqualsAutoDiff<sensors::FullOpenCVModel>(generic);
  const double fov[5] = {500, 510, 320, 240, 0.3};
  ExpectChainRuleEqualsAutoDiff<sensors::FOVModel>(fov);
  ExpectChainRuleEqualsAutoDiff<sensors::SimpleRadialFisheyeModel>(one_focal);
  ExpectChainRuleEqualsAutoDiff<sensors::RadialFisheyeModel>(one_focal);
  ExpectChainRuleEqualsAutoDiff<sensors::ThinPrismFisheyeModel>(generic);
  const double photogrammetric[12] = {7.457, 3.615, 2.613, 3e-3, -1e-4, 2e-6, 1e-4, -2e-4, 1e-4, 0.0,
                                      0.0031913, 0.0031913};
  ExpectChainRuleEqualsAutoDiff<PhotogrammetricModel>(photogrammetric);
}

TEST(SphericalReprojectionError, ZeroAtTheTruthAndAnAngleOnTheSphere) {
  const auto params = EquirectangularModel::DefaultParams(2000, 1000);  // f = 1000/π px/rad
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 0};
  const double x[3] = {2.0, -1.0, 3.0};
  double xy[2];
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), x, xy));
  std::unique_ptr<ceres::CostFunction> cost(SphericalReprojectionError<EquirectangularModel>::Create(
      Eigen::Vector2d(xy[0], xy[1]), 2.0, params.data()));
  const double* blocks[4] = {q, t, x, params.data()};
  double r[2];
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], 0.0, 1e-9);
  EXPECT_NEAR(r[1], 0.0, 1e-9);

  // On the equator one pixel of column is exactly 1/f rad: a point 3 px to the right
  // gives ‖r‖ = 3 px / σ.
  const double on_equator[3] = {0.0, 0.0, 5.0};
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), on_equator, xy));
  std::unique_ptr<ceres::CostFunction> shifted(
      SphericalReprojectionError<EquirectangularModel>::Create(
          Eigen::Vector2d(xy[0] - 3.0, xy[1]), 2.0, params.data()));
  const double* blocks2[4] = {q, t, on_equator, params.data()};
  ASSERT_TRUE(shifted->Evaluate(blocks2, r, nullptr));
  EXPECT_NEAR(std::hypot(r[0], r[1]), 1.5, 1e-9);
}

TEST(SphericalReprojectionError, SeamAndPoleAreHarmless) {
  const double width = 2000;
  const auto params = EquirectangularModel::DefaultParams(width, 1000);
  const double q[4] = {0, 0, 0, 1}, t[3] = {0, 0, 0};
  // Observed 0.2 px right of the left edge; the point projects 0.3 px left of the right
  // edge: the angular residual is 0.5 px, not W - 0.5.
  const double phi = M_PI - 0.3 / params[0];
  const double x[3] = {std::sin(phi), 0.0, std::cos(phi)};
  std::unique_ptr<ceres::CostFunction> cost(SphericalReprojectionError<EquirectangularModel>::Create(
      Eigen::Vector2d(0.2, 500), 1.0, params.data()));
  const double* blocks[4] = {q, t, x, params.data()};
  double r[2];
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(std::hypot(r[0], r[1]), 0.5, 1e-6);

  // At the zenith any column names the same direction: a point straight up observed at
  // row 0, column 1234 has zero residual.
  const double up[3] = {0.0, -4.0, 0.0};
  std::unique_ptr<ceres::CostFunction> pole(SphericalReprojectionError<EquirectangularModel>::Create(
      Eigen::Vector2d(1234, 0), 1.0, params.data()));
  const double* blocks3[4] = {q, t, up, params.data()};
  ASSERT_TRUE(pole->Evaluate(blocks3, r, nullptr));
  EXPECT_NEAR(std::hypot(r[0], r[1]), 0.0, 1e-9);
}

TEST(SphericalReprojectionError, GradientCheck) {
  const auto params = EquirectangularModel::DefaultParams(2000, 1000);
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, 0.3, -0.1).normalized();
  const double t[3] = {0.1, 0.2, -0.3}, x[3] = {-2.0, -1.0, -3.0};
  std::unique_ptr<ceres::CostFunction> cost(SphericalReprojectionError<EquirectangularModel>::Create(
      Eigen::Vector2d(400, 300), 1.0, params.data()));
  CheckGradients(cost, {q.coeffs().data(), t, x, params.data()});
}

TEST(CreateReprojectionCost, DispatchesEveryModel) {
  const double params[12] = {500, 510, 320, 240, 0.5, 0, 0, 0, 0, 0, 0, 0};
  for (CameraModelId id : {CameraModelId::kSimplePinhole, CameraModelId::kPinhole,
                           CameraModelId::kSimpleRadial, CameraModelId::kRadial,
                           CameraModelId::kOpenCV, CameraModelId::kOpenCVFisheye,
                           CameraModelId::kFullOpenCV, CameraModelId::kFOV,
                           CameraModelId::kSimpleRadialFisheye, CameraModelId::kRadialFisheye,
                           CameraModelId::kThinPrismFisheye, CameraModelId::kEquirectangular,
                           CameraModelId::kPhotogrammetric}) {
    std::unique_ptr<ceres::CostFunction> cost(
        CreateReprojectionCost(id, Eigen::Vector2d(1, 2), 1.0, params));
    ASSERT_NE(cost, nullptr);
    EXPECT_EQ(cost->parameter_block_sizes().back(), sensors::CameraModelNumParams(id))
        << static_cast<int>(id);
  }
  EXPECT_EQ(CreateReprojectionCost(CameraModelId::kInvalid, Eigen::Vector2d(1, 2), 1.0, params),
            nullptr);
}

}  // namespace
}  // namespace mmba::factors
