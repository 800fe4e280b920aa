#include "mmba/registration/mi/point_samples.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <gtest/gtest.h>

#include "mmba/registration/mi/mi_registration.h"
#include "synthetic_scene.h"

namespace mmba::registration::mi {
namespace {

class PointSamplesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = testing::StreetCamera();
    truth_ = testing::StreetCamFromLidar(Eigen::Vector3d(0.5, 0.3, 0.2), 4.0);
    points_ = PrepareLidarPoints(testing::StreetCloud(0.06));
    frame_.name = "street";
    frame_.views = MakeViews(testing::StreetPhoto(camera_, truth_), camera_, ViewOptions(),
                             "street.png");
    frame_.points = &points_;
  }
  /// The street photo through its pinhole camera and through the same camera as a
  /// distortion-free OPENCV model (the generic model's path).
  std::pair<View, View> PinholeAndGenericViews() const {
    sensors::Camera opencv = camera_;
    opencv.model_id = sensors::CameraModelId::kOpenCV;
    opencv.params = {camera_.params[0], camera_.params[1], camera_.params[2], camera_.params[3],
                     0.0, 0.0, 0.0, 0.0};
    const GrayImage photo = frame_.views[0].image;
    return {MakeViews(photo, camera_, ViewOptions(), "pinhole")[0],
            MakeViews(photo, opencv, ViewOptions(), "opencv")[0]};
  }
  sensors::Camera camera_;
  Rigid3d truth_;
  LidarPoints points_;
  Frame frame_;
};

RegistrationOptions SampledOptions() {
  RegistrationOptions options;
  options.point_samples = true;  // the default; explicit here
  return options;
}

// One sample per covered pixel at the reference pose is the rendered B-spline histogram (up to
// float rounding: the depth value from log(range²)/2 instead of log(range), the sums in
// another order; 1e-6 is far below the 1e-3 tolerance of the search).
TEST_F(PointSamplesTest, PerPixelSamplesAtTheReferenceEqualTheRenderedMetric) {
  for (Representation representation : {Representation::kIntensity, Representation::kDepth}) {
    RegistrationOptions options = SampledOptions();
    options.render.representation = representation;
    const FrameSetEvaluator evaluator({frame_}, truth_, options);
    ASSERT_TRUE(evaluator.UsesSamples(options.metric));
    for (int level = 0; level < evaluator.levels(); ++level) {
      const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, level, false);
      const MetricValue rendered = evaluator.Evaluate(truth_, level, options.metric);
      const MetricValue sampled = evaluator.Evaluate(truth_, level, options.metric, &set);
      EXPECT_GT(set.samples, 1000u);
      EXPECT_DOUBLE_EQ(sampled.samples, rendered.samples) << "level " << level;
      EXPECT_NEAR(sampled.value, rendered.value, 1e-6) << "level " << level;
      EXPECT_NEAR(sampled.mi, rendered.mi, 1e-6) << "level " << level;
    }
  }
}

