#include "mmba/registration/mi/lidar_image.h"

#include <cmath>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::registration::mi {
namespace {

sensors::Camera Pinhole(int w, int h, double f) {
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kPinhole;
  camera.width = w;
  camera.height = h;
  camera.params = {f, f, w / 2.0, h / 2.0};
  return camera;
}

View ImageView(const sensors::Camera& camera) {
  View view;
  view.camera = camera;
  view.image = GrayImage(static_cast<int>(camera.width), static_cast<int>(camera.height));
  return view;
}

TEST(LidarImage, PointLandsWhereTheCameraProjectsIt) {
  const sensors::Camera camera = Pinhole(100, 80, 50.0);
  LidarPoints points;
  points.points_in_lidar = {Eigen::Vector3f(1.0f, -0.5f, 10.0f)};
  points.intensity01 = {0.75f};
  RenderOptions options;
  options.point_radius_m = 0;  // one pixel
  LidarImage out;
  RenderLidarImage(points, ImageView(camera), Rigid3d(), options, &out);
  // x = 50·0.1 + 50 = 55, y = 50·(−0.05) + 40 = 37.5 → pixel (55, 37).
  ASSERT_EQ(out.covered_pixels, 1u);
  EXPECT_EQ(out.point_index[37 * 100 + 55], 0);
  EXPECT_FLOAT_EQ(out.value[37 * 100 + 55], 0.75f);
  EXPECT_NEAR(out.offset_x[37 * 100 + 55], 55.0 - 55.5, 1e-5);
  EXPECT_NEAR(out.offset_y[37 * 100 + 55], 37.5 - 37.5, 1e-5);
  // Behind the camera: nothing.
  points.points_in_lidar[0].z() = -10.f;
  RenderLidarImage(points, ImageView(camera), Rigid3d(), options, &out);
  EXPECT_EQ(out.covered_pixels, 0u);
}

TEST(LidarImage, ZBufferHidesTheFarSideOfAWall) {
  const sensors::Camera camera = Pinhole(120, 120, 60.0);
  LidarPoints points;
  // Far wall at z = 12 (intensity 0.9), near wall at z = 4 covering |x|,|y| <= 1 (0.1),
  // far sampled at 5 cm, near at 15 cm (2.25 px apart): the near wall's footprints must hide
  // every far point behind it.
  for (float x = -4; x <= 4; x += 0.05f) {
    for (float y = -4; y <= 4; y += 0.05f) {
      points.points_in_lidar.emplace_back(x, y, 12.f);
      points.intensity01.push_back(0.9f);
    }
  }
  for (float x = -1; x <= 1.01f; x += 0.15f) {
    for (float y = -1; y <= 1.01f; y += 0.15f) {
      points.points_in_lidar.emplace_back(x, y, 4.f);
      points.intensity01.push_back(0.1f);
    }
  }
  RenderOptions options;
  options.point_radius_m = 0.03;  // at 4 m: 0.45 px -> radius 0: the far wall leaks
  options.max_point_radius_px = 3;
  LidarImage leaky;
  RenderLidarImage(points, ImageView(camera), Rigid3d(), options, &leaky);
  options.point_radius_m = 0.1;   // at 4 m: 1.5 px -> radius 1: 3x3 footprints close gaps
  LidarImage solid;
  RenderLidarImage(points, ImageView(camera), Rigid3d(), options, &solid);
  // The near wall covers x, y in 60 ± 15 px; look inside with a margin.
  // (1.01 in the loops: float steps of 0.15 reach 1.0 only approximately.)
  int far_inside_leaky = 0, far_inside_solid = 0, near_inside = 0;
  for (int r = 48; r < 72; ++r) {
    for (int c = 48; c < 72; ++c) {
      far_inside_leaky += leaky.value[r * 120 + c] > 0.5f;
      far_inside_solid += solid.value[r * 120 + c] > 0.5f;
      near_inside += std::abs(solid.value[r * 120 + c] - 0.1f) < 1e-6f;
    }
  }
  EXPECT_GT(far_inside_leaky, 10);  // without footprints the far wall shows through
  EXPECT_EQ(far_inside_solid, 0);
  EXPECT_EQ(near_inside, 24 * 24);
}

// LidarPoints::tie_rank: points stored in another order render the image of the ranked
// order, also where equally near points compete for a pixel (duplicates with different
// intensities: without the rank, the reversed order would let the other duplicate win).
TEST(LidarImage, TieRankKeepsTheWinnersOfTheRankedOrder) {
  const sensors::Camera camera = Pinhole(60, 40, 30.0);
  LidarPoints cloud_order;
  for (float x = -1.5f; x <= 1.5f; x += 0.1f) {
    for (float y = -1.f; y <= 1.f; y += 0.1f) {
      // Two points at the same place (equal range), different intensities.
      cloud_order.points_in_lidar.emplace_back(x, y, 3.f);
      cloud_order.intensity01.push_back(0.2f);
      cloud_order.points_in_lidar.emplace_back(x, y, 3.f);
      cloud_order.intensity01.push_back(0.8f);
    }
  }
  RenderOptions options;
  options.point_radius_m = 0.1;  // overlapping footprints: many ties between neighbours too
  LidarImage expected;
  RenderLidarImage(cloud_order, ImageView(camera), Rigid3d(), options, &expected);
  // Reversed storage order, each point ranked by its cloud-order position.
  const uint32_t n = static_cast<uint32_t>(cloud_order.size());
  LidarPoints reversed;
  for (uint32_t j = 0; j < n; ++j) {
    const uint32_t k = n - 1 - j;
    reversed.points_in_lidar.push_back(cloud_order.points_in_lidar[k]);
    reversed.intensity01.push_back(cloud_order.intensity01[k]);
    reversed.tie_rank.push_back(k);
  }
  reversed.index_of_rank.resize(n);
  for (uint32_t j = 0; j < n; ++j) reversed.index_of_rank[reversed.tie_rank[j]] = j;
  LidarImage ranked;
  RenderLidarImage(reversed, ImageView(camera), Rigid3d(), options, &ranked);
  ASSERT_GT(expected.covered_pixels, 500u);
  EXPECT_EQ(ranked.covered_pixels, expected.covered_pixels);
  int lower_intensity_winners = 0;
  for (size_t k = 0; k < expected.value.size(); ++k) {
    ASSERT_EQ(ranked.value[k], expected.value[k]) << "pixel " << k;
    ASSERT_EQ(ranked.depth[k], expected.depth[k]) << "pixel " << k;
    ASSERT_EQ(ranked.offset_x[k], expected.offset_x[k]) << "pixel " << k;
    ASSERT_EQ(ranked.offset_y[k], expected.offset_y[k]) << "pixel " << k;
    if (expected.point_index[k] < 0) {
      ASSERT_EQ(ranked.point_index[k], -1);
    } else {
      ASSERT_EQ(ranked.point_index[k], static_cast<int>(n - 1 - expected.point_index[k]));
      lower_intensity_winners += expected.value[k] == 0.2f;
    }
  }
  // The cloud order's first duplicate (0.2) wins every tie.
  EXPECT_EQ(lower_intensity_winners, static_cast<int>(expected.covered_pixels));
  // Without the rank, the reversed storage lets the other duplicate win.
  reversed.tie_rank.clear();
  reversed.index_of_rank.clear();
  LidarImage unranked;
  RenderLidarImage(reversed, ImageView(camera), Rigid3d(), options, &unranked);
  int differing = 0;
  for (size_t k = 0; k < expected.value.size(); ++k) differing += unranked.value[k] != expected.value[k];
  EXPECT_GT(differing, 500);
}

TEST(LidarImage, PerspectiveCutOfAPanoramaLooksWhereItShould) {
  sensors::Camera pano;
  pano.model_id = sensors::CameraModelId::kEquirectangular;
  pano.width = 720;
  pano.height = 360;
  const auto p = sensors::EquirectangularModel::DefaultParams(720, 360);
  pano.params.assign(p.begin(), p.end());
  GrayImage image(720, 360);
  for (int r = 0; r < 360; ++r) {
    for (int c = 0; c < 720; ++c) image.at(c, r) = static_cast<float>(c % 256);
  }
  ViewOptions options;
  options.kind = ViewKind::kPerspective;
  options.perspective_width = 100;
  options.perspective_height = 60;
  options.perspective_yaw_deg = {90.0};
  const std::vector<View> views = MakeViews(image, pano, options, "pano.png");
  ASSERT_EQ(views.size(), 1u);
  // The view's centre looks 90° right: panorama column cx + f·π/2 = 360 + 180 = 540.
  const float centre = views[0].image.at(50, 30);
  EXPECT_NEAR(centre, 540 % 256, 2.0);  // pixel centre is half a pixel off the axis
  // A point 90° right of the panorama centre renders at the view's centre.
  LidarPoints points;
  points.points_in_lidar = {Eigen::Vector3f(10.f, 0.f, 0.f)};
  points.intensity01 = {1.f};
  RenderOptions render;
  render.point_radius_m = 0;
  LidarImage out;
  RenderLidarImage(points, views[0], Rigid3d(), render, &out);
  ASSERT_EQ(out.covered_pixels, 1u);
  EXPECT_EQ(out.point_index[30 * 100 + 50], 0);
  // Cube: four faces; the whole panorama renders a point behind the camera.
  options.kind = ViewKind::kCube;
  options.cube_face_size = 32;
  EXPECT_EQ(MakeViews(image, pano, options, "pano.png").size(), 4u);
  options.kind = ViewKind::kImage;
  const std::vector<View> whole = MakeViews(image, pano, options, "pano.png");
  points.points_in_lidar = {Eigen::Vector3f(0.f, 0.f, -10.f)};
  RenderLidarImage(points, whole[0], Rigid3d(), render, &out);
  EXPECT_EQ(out.covered_pixels, 1u);
  // A perspective cut needs a panorama.
  options.kind = ViewKind::kPerspective;
  EXPECT_THROW(MakeViews(GrayImage(100, 80), Pinhole(100, 80, 50), options, "photo.png"),
               InputError);
}

TEST(LidarImage, CutPixelsAreCountedInPanoramaPixels) {
  sensors::Camera pano;
  pano.model_id = sensors::CameraModelId::kEquirectangular;
  pano.width = 720;
  pano.height = 360;
  const auto p = sensors::EquirectangularModel::DefaultParams(720, 360);
  pano.params.assign(p.begin(), p.end());
  ViewOptions options;
  options.kind = ViewKind::kPerspective;
  options.perspective_width = 400;  // 90°: f = 200 cut px/rad against 720/2π = 114.6
  options.perspective_height = 200;
  options.perspective_yaw_deg = {0.0};
  const std::vector<View> views = MakeViews(GrayImage(720, 360), pano, options, "pano.png");
  ASSERT_EQ(views.size(), 1u);
  EXPECT_NEAR(views[0].image_pixels_per_pixel, (720 / (2 * M_PI)) / 200.0, 1e-9);
  EXPECT_NEAR(DownsampleView(views[0]).image_pixels_per_pixel,
              2 * views[0].image_pixels_per_pixel, 1e-12);
  options.kind = ViewKind::kImage;
  EXPECT_EQ(MakeViews(GrayImage(720, 360), pano, options, "pano.png")[0].image_pixels_per_pixel,
            1.0);
}

TEST(LidarImage, HeadingsFollowTheLidar) {
  sensors::Camera pano;
  pano.model_id = sensors::CameraModelId::kEquirectangular;
  pano.width = 360;
  pano.height = 180;
  const auto p = sensors::EquirectangularModel::DefaultParams(360, 180);
  pano.params.assign(p.begin(), p.end());
  // A wall 5 m to the left of the camera (x = −5, camera x right, z forward) and a smaller
  // one behind it: the best cut looks left (−90°), the second behind (±180°); the ground
  // alone would give nothing.
  LidarPoints points;
  for (float y = -3; y <= 3; y += 0.05f) {
    for (float z = -6; z <= 6; z += 0.05f) points.points_in_lidar.emplace_back(-5.f, y, z);
    for (float x = -2; x <= 2; x += 0.05f) points.points_in_lidar.emplace_back(x, y, -5.f);
  }
  ViewOptions options;
  options.kind = ViewKind::kPerspective;
  RenderOptions render;
  render.representation = Representation::kPoints;
  const std::vector<double> headings =
      SelectPerspectiveHeadings(points, pano, Rigid3d(), options, render, 2);
  ASSERT_EQ(headings.size(), 2u);
  EXPECT_NEAR(headings[0], -90.0, 1e-9);
  EXPECT_NEAR(std::abs(headings[1]), 180.0, 1e-9);
}

TEST(LidarImage, DownsampledViewProjectsAtHalfTheCoordinates) {
  const View view = ImageView(Pinhole(100, 80, 50.0));
  const View half = DownsampleView(view);
  EXPECT_EQ(half.camera.width, 50u);
  EXPECT_EQ(half.camera.height, 40u);
  const Eigen::Vector3d point(1.0, -0.5, 10.0);
  const Eigen::Vector2d full_xy = *view.camera.ImgFromCam(point);
  const Eigen::Vector2d half_xy = *half.camera.ImgFromCam(point);
  EXPECT_NEAR(half_xy.x(), full_xy.x() / 2, 1e-12);
  EXPECT_NEAR(half_xy.y(), full_xy.y() / 2, 1e-12);
}

TEST(LidarImage, IntensityIsStretchedBetweenPercentiles) {
  io::PointCloud cloud;
  for (int i = 0; i < 1000; ++i) {
    cloud.points.emplace_back(i, 0, 0);
    cloud.intensity.push_back(i == 999 ? 1e6f : static_cast<float>(i));  // one specular
  }
  const LidarPoints points = PrepareLidarPoints(cloud);
  ASSERT_TRUE(points.has_intensity());
  EXPECT_FLOAT_EQ(points.intensity01[999], 1.f);
  EXPECT_NEAR(points.intensity01[500], 0.5, 0.02);  // not crushed by the outlier
  cloud.intensity.clear();
  EXPECT_FALSE(PrepareLidarPoints(cloud).has_intensity());
}

}  // namespace
}  // namespace mmba::registration::mi
