#include "mmba/registration/mi/lidar_image.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <random>

#include <gtest/gtest.h>

#include "synthetic_scene.h"

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

// The z-buffer against a brute-force one: for every pixel, the smallest key over the points
// whose footprint (radius = min(max, ⌊point_radius_m · f / range⌋)) covers it. Points near
// every edge and at every range (footprints of 1 to 2·max + 1 pixels: the fixed windows and,
// above radius 3, the row loop), duplicates for ties; one thread and two.
TEST(LidarImage, ZBufferEqualsTheBruteForceMinimumOverFootprints) {
  const int w = 61, h = 23;
  const double f = 30.0;
  const sensors::Camera camera = Pinhole(w, h, f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  LidarPoints points;
  for (int k = 0; k < 400; ++k) {
    const float z = 0.6f + 12.f * u(rng) * u(rng);
    const float x = (u(rng) * 1.2f - 0.6f) * (w / f) * z;  // a margin outside the image
    const float y = (u(rng) * 1.2f - 0.6f) * (h / f) * z;
    points.points_in_lidar.emplace_back(x, y, z);
    points.intensity01.push_back(u(rng));
    if (k % 7 == 0) {  // an equally near twin: a tie the rank decides
      points.points_in_lidar.emplace_back(x, y, z);
      points.intensity01.push_back(u(rng));
    }
  }
  for (int max_radius : {2, 6}) {
    RenderOptions options;
    options.max_point_radius_px = max_radius;
    options.point_radius_m = 0.2;
    std::vector<uint64_t> expected(static_cast<size_t>(w) * h, kEmptyZBufferKey);
    std::vector<int> radii(2 * max_radius + 1, 0);
    const float radius_factor = static_cast<float>(options.point_radius_m * f);
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3f p = points.points_in_lidar[i];
      const float range2 = p.squaredNorm();
      const double xy[2] = {f * (static_cast<double>(p.x()) / p.z()) + w / 2.0,
                            f * (static_cast<double>(p.y()) / p.z()) + h / 2.0};
      if (!(xy[0] >= 0 && xy[1] >= 0 && xy[0] < w && xy[1] < h)) continue;
      const float range = std::sqrt(range2);
      const int radius = std::min(max_radius, static_cast<int>(radius_factor / range));
      ++radii[radius];
      uint32_t bits;
      std::memcpy(&bits, &range, sizeof(bits));
      const uint64_t key = (static_cast<uint64_t>(bits) << 32) | static_cast<uint32_t>(i);
      for (int r = static_cast<int>(xy[1]) - radius; r <= static_cast<int>(xy[1]) + radius; ++r) {
        for (int c = static_cast<int>(xy[0]) - radius; c <= static_cast<int>(xy[0]) + radius;
             ++c) {
          if (r < 0 || c < 0 || r >= h || c >= w) continue;
          uint64_t& cell = expected[static_cast<size_t>(r) * w + c];
          cell = std::min(cell, key);
        }
      }
    }
    for (int radius = 0; radius <= max_radius; ++radius) {
      EXPECT_GT(radii[radius], 10) << "radius " << radius << " barely exercised";
    }
    for (bool two_threads : {false, true}) {
      SCOPED_TRACE(::testing::Message() << "max radius " << max_radius << ", two threads "
                                      << two_threads);
      LidarImage image;
      RenderLidarImage(points, ImageView(camera), Rigid3d(), options, &image, two_threads);
      ASSERT_GE(image.zbuffer.size(), expected.size());
      size_t covered = 0;
      for (size_t k = 0; k < expected.size(); ++k) {
        ASSERT_EQ(image.zbuffer[k], expected[k]) << "pixel " << k;
        covered += expected[k] != kEmptyZBufferKey;
      }
      EXPECT_EQ(image.covered_pixels, covered);
      EXPECT_GT(covered, expected.size() / 2);
      EXPECT_LT(covered, expected.size());
    }
  }
}

