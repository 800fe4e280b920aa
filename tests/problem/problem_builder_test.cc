#include "mmba/problem/problem_builder.h"

#include <map>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/problem/reprojection_group.h"
#include "mmba/problem/solve.h"

namespace mmba {
namespace {

using sensors::CameraModelId;

// A simulated block: cameras of four models on a ring looking at a cloud of points
// around the origin; observations with Gaussian noise of `noise_px`.
struct SimulatedBlock {
  Scene truth;
  std::vector<ReprojectionObservation> observations;
};

sensors::Camera MakeCamera(uint64_t id, CameraModelId model, std::vector<double> params) {
  sensors::Camera camera;
  camera.camera_id = CameraId(id);
  camera.model_id = model;
  camera.width = model == CameraModelId::kEquirectangular ? 2000 : 640;
  camera.height = model == CameraModelId::kEquirectangular ? 1000 : 480;
  camera.params = std::move(params);
  return camera;
}

SimulatedBlock Simulate(double noise_px, int seed = 7) {
  SimulatedBlock block;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  block.truth.AddCamera(MakeCamera(1, CameraModelId::kPinhole, {500, 505, 320, 240}));
  block.truth.AddCamera(
      MakeCamera(2, CameraModelId::kOpenCV, {480, 485, 318, 242, -0.08, 0.01, 0.001, -0.001}));
  block.truth.AddCamera(MakeCamera(
      3, CameraModelId::kOpenCVFisheye, {300, 302, 320, 240, 0.03, -0.01, 0.002, -0.001}));
  const auto equirect = sensors::EquirectangularModel::DefaultParams(2000, 1000);
  block.truth.AddCamera(MakeCamera(4, CameraModelId::kEquirectangular,
                                   {equirect[0], equirect[1], equirect[2]}));
  const int num_images = 12;
  for (int i = 0; i < num_images; ++i) {
    const double angle = 2.0 * M_PI * i / num_images * 0.5 - 0.8;  // an arc of ~180°
    const Eigen::Vector3d centre(8.0 * std::sin(angle), 0.3 * std::sin(3.0 * angle),
                                 -8.0 * std::cos(angle));
    // Look at the origin: z axis towards it, y down (world y is down here too).
    const Eigen::Vector3d z = (-centre).normalized();
    const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d world_from_cam;
    world_from_cam << x, y, z;
    const Rigid3d cam_from_world(Eigen::Quaterniond(world_from_cam.transpose()),
                                 -(world_from_cam.transpose() * centre));
    block.truth.AddImage(ImageId(i + 1), CameraId(1 + i % 4), cam_from_world);
  }
  for (int j = 0; j < 300; ++j) {
    block.truth.AddPoint(Point3DId(j + 1),
                         Eigen::Vector3d(2.5 * uniform(rng), 2.0 * uniform(rng), 2.0 * uniform(rng)));
  }
  for (ImageId image_id : block.truth.SortedImageIds()) {
    const ImagePose& image = block.truth.Image(image_id);
    const sensors::Camera& camera = block.truth.Camera(image.camera_id);
    for (int j = 1; j <= 300; ++j) {
      const auto xy = camera.ImgFromCam(image.cam_from_world * block.truth.Point(Point3DId(j)));
      if (!xy || xy->x() < 0 || xy->y() < 0 || xy->x() > camera.width ||
          xy->y() > camera.height) {
        continue;
      }
      block.observations.push_back({image_id, Point3DId(j),
                                    *xy + Eigen::Vector2d(noise(rng), noise(rng)), 1.0});
    }
  }
  return block;
}

Scene Perturb(const Scene& truth, double rotation_rad, double translation, double point,
              int seed = 11) {
  Scene scene = truth;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (auto& [id, image] : scene.images()) {
    const Eigen::Vector3d axis(n(rng), n(rng), n(rng));
    image.cam_from_world.rotation =
        (Eigen::Quaterniond(Eigen::AngleAxisd(rotation_rad, axis.normalized())) *
         image.cam_from_world.rotation).normalized();
    image.cam_from_world.translation += translation * Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  for (auto& [id, p] : scene.points()) p += point * Eigen::Vector3d(n(rng), n(rng), n(rng));
  return scene;
}

// Projection centres of a scene, in image-id order.
Eigen::Matrix3Xd Centres(const Scene& scene) {
  const auto ids = scene.SortedImageIds();
  Eigen::Matrix3Xd c(3, ids.size());
  for (size_t i = 0; i < ids.size(); ++i) {
    c.col(i) = scene.Image(ids[i]).cam_from_world.TargetOriginInSource();
  }
  return c;
}

TEST(ProblemBuilder, RecoversASimulatedBlockOfMixedCameraModels) {
  const SimulatedBlock block = Simulate(0.5);
  ASSERT_GT(block.observations.size(), 1500u);
  Scene scene = Perturb(block.truth, 0.02, 0.15, 0.1);
  ProblemBuilder builder(&scene);
  builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations));
  SolveOptions options;
  options.log_progress = false;
  const SolveResult result = Solve(builder, options);
  ASSERT_TRUE(result.converged) << result.reason;
  EXPECT_GT(result.before[0].rms_units, 5.0);
  // The residual RMS is at the noise level: ‖r‖ of 2-D N(0, 0.5²) has RMS 0.5·√2.
  EXPECT_NEAR(result.after[0].rms_units, 0.5 * std::sqrt(2.0), 0.1);
  EXPECT_EQ(result.after[0].num_skipped, 0u);