// With the orientation classes (seven histogram blocks, values class + fraction): per-pixel
// samples at the reference equal the rendered metric, and the pinhole's batch path (one sample
// per point, the class weights without a branch) fills the same histogram as the generic
// model's, bit for bit, away from the reference too.
TEST_F(PointSamplesTest, ClassedSamplesEqualTheRenderedMetricAndTheGenericModel) {
  LidarPoints classed = points_;
  const Eigen::Vector3f centre = truth_.Inverse().translation.cast<float>();
  const int classes = EncodeOrientationClasses(centre, 4, 0.5f, &classed);
  ASSERT_GE(classed.classes, 4);
  Frame frame = frame_;
  frame.points = &classed;
  RegistrationOptions options = SampledOptions();
  options.metric.lidar_classes = classes;
  const FrameSetEvaluator evaluator({frame}, truth_, options);
  for (int level = 0; level < evaluator.levels(); ++level) {
    const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, level, false);
    const MetricValue rendered = evaluator.Evaluate(truth_, level, options.metric);
    const MetricValue sampled = evaluator.Evaluate(truth_, level, options.metric, &set);
    EXPECT_DOUBLE_EQ(sampled.samples, rendered.samples) << "level " << level;
    EXPECT_NEAR(sampled.mi, rendered.mi, 1e-6) << "level " << level;
  }
  const auto [pinhole_view, opencv_view] = PinholeAndGenericViews();
  RenderOptions render;
  LidarImage rendered;
  RenderLidarImage(classed, pinhole_view, truth_, render, &rendered);
  const ViewSamples samples = MakeViewSamples(classed, rendered, render, true);
  MetricOptions metric;
  metric.lidar_classes = classes;
  for (double scale : {0.0, 3.0}) {
    Vector6d offset;
    offset << 0.02, -0.03, 0.01, 0.1, -0.2, 0.15;
    const Rigid3d pose = ApplyCorrection(truth_, scale * offset);
    JointHistogram a(metric), b(metric);
    AccumulateViewSamples(samples, pinhole_view, pose, render, 0, samples.points(), &a);
    AccumulateViewSamples(samples, opencv_view, pose, render, 0, samples.points(), &b);
    const MetricValue va = a.Evaluate(), vb = b.Evaluate();
    EXPECT_GT(va.samples, 1000) << "offset x " << scale;
    EXPECT_EQ(va.samples, vb.samples) << "offset x " << scale;
    EXPECT_EQ(va.mi, vb.mi) << "offset x " << scale;
    EXPECT_EQ(va.joint_entropy, vb.joint_entropy) << "offset x " << scale;
  }
}

// One weighted sample per point: the weights add up to (nearly all) the covered pixels, and
// the metric still peaks at the true pose along every parameter.
TEST_F(PointSamplesTest, PerPointSamplesKeepThePixelWeightsAndThePeak) {
  RegistrationOptions options = SampledOptions();
  const FrameSetEvaluator evaluator({frame_}, truth_, options);
  const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, 0, true);
  const FrameSetEvaluator::SampleSet pixels = evaluator.MakeSampleSet(truth_, 0, false);
  double weight = 0;
  for (const ViewSamples& view : set.views) {
    ASSERT_EQ(view.samples(), view.points());
    for (float w : view.sample_weight) weight += w;
  }
  // The block weights share each block's covered pixels among its samples: all of them but
  // those of the few blocks whose every point is hidden at its own pixel.
  EXPECT_LE(weight, static_cast<double>(pixels.samples) * (1 + 1e-6));
  EXPECT_GT(weight, 0.98 * static_cast<double>(pixels.samples));
  EXPECT_LT(set.samples, pixels.samples);
  // With sample_block_px 0 (each point at its won pixel) the weights are the won pixel
  // counts: exactly the covered pixels.
  RegistrationOptions won_pixel = options;
  won_pixel.sample_block_px = 0;
  const FrameSetEvaluator won_evaluator({frame_}, truth_, won_pixel);
  double won_weight = 0;
  for (const ViewSamples& view : won_evaluator.MakeSampleSet(truth_, 0, true).views) {
    for (float w : view.sample_weight) won_weight += w;
  }
  EXPECT_DOUBLE_EQ(won_weight, static_cast<double>(pixels.samples));
  const double at_truth = evaluator.Evaluate(truth_, 0, options.metric, &set).value;
  for (int axis = 0; axis < 6; ++axis) {
    for (double sign : {-1.0, 1.0}) {
      Vector6d offset = Vector6d::Zero();
      offset[axis] = sign * (axis < 3 ? 0.03 : 0.3);  // a few pixels
      const double moved =
          evaluator.Evaluate(ApplyCorrection(truth_, offset), 0, options.metric, &set).value;
      EXPECT_LT(moved, at_truth) << ParameterName(axis) << " " << sign;
    }
  }
}

