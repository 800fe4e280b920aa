// Initial orientation on a simulated network with exact truth: space resection, forward
// intersection, relative orientation and the growing block, with blunders that must be found
// and reported by image and point.
#include "mmba/orientation/block_initialisation.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/orientation/intersection.h"
#include "mmba/orientation/relative_orientation.h"
#include "mmba/orientation/resection.h"

namespace mmba::orientation {
namespace {

/// 10 images on a ring of radius 6 m, 2 m up, looking at the origin; 150 points in a 4 × 4 m
/// patch with ±0.5 m relief; an OPENCV camera with distortion, 2000 × 1500 px.
struct Network {
  sensors::Camera camera;
  std::map<std::string, Rigid3d> poses;
  std::map<std::string, Eigen::Vector3d> points;
  std::vector<BlockMeasurement> measurements;

  Network() {
    camera.model_id = sensors::CameraModelId::kOpenCV;
    camera.width = 2000;
    camera.height = 1500;
    camera.params = {1800, 1800, 1000, 750, -0.05, 0.01, 0.001, -0.0005};
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-2, 2), h(-0.5, 0.5);
    for (int i = 0; i < 150; ++i) points["P" + std::to_string(i)] = Eigen::Vector3d(u(rng), u(rng), h(rng));
    for (int k = 0; k < 10; ++k) {
      const double a = 2 * M_PI * k / 10;
      const Eigen::Vector3d centre(6 * std::cos(a), 6 * std::sin(a), 4.0);
      const Eigen::Vector3d z = (-centre).normalized();
      const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
      Eigen::Matrix3d r;  // rows: camera axes in the world
      r.row(0) = x;
      r.row(1) = z.cross(x);
      r.row(2) = z;
      poses[std::to_string(k + 1)] = Rigid3d(Eigen::Quaterniond(r), -r * centre);
    }
    for (const auto& [image, pose] : poses) {
      for (const auto& [id, p] : points) {
        const auto xy = camera.ImgFromCam(pose * p);
        if (xy && xy->x() > 0 && xy->y() > 0 && xy->x() < 2000 && xy->y() < 1500) measurements.push_back({image, id, *xy});
      }
    }
  }
  BlockInput Input(int control) const {
    BlockInput in;
    in.camera = &camera;
    for (const auto& [image, pose] : poses) in.images.push_back(image);
    in.measurements = measurements;
    for (int i = 0; i < control; ++i) in.control["P" + std::to_string(i)] = points.at("P" + std::to_string(i));
    return in;
  }
};

TEST(Resection, ExactAndWithBlunders) {
  const Network n;
  std::vector<Eigen::Vector2d> xy;
  std::vector<Eigen::Vector3d> xyz;
  for (const BlockMeasurement& m : n.measurements) {
    if (m.image_id != "3") continue;
    xy.push_back(m.xy_px);
    xyz.push_back(n.points.at(m.point_id));
  }
  ASSERT_GT(xy.size(), 50u);
  xy[4] += Eigen::Vector2d(40, -25);  // blunders
  xy[9] += Eigen::Vector2d(-15, 12);
  const ResectionResult r = Resect(n.camera, xy, xyz, ResectionOptions{});
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_FALSE(r.inlier[4]);
  EXPECT_FALSE(r.inlier[9]);
  EXPECT_EQ(r.num_inliers(), xy.size() - 2);
  EXPECT_LT(RotationDifferenceRad(r.cam_from_world, n.poses.at("3")), 1e-8);
  EXPECT_LT(TranslationDifference(r.cam_from_world, n.poses.at("3")), 1e-8);
  EXPECT_LT(r.rms_px, 1e-6);
  const ResectionResult few = Resect(n.camera, {xy[0], xy[1], xy[2]}, {xyz[0], xyz[1], xyz[2]}, ResectionOptions{});
  EXPECT_FALSE(few.ok);
  EXPECT_EQ(few.reason, "3 points of known coordinates, 4 needed");
}

TEST(Intersection, ExactFromTwoAndMoreRays) {
  const Network n;
  const Eigen::Vector3d truth = n.points.at("P17");
  std::vector<Ray> rays;
  for (const auto& [image, pose] : n.poses) {
    const auto xy = n.camera.ImgFromCam(pose * truth);
    if (xy) rays.push_back({&n.camera, pose, *xy});
  }
  ASSERT_GE(rays.size(), 3u);
  const IntersectionResult r = Intersect(rays, 2.0);
  ASSERT_TRUE(r.ok);
  EXPECT_LT((r.point_in_world - truth).norm(), 1e-9);
  EXPECT_LT(r.max_error_px, 1e-6);
  const IntersectionResult two = Intersect({rays[0], rays[1]}, 2.0);
  EXPECT_LT((two.point_in_world - truth).norm(), 1e-9);
  const IntersectionResult narrow = Intersect({rays[0], rays[1]}, 60.0);  // rays 36° apart
  EXPECT_FALSE(narrow.ok);
}

TEST(RelativeOrientation, RecoversRotationAndBaseDirection) {
  const Network n;
  std::vector<Eigen::Vector2d> a, b;
  for (const auto& [id, p] : n.points) {
    const auto xa = n.camera.ImgFromCam(n.poses.at("1") * p), xb = n.camera.ImgFromCam(n.poses.at("2") * p);
    if (xa && xb) a.push_back(*xa), b.push_back(*xb);
  }
  const RelativeOrientationResult r = RelativeOrientation(n.camera, n.camera, a, b, 1.0);
  ASSERT_TRUE(r.ok) << r.reason;
  const Rigid3d truth = n.poses.at("2") * n.poses.at("1").Inverse();
  EXPECT_LT(RotationDifferenceRad(r.cam2_from_cam1, truth), 1e-6);
  EXPECT_LT((r.cam2_from_cam1.translation - truth.translation.normalized()).norm(), 1e-6);
}

TEST(InitialiseBlock, FromControlWithBlunders) {
  Network n;
  n.measurements[30].xy_px += Eigen::Vector2d(50, 0);   // a blunder of a point
  n.measurements[200].xy_px += Eigen::Vector2d(0, -35);
  n.measurements.push_back({"4", "LONE", {500, 500}});  // measured in one image only
  const BlockResult r = InitialiseBlock(n.Input(8), BlockOptions{});
  EXPECT_EQ(r.frame, "control");
  ASSERT_EQ(r.cam_from_world.size(), 10u);
  for (const auto& [image, pose] : r.cam_from_world) {
    EXPECT_LT(TranslationDifference(pose, n.poses.at(image)), 1e-6) << image;
  }
  for (const auto& [id, p] : n.points) {
    ASSERT_TRUE(r.points.count(id)) << id;
    EXPECT_LT((r.points.at(id) - p).norm(), 1e-6) << id;
  }
  std::set<std::pair<std::string, std::string>> found;
  for (const InitialOutlier& o : r.outliers) found.insert({o.image_id, o.point_id});
  EXPECT_TRUE(found.count({n.measurements[30].image_id, n.measurements[30].point_id}));
  EXPECT_TRUE(found.count({n.measurements[200].image_id, n.measurements[200].point_id}));
  EXPECT_EQ(found.size(), 2u);
  EXPECT_EQ(r.failed_points.at("LONE"), "measured in one image only (image 4)");
}

TEST(InitialiseBlock, WithoutControlByRelativeOrientation) {
  const Network n;
  const BlockResult r = InitialiseBlock(n.Input(0), BlockOptions{});
  EXPECT_EQ(r.frame, "relative orientation (arbitrary frame, unit base)");
  ASSERT_EQ(r.cam_from_world.size(), 10u);
  // Equal to the truth after a similarity.
  Eigen::Matrix3Xd a(3, n.points.size()), b(3, n.points.size());
  int k = 0;
  for (const auto& [id, p] : n.points) a.col(k) = r.points.at(id), b.col(k++) = p;
  const Eigen::Matrix4d s = Eigen::umeyama(a, b, true);
  const Eigen::Matrix3Xd moved = (s.topLeftCorner<3, 3>() * a).colwise() + s.topRightCorner<3, 1>();
  EXPECT_LT((moved - b).cwiseAbs().maxCoeff(), 1e-6);
  // With 4 control points, moved onto them.
  const BlockResult c = InitialiseBlock(n.Input(3), BlockOptions{});
  EXPECT_EQ(c.frame, "relative orientation, similarity on 3 control points");
  EXPECT_LT((c.points.at("P40") - n.points.at("P40")).norm(), 1e-6);
  EXPECT_LT(TranslationDifference(c.cam_from_world.at("5"), n.poses.at("5")), 1e-6);
}

TEST(InitialiseBlock, PriorPosesAndUnorientableImages) {
  Network n;
  BlockInput in = n.Input(0);
  in.prior_cam_from_world = {{"1", n.poses.at("1")}, {"2", n.poses.at("2")}, {"3", n.poses.at("3")}};
  in.images.push_back("11");
  in.measurements.push_back({"11", "P1", {100, 100}});
  in.measurements.push_back({"11", "P2", {200, 100}});
  const BlockResult r = InitialiseBlock(in, BlockOptions{});
  EXPECT_EQ(r.frame, "prior EO");
  EXPECT_EQ(r.cam_from_world.size(), 10u);
  EXPECT_LT(TranslationDifference(r.cam_from_world.at("8"), n.poses.at("8")), 1e-6);
  EXPECT_EQ(r.failed_images.at("11"), "too few points to orient: 2 of its points have coordinates, 4 needed");
}

}  // namespace
}  // namespace mmba::orientation