  // Up to the free-network datum (fixed by the two-pose gauge), the geometry is the truth.
  const Eigen::Matrix4d similarity = Eigen::umeyama(Centres(scene), Centres(block.truth), true);
  const Eigen::Matrix3Xd aligned =
      (similarity * Centres(scene).colwise().homogeneous()).topRows<3>();
  EXPECT_LT((aligned - Centres(block.truth)).colwise().norm().maxCoeff(), 0.02);
  double max_point_error = 0.0;
  for (const auto& [id, p] : scene.points()) {
    const Eigen::Vector3d q = (similarity * p.homogeneous()).head<3>();
    max_point_error = std::max(max_point_error, (q - block.truth.Point(id)).norm());
  }
  EXPECT_LT(max_point_error, 0.05);
}

TEST(ProblemBuilder, TwoPoseGaugeHoldsFirstPoseAndDistance) {
  const SimulatedBlock block = Simulate(0.3);
  Scene scene = Perturb(block.truth, 0.01, 0.1, 0.05);
  const Rigid3d first = scene.Image(ImageId(1)).cam_from_world;
  const double distance = (scene.Image(ImageId(1)).cam_from_world.TargetOriginInSource() -
                           scene.Image(ImageId(2)).cam_from_world.TargetOriginInSource())
                              .norm();
  ProblemBuilder builder(&scene);
  builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations));
  SolveOptions options;
  options.log_progress = false;
  const SolveResult result = Solve(builder, options);
  ASSERT_TRUE(result.converged);
  EXPECT_LT(RotationDifferenceRad(scene.Image(ImageId(1)).cam_from_world, first), 1e-12);
  EXPECT_LT(TranslationDifference(scene.Image(ImageId(1)).cam_from_world, first), 1e-12);
  const double after = (scene.Image(ImageId(1)).cam_from_world.TargetOriginInSource() -
                        scene.Image(ImageId(2)).cam_from_world.TargetOriginInSource())
                           .norm();
  EXPECT_NEAR(after, distance, 1e-9);
  EXPECT_NE(result.gauge.find("pose of image 1 fixed, distance from image 1 to image 2"),
            std::string::npos);
}

TEST(ProblemBuilder, FixedImagesAndIntrinsicsSubsets) {
  const SimulatedBlock block = Simulate(0.3);
  Scene scene = Perturb(block.truth, 0.01, 0.1, 0.05);
  for (ImageId id : {ImageId(1), ImageId(2), ImageId(3)}) {
    scene.Image(id).cam_from_world = block.truth.Image(id).cam_from_world;
  }
  // Wrong focal length of the pinhole camera and wrong distortion of the OpenCV camera.
  scene.Camera(CameraId(1)).params[0] *= 1.03;
  scene.Camera(CameraId(2)).params[4] = 0.0;
  const std::vector<double> pinhole_before = scene.Camera(CameraId(1)).params;
  ProblemBuilder builder(&scene);
  builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations));
  GaugeOptions gauge;
  gauge.kind = GaugeOptions::Kind::kFixedImages;
  gauge.fixed_images = {ImageId(1), ImageId(2), ImageId(3)};
  builder.set_gauge(gauge);
  ParameterOptions parameters;
  parameters.refine_focal = true;
  parameters.refine_extra = true;
  builder.set_parameter_options(parameters);
  SolveOptions options;
  options.log_progress = false;
  const SolveResult result = Solve(builder, options);
  ASSERT_TRUE(result.converged);
  for (ImageId id : {ImageId(1), ImageId(2), ImageId(3)}) {
    EXPECT_EQ(scene.Image(id).cam_from_world.translation,
              block.truth.Image(id).cam_from_world.translation);
  }
  const auto& pinhole = scene.Camera(CameraId(1)).params;
  EXPECT_NEAR(pinhole[0], 500.0, 1.0);  // focal refined
  EXPECT_NEAR(pinhole[1], 505.0, 1.0);
  EXPECT_EQ(pinhole[2], pinhole_before[2]);  // principal point held
  EXPECT_EQ(pinhole[3], pinhole_before[3]);
  EXPECT_NEAR(scene.Camera(CameraId(2)).params[4], -0.08, 0.015);  // distortion refined from 0
  EXPECT_NEAR(result.after[0].rms_units, 0.3 * std::sqrt(2.0), 0.1);
}