// The pinhole camera's samples are projected in blocks and their photo values gathered eight
// at a time (AVX2 where the CPU has it); with one sample per point and a fixed LiDAR value
// (intensity, points) the block's tests and the LiDAR bin weights without branches; every
// other model one point at a time. The same camera as OPENCV without distortion takes the
// general path: the same histogram, bit for bit, for per-pixel and per-point samples, each
// representation, the coarser levels' bins, at the reference and away, and for the two parts
// of the points that an evaluation on two threads fills.
TEST_F(PointSamplesTest, PinholeBlocksAccumulateAsTheGenericModel) {
  ASSERT_EQ(camera_.model_id, sensors::CameraModelId::kPinhole);
  const auto [pinhole_view, opencv_view] = PinholeAndGenericViews();
  for (Representation representation :
       {Representation::kIntensity, Representation::kPoints, Representation::kDepth}) {
    RenderOptions render;
    render.representation = representation;
    LidarImage rendered;
    RenderLidarImage(points_, pinhole_view, truth_, render, &rendered);
    // Per pixel; per point at the won pixel (block 0); per point at the projection (block 8).
    for (int placement_block : {-1, 0, 8}) {
      const bool per_point = placement_block >= 0;
      PerPointPlacement placement;
      placement.block_px = std::max(0, placement_block);
      const ViewSamples samples = MakeViewSamples(points_, rendered, render, per_point, placement);
      ASSERT_GT(samples.points(), 2000u);  // many batches, and a partial last block
      for (int bins : {64, 16}) {
        SCOPED_TRACE(std::string(RepresentationName(representation)) +
                     (per_point ? ", per point, block " + std::to_string(placement_block)
                                : std::string(", per pixel")) +
                     ", bins " + std::to_string(bins));
        for (double scale : {0.0, 0.5, 3.0}) {
          Vector6d offset;
          offset << 0.02, -0.03, 0.01, 0.1, -0.2, 0.15;
          const Rigid3d pose = ApplyCorrection(truth_, scale * offset);
          MetricOptions metric;
          metric.bins = bins;
          JointHistogram a(metric), b(metric), first(metric), second(metric);
          AccumulateViewSamples(samples, pinhole_view, pose, render, 0, samples.points(), &a);
          AccumulateViewSamples(samples, opencv_view, pose, render, 0, samples.points(), &b);
          // The two parts of an evaluation on two threads (a split inside a block).
          const size_t half = samples.points() / 2 + 13;
          AccumulateViewSamples(samples, pinhole_view, pose, render, 0, half, &first);
          AccumulateViewSamples(samples, pinhole_view, pose, render, half, samples.points(),
                                &second);
          JointHistogram generic_first(metric), generic_second(metric);
          AccumulateViewSamples(samples, opencv_view, pose, render, 0, half, &generic_first);
          AccumulateViewSamples(samples, opencv_view, pose, render, half, samples.points(),
                                &generic_second);
          first.Merge(second);
          generic_first.Merge(generic_second);
          const MetricValue va = a.Evaluate(), vb = b.Evaluate();
          const MetricValue parts = first.Evaluate(), generic_parts = generic_first.Evaluate();
          EXPECT_GT(va.samples, 1000) << "offset x " << scale;
          EXPECT_EQ(va.samples, vb.samples) << "offset x " << scale;
          EXPECT_EQ(va.mi, vb.mi) << "offset x " << scale;
          EXPECT_EQ(va.joint_entropy, vb.joint_entropy) << "offset x " << scale;
          EXPECT_EQ(parts.samples, va.samples) << "offset x " << scale;
          EXPECT_EQ(parts.mi, generic_parts.mi) << "offset x " << scale;
          EXPECT_EQ(parts.joint_entropy, generic_parts.joint_entropy) << "offset x " << scale;
        }
      }
    }
  }
}

