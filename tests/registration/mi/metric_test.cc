#include "mmba/registration/mi/metric.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/nelder_mead.h"

namespace mmba::registration::mi {
namespace {

// A LiDAR image covering every pixel with `values`, and a photo.
LidarImage Covered(int w, int h, const std::vector<float>& values) {
  LidarImage l;
  l.width = w;
  l.height = h;
  l.value = values;
  l.depth.assign(values.size(), 1.f);
  l.offset_x.assign(values.size(), 0.f);
  l.offset_y.assign(values.size(), 0.f);
  l.point_index.resize(values.size());
  for (size_t i = 0; i < values.size(); ++i) l.point_index[i] = static_cast<int>(i);
  l.covered_pixels = values.size();
  return l;
}

TEST(Metric, IdenticalUniformImagesGiveTheEntropy) {
  // 8 equiprobable levels: MI = H = 3 bits, NMI = 2, NID = 0.
  const int w = 64, h = 64;
  std::vector<float> v(w * h);
  GrayImage photo(w, h);
  for (int i = 0; i < w * h; ++i) {
    const int level = i % 8;
    v[i] = level / 7.f;
    photo.pixels[i] = 255.f * level / 7.f;
  }
  MetricOptions options;
  options.bins = 8;
  options.smoothing = Smoothing::kNone;
  options.region = Region::kOverlap;
  options.kind = MetricKind::kMi;
  JointHistogram histogram(options);
  histogram.Add(Covered(w, h, v), photo);
  const MetricValue m = histogram.Evaluate();
  EXPECT_NEAR(m.mi, 3.0, 1e-9);
  EXPECT_NEAR(m.joint_entropy, 3.0, 1e-9);
  EXPECT_NEAR(m.nmi, 2.0, 1e-9);
  EXPECT_NEAR(m.nid, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(m.value, m.mi);
}

TEST(Metric, IndependentImagesGiveNearZeroAndInversionDoesNotMatter) {
  const int w = 200, h = 200;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<float> v(w * h);
  GrayImage independent(w, h), inverted(w, h);
  for (int i = 0; i < w * h; ++i) {
    v[i] = u(rng);
    independent.pixels[i] = 255.f * u(rng);
    inverted.pixels[i] = 255.f * (1.f - v[i]);
  }
  MetricOptions options;
  options.bins = 16;
  options.region = Region::kOverlap;
  for (Smoothing s : {Smoothing::kNone, Smoothing::kParzen, Smoothing::kBSpline}) {
    options.smoothing = s;
    JointHistogram a(options), b(options);
    a.Add(Covered(w, h, v), independent);
    b.Add(Covered(w, h, v), inverted);
    const MetricValue ma = a.Evaluate(), mb = b.Evaluate();
    SCOPED_TRACE(SmoothingName(s));
    EXPECT_LT(ma.mi, 0.02);          // plug-in bias only
    EXPECT_GT(mb.mi, 1.5);  // a deterministic (inverted) relation
    EXPECT_GT(mb.nmi, ma.nmi);
    EXPECT_LT(mb.nid, ma.nid);
    EXPECT_GE(ma.nid, 0.0);
    EXPECT_LE(ma.nid, 1.0);
  }
}

TEST(Metric, WholeImageCountsEmptyPixelsInTheirOwnBin) {
  const int w = 10, h = 10;
  LidarImage l = Covered(w, h, std::vector<float>(w * h, 0.5f));
  GrayImage photo(w, h, 100.f);
  for (int i = 0; i < 50; ++i) {
    l.point_index[i] = -1;  // empty half ...
    photo.pixels[i] = 250.f;  // ... where the photo is bright (sky)
  }
  MetricOptions options;
  options.bins = 8;
  options.smoothing = Smoothing::kNone;
  options.region = Region::kWholeImage;
  JointHistogram whole(options);
  whole.Add(l, photo);
  const MetricValue m = whole.Evaluate();
  EXPECT_DOUBLE_EQ(m.samples, 100);
  EXPECT_DOUBLE_EQ(m.lidar_samples, 50);
  EXPECT_NEAR(m.mi, 1.0, 1e-9);  // coverage predicts the photo: one bit
  options.region = Region::kOverlap;
  JointHistogram overlap(options);
  overlap.Add(l, photo);
  EXPECT_DOUBLE_EQ(overlap.Evaluate().samples, 50);
  EXPECT_NEAR(overlap.Evaluate().mi, 0.0, 1e-12);
}

TEST(Metric, PairsGiveTheSameHistogramAsImagesAndShufflingDestroysTheRelation) {
  // Values at both ends of the range exercise the padded edge bins of the B-spline histogram.
  const int w = 120, h = 100;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<float> v(w * h), photo_values(w * h);
  GrayImage photo(w, h);
  for (int i = 0; i < w * h; ++i) {
    v[i] = i % 7 == 0 ? 0.f : (i % 7 == 1 ? 1.f : u(rng));
    photo.pixels[i] = photo_values[i] = 255.f * v[i];
  }
  for (Smoothing s : {Smoothing::kNone, Smoothing::kBSpline}) {
    SCOPED_TRACE(SmoothingName(s));
    MetricOptions options;
    options.bins = 16;
    options.smoothing = s;
    options.region = Region::kOverlap;
    JointHistogram image(options), pairs(options), shuffled(options);
    image.Add(Covered(w, h, v), photo);
    std::vector<float> values = photo_values;
    pairs.AddPairs(v, values);
    const MetricValue a = image.Evaluate(), b = pairs.Evaluate();
    EXPECT_NEAR(a.mi, b.mi, 1e-9);
    EXPECT_NEAR(a.joint_entropy, b.joint_entropy, 1e-9);
    EXPECT_GT(a.mi, 2.0);  // a deterministic relation over 16 bins
    std::shuffle(values.begin(), values.end(), rng);
    shuffled.AddPairs(v, values);
    EXPECT_LT(shuffled.Evaluate().mi, 0.05);  // plug-in bias only
  }
}

// Add() fills the B-spline histogram in chunks of a row (weights first, then the adds): it
// must give the same sums, bit for bit, as the same samples added one by one (AddPairs: the
// per-sample path) in the image's pixel order — LiDAR gaps, sub-pixel offsets, rows wider
// than a chunk (700 px), both regions.
TEST(Metric, ChunkedImageHistogramEqualsThePerSampleSums) {
  const int w = 700, h = 9;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.f, 1.f), off(-0.5f, 0.5f);
  LidarImage l;
  l.width = w;
  l.height = h;
  GrayImage photo(w, h);
  for (int k = 0; k < w * h; ++k) {
    // The first row over the whole range (edge bins); the others in narrow bands, so that
    // each bin gets many adds within a chunk and any change of their order shows in the sums.
    const bool wide = k < w;
    photo.pixels[k] = wide ? 255.f * u(rng) : 100.f + 10.f * u(rng);
    const bool covered = u(rng) < 0.7f;
    l.value.push_back(covered ? (wide ? u(rng) : 0.4f + 0.05f * u(rng)) : -1.f);
    l.depth.push_back(1.f);
    l.offset_x.push_back(covered ? off(rng) : 0.f);
    l.offset_y.push_back(covered ? off(rng) : 0.f);
    l.point_index.push_back(covered ? k : -1);
    l.covered_pixels += covered;
  }
  for (Region region : {Region::kOverlap, Region::kWholeImage}) {
    SCOPED_TRACE(RegionName(region));
    MetricOptions options;
    options.region = region;  // B-spline, 64 bins: the defaults
    std::vector<float> lidar01, photo255;
    for (int r = 0; r < h; ++r) {
      for (int c = 0; c < w; ++c) {
        const int k = r * w + c;
        const bool covered = l.point_index[k] >= 0;
        lidar01.push_back(covered ? l.value[k] : -1.f);
        photo255.push_back(covered ? SampleClamped(photo, c + 0.5f + l.offset_x[k],
                                                   r + 0.5f + l.offset_y[k])
                                   : photo.pixels[k]);
      }
    }
    JointHistogram image(options), pairs(options);
    image.Add(l, photo);
    pairs.AddPairs(lidar01, photo255);
    const MetricValue a = image.Evaluate(), b = pairs.Evaluate();
    EXPECT_EQ(a.mi, b.mi);
    EXPECT_EQ(a.nmi, b.nmi);
    EXPECT_EQ(a.joint_entropy, b.joint_entropy);
    EXPECT_EQ(a.samples, b.samples);
    EXPECT_EQ(a.lidar_samples, b.lidar_samples);
    EXPECT_EQ(a.samples, region == Region::kOverlap ? l.covered_pixels : w * h);
  }
}

// The point samples' batches (photo bins clamped by min/max, AVX2 adds of four doubles where
// the CPU has them) against one sample at a time (AddCoveredBins' comparisons): the same sums,
// bit for bit, with weights, many adds to the same bins, photo values on the edges of the
// range and of the bins, and coarser levels' bins.
TEST(Metric, CoveredBatchEqualsOneSampleAtATime) {
  for (int bins : {64, 16, 8}) {
    SCOPED_TRACE("bins " + std::to_string(bins));
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    MetricOptions options;  // B-spline, overlap: the point samples' histogram
    options.bins = bins;
    JointHistogram batched(options), single(options);
    constexpr int kBatch = JointHistogram::kBatch;
    int bx[kBatch];
    float wx[4][kBatch], photo[kBatch], weight[kBatch];
    for (int round = 0; round < 8; ++round) {
      const int count = round == 6 ? 37 : kBatch;  // a partial batch too
      for (int k = 0; k < count; ++k) {
        // Narrow bands (many adds to the same bins), the first round over the whole range,
        // the last on the range's ends and the bins' edges.
        const float lidar01 = round == 0 ? u(rng) : 0.3f + 0.05f * u(rng);
        photo[k] = round == 0 ? 255.f * u(rng) : 120.f + 8.f * u(rng);
        if (round == 7) {
          const float edges[4] = {0.f, 255.f, 1e-3f, 254.999f};
          photo[k] = k < 4 ? edges[k] : static_cast<float>(k % bins) * 255.f / (bins - 1);
        }
        weight[k] = static_cast<float>(1 + static_cast<int>(4 * u(rng)));
        float w[4];
        batched.LidarWeights(lidar01, &bx[k], w);
        for (int i = 0; i < 4; ++i) wx[i][k] = w[i];
        single.AddCovered(bx[k], w, photo[k], weight[k]);
        batched.AddCoveredCount(weight[k]);
      }
      batched.AddCoveredBatch(count, bx, wx, photo, weight);
    }
    const MetricValue a = batched.Evaluate(), b = single.Evaluate();
    EXPECT_GT(a.samples, 1000);
    EXPECT_EQ(a.samples, b.samples);
    EXPECT_EQ(a.mi, b.mi);
    EXPECT_EQ(a.nmi, b.nmi);
    EXPECT_EQ(a.joint_entropy, b.joint_entropy);
  }
}

// The histogram read straight from the z-buffer (the evaluator's path) against the rendered
// image's: the same sums, bit for bit, for each representation and region, with ties in the
// z-buffer and a ranked (reordered) cloud.
TEST(Metric, ZBufferHistogramEqualsTheRenderedImages) {
  const int w = 300, h = 40;
  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kPinhole;
  camera.width = w;
  camera.height = h;
  camera.params = {150.0, 150.0, w / 2.0, h / 2.0};
  View view;
  view.camera = camera;
  view.image = GrayImage(w, h);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (float& v : view.image.pixels) v = 255.f * u(rng);
  LidarPoints points;
  for (int k = 0; k < 8000; ++k) {
    const float z = 1.f + 30.f * u(rng);
    points.points_in_lidar.emplace_back((2.4f * u(rng) - 1.2f) * z, (0.3f * u(rng) - 0.15f) * z,
                                        z);
    points.intensity01.push_back(u(rng));
  }
  // Ranked storage: reversed, each point ranked by its original position.
  const uint32_t n = static_cast<uint32_t>(points.size());
  LidarPoints ranked;
  for (uint32_t j = 0; j < n; ++j) {
    ranked.points_in_lidar.push_back(points.points_in_lidar[n - 1 - j]);
    ranked.intensity01.push_back(points.intensity01[n - 1 - j]);
    ranked.tie_rank.push_back(n - 1 - j);
  }
  ranked.index_of_rank.resize(n);
  for (uint32_t j = 0; j < n; ++j) ranked.index_of_rank[ranked.tie_rank[j]] = j;
  const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())),
                     Eigen::Vector3d(0.02, -0.01, 0.03));
  for (const LidarPoints* cloud : {&points, &ranked}) {
    for (Representation representation :
         {Representation::kIntensity, Representation::kPoints, Representation::kDepth}) {
      for (Region region : {Region::kOverlap, Region::kWholeImage}) {
        SCOPED_TRACE(testing::Message() << RepresentationName(representation) << " "
                                        << RegionName(region) << " ranked "
                                        << !cloud->tie_rank.empty());
        RenderOptions render;
        render.representation = representation;
        MetricOptions options;
        options.region = region;
        LidarImage image, zbuffer;
        RenderLidarImage(*cloud, view, pose, render, &image);
        RenderLidarZBuffer(*cloud, view, pose, render, &zbuffer, true);
        ASSERT_GT(image.covered_pixels, static_cast<size_t>(w * h / 3));
        JointHistogram rendered(options), direct(options);
        rendered.Add(image, view.image);
        direct.AddZBuffer(zbuffer, *cloud, render, view.image);
        const MetricValue a = rendered.Evaluate(), b = direct.Evaluate();
        EXPECT_EQ(a.mi, b.mi);
        EXPECT_EQ(a.nmi, b.nmi);
        EXPECT_EQ(a.joint_entropy, b.joint_entropy);
        EXPECT_EQ(a.samples, b.samples);
        EXPECT_EQ(a.lidar_samples, b.lidar_samples);
        EXPECT_GT(a.mi, 0.0);
      }
    }
  }
}