TEST(ProblemBuilder, RobustLossFlagsGrossErrors) {
  SimulatedBlock block = Simulate(0.5);
  // Every 47th observation off by 40 px (a stride prime to the 300 points per image, so
  // no point gets the same error in every image), among points seen in at least 5 images
  // (with fewer views the point itself absorbs part of the error: low redundancy).
  std::map<Point3DId, int> track_length;
  for (const auto& obs : block.observations) ++track_length[obs.point3D_id];
  std::vector<size_t> corrupted;
  for (size_t i = 0; i < block.observations.size(); i += 47) {
    if (track_length[block.observations[i].point3D_id] < 5) continue;
    block.observations[i].xy += Eigen::Vector2d(40.0, -25.0);
    corrupted.push_back(i);
  }
  ASSERT_GT(corrupted.size(), 20u);
  Scene scene = Perturb(block.truth, 0.005, 0.05, 0.03);
  ProblemBuilder builder(&scene);
  LossOptions loss;
  loss.type = LossType::kCauchy;
  loss.scale = 2.0;
  auto& group = builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations, loss));
  SolveOptions options;
  options.log_progress = false;
  const SolveResult result = Solve(builder, options);
  ASSERT_TRUE(result.converged);
  const GroupEvaluation evaluation = group.Evaluate();
  size_t flagged = 0;
  for (size_t i : corrupted) {
    flagged += evaluation.observations[i].outlier;
  }
  EXPECT_EQ(flagged, corrupted.size());
  EXPECT_LE(evaluation.num_outliers, corrupted.size() + 5);
}

TEST(ProblemBuilder, PointsBehindACameraAreSkippedAndCounted) {
  SimulatedBlock block = Simulate(0.5);
  Scene scene = block.truth;
  // Move point 1 behind image 1 (a pinhole camera): it is still observed there.
  const Rigid3d& cam_from_world = scene.Image(ImageId(1)).cam_from_world;
  scene.Point(Point3DId(1)) = cam_from_world.Inverse() * Eigen::Vector3d(0.1, 0.1, -3.0);
  block.observations.push_back({ImageId(1), Point3DId(1), Eigen::Vector2d(300, 200), 1.0});
  block.observations.push_back({ImageId(99), Point3DId(2), Eigen::Vector2d(300, 200), 1.0});
  ReprojectionGroup* group = nullptr;
  ProblemBuilder builder(&scene);
  group = static_cast<ReprojectionGroup*>(
      &builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations)));
  builder.Build();
  EXPECT_GE(group->skipped_behind(), 1u);
  EXPECT_EQ(group->skipped_missing(), 1u);
  EXPECT_EQ(group->residual_blocks().size() + group->num_skipped(), block.observations.size());
}

TEST(ProblemBuilder, BuildThenSolveAddsTheBlocksOnce) {
  const SimulatedBlock block = Simulate(0.5);
  Scene scene = Perturb(block.truth, 0.005, 0.05, 0.03);
  ProblemBuilder builder(&scene);
  FactorGroup& group = builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations));
  ceres::Problem& problem = builder.Build();
  const int num_blocks = problem.NumResidualBlocks();
  problem.SetParameterBlockConstant(scene.Point(Point3DId(1)).data());  // caller's own control
  SolveOptions options;
  options.log_progress = false;
  const SolveResult result = Solve(builder, options);
  ASSERT_TRUE(result.converged);
  EXPECT_EQ(builder.problem().NumResidualBlocks(), num_blocks);
  EXPECT_EQ(group.residual_blocks().size(), static_cast<size_t>(num_blocks));
  EXPECT_EQ(result.after[0].num_observations, block.observations.size());
}

TEST(ProblemBuilder, GaugeErrorsAreInputErrors) {
  const SimulatedBlock block = Simulate(0.5);
  Scene scene = block.truth;
  ProblemBuilder builder(&scene);
  builder.AddGroup(std::make_unique<ReprojectionGroup>(block.observations));
  GaugeOptions gauge;
  gauge.first = ImageId(1);
  gauge.second = ImageId(42);
  builder.set_gauge(gauge);
  EXPECT_THROW(builder.Build(), InputError);
}

}  // namespace
}  // namespace mmba