// The probe displacement measures how far a pose moves the image: zero at the reference,
// f·angle pixels for a small yaw of the camera about its own axis.
TEST_F(PointSamplesTest, ProbeDisplacementMeasuresTheImageMotion) {
  RegistrationOptions options = SampledOptions();
  const FrameSetEvaluator evaluator({frame_}, truth_, options);
  const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, 0, true);
  EXPECT_NEAR(evaluator.SampleSetDisplacementPx(set, truth_), 0.0, 1e-3);
  const double angle = 0.5 * M_PI / 180.0;
  // Rotation of the camera about its own y axis (image columns move by ≈ f·angle).
  const Rigid3d turned(Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY())) *
                           truth_.rotation,
                       Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()) * truth_.translation);
  const double moved = evaluator.SampleSetDisplacementPx(set, turned);
  EXPECT_GT(moved, 0.9 * camera_.params[0] * angle);
  EXPECT_LT(moved, 1.5 * camera_.params[0] * angle);
}

// On by default; point_samples = false renders even when handed a set. Away
// from the set's reference pose the sampled metric (visibility frozen) is not the rendered one,
// so the comparison below tells which path was taken.
TEST_F(PointSamplesTest, OnByDefaultAndSwitchable) {
  RegistrationOptions options;
  EXPECT_TRUE(options.point_samples);
  Vector6d moved;
  moved << 0.02, -0.01, 0.01, 0.2, -0.1, 0.15;
  const Rigid3d pose = ApplyCorrection(truth_, moved);
  {
    const FrameSetEvaluator evaluator({frame_}, truth_, options);
    EXPECT_TRUE(evaluator.UsesSamples(options.metric));
    const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, 0, true);
    EXPECT_NE(evaluator.Evaluate(pose, 0, options.metric, &set).value,
              evaluator.Evaluate(pose, 0, options.metric).value);
  }
  options.point_samples = false;
  const FrameSetEvaluator evaluator({frame_}, truth_, options);
  EXPECT_FALSE(evaluator.UsesSamples(options.metric));
  const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, 0, true);
  EXPECT_EQ(evaluator.Evaluate(pose, 0, options.metric, &set).value,
            evaluator.Evaluate(pose, 0, options.metric).value);
}

// End to end with point samples: a 0.1 m / 1° start is recovered and reported ok.
TEST_F(PointSamplesTest, RegistrationWithPointSamplesRecoversThePose) {
  Vector6d perturbation;
  perturbation << 0.1, -0.08, 0.06, 1.0, -0.8, 0.9;
  const Rigid3d start = ApplyCorrection(truth_, perturbation);
  const RegistrationResult result = RegisterFrames({frame_}, start, SampledOptions());
  EXPECT_TRUE(result.ok()) << result.reason;
  const PixelOffsetStats after = PixelOffsets(points_, frame_.views[0], truth_,
                                              result.cam_from_lidar, RenderOptions());
  EXPECT_LT(after.median_px, 0.5);
}

// A set of another level, or a metric the samples cannot give, falls back to rendering: the
// whole image when the evaluator's own region is the overlap (its sets carry no background),
// or the whole image with other bins than the options'.
TEST_F(PointSamplesTest, OtherLevelOrWholeImageMetricIsRendered) {
  RegistrationOptions options = SampledOptions();
  const FrameSetEvaluator evaluator({frame_}, truth_, options);
  const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, 1, true);
  EXPECT_EQ(evaluator.Evaluate(truth_, 0, options.metric, &set).value,
            evaluator.Evaluate(truth_, 0, options.metric).value);
  MetricOptions whole = options.metric;
  whole.region = Region::kWholeImage;
  EXPECT_FALSE(evaluator.UsesSamples(whole));
  const FrameSetEvaluator::SampleSet level1 = evaluator.MakeSampleSet(truth_, 1, true);
  EXPECT_TRUE(level1.background.empty());
  EXPECT_EQ(evaluator.Evaluate(truth_, 1, whole, &level1).value,
            evaluator.Evaluate(truth_, 1, whole).value);
  RegistrationOptions whole_options = options;
  whole_options.metric.region = Region::kWholeImage;
  const FrameSetEvaluator whole_evaluator({frame_}, truth_, whole_options);
  EXPECT_TRUE(whole_evaluator.UsesSamples(whole_options.metric));
  MetricOptions other_bins = whole_options.metric;
  other_bins.bins = 32;
  EXPECT_FALSE(whole_evaluator.UsesSamples(other_bins));
  const FrameSetEvaluator::SampleSet whole_set = whole_evaluator.MakeSampleSet(truth_, 0, true);
  EXPECT_EQ(whole_evaluator.Evaluate(truth_, 0, other_bins, &whole_set).value,
            whole_evaluator.Evaluate(truth_, 0, other_bins).value);
}