// lidar_classes = K: the metric conditioned on the class, Σ_c p(c)·metric_c, equals the
// weighted sum of each class's histogram evaluated alone (three classes with different
// relations to the photo, encoded as EncodeSurfaceClasses does: class + fraction), for MI,
// NMI and NID, with each smoothing.
TEST(Metric, ClassConditionedMetricIsTheWeightedSumOfTheClasses) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> u(0, 4091);
  constexpr int kClasses = 3;
  const int count[kClasses] = {20000, 10000, 10000};
  std::vector<float> lidar[kClasses], photo[kClasses], all_lidar, all_photo;
  for (int c = 0; c < kClasses; ++c) {
    std::vector<float> encoded;
    for (int i = 0; i < count[c]; ++i) {
      // Fractions k / 4096: class + fraction is exact in float, so each class's positions
      // are those of its values alone.
      const float value = static_cast<float>(u(rng)) / 4096.f;
      const float grey = c == 0 ? 255.f * value
                         : c == 1 ? 255.f * (1.f - value)
                                  : 128.f + 100.f * std::sin(12.f * value);
      lidar[c].push_back(value);
      encoded.push_back(static_cast<float>(c) + value);
      photo[c].push_back(grey);
    }
    all_lidar.insert(all_lidar.end(), encoded.begin(), encoded.end());
    all_photo.insert(all_photo.end(), photo[c].begin(), photo[c].end());
  }
  for (const Smoothing smoothing : {Smoothing::kBSpline, Smoothing::kParzen, Smoothing::kNone}) {
    for (const MetricKind kind : {MetricKind::kMi, MetricKind::kNmi, MetricKind::kNid}) {
      MetricOptions plain;
      plain.kind = kind;
      plain.smoothing = smoothing;
      MetricOptions conditioned = plain;
      conditioned.lidar_classes = kClasses;
      JointHistogram all(conditioned);
      all.AddPairs(all_lidar, all_photo);
      const MetricValue v = all.Evaluate();
      MetricValue expected;
      expected.nid = 0;
      for (int c = 0; c < kClasses; ++c) {
        JointHistogram part(plain);
        part.AddPairs(lidar[c], photo[c]);
        const MetricValue m = part.Evaluate();
        const double p = count[c] / 40000.0;
        expected.mi += p * m.mi;
        expected.nmi += p * m.nmi;
        expected.nid += p * m.nid;
        expected.joint_entropy += p * m.joint_entropy;
      }
      SCOPED_TRACE(SmoothingName(smoothing) + " " + MetricName(kind));
      EXPECT_NEAR(v.mi, expected.mi, 1e-9);
      EXPECT_NEAR(v.nmi, expected.nmi, 1e-9);
      EXPECT_NEAR(v.nid, expected.nid, 1e-9);
      EXPECT_NEAR(v.joint_entropy, expected.joint_entropy, 1e-9);
      EXPECT_EQ(v.samples, 40000);
      // Conditioned on the class, each class's own relation counts in full: more than the MI
      // of the mixture of the three.
      JointHistogram mixed(plain);
      for (int c = 0; c < kClasses; ++c) mixed.AddPairs(lidar[c], photo[c]);
      EXPECT_GT(v.mi, mixed.Evaluate().mi + 0.3);
    }
  }
  MetricOptions bad;
  bad.lidar_classes = kMaxLidarClasses + 1;
  std::string error;
  EXPECT_FALSE(bad.Check(&error));
  EXPECT_NE(error.find("lidar_classes 17 must be in 1..16"), std::string::npos) << error;
}

