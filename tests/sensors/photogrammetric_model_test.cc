#include "mmba/sensors/photogrammetric_model.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/sensors/camera.h"

namespace mmba::sensors {
namespace {

// DBAT 0.9.2's self-calibration of the Olympus C4040Z on its camcaldemo
// (data/dbat/camcaldemo/c4040z.xml): 8 % radial distortion at the corners.
Camera DbatC4040z() {
  Camera camera;
  camera.model_id = CameraModelId::kPhotogrammetric;
  camera.width = 2272;
  camera.height = 1704;
  const double pitch = 5.43764 / 1704;
  camera.params = {7.45699532273933752, 3.61546239970888994, 2.61329279848268081,
                   0.00458860662755811253, -4.51350997187018702e-05, -2.05253370760761127e-06,
                   -6.12803065099492536e-05, -4.41170561685059337e-05, 0.000389597677690423,
                   0, pitch, pitch};
  return camera;
}

// c = 10 mm, principal point (5, 4) mm, pitch 0.01 mm. Pixel (800, 200) is x̄ = 8 − 5 = 3 mm
// right of and ȳ = 4 − 2 = 2 mm above the principal point. r² = 13,
// K1 r² + K2 r⁴ = 1e-3·13 + 1e-5·169 = 0.01469,
// Δx = 3·0.01469 + 1e-4·(13 + 18) + 2·(−2e-4)·6 = 0.04477,
// Δy = 2·0.01469 + (−2e-4)·(13 + 8) + 2·1e-4·6 = 0.02638,
// ray = (3.04477 / 10, −2.02638 / 10, 1) (y down).
TEST(PhotogrammetricModel, HandComputedCorrection) {
  const double params[12] = {10, 5, 4, 1e-3, 1e-5, 0, 1e-4, -2e-4, 0, 0, 0.01, 0.01};
  double ray[3];
  PhotogrammetricModel::CamFromImg(params, 800.0, 200.0, ray);
  EXPECT_NEAR(ray[0], 0.304477, 1e-12);
  EXPECT_NEAR(ray[1], -0.202638, 1e-12);
  EXPECT_EQ(ray[2], 1.0);
  double xy[2];
  ASSERT_TRUE(PhotogrammetricModel::ImgFromCam(params, ray, xy));
  EXPECT_NEAR(xy[0], 800.0, 1e-9);
  EXPECT_NEAR(xy[1], 200.0, 1e-9);
  // K3: Δx gains x̄ K3 r⁶ = 3·1e-7·2197.
  const double with_k3[12] = {10, 5, 4, 1e-3, 1e-5, 1e-7, 1e-4, -2e-4, 0, 0, 0.01, 0.01};
  PhotogrammetricModel::CamFromImg(with_k3, 800.0, 200.0, ray);
  EXPECT_NEAR(ray[0], 0.304477 + 3e-7 * 2197 / 10, 1e-12);
}

// Affinity and shear act before the lens correction: x̂ = (1 + b1) x̄ + b2 ȳ = 1.01·3 + 0.02·2.
TEST(PhotogrammetricModel, HandComputedAffinity) {
  const double params[12] = {10, 5, 4, 0, 0, 0, 0, 0, 0.01, 0.02, 0.01, 0.01};
  double ray[3];
  PhotogrammetricModel::CamFromImg(params, 800.0, 200.0, ray);
  EXPECT_NEAR(ray[0], 0.307, 1e-12);
  EXPECT_NEAR(ray[1], -0.2, 1e-12);
}

// Pixels: x right, y down, origin at the image's top-left corner. The principal point images
// the axis; a point right of and below the axis lands right of and below it.
TEST(PhotogrammetricModel, PixelConvention) {
  const Camera camera = DbatC4040z();
  const auto axis = camera.ImgFromCam(Eigen::Vector3d(0, 0, 2));
  ASSERT_TRUE(axis.has_value());
  EXPECT_NEAR(axis->x(), camera.params[1] / camera.params[10], 1e-9);
  EXPECT_NEAR(axis->y(), camera.params[2] / camera.params[11], 1e-9);
  const auto right_below = camera.ImgFromCam(Eigen::Vector3d(0.3, 0.2, 2));
  ASSERT_TRUE(right_below.has_value());
  EXPECT_GT(right_below->x(), axis->x() + 100);
  EXPECT_GT(right_below->y(), axis->y() + 100);
}

// ImgFromCam ∘ CamFromImg over the whole image of a strongly distorted real calibration.
TEST(PhotogrammetricModel, RoundTripOverTheImage) {
  const Camera camera = DbatC4040z();
  double worst = 0;
  int checked = 0;
  for (int y = 0; y <= 1704; y += 24) {
    for (int x = 0; x <= 2272; x += 24) {
      const Eigen::Vector2d xy(x, y);
      const Eigen::Vector3d ray = camera.CamFromImg(xy);
      ASSERT_TRUE(ray.allFinite()) << x << " " << y;
      const auto back = camera.ImgFromCam(ray * 3.0);
      ASSERT_TRUE(back.has_value());
      worst = std::max(worst, (*back - xy).norm());
      ++checked;
    }
  }
  EXPECT_EQ(checked, 72 * 95);
  EXPECT_LT(worst, 1e-9);
}

TEST(PhotogrammetricModel, DispatchNamesAndParameterGroups) {
  const CameraModelId id = CameraModelFromName("PHOTOGRAMMETRIC");
  EXPECT_EQ(id, CameraModelId::kPhotogrammetric);
  EXPECT_EQ(CameraModelNumParams(id), 12);
  EXPECT_EQ(CameraModelParamNames(id),
            (std::vector<std::string>{"c", "xp", "yp", "K1", "K2", "K3", "P1", "P2", "b1", "b2",
                                      "pixel_width_mm", "pixel_height_mm"}));
  EXPECT_EQ(CameraModelParamIdx(id, "P2"), 7);
  EXPECT_EQ(CameraModelParamIdx(id, "k1"), -1);
  EXPECT_EQ(CameraModelFocalIdxs(id), std::vector<int>{0});
  EXPECT_EQ(CameraModelPrincipalIdxs(id), (std::vector<int>{1, 2}));
  EXPECT_EQ(CameraModelFixedIdxs(id), (std::vector<int>{10, 11}));
  EXPECT_EQ(CameraModelExtraIdxs(id), (std::vector<int>{3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(CameraModelFixedIdxs(CameraModelId::kOpenCV), std::vector<int>{});
  EXPECT_EQ(CameraModelParamNames(CameraModelId::kOpenCV),
            (std::vector<std::string>{"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"}));
  // c in pixels: 7.457 mm / 0.0031911 mm.
  EXPECT_NEAR(DbatC4040z().MeanFocalLength(), 7.45699532273933752 / (5.43764 / 1704), 1e-9);
}

TEST(PhotogrammetricModel, RejectsPointsBehindTheCamera) {
  const Camera camera = DbatC4040z();
  EXPECT_FALSE(camera.ImgFromCam(Eigen::Vector3d(0.1, 0.1, -1)).has_value());
}

}  // namespace
}  // namespace mmba::sensors