// The pinhole camera's block-wise projection (written out for the vectoriser) against the
// generic per-point path with Eigen's expressions: the same camera as OPENCV with zero
// distortion must give the same z-buffer, bit for bit (ranges, winners), at a rotated and
// shifted pose with points behind the camera, beside it and outside the range limits.
TEST(LidarImage, PinholeBlocksProjectAsTheGenericModel) {
  sensors::Camera pinhole = Pinhole(200, 150, 120.0);
  sensors::Camera opencv = pinhole;
  opencv.model_id = sensors::CameraModelId::kOpenCV;
  opencv.params = {120.0, 120.0, 100.0, 75.0, 0.0, 0.0, 0.0, 0.0};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  LidarPoints points;
  for (int k = 0; k < 20011; ++k) {  // not a multiple of the block
    points.points_in_lidar.emplace_back(30.f * u(rng), 20.f * u(rng), 40.f * u(rng) + 25.f);
    points.intensity01.push_back(0.5f + 0.5f * u(rng));
  }
  const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                     Eigen::Vector3d(0.7, -0.4, 1.3));
  RenderOptions options;
  options.max_range_m = 50.0;
  options.min_range_m = 2.0;
  for (bool two_threads : {false, true}) {
    LidarImage a, b;
    RenderLidarImage(points, ImageView(pinhole), pose, options, &a, two_threads);
    RenderLidarImage(points, ImageView(opencv), pose, options, &b, two_threads);
    ASSERT_GT(a.covered_pixels, 3000u);
    ASSERT_LT(a.covered_pixels, 25000u);
    EXPECT_EQ(a.covered_pixels, b.covered_pixels);
    for (size_t k = 0; k < a.point_index.size(); ++k) {
      ASSERT_EQ(a.zbuffer[k], b.zbuffer[k]) << "pixel " << k;
      ASSERT_EQ(a.offset_x[k], b.offset_x[k]) << "pixel " << k;
      ASSERT_EQ(a.offset_y[k], b.offset_y[k]) << "pixel " << k;
    }
  }
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

// Incidence correction: the synthetic street's intensity taken as the albedo ρ and measured
// by a scanner at the origin as ρ·cos^k θ (θ on the local plane; points without one at a
// fixed cos 0.5). The fitted exponent is k, for Lambert (k = 1) and a rougher surface (0.5),
// and the corrected values follow ρ again; for k = 0 (a scanner that already normalises)
// the values stay as they were; a cloud too small to fit is not corrected.
TEST(IncidenceCorrection, FitsTheExponentAndGivesTheAlbedoBack) {
  const io::PointCloud street = testing::StreetCloud(0.06);
  const std::vector<Eigen::Vector3f> normals =
      LocalPlaneNormals(PrepareLidarPoints(street).points_in_lidar, 0.5f);
  IncidenceCorrection correction;
  correction.scanner = [](size_t) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); };
  const auto cos_incidence = [&](size_t i) {
    if (normals[i].isZero()) return 0.5;
    return std::max(0.1, std::abs(normals[i].cast<double>().dot(street.points[i].normalized())));
  };
  // Correlation of two value lists over the points with a plane.
  const auto correlation = [&](const std::vector<float>& a, const std::vector<float>& b) {
    double n = 0, sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      if (normals[i].isZero()) continue;
      n += 1, sa += a[i], sb += b[i], saa += a[i] * a[i], sbb += b[i] * b[i], sab += a[i] * b[i];
    }
    return (sab - sa * sb / n) / std::sqrt((saa - sa * sa / n) * (sbb - sb * sb / n));
  };
  const std::vector<float> albedo = PrepareLidarPoints(street).intensity01;
  for (const double k : {1.0, 0.5, 0.0}) {
    io::PointCloud measured = street;
    for (size_t i = 0; i < measured.size(); ++i) {
      measured.intensity[i] = static_cast<float>(street.intensity[i] * std::pow(cos_incidence(i), k));
    }
    IncidenceFit fit;
    std::vector<Eigen::Vector3f> normals_out;
    const LidarPoints corrected = PrepareLidarPoints(measured, correction, &fit, &normals_out);
    const LidarPoints plain = PrepareLidarPoints(measured);
    EXPECT_NEAR(fit.exponent, k, 0.02) << "k " << k;
    EXPECT_GT(fit.points, street.size() / 2);
    EXPECT_EQ(normals_out, normals);
    EXPECT_GT(correlation(corrected.intensity01, albedo), 0.99) << "k " << k;
    if (k == 1.0) {
      EXPECT_LT(correlation(plain.intensity01, albedo), 0.9);  // what the correction is for
    }
    if (k == 0.0) {
      for (size_t i = 0; i < measured.size(); i += 7) {
        ASSERT_NEAR(corrected.intensity01[i], plain.intensity01[i], 0.02f) << "point " << i;
      }
    }
  }
  // Too few points with a plane to fit: the values as measured.
  io::PointCloud small;
  for (size_t i = 0; i < 500; ++i) {
    small.points.push_back(street.points[i * 97]);
    small.intensity.push_back(street.intensity[i * 97]);
  }
  IncidenceFit fit;
  EXPECT_EQ(PrepareLidarPoints(small, correction, &fit).intensity01, PrepareLidarPoints(small).intensity01);
  EXPECT_EQ(fit.exponent, 0.0);
}