TEST(Metric, OptionsCheckNamesTheField) {
  MetricOptions options;
  options.bins = 2;
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("bins 2"), std::string::npos) << error;
}

TEST(NelderMead, FindsTheMaximumOfAQuadraticWithinBounds) {
  Vector6d center;
  center << 0.3, -0.2, 0.1, 1.5, -0.7, 0.4;
  auto f = [&](const Vector6d& x) { return -(x - center).squaredNorm(); };
  NelderMeadOptions options;
  options.parameter_tolerance = 1e-4;
  options.function_tolerance = 1e-10;
  options.max_iterations = 2000;
  NelderMeadResult r = MaximizeNelderMead(f, Vector6d::Zero(), options);
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.x - center).norm(), 1e-3);
  // Bounds: the optimum outside the box lands on the box.
  options.lower = Vector6d::Constant(-1.0);
  options.upper = Vector6d::Constant(1.0);
  r = MaximizeNelderMead(f, Vector6d::Zero(), options);
  EXPECT_NEAR(r.x[3], 1.0, 1e-3);
  EXPECT_LE(r.x.maxCoeff(), 1.0);
  EXPECT_GE(r.x.minCoeff(), -1.0);
}

TEST(NelderMead, PaperDefaults) {
  const NelderMeadOptions options;
  EXPECT_DOUBLE_EQ(options.initial_step[0], 1.0);
  EXPECT_DOUBLE_EQ(options.parameter_tolerance, 0.1);
  EXPECT_DOUBLE_EQ(options.function_tolerance, 0.001);
  EXPECT_EQ(options.max_iterations, 200);
}

}  // namespace
}  // namespace mmba::registration::mi
