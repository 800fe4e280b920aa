#include "mmba/sensors/camera_models.h"

#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "mmba/sensors/camera.h"

namespace mmba::sensors {
namespace {

// Typical parameters of each model (a 640×480 image; the panorama is 2000×1000).
std::vector<double> TypicalParams(CameraModelId id) {
  switch (id) {
    case CameraModelId::kSimplePinhole: return {500, 320, 240};
    case CameraModelId::kPinhole: return {500, 510, 320, 240};
    case CameraModelId::kSimpleRadial: return {500, 320, 240, -0.08};
    case CameraModelId::kRadial: return {500, 320, 240, -0.08, 0.01};
    case CameraModelId::kOpenCV: return {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002};
    case CameraModelId::kOpenCVFisheye: return {300, 305, 320, 240, 0.05, -0.01, 0.002, -0.001};
    case CameraModelId::kFullOpenCV:
      return {500, 510, 320, 240, -0.1, 0.02, 0.001, -0.002, 0.003, 0.01, -0.005, 0.001};
    case CameraModelId::kFOV: return {500, 510, 320, 240, 0.9};
    case CameraModelId::kSimpleRadialFisheye: return {300, 320, 240, 0.04};
    case CameraModelId::kRadialFisheye: return {300, 320, 240, 0.04, -0.01};
    case CameraModelId::kThinPrismFisheye:
      return {300, 305, 320, 240, 0.03, -0.01, 0.001, -0.002, 0.002, -0.001, 0.0005, -0.0004};
    // An EOS 5D Mark II (36 × 24 mm, 5616 × 3744 px, c = 24.5 mm) as DBAT calibrated it on
    // romabundledemo, with decentering, affinity and shear added.
    case CameraModelId::kPhotogrammetric:
      return {24.54, 18.08, 12.02, 2.2e-4, -1.9e-7, 1e-10, 1.5e-5, -2.5e-5, 3e-4, -1e-4,
              36.0 / 5616, 24.0 / 3744};
    case CameraModelId::kEquirectangular: {
      const auto p = EquirectangularModel::DefaultParams(2000, 1000);
      return {p[0], p[1], p[2]};
    }
    default: return {};
  }
}

// Points the model images well: for perspective models within ±40° of the axis, for the
// panorama all around (avoiding the exact poles).
std::vector<Eigen::Vector3d> GridPoints(bool spherical) {
  std::vector<Eigen::Vector3d> points;
  for (double az = -170; az <= 170; az += (spherical ? 20 : 8)) {
    for (double el = -70; el <= 70; el += (spherical ? 20 : 8)) {
      if (!spherical && (std::abs(az) > 40 || std::abs(el) > 30)) continue;
      const double a = az * M_PI / 180, e = el * M_PI / 180;
      const double range = 3.0 + 0.01 * (az + el + 200);
      points.emplace_back(range * std::cos(e) * std::sin(a), -range * std::sin(e),
                          range * std::cos(e) * std::cos(a));
    }
  }
  return points;
}

template <typename Model>
void CheckModel() {
  SCOPED_TRACE(Model::kName);
  const bool spherical = Model::kModelId == CameraModelId::kEquirectangular;
  const std::vector<double> params = TypicalParams(Model::kModelId);
  ASSERT_EQ(static_cast<int>(params.size()), Model::kNumParams);
  int checked = 0;
  for (const Eigen::Vector3d& point : GridPoints(spherical)) {
    double xy[2];
    ASSERT_TRUE(Model::ImgFromCam(params.data(), point.data(), xy));
    // Round trip: the ray of the pixel points at the point.
    double ray[3];
    Model::CamFromImg(params.data(), xy[0], xy[1], ray);
    const Eigen::Vector3d r(ray[0], ray[1], ray[2]);
    EXPECT_LT(r.normalized().cross(point.normalized()).norm(), 1e-9) << point.transpose();
    EXPECT_GT(r.dot(point), 0.0);

    // Jacobian sweep: Jets against central differences, w.r.t. point and parameters.
    using Jet = ceres::Jet<double, 3 + Model::kNumParams>;
    Jet point_jet[3];
    std::vector<Jet> params_jet(Model::kNumParams);
    for (int i = 0; i < 3; ++i) point_jet[i] = Jet(point[i], i);
    for (int i = 0; i < Model::kNumParams; ++i) params_jet[i] = Jet(params[i], 3 + i);
    Jet xy_jet[2];
    ASSERT_TRUE(Model::ImgFromCam(params_jet.data(), point_jet, xy_jet));
    EXPECT_NEAR(xy_jet[0].a, xy[0], 1e-9);
    for (int k = 0; k < 3 + Model::kNumParams; ++k) {
      std::vector<double> pp = params, pm = params;
      Eigen::Vector3d xp = point, xm = point;
      // PHOTOGRAMMETRIC's coefficients are tiny (K3 ~ 1e-10 mm^-6): a relative step, and the
      // difference quotient is then only as good as the pixels (~1e-11 px) over the step.
      const bool relative = Model::kModelId == CameraModelId::kPhotogrammetric;
      const double h = k < 3 ? 1e-6
                     : relative ? 1e-3 * std::abs(params[k - 3])
                                : 1e-7 * std::max(1.0, std::abs(params[k - 3]));
      const double noise = relative ? 2e-11 / h : 0.0;
      if (k < 3) {
        xp[k] += h;
        xm[k] -= h;
      } else {
        pp[k - 3] += h;
        pm[k - 3] -= h;
      }
      double yp[2], ym[2];
      ASSERT_TRUE(Model::ImgFromCam(pp.data(), xp.data(), yp));
      ASSERT_TRUE(Model::ImgFromCam(pm.data(), xm.data(), ym));
      for (int c = 0; c < 2; ++c) {
        const double numeric = (yp[c] - ym[c]) / (2 * h);
        EXPECT_NEAR(xy_jet[c].v[k], numeric, 1e-4 * std::max(1.0, std::abs(numeric)) + noise)
            << "component " << c << " derivative " << k << " at " << point.transpose();
      }
    }
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(CameraModels, RoundTripAndJacobians) {
#define MMBA_CHECK(Model) CheckModel<Model>();
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CHECK)
#undef MMBA_CHECK
}

TEST(CameraModels, PerspectiveRejectsPointsBehind) {
  const std::vector<double> params = TypicalParams(CameraModelId::kPinhole);
  const double behind[3] = {0.1, 0.2, -1.0};
  double xy[2] = {-7, -7};
  EXPECT_FALSE(PinholeModel::ImgFromCam(params.data(), behind, xy));
  EXPECT_EQ(xy[0], -7);
}

TEST(CameraModels, PinholeHandComputed) {
  const double params[4] = {500, 510, 320, 240};
  const double point[3] = {1.0, -0.5, 4.0};
  double xy[2];
  ASSERT_TRUE(PinholeModel::ImgFromCam(params, point, xy));
  EXPECT_DOUBLE_EQ(xy[0], 500 * 0.25 + 320);
  EXPECT_DOUBLE_EQ(xy[1], 510 * -0.125 + 240);
}

// Eq. (5)-(6) of Wang et al. 2012 in the camera frame (x right, y down, z forward):
// the centre column looks forward, the top row up, the column grows to the right.
TEST(CameraModels, EquirectangularMatchesThePaperMapping) {
  const double width = 2000, height = 1000;
  const auto params = EquirectangularModel::DefaultParams(width, height);
  double xy[2];
  const double forward[3] = {0, 0, 5};
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), forward, xy));
  EXPECT_NEAR(xy[0], width / 2, 1e-9);
  EXPECT_NEAR(xy[1], height / 2, 1e-9);
  const double right[3] = {2, 0, 0};
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), right, xy));
  EXPECT_NEAR(xy[0], 0.75 * width, 1e-9);
  const double up[3] = {0, -3, 1e-9};
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), up, xy));
  EXPECT_NEAR(xy[1], 0.0, 1e-6);
  // 45° above the horizon, 90° left: θ = 45°, φ = -90° -> r = H/4, c = W/4.
  const double up_left[3] = {-1, -1, 0};
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), up_left, xy));
  EXPECT_NEAR(xy[0], width / 4, 1e-9);
  EXPECT_NEAR(xy[1], height / 4, 1e-9);
  // Just either side of the seam behind the camera: columns near 0 and near W.
  const double behind_left[3] = {-1e-3, 0, -1}, behind_right[3] = {1e-3, 0, -1};
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), behind_left, xy));
  EXPECT_LT(xy[0], 1.0);
  ASSERT_TRUE(EquirectangularModel::ImgFromCam(params.data(), behind_right, xy));
  EXPECT_GT(xy[0], width - 1.0);
  const double origin[3] = {0, 0, 0};
  EXPECT_FALSE(EquirectangularModel::ImgFromCam(params.data(), origin, xy));
}