// Surface classes: the synthetic street's ground (z = −1.8) is horizontal, its façades, end
// wall and boxes' fronts are not; a tilted frame (up not z) follows `up`. The encoding puts
// class 0 in [0, 0.4] and class 1 in [0.6, 1].
TEST(SurfaceClasses, GroundAgainstWalls) {
  const io::PointCloud cloud = testing::StreetCloud(0.06);
  const std::vector<uint8_t> classes = SurfaceClasses(
      std::vector<Eigen::Vector3f>(PrepareLidarPoints(cloud).points_in_lidar), Eigen::Vector3f::UnitZ(), 0.5f);
  ASSERT_EQ(classes.size(), cloud.size());
  size_t ground = 0, ground_right = 0, other = 0, other_right = 0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    // Ground points more than 0.5 m from a wall's foot, wall points more than 0.5 m above it
    // (a voxel at a foot holds both, and is neither plane).
    const Eigen::Vector3d& p = cloud.points[i];
    if (std::abs(p.z() + 1.8) < 0.02 && std::abs(std::abs(p.y()) - 6.0) > 0.5 && p.x() < 27.5 &&
        !(p.x() > 7.5 && p.x() < 8.5) && !(p.x() > 13.5 && p.x() < 14.5)) {
      ++ground;
      ground_right += classes[i] == 0;
    } else if (p.z() > -1.2) {
      ++other;
      other_right += classes[i] == 1;
    }
  }
  ASSERT_GT(ground, 1000u);
  ASSERT_GT(other, 1000u);
  EXPECT_GT(ground_right, 0.98 * ground);
  EXPECT_GT(other_right, 0.95 * other);
  // The same cloud turned 90° about x: the ground is now a wall of the frame whose up is y.
  std::vector<Eigen::Vector3f> turned;
  for (const Eigen::Vector3d& p : cloud.points) turned.emplace_back(p.x(), -p.z(), p.y());
  EXPECT_EQ(SurfaceClasses(turned, Eigen::Vector3f::UnitY(), 0.5f), classes);

  LidarPoints points = PrepareLidarPoints(cloud);
  const std::vector<float> before = points.intensity01;
  EncodeSurfaceClasses(classes, &points);
  for (size_t i = 0; i < classes.size(); i += 97) {
    EXPECT_EQ(std::floor(points.intensity01[i]), classes[i]);
    EXPECT_NEAR(points.intensity01[i] - classes[i], 0.999f * before[i], 1e-6f);
  }
}