// The whole image from samples (the background as the complement of the samples' photo
// values, JointHistogram::AddBackgroundComplement): per-pixel samples at the reference give
// the rendered whole-image metric, every pyramid level, for intensity and points; away from
// the reference the sample count stays the view's pixels, and with one sample per point the
// metric stays within a small margin of the rendered one and peaks where it does.
TEST_F(PointSamplesTest, WholeImageFromSamplesEqualsTheRenderedMetric) {
  for (Representation representation : {Representation::kIntensity, Representation::kPoints}) {
    RegistrationOptions options = SampledOptions();
    options.render.representation = representation;
    options.metric.region = Region::kWholeImage;
    const FrameSetEvaluator evaluator({frame_}, truth_, options);
    ASSERT_TRUE(evaluator.UsesSamples(options.metric));
    const double pixels = static_cast<double>(camera_.width) * camera_.height;
    for (int level = 0; level < evaluator.levels(); ++level) {
      const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, level, false);
      ASSERT_EQ(set.background.size(), set.views.size());
      const MetricValue rendered = evaluator.Evaluate(truth_, level, options.metric);
      const MetricValue sampled = evaluator.Evaluate(truth_, level, options.metric, &set);
      EXPECT_DOUBLE_EQ(sampled.samples, rendered.samples) << "level " << level;
      EXPECT_DOUBLE_EQ(sampled.lidar_samples, rendered.lidar_samples) << "level " << level;
      EXPECT_NEAR(sampled.mi, rendered.mi, 1e-6) << "level " << level;
      EXPECT_NEAR(sampled.value, rendered.value, 1e-6) << "level " << level;
    }
    EXPECT_DOUBLE_EQ(evaluator.Evaluate(truth_, 0, options.metric).samples, pixels);
    const FrameSetEvaluator::SampleSet set = evaluator.MakeSampleSet(truth_, 0, true);
    const double at_truth = evaluator.Evaluate(truth_, 0, options.metric, &set).value;
    const double rendered_truth = evaluator.Evaluate(truth_, 0, options.metric).value;
    for (int axis = 0; axis < 6; ++axis) {
      for (double sign : {-1.0, 1.0}) {
        Vector6d offset = Vector6d::Zero();
        offset[axis] = sign * (axis < 3 ? 0.03 : 0.3);  // a few pixels
        const Rigid3d pose = ApplyCorrection(truth_, offset);
        const MetricValue moved = evaluator.Evaluate(pose, 0, options.metric, &set);
        const MetricValue rendered = evaluator.Evaluate(pose, 0, options.metric);
        EXPECT_DOUBLE_EQ(moved.samples, pixels) << ParameterName(axis) << " " << sign;
        if (representation == Representation::kIntensity) {
          EXPECT_LT(moved.value, at_truth) << ParameterName(axis) << " " << sign;
        } else {
          // The street's photo shows intensity: the coverage alone tells little (changes of
          // 1e-4 to 3e-3), and the samples follow the rendered metric's changes within 4e-4.
          EXPECT_NEAR(moved.value - at_truth, rendered.value - rendered_truth, 4e-4)
              << ParameterName(axis) << " " << sign;
        }
      }
    }
  }
}