TEST(Camera, RuntimeDispatchAndNames) {
  EXPECT_EQ(CameraModelFromName("OPENCV_FISHEYE"), CameraModelId::kOpenCVFisheye);
  EXPECT_EQ(CameraModelFromName("PINHOL"), CameraModelId::kInvalid);
  EXPECT_EQ(CameraModelFromInt(6), CameraModelId::kFullOpenCV);
  EXPECT_EQ(CameraModelFromInt(42), CameraModelId::kInvalid);
  EXPECT_EQ(CameraModelNumParams(CameraModelId::kOpenCV), 8);
  EXPECT_EQ(CameraModelExtraIdxs(CameraModelId::kOpenCV), (std::vector<int>{4, 5, 6, 7}));
  EXPECT_EQ(CameraModelExtraIdxs(CameraModelId::kEquirectangular), std::vector<int>{});
  Camera camera;
  camera.model_id = CameraModelId::kSimpleRadial;
  camera.params = {500, 320, 240, -0.05};
  const auto xy = camera.ImgFromCam(Eigen::Vector3d(0.3, 0.1, 2.0));
  ASSERT_TRUE(xy.has_value());
  const Eigen::Vector3d ray = camera.CamFromImg(*xy);
  EXPECT_NEAR(ray.x(), 0.15, 1e-9);
  EXPECT_NEAR(ray.y(), 0.05, 1e-9);
  EXPECT_FALSE(camera.ImgFromCam(Eigen::Vector3d(0, 0, -1)).has_value());
}