// Orientation classes seen from the middle of the street (the origin): the ground faces up
// (0), the façade at y = 6 faces −y (azimuth −90°: with 4 sectors centred on 0°, 90°, 180°,
// −90°, class 2 + 3), the façade at y = −6 faces +y (class 2 + 1), the end wall at x = 28
// faces −x (class 2 + 2). Seen from beyond the end wall, that wall faces +x (class 2 + 0).
TEST(SurfaceClasses, OrientationTowardsTheViewpoint) {
  const io::PointCloud cloud = testing::StreetCloud(0.06);
  const std::vector<Eigen::Vector3f> points = PrepareLidarPoints(cloud).points_in_lidar;
  const std::vector<Eigen::Vector3f> normals = LocalPlaneNormals(points, 0.5f);
  const std::vector<uint8_t> classes =
      OrientationClasses(points, normals, Eigen::Vector3f::UnitZ(), Eigen::Vector3f::Zero(), 4);
  const std::vector<uint8_t> behind = OrientationClasses(
      points, normals, Eigen::Vector3f::UnitZ(), Eigen::Vector3f(40.f, 0.f, 0.f), 4);
  ASSERT_EQ(classes.size(), cloud.size());
  // Per part: points, right ones (from the middle), right ones (from behind the end wall).
  struct Part {
    int expected, expected_behind;
    size_t n = 0, right = 0, right_behind = 0;
  };
  Part ground{0, 0}, left{5, 5}, right{3, 3}, end{4, 2};
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    Part* part = nullptr;
    if (std::abs(p.z() + 1.8) < 0.02 && std::abs(std::abs(p.y()) - 6.0) > 0.5 && p.x() < 7.5) {
      part = &ground;
    } else if (p.z() > -1.2 && p.x() < 27.5 && std::abs(p.y() - 6.0) < 0.05) {
      part = &left;
    } else if (p.z() > -1.2 && p.x() < 27.5 && std::abs(p.y() + 6.0) < 0.05) {
      part = &right;
    } else if (p.z() > -1.2 && std::abs(p.x() - 28.0) < 0.05 && std::abs(p.y()) < 5.5) {
      part = &end;
    }
    if (part == nullptr) continue;
    ++part->n;
    part->right += classes[i] == part->expected;
    part->right_behind += behind[i] == part->expected_behind;
  }
  for (const Part* part : {&ground, &left, &right, &end}) {
    SCOPED_TRACE(part->expected);
    ASSERT_GT(part->n, 1000u);
    EXPECT_GT(part->right, 0.95 * part->n);
    EXPECT_GT(part->right_behind, 0.95 * part->n);
  }
  // No plane: isolated points.
  const std::vector<Eigen::Vector3f> scattered = {{0, 0, 0}, {5, 5, 5}, {-7, 2, 9}};
  EXPECT_EQ(OrientationClasses(scattered, LocalPlaneNormals(scattered, 0.5f),
                               Eigen::Vector3f::UnitZ(), Eigen::Vector3f::Zero(), 4),
            std::vector<uint8_t>(3, 6));
}

// A binary PGM of one row: maxval above 255 stores big-endian 16-bit values.
std::string WritePgm(const std::string& name, int maxval, const std::vector<int>& values) {
  const std::string path =
      (std::filesystem::temp_directory_path() / (name + std::to_string(::getpid()) + ".pgm")).string();
  std::ofstream out(path, std::ios::binary);
  out << "P5\n" << values.size() << " 1\n" << maxval << "\n";
  for (int v : values) {
    if (maxval > 255) out.put(static_cast<char>(v >> 8));
    out.put(static_cast<char>(v & 0xff));
  }
  return path;
}

// Deeper images come onto the metric's 0..255 by the sensor's range: a 12-bit camera's values
// (in 16 bits) are not divided by 256 into 16 grey levels, black stays black, the largest
// value the depth holds is 255; 8-bit images are read as they are.
TEST(ReadGrayImage, DeeperImagesBySensorRange) {
  struct Case {
    int maxval;
    std::vector<int> values;
    double full;  // the range the values are read against
  };
  for (const Case& c : {Case{255, {0, 10, 200, 255}, 255.0}, Case{4095, {0, 16, 2048, 4095}, 4095.0},
                        Case{4095, {0, 16, 300, 1000}, 1023.0},  // only 10 bits used
                        Case{65535, {0, 257, 32768, 65535}, 65535.0},
                        Case{65535, {0, 3, 100, 255}, 255.0}}) {  // 8-bit values in 16 bits
    SCOPED_TRACE(c.maxval);
    const std::string path = WritePgm("mmba_gray", c.maxval, c.values);
    const GrayImage image = ReadGrayImage(path);
    std::filesystem::remove(path);
    ASSERT_EQ(image.width, 4);
    ASSERT_EQ(image.height, 1);
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(image.at(i, 0), c.values[i] * 255.0 / c.full, 1e-4) << i;
    }
  }
}

}  // namespace
}  // namespace mmba::registration::mi