// The footprint decides visibility only (PerPointPlacement, block_px > 0): at the edge of a
// near wall in front of a far one, the far points whose own pixel the near wall's footprint
// covers are not sampled (with block 0 they are, displaced onto a pixel beside the edge);
// every sample is at its point's own projection; a block's weights add up to its covered
// pixels.
TEST(PerPointPlacementTest, FarPointsHiddenAtTheirOwnPixelAreNotSampledAndWeightsShareBlocks) {
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kPinhole;
  camera.width = 64;
  camera.height = 64;
  camera.params = {64.0, 64.0, 32.0, 32.0};
  const View view = MakeViews(GrayImage(64, 64), camera, ViewOptions(), "edge")[0];
  LidarPoints points;
  auto wall = [&](double z, double x0, double x1, double step, float intensity) {
    for (double x = x0; x <= x1; x += step) {
      for (double y = -0.5 * z; y <= 0.5 * z; y += step) {
        points.points_in_lidar.emplace_back(x, y, z);
        points.intensity01.push_back(intensity);
      }
    }
  };
  wall(0.8, -0.5, -0.01, 0.01, 0.9);  // the near wall: the left half, footprint 2 px
  wall(1.5, -0.8, 0.8, 0.02, 0.1);    // the far wall behind it: 0.85 px apart, footprint 1 px
  RenderOptions render;
  LidarImage rendered;
  RenderLidarImage(points, view, Rigid3d(), render, &rendered);
  const PerPointPlacement placement;  // the default: block 8
  ASSERT_GT(placement.block_px, 0);
  const ViewSamples samples = MakeViewSamples(points, rendered, render, true, placement);
  PerPointPlacement won_pixel;
  won_pixel.block_px = 0;
  const ViewSamples old_samples = MakeViewSamples(points, rendered, render, true, won_pixel);
  ASSERT_GT(samples.points(), 500u);

  // Far points: sampled (and where) in each placement, by their position.
  auto far_points_behind_the_edge = [&](const ViewSamples& set) {
    int count = 0;
    for (size_t j = 0; j < set.points(); ++j) {
      const Eigen::Vector3f& p = set.points_in_lidar[j];
      if (p.z() < 1.f) continue;
      const int c = static_cast<int>(std::floor(64.0 * p.x() / p.z() + 32.0));
      const int r = static_cast<int>(std::floor(64.0 * p.y() / p.z() + 32.0));
      if (rendered.depth[static_cast<size_t>(r) * 64 + c] < 1.f) ++count;  // near wall there
    }
    return count;
  };
  EXPECT_EQ(far_points_behind_the_edge(samples), 0);
  EXPECT_GT(far_points_behind_the_edge(old_samples), 0);  // the displaced ones

  std::map<int, double> block_weight, block_pixels;
  for (size_t j = 0; j < samples.points(); ++j) {
    EXPECT_EQ(samples.sample_offset[j][0], 0);
    EXPECT_EQ(samples.sample_offset[j][1], 0);
    const Eigen::Vector3f& p = samples.points_in_lidar[j];
    const int c = static_cast<int>(std::floor(64.0 * p.x() / p.z() + 32.0));
    const int r = static_cast<int>(std::floor(64.0 * p.y() / p.z() + 32.0));
    block_weight[(r / 8) * 8 + c / 8] += samples.sample_weight[j];
  }
  for (size_t k = 0; k < rendered.point_index.size(); ++k) {
    if (rendered.point_index[k] < 0) continue;
    const int c = static_cast<int>(k % 64), r = static_cast<int>(k / 64);
    block_pixels[(r / 8) * 8 + c / 8] += 1;
  }
  ASSERT_EQ(block_weight.size(), block_pixels.size());  // every block keeps a sample here
  for (const auto& [block, weight] : block_weight) {
    EXPECT_NEAR(weight, block_pixels[block], 1e-3) << "block " << block;
  }
}

}  // namespace
}  // namespace mmba::registration::mi