// A fisheye whose image corners lie beyond 90° from its axis (equidistant, f = 100 px on a
// 400×400 image: the corner is 283 px = 2.83 rad from the centre): a perspective model's ray
// (u, v, 1) cannot point there, so the corner's ray is NaN, while a pixel 80° off the axis gets
// a ray that images back to it.
TEST(Camera, FisheyePixelsBeyondNinetyDegreesHaveNoRay) {
  Camera camera;
  camera.model_id = CameraModelId::kOpenCVFisheye;
  camera.width = 400;
  camera.height = 400;
  camera.params = {100, 100, 200, 200, 0, 0, 0, 0};
  EXPECT_FALSE(camera.CamFromImg(Eigen::Vector2d(2, 2)).allFinite());
  EXPECT_FALSE(camera.CamFromImg(Eigen::Vector2d(200 + 100 * M_PI * 0.55, 200)).allFinite());
  const Eigen::Vector2d inside(200 + 100 * 80.0 * M_PI / 180.0, 200);
  const Eigen::Vector3d ray = camera.CamFromImg(inside);
  ASSERT_TRUE(ray.allFinite());
  EXPECT_NEAR(std::acos(ray.normalized().z()), 80.0 * M_PI / 180.0, 1e-9);
  const auto back = camera.ImgFromCam(ray);
  ASSERT_TRUE(back.has_value());
  EXPECT_LT((*back - inside).norm(), 1e-6);
}

// Real calibrations with strong distortion keep a ray for every pixel of their image: the
// domain check of CamFromImg (its ray images back within 0.01 px) must not cut off the corners
// of an ordinary lens. The OpenCV sample's left camera (data/SOURCES.md's chessboard row:
// k1 -0.266, k3 +0.238, FULL_OPENCV), the Balbianello photos' SIMPLE_RADIAL (data/colmap) and
// a wide fisheye (OPENCV_FISHEYE, 75° at the corner), every 4th pixel of each image.
TEST(Camera, StronglyDistortedRealCalibrationsHaveARayForEveryPixel) {
  std::vector<Camera> cameras(3);
  cameras[0].model_id = CameraModelId::kFullOpenCV;
  cameras[0].width = 640;
  cameras[0].height = 480;
  cameras[0].params = {535.91573396163199, 535.91573396163199, 342.28315473308373,
                       235.57082909788173, -0.26637260909660682, -0.038588898922304653,
                       0.0017831947042852964, -0.00028122100441115472, 0.23839153080878486,
                       0, 0, 0};
  cameras[1].model_id = CameraModelId::kSimpleRadial;
  cameras[1].width = 640;
  cameras[1].height = 427;
  cameras[1].params = {528.84624146002591, 320, 213.5, -0.1069875854982123};
  cameras[2].model_id = CameraModelId::kOpenCVFisheye;
  cameras[2].width = 1920;
  cameras[2].height = 1080;
  cameras[2].params = {841, 841, 960, 540, 0.02, -0.01, 0.003, -0.001};
  for (const Camera& camera : cameras) {
    int missing = 0;
    double worst = 0;
    for (int y = 0; y <= static_cast<int>(camera.height); y += 4) {
      for (int x = 0; x <= static_cast<int>(camera.width); x += 4) {
        const Eigen::Vector2d xy(x, y);
        const Eigen::Vector3d ray = camera.CamFromImg(xy);
        if (!ray.allFinite()) {
          ++missing;
          continue;
        }
        const auto back = camera.ImgFromCam(ray);
        ASSERT_TRUE(back.has_value());
        worst = std::max(worst, (*back - xy).norm());
      }
    }
    EXPECT_EQ(missing, 0) << CameraModelName(camera.model_id);
    EXPECT_LT(worst, 1e-6) << CameraModelName(camera.model_id);
  }
}

}  // namespace
}  // namespace mmba::sensors
