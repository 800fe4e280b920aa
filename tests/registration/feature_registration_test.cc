#include "mmba/registration/cloud/feature_registration.h"
#include "mmba/registration/cloud/registration_settings.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <tuple>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/registration/cloud/robust_estimators.h"

namespace mmba::registration {
namespace {

namespace fs = std::filesystem;

const std::string kPclDir = std::string(MMBA_SOURCE_DIR) + "/data/pointclouds/pcl_test/";

// PCL's own registration test: bun0 → bun4 (test/registration/test_registration.cpp).
// The truth of PCL's bun0 → bun4: PCL's test clouds are subsets of the Stanford scans bun000 and
// bun045, whose alignment the Stanford repository's bun.conf gives as `bmesh NAME tx ty tz qx qy
// qz qw`, p_common = R(q)ᵀ·p + t (the convention of bench/stanford_conf.py). bun000 is at the
// identity, so target_from_source = common_from(bun045)⁻¹.
Eigen::Matrix4d Bun0ToBun4() {
  const Eigen::Quaterniond q(0.955586, 0.00548449, -0.294635, -0.0038555);  // w, x, y, z
  Eigen::Matrix4d common_from_bun045 = Eigen::Matrix4d::Identity();
  common_from_bun045.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix().transpose();
  common_from_bun045.topRightCorner<3, 1>() = Eigen::Vector3d(-0.0520211, -0.000383981, -0.0109223);
  return common_from_bun045.inverse();
}

// Rotation angle (degrees) between two poses, and the RMS over `points` of where they put them.
std::pair<double, double> PoseErrors(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b,
                                     const std::vector<Eigen::Vector3d>& points) {
  const Eigen::Matrix3d dr = a.topLeftCorner<3, 3>() * b.topLeftCorner<3, 3>().transpose();
  const double angle = std::acos(std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : points) {
    sum += ((a - b).topLeftCorner<3, 3>() * p + (a - b).topRightCorner<3, 1>()).squaredNorm();
  }
  return {angle, std::sqrt(sum / static_cast<double>(points.size()))};
}

io::PointCloud Transformed(const io::PointCloud& c, const Eigen::Matrix4d& m) {
  io::PointCloud out = c;
  for (auto& p : out.points) p = m.topLeftCorner<3, 3>() * p + m.topRightCorner<3, 1>();
  for (auto& n : out.normals) n = m.topLeftCorner<3, 3>() * n;
  return out;
}

// PCL's bun0 → bun4 against the truth from bun.conf. PCL's own tests of this pair
// (test/registration/test_registration.cpp) compare its ICP's matrix entry by entry at 1e-3
// with a matrix that is itself an ICP local minimum 6.5° from bun.conf's truth, and require of
// SAC-IA a fitness score (mean squared distance to the nearest target point) < 0.0005 m². Here:
// within 1° and 1.5 mm RMS of the truth (measured 0.40° / 0.54 mm with SHOT), and PCL's SAC-IA
// criterion.
TEST(FeatureRegistration, PclBun0ToBun4WithinPclTolerance) {
  const io::PointCloud bun0 = io::ReadPointCloud(kPclDir + "bun0.pcd");
  const io::PointCloud bun4 = io::ReadPointCloud(kPclDir + "bun4.pcd");
  for (const char* name : {"auto", "fpfh", "shot"}) {
    SCOPED_TRACE(name);
    CloudRegistrationOptions options;
    ASSERT_TRUE(ParseDescriptor(name, &options.descriptor));
    const CloudRegistrationResult r = RegisterClouds(bun0, bun4, options);
    ASSERT_TRUE(r.ok()) << r.reason;
    const auto [angle_deg, rms_m] = PoseErrors(r.target_from_source, Bun0ToBun4(), bun0.points);
    EXPECT_LT(angle_deg, 1.0) << r.target_from_source;
    EXPECT_LT(rms_m, 1.5e-3) << r.target_from_source;
    double squared = 0.0;
    for (const Eigen::Vector3d& p : bun0.points) {
      const Eigen::Vector3d q = r.target_from_source.topLeftCorner<3, 3>() * p + r.target_from_source.topRightCorner<3, 1>();
      double best = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector3d& t : bun4.points) best = std::min(best, (q - t).squaredNorm());
      squared += best;
    }
    EXPECT_LT(squared / static_cast<double>(bun0.size()), 5e-4);  // PCL's SAC-IA test
    std::printf("[ measured ] %s: %.3f deg, %.3f mm RMS from bun.conf's truth\n", name, angle_deg, rms_m * 1e3);
    EXPECT_GT(r.fitness, 0.5);
    EXPECT_GT(r.num_keypoints_source, 3u);
    EXPECT_GT(r.confidence, 0.0);
  }
}

// Every setting by name (register-cloud --set): numbers, integers and switches set, each
// refused outside its range or of the wrong kind (the options then unchanged), unknown names
// refused, and the list names each with its default.
TEST(RegistrationSettings, SetByNameWithinTheirRanges) {
  CloudRegistrationOptions options;
  std::string problem;
  ASSERT_TRUE(SetRegistrationSetting("keypoint_threshold", "0.05", &options, &problem)) << problem;
  EXPECT_EQ(options.keypoint_threshold, 0.05);
  ASSERT_TRUE(SetRegistrationSetting("sac_ia_iterations", "2000", &options, &problem)) << problem;
  EXPECT_EQ(options.sac_ia_iterations, 2000);
  ASSERT_TRUE(SetRegistrationSetting("symmetry_turns", "false", &options, &problem)) << problem;
  EXPECT_FALSE(options.symmetry_turns);
  ASSERT_TRUE(SetRegistrationSetting("symmetry_turns", "1", &options, &problem)) << problem;
  EXPECT_TRUE(options.symmetry_turns);
  for (const auto& [name, value, fragment] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"keypoint_threshold", "0.5", "expected a number 0..1/3"},
           {"sac_ia_iterations", "2.5", "expected an integer >= 1"},
           {"sac_ia_iterations", "0", "expected an integer >= 1"},
           {"min_fitness", "0", "expected a number (0, 1]"},
           {"icp_distance_spacing", "nan", "found 'nan'"},
           {"symmetry_turns", "yes", "expected true or false"},
           {"no_such_thing", "1", "unknown setting 'no_such_thing'"}}) {
    const CloudRegistrationOptions before = options;
    problem.clear();
    EXPECT_FALSE(SetRegistrationSetting(name, value, &options, &problem)) << name << "=" << value;
    EXPECT_NE(problem.find(fragment), std::string::npos) << problem;
    EXPECT_EQ(options.keypoint_threshold, before.keypoint_threshold);
    EXPECT_EQ(options.sac_ia_iterations, before.sac_ia_iterations);
    EXPECT_EQ(options.min_fitness, before.min_fitness);
  }
  const std::vector<RegistrationSetting> all = RegistrationSettings();
  ASSERT_GE(all.size(), 40u);
  bool listed = false;
  for (const RegistrationSetting& setting : all) {
    listed = listed || (setting.name == "keypoint_threshold" && setting.default_value == "0.1" &&
                        setting.kind == "number");
    CloudRegistrationOptions defaults;  // each default is accepted as its own value
    EXPECT_TRUE(SetRegistrationSetting(setting.name, setting.default_value, &defaults, &problem)) << problem;
  }
  EXPECT_TRUE(listed);
}

// Linear-interpolated percentile of `v` (numpy's default).
double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double x = q / 100.0 * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(x));
  return i + 1 < v.size() ? v[i] + (x - i) * (v[i + 1] - v[i]) : v.back();
}

TEST(FeatureRegistration, SourceMovedPastItsOriginIsRetriedWithTurnedNormals) {
  // PCL's table scene cut along y into two pieces sharing 40 % of its extent (as
  // bench/register_real_sweep.py cuts it), every 4th point of each; the source moved by the
  // sweep's draw 3 (seed 36), which puts its origin — towards which its estimated normals face
  // — on the far side of the table, so its normals are turned against the target's. With the
  // normals as estimated no hypothesis fits (4.9 % overlap); NormalOrientation::kAuto retries
  // with the source's normals turned and consistent over the neighbour graph, and registers.
  io::ReadOptions read;
  read.skip_invalid_points = true;
  const io::PointCloud table =
      io::ReadPointCloud(kPclDir + "table_scene_mug_stereo_textured.pcd", read);
  std::vector<double> y;
  for (const auto& p : table.points) y.push_back(p.y());
  const double lo = Percentile(y, 1), hi = Percentile(y, 99), mid = Percentile(y, 50);
  const double half = 0.5 * 0.4 * (hi - lo);
  Eigen::Matrix4d move;
  move << -5.214574355684060691e-01, 8.273718261681045627e-01, 2.086576242404725723e-01,
      -6.392340605923165775e-01, 3.415013812631481072e-01, 4.264610332128904169e-01,
      -8.375606209381838418e-01, 8.265629226243931260e-01, -7.819584064934557155e-01,
      -3.654953466382985794e-01, -5.049298982036680705e-01, 2.080130942032248631e-01, 0, 0, 0, 1;
  io::PointCloud source, target;
  size_t in_source = 0, in_target = 0;
  for (const auto& p : table.points) {
    if (p.y() <= mid + half && in_source++ % 4 == 0) source.points.push_back(p);
    if (p.y() >= mid - half && in_target++ % 4 == 1) target.points.push_back(p);
  }
  source = Transformed(source, move);
  CloudRegistrationOptions options;
  options.normal_orientation = NormalOrientation::kViewpoint;
  const CloudRegistrationResult first = RegisterClouds(source, target, options);
  EXPECT_FALSE(first.ok());  // the failure the retry is for
  options.normal_orientation = NormalOrientation::kAuto;
  const CloudRegistrationResult r = RegisterClouds(source, target, options);
  ASSERT_TRUE(r.ok()) << r.reason;
  const Eigen::Matrix4d error = r.target_from_source * move;  // identity when right
  EXPECT_LT(Eigen::AngleAxisd(Eigen::Matrix3d(error.topLeftCorner<3, 3>())).angle() * 180 / M_PI,
            0.05);
  EXPECT_LT((error.topRightCorner<3, 1>().norm()), 0.001);
  ASSERT_FALSE(r.notes.empty());
  EXPECT_NE(r.notes.front().find("the source's turned"), std::string::npos) << r.notes.front();
  EXPECT_EQ(r.runtime.front().stage, "first try (normals towards the origin)");
  EXPECT_GT(r.total_seconds(), r.runtime.front().seconds);
}

// PCL's bunny parts (bun01–03: parts of bun0 in its frame, the truth the identity), each moved
// by a turn of 35–110° and a shift: a part registered to the whole or to a part that shares
// most of it is "ok" and right; two parts that share 1–11 % of their points are refused —
// never a wrong pose reported as ok. (The moves are fixed draws; the CLI gives the same verdicts
// for other draws.)
TEST(FeatureRegistration, PclBunnyPartsRegisteredOrRefused) {
  const auto part = [](const std::string& name) { return io::ReadPointCloud(kPclDir + name + ".pcd"); };
  struct Case {
    std::string source, target;
    bool overlapping;
    Eigen::Vector3d axis;
    double angle_deg;
    Eigen::Vector3d shift;
  };
  const std::vector<Case> cases = {
      {"bun02", "bun0", true, {0.3, 1.0, -0.2}, 70, {0.05, -0.12, 0.08}},
      {"bun01", "bun0", true, {-1.0, 0.2, 0.5}, 110, {-0.1, 0.03, 0.2}},
      {"bun0", "bun03", true, {0.1, 0.2, 1.0}, 35, {0.2, 0.1, -0.05}},
      {"bun02", "bun03", true, {1.0, -0.5, 0.3}, 80, {-0.07, 0.15, 0.02}},
      {"bun01", "bun02", false, {0.2, 1.0, 0.4}, 60, {0.1, 0.1, 0.1}},
      {"bun03", "bun01", false, {-0.6, 0.3, 1.0}, 95, {-0.15, 0.05, 0.1}},
  };
  for (const Case& c : cases) {
    Eigen::Matrix4d move = Eigen::Matrix4d::Identity();
    move.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(c.angle_deg * M_PI / 180.0, c.axis.normalized()).toRotationMatrix();
    move.topRightCorner<3, 1>() = c.shift;
    const io::PointCloud source = Transformed(part(c.source), move);
    const CloudRegistrationResult r = RegisterClouds(source, part(c.target), CloudRegistrationOptions());
    const std::string name = c.source + " -> " + c.target + ": " + r.BriefReport();
    if (r.ok()) {
      const auto [angle, rms] = PoseErrors(r.target_from_source, move.inverse(), source.points);
      EXPECT_LT(angle, 1.0) << name;
      EXPECT_LT(rms, 0.0015) << name;
    }
    EXPECT_EQ(r.ok(), c.overlapping) << name;
  }
}

TEST(FeatureRegistration, AmbiguousFirstTryIsNotRetried) {
  // bun4 moved by −2 × its centroid (its origin now behind it), FPFH only: the first try's
  // best pose fits and is refused as ambiguous. A retry would draw other hypotheses without
  // that competitor (on the simulated gate it reported a 180° twin "ok"); there is none.
  const io::PointCloud bun0 = io::ReadPointCloud(kPclDir + "bun0.pcd");
  const io::PointCloud bun4 = io::ReadPointCloud(kPclDir + "bun4.pcd");
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : bun4.points) centroid += p;
  centroid /= static_cast<double>(bun4.size());
  Eigen::Matrix4d move = Eigen::Matrix4d::Identity();
  move.topRightCorner<3, 1>() = -2.0 * centroid;
  const io::PointCloud source = Transformed(bun4, move);
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  const CloudRegistrationResult r = RegisterClouds(source, bun0, options);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.reason.rfind("ambiguous", 0), 0u) << r.reason;
  for (const std::string& note : r.notes) EXPECT_EQ(note.find("retried"), std::string::npos) << note;
  for (const StageTime& t : r.runtime) EXPECT_NE(t.stage.rfind("retry", 0), 0u) << t.stage;
}

TEST(FeatureRegistration, MapGridCoordinatesGiveTheSameRegistration) {
  // Survey clouds come in map-grid coordinates (UTM: 10^5–10^7 m), where a float resolves
  // only 0.25–0.5 m: before, two such clouds failed ("all points of a cloud coincide", "too
  // few keypoints"). Two overlapping sectors (200°, sharing 100°) of a levelled Velodyne scan
  // with independent 1.5 cm range noise, both moved into a grid, must register to the pose
  // the same clouds get near the origin. (Their normals are oriented up and inwards there,
  // not towards the far grid origin, so this is not the same computation.)
  const io::PointCloud scan =
      io::ReadPointCloud(std::string(MMBA_SOURCE_DIR) + "/data/kitti/velodyne/000000.bin");
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.015);
  io::PointCloud a, b;
  for (const Eigen::Vector3d& p : scan.points) {
    const double azimuth = std::atan2(p.y(), p.x()) * 180.0 / M_PI;
    const double range = p.norm();
    if (range < 1e-6) continue;
    if (azimuth > -150 && azimuth < 50) a.points.push_back(p * (1.0 + noise(rng) / range));
    if (azimuth > -50 && azimuth < 150) b.points.push_back(p * (1.0 + noise(rng) / range));
  }
  Eigen::Matrix4d move = Eigen::Matrix4d::Identity();  // the source 20° and 3 m off
  move.topLeftCorner<3, 3>() = Eigen::AngleAxisd(20.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  move.topRightCorner<3, 1>() = Eigen::Vector3d(3.0, -1.0, 0.2);
  a = Transformed(a, move);
  CloudRegistrationOptions options;
  const CloudRegistrationResult local = RegisterClouds(a, b, options);
  ASSERT_TRUE(local.ok()) << local.BriefReport();
  EXPECT_LT(TransformRmsOnCloud(a, local.target_from_source, move.inverse()), 0.005);
  Eigen::Matrix4d grid = Eigen::Matrix4d::Identity();
  grid.topRightCorner<3, 1>() = Eigen::Vector3d(512345.678, 5412345.678, 312.3);
  const io::PointCloud a_grid = Transformed(a, grid), b_grid = Transformed(b, grid);
  const CloudRegistrationResult r = RegisterClouds(a_grid, b_grid, options);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  EXPECT_LT(TransformRmsOnCloud(a_grid, r.target_from_source, grid * move.inverse() * grid.inverse()),
            0.005) << r.target_from_source;
  EXPECT_NEAR(r.fitness, local.fitness, 0.05);
  // The covariance's centre is in the target's (grid) frame.
  EXPECT_LT((r.covariance_centre - (local.covariance_centre + grid.topRightCorner<3, 1>())).norm(), 0.1);
  // Spacing in the grid is the cloud's own.
  EXPECT_NEAR(EstimatePointSpacing(b_grid), EstimatePointSpacing(b), 1e-4);
}

TEST(FeatureRegistration, PaperModeEveryDescriptorOnBunny) {
  // bun4 against a rotated, shifted copy of itself: every descriptor of the paper must work
  // on an exact overlap.
  const io::PointCloud bun4 = io::ReadPointCloud(kPclDir + "bun4.pcd");
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  truth.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(1.0, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  truth.topRightCorner<3, 1>() = Eigen::Vector3d(0.3, -0.1, 0.05);
  const io::PointCloud moved = Transformed(bun4, truth);
  for (const char* name : {"fpfh", "shot", "si", "sc3d"}) {
    SCOPED_TRACE(name);
    CloudRegistrationOptions options;
    ASSERT_TRUE(ParseDescriptor(name, &options.descriptor));
    options.use_existing_normals = false;
    options.paper_only = true;
    const CloudRegistrationResult r = RegisterClouds(bun4, moved, options);
    ASSERT_EQ(r.status, "unverified") << r.reason;
    EXPECT_LT(TransformRmsOnCloud(bun4, r.target_from_source, truth), 1e-3);
  }
}

TEST(FeatureRegistration, GravityAlignedYawOnly) {
  const io::PointCloud bun0 = io::ReadPointCloud(kPclDir + "bun0.pcd");
  const io::PointCloud bun4 = io::ReadPointCloud(kPclDir + "bun4.pcd");
  CloudRegistrationOptions options;
  options.gravity_aligned = true;
  options.up = Eigen::Vector3d::UnitY();  // the bunny scans turn about y
  const CloudRegistrationResult r = RegisterClouds(bun0, bun4, options);
  ASSERT_TRUE(r.ok()) << r.reason;
  const auto [angle_deg, rms_m] = PoseErrors(r.target_from_source, Bun0ToBun4(), bun0.points);
  std::printf("[ measured ] gravity-aligned: %.3f deg, %.3f mm RMS from bun.conf's truth\n", angle_deg, rms_m * 1e3);
  EXPECT_LT(angle_deg, 1.0);
  EXPECT_LT(rms_m, 1.5e-3);
  // Hypotheses turn about y only; the final free ICP may tilt by a little.
  const Eigen::Vector3d y = r.target_from_source.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitY();
  EXPECT_GT(y.y(), std::cos(2.0 * M_PI / 180.0));
  const auto tilt_note = [](const CloudRegistrationResult& result) {
    for (const std::string& n : result.notes) {
      if (n.find("--gravity-aligned: the pose tilts") != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_FALSE(tilt_note(r));
  // The wrong axis: the scans turn 34° about y, not about z. A pose found all the same must
  // say that it tilts the source against the levelling the user asserted.
  options.up = Eigen::Vector3d::UnitZ();
  const CloudRegistrationResult wrong_up = RegisterClouds(bun0, bun4, options);
  ASSERT_TRUE(wrong_up.ok()) << wrong_up.BriefReport();  // the free fine ICP finds the tilt
  EXPECT_TRUE(tilt_note(wrong_up)) << wrong_up.BriefReport();
}

TEST(FeatureRegistration, AnObjectFarFromItsOriginRegistersAsNearIt) {
  // The ICP turned about the coordinates' origin: 30 m from it, the 15 cm bunny moved by the
  // second-order term of each step's turn (0.46 m at 10°) and no hypothesis converged ("only
  // 0 % within τ"), though the same pair registers at the origin. Each cloud is now registered
  // about its own centre (and the ICP turns the source about its centroid). Also: every point written twice (a tiled LAS, a mesh export) made the
  // median spacing 0 ("all points of a cloud coincide"); one blunder a million km away must not
  // move the centre.
  const io::PointCloud bun0 = io::ReadPointCloud(kPclDir + "bun0.pcd");
  const io::PointCloud bun4 = io::ReadPointCloud(kPclDir + "bun4.pcd");
  for (const Eigen::Vector3d& offset :
       {Eigen::Vector3d(0, 0, 30), Eigen::Vector3d(20, -20, 20), Eigen::Vector3d(345.6, 0, 312.3)}) {
    Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
    shift.topRightCorner<3, 1>() = offset;
    io::PointCloud source = Transformed(bun0, shift), target = Transformed(bun4, shift);
    source.normals.clear();  // estimated, as for a cloud without them
    target.normals.clear();
    const Eigen::Matrix4d truth = shift * Bun0ToBun4() * shift.inverse();
    const CloudRegistrationResult r = RegisterClouds(source, target, CloudRegistrationOptions{});
    ASSERT_TRUE(r.ok()) << offset.transpose() << ": " << r.reason;
    EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, truth), 0.004) << offset.transpose();
  }
  io::PointCloud twice = bun0, far = bun4;
  twice.normals.clear();
  far.normals.clear();
  twice.points.insert(twice.points.end(), bun0.points.begin(), bun0.points.end());
  far.points.push_back(Eigen::Vector3d(1e9, 0, 0));
  EXPECT_NEAR(EstimatePointSpacing(twice), EstimatePointSpacing(bun0), 1e-9);
  const CloudRegistrationResult r = RegisterClouds(twice, far, CloudRegistrationOptions{});
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_LT(TransformRmsOnCloud(bun0, r.target_from_source, Bun0ToBun4()), 0.004);
}

TEST(FeatureRegistration, StanfordScansAgainstBunConf) {
  const std::string dir = "/work/shared/data/pointclouds/stanford_bunny/";
  if (!fs::exists(dir + "bun000.ply") || !fs::exists(dir + "bun045.ply")) {
    GTEST_SKIP() << "Stanford bunny scans (research licence) not present in " << dir;
  }
  const io::PointCloud bun000 = io::ReadPointCloud(dir + "bun000.ply");
  const io::PointCloud bun045 = io::ReadPointCloud(dir + "bun045.ply");
  // bun.conf: bun045 t = (-0.0520211, -0.000383981, -0.0109223), q = (0.00548449, -0.294635,
  // -0.0038555, 0.955586) (x y z w); p_common = R(q)ᵀ·p + t; bun000 is the identity.
  const Eigen::Quaterniond q(0.955586, 0.00548449, -0.294635, -0.0038555);
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  truth.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix().transpose();
  truth.topRightCorner<3, 1>() = Eigen::Vector3d(-0.0520211, -0.000383981, -0.0109223);
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;  // the default "auto" also runs SHOT (slower test)
  const CloudRegistrationResult r = RegisterClouds(bun045, bun000, options);
  ASSERT_TRUE(r.ok()) << r.reason;
  const Eigen::Matrix3d dr =
      truth.topLeftCorner<3, 3>().transpose() * r.target_from_source.topLeftCorner<3, 3>();
  EXPECT_LT(RotationAngleDeg(dr), 0.15);
  EXPECT_LT((truth.topRightCorner<3, 1>() - r.target_from_source.topRightCorner<3, 1>()).norm(),
            0.3e-3);
}

TEST(FeatureRegistration, FailuresAreReportedNotGuessed) {
  const io::PointCloud bun0 = io::ReadPointCloud(kPclDir + "bun0.pcd");
  CloudRegistrationOptions options;
  // Empty cloud.
  CloudRegistrationResult r = RegisterClouds(io::PointCloud{}, bun0, options);
  EXPECT_EQ(r.status, "failed");
  EXPECT_NE(r.reason.find("empty"), std::string::npos) << r.reason;
  // NaN point.
  io::PointCloud nan_cloud = bun0;
  nan_cloud.points[5].y() = std::nan("");
  r = RegisterClouds(nan_cloud, bun0, options);
  EXPECT_EQ(r.status, "failed");
  EXPECT_NE(r.reason.find("not finite"), std::string::npos) << r.reason;
  // Too sparse for the (given) radii.
  CloudRegistrationOptions tiny = options;
  tiny.normal_radius_m = 1e-4;
  tiny.support_radius_m = 2e-4;
  r = RegisterClouds(bun0, bun0, tiny);
  EXPECT_EQ(r.status, "failed");
  EXPECT_NE(r.reason.find("sparse"), std::string::npos) << r.reason;
  // A dozen points of the bunny (above the hard minimum of 10): the failure says the cloud has
  // too few points, not only its symptom.
  io::PointCloud dozen;
  for (size_t i = 0; i < 12; ++i) dozen.points.push_back(bun0.points[i * (bun0.size() - 1) / 11]);
  r = RegisterClouds(dozen, bun0, options);
  EXPECT_EQ(r.status, "failed") << r.BriefReport();
  EXPECT_NE(r.reason.find("the source has only 12 points: too few"), std::string::npos) << r.reason;
  // No overlap: a random blob registered to the bunny.
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0.0, 0.05);
  io::PointCloud blob;
  for (int i = 0; i < 400; ++i) blob.points.emplace_back(5 + g(rng), g(rng), g(rng));
  r = RegisterClouds(blob, bun0, options);
  EXPECT_EQ(r.status, "failed") << r.BriefReport();
  EXPECT_FALSE(r.reason.empty());
  // A plane against a plane: any in-plane shift fits; never an "ok" with a wrong transform.
  io::PointCloud plane, plane2;
  for (int i = 0; i < 40; ++i) {
    for (int j = 0; j < 40; ++j) {
      plane.points.emplace_back(0.01 * i, 0.01 * j, 0.0);
      plane2.points.emplace_back(0.01 * i + 0.123, 0.01 * j - 0.05, 0.0);
    }
  }
  // Overlap and normals agree at every in-plane shift: ambiguous; and without the
  // ambiguity test (max_ambiguity 1), the pose is not resolved.
  r = RegisterClouds(plane, plane2, options);
  EXPECT_EQ(r.status, "failed") << r.BriefReport();
  CloudRegistrationOptions no_ambiguity = options;
  no_ambiguity.max_ambiguity = 1.0;
  r = RegisterClouds(plane, plane2, no_ambiguity);
  EXPECT_EQ(r.status, "failed") << r.BriefReport();
  EXPECT_NE(r.reason.find("not resolved"), std::string::npos) << r.reason;
  EXPECT_FALSE(std::isfinite(r.resolution_m));
  // The fit's own uncertainty says the same: the in-plane shifts and the turn about the normal
  // are free (a singular Gauss–Newton matrix), so no finite covariance is claimed.
  EXPECT_LT(r.constraint_ratio, 1e-6);
  EXPECT_FALSE(std::isfinite(r.sigma_rms_m));
  EXPECT_FALSE(r.covariance.allFinite());
  EXPECT_NE(r.weakest_motion.find("unconstrained"), std::string::npos) << r.weakest_motion;
  // Bad options are an InputError.
  CloudRegistrationOptions bad = options;
  bad.min_fitness = 0;
  EXPECT_THROW(RegisterClouds(bun0, bun0, bad), InputError);
}

// Uniform random points on the six faces of the box [lo, hi], one per spacing² on average.
void SampleBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double spacing,
               std::mt19937* rng, io::PointCloud* out) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector3d size = hi - lo;
  for (int axis = 0; axis < 3; ++axis) {
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const int n = static_cast<int>(size[a] * size[b] / (spacing * spacing));
    for (double face : {lo[axis], hi[axis]}) {
      for (int i = 0; i < n; ++i) {
        Eigen::Vector3d p;
        p[axis] = face;
        p[a] = lo[a] + u(*rng) * size[a];
        p[b] = lo[b] + u(*rng) * size[b];
        out->points.push_back(p);
      }
    }
  }
}

// A gate (two posts, a beam, a door panel) with optional relief blocks on its front and the
// door off the posts' mid-plane: without them it is symmetric under a 180° turn about z.
io::PointCloud Gate(double spacing, bool details, uint32_t seed) {
  std::mt19937 rng(seed);
  io::PointCloud gate;
  SampleBox({-2.0, 0.0, 0.0}, {-1.5, 0.5, 2.5}, spacing, &rng, &gate);
  SampleBox({1.5, 0.0, 0.0}, {2.0, 0.5, 2.5}, spacing, &rng, &gate);
  SampleBox({-2.2, -0.05, 2.5}, {2.2, 0.55, 3.0}, spacing, &rng, &gate);
  const double door_y = details ? 0.3 : 0.22;
  SampleBox({-1.5, door_y, 0.0}, {1.5, door_y + 0.06, 2.5}, spacing, &rng, &gate);
  if (details) {
    const double blocks[][3] = {{-1.9, 0.6, 0.3}, {-1.85, 1.7, 0.25}, {1.6, 1.1, 0.3},
                                {-0.9, 2.6, 0.35}, {0.7, 2.65, 0.3}, {-0.8, 1.2, 0.4},
                                {0.5, 0.4, 0.3}};
    for (const auto& b : blocks) {
      const double y_front = b[1] > 2.5 ? -0.05 : (std::abs(b[0]) > 1.5 ? 0.0 : door_y);
      SampleBox({b[0], y_front - 0.08, b[1]}, {b[0] + b[2], y_front, b[1] + b[2]}, spacing, &rng,
                &gate);
    }
  }
  return gate;
}

// A LiDAR-like reference: the room around the gate (10 × 10 × 4 m, coarser) plus the gate.
io::PointCloud Room(const io::PointCloud& gate, uint32_t seed) {
  std::mt19937 rng(seed);
  io::PointCloud room;
  SampleBox({-5, -5, 0}, {5, 5, 4}, 0.2, &rng, &room);
  room.points.insert(room.points.end(), gate.points.begin(), gate.points.end());
  return room;
}

Eigen::Matrix4d BlockPose() {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(2.3, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  t.topRightCorner<3, 1>() = Eigen::Vector3d(3.0, -2.0, 0.7);
  return t;
}

TEST(FeatureRegistration, ObjectInsideALargeReference) {
  // One object's reconstruction against a whole LiDAR model of its room: the coarse level must
  // not thin the object away for the room's sake, and the fine check runs on the reference
  // cropped to the object. Source and reference are independent samples of the surface.
  const Eigen::Matrix4d source_from_world = BlockPose();
  const io::PointCloud source = Transformed(Gate(0.07, true, 1), source_from_world);
  const io::PointCloud reference = Room(Gate(0.07, true, 2), 3);
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  const CloudRegistrationResult r = RegisterClouds(source, reference, options);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  const Eigen::Matrix4d truth = source_from_world.inverse();
  EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, truth), 0.02) << r.BriefReport();
  EXPECT_GT(r.significance, options.min_significance);
  // The pose is resolved to a few fine spacings, and the stated resolution bounds the error.
  EXPECT_LE(r.resolution_m, options.max_resolution_spacing * r.fine_spacing_m);
  EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, truth), r.resolution_m);
  // A finite covariance within the same bound; symmetric, positive definite.
  EXPECT_LE(options.resolution_t * r.sigma_rms_m, options.max_resolution_spacing * r.fine_spacing_m);
  ASSERT_TRUE(r.covariance.allFinite());
  EXPECT_LT((r.covariance - r.covariance.transpose()).cwiseAbs().maxCoeff(),
            1e-9 * r.covariance.cwiseAbs().maxCoeff());
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(r.covariance);
  EXPECT_GT(eig.eigenvalues()(0), 0.0);
  EXPECT_GT(r.sigma_translation_m.minCoeff(), 0.0);
  EXPECT_GT(r.sigma_rotation_deg.minCoeff(), 0.0);
}

// `fraction` × the cloud's size of uniform points in its bounding box (a dense matcher's
// blunders), appended after the cloud's own points.
io::PointCloud WithScatter(const io::PointCloud& cloud, double fraction, uint32_t seed) {
  std::mt19937 rng(seed);
  Eigen::Vector3d lo = cloud.points[0], hi = cloud.points[0];
  for (const Eigen::Vector3d& p : cloud.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  std::uniform_real_distribution<double> u(0.0, 1.0);
  io::PointCloud out = cloud;
  const size_t n = static_cast<size_t>(fraction * static_cast<double>(cloud.size()));
  for (size_t i = 0; i < n; ++i) {
    out.points.push_back(lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo));
  }
  return out;
}

TEST(FeatureRegistration, ScatteredBlundersAreRemovedFirst) {
  // Two overlapping pieces of PCL's table scan (a stereo camera's), each a different 70 %
  // of its points with 0.5 mm of noise of its own, and each with 5 % of its points scattered
  // uniformly over its box. The blunders are removed before anything else (by default), so
  // the coarse level and the spacing (hence R_n and R_s) are those of the clean pieces; the
  // clean pieces are registered as given.
  io::ReadOptions read;
  read.skip_invalid_points = true;
  const io::PointCloud table = io::ReadPointCloud(kPclDir + "table_scene_mug_stereo_textured.pcd", read);
  std::vector<double> xs;
  for (const Eigen::Vector3d& p : table.points) xs.push_back(p.x());
  const double lo = Percentile(xs, 1), hi = Percentile(xs, 99), mid = Percentile(xs, 50);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.0005);
  io::PointCloud clean_source, clean_target;
  for (const Eigen::Vector3d& p : table.points) {
    const Eigen::Vector3d jitter(noise(rng), noise(rng), noise(rng));
    if (p.x() <= mid + 0.25 * (hi - lo) && u(rng) < 0.7) clean_source.points.push_back(p + jitter);
    if (p.x() >= mid - 0.25 * (hi - lo) && u(rng) < 0.7) clean_target.points.push_back(p - jitter);
  }
  const Eigen::Matrix4d source_from_target = BlockPose();
  clean_source = Transformed(clean_source, source_from_target);
  const io::PointCloud source = WithScatter(clean_source, 0.05, 4);
  const io::PointCloud target = WithScatter(clean_target, 0.05, 5);
  const CloudRegistrationOptions options;
  const CloudRegistrationResult clean = RegisterClouds(clean_source, clean_target, options);
  ASSERT_TRUE(clean.ok()) << clean.BriefReport();
  EXPECT_EQ(clean.blunders_removed_source + clean.blunders_removed_target, 0u);
  const CloudRegistrationResult r = RegisterClouds(source, target, options);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  EXPECT_LT(TransformRmsOnCloud(clean_source, r.target_from_source, source_from_target.inverse()), 0.002)
      << r.BriefReport();
  // Most of the blunders go, hardly any surface point.
  const size_t scattered_source = source.size() - clean_source.size();
  const size_t scattered_target = target.size() - clean_target.size();
  EXPECT_GE(r.blunders_removed_source, scattered_source * 9 / 10);
  EXPECT_LE(r.blunders_removed_source, scattered_source + clean_source.size() / 200);
  EXPECT_GE(r.blunders_removed_target, scattered_target * 9 / 10);
  EXPECT_LE(r.blunders_removed_target, scattered_target + clean_target.size() / 200);
  EXPECT_NEAR(r.point_spacing_m, clean.point_spacing_m, 0.1 * clean.point_spacing_m);
  // Kept, they take voxels of their own at the coarse level and coarsen it.
  CloudRegistrationOptions keep = options;
  keep.remove_blunders = false;
  const CloudRegistrationResult kept = RegisterClouds(source, target, keep);
  EXPECT_EQ(kept.blunders_removed_source + kept.blunders_removed_target, 0u);
  EXPECT_GT(kept.point_spacing_m, 1.2 * clean.point_spacing_m) << kept.BriefReport();
}

// FPFH registration of `source` onto `reference` with each fine-ICP objective
// (point-to-plane, then plane-to-plane): the error against `truth` (RMS over the source) and
// the stated σ; NaN for a registration that was not ok (a failure of the test).
struct ObjectiveResult {
  std::string objective;
  double error_m, sigma_m, gate_sensitivity_m;
};
std::vector<ObjectiveResult> WithBothObjectives(const io::PointCloud& source,
                                                const io::PointCloud& reference,
                                                const Eigen::Matrix4d& truth) {
  std::vector<ObjectiveResult> out;
  for (const bool plane_to_plane : {false, true}) {
    CloudRegistrationOptions options;
    options.descriptor = Descriptor::kFpfh;
    options.icp_plane_to_plane = plane_to_plane;
    const CloudRegistrationResult r = RegisterClouds(source, reference, options);
    ObjectiveResult o{plane_to_plane ? "plane-to-plane" : "point-to-plane",
                      std::numeric_limits<double>::quiet_NaN(), r.sigma_rms_m,
                      r.gate_sensitivity_m};
    EXPECT_TRUE(r.ok()) << o.objective << ": " << r.BriefReport();
    if (r.ok()) o.error_m = TransformRmsOnCloud(source, r.target_from_source, truth);
    std::printf("[ measured ] %s: %.2f mm RMS from the truth, sigma %.2f mm\n",
                o.objective.c_str(), o.error_m * 1e3, o.sigma_m * 1e3);
    out.push_back(o);
  }
  return out;
}

TEST(FeatureRegistration, ModelWithoutTheReliefStatesItsBias) {
  // A model that leaves out relief the reference has (a plane proxy of a detailed façade).
  // The fine ICP pulls the source's faces towards whatever relief falls within its last
  // correspondence distance, an error the residuals' covariance alone puts at a fraction of
  // the actual one (here 0.7 mm stated, 3.0 mm actual; the simulated cathedral's plane proxy
  // 0.7 cm stated, 8 cm actual). The pose's move with that distance halved and doubled is part
  // of the stated uncertainty (here 3.1 mm).
  const Eigen::Matrix4d source_from_world = BlockPose();
  const io::PointCloud source = Transformed(Gate(0.07, true, 1), source_from_world);
  // The reference's front (the faces towards −y: the beam's at y = −0.05 m, the posts' at 0)
  // stands 4 cm proud over its left half (x < 0): the model has one plane where the
  // reference has two levels.
  io::PointCloud reference = Room(Gate(0.07, true, 2), 3);
  for (Eigen::Vector3d& p : reference.points) {
    const bool front = std::abs(p.y() + (p.z() > 2.5 ? 0.05 : 0.0)) < 1e-9;
    if (front && p.x() < 0.0 && std::abs(p.x()) <= 2.2) p.y() -= 0.04;
  }
  for (const ObjectiveResult& o : WithBothObjectives(source, reference, source_from_world.inverse())) {
    SCOPED_TRACE(o.objective);
    EXPECT_GT(o.gate_sensitivity_m, 0.0);
    EXPECT_LT(o.error_m, 2.0 * o.sigma_m);
  }
}

// The fine ICP's two objectives (point-to-plane, the default; `icp_plane_to_plane`:
// plane-to-plane, Segal et al. 2009): another sample of the same gate, inside its room,
// registers with both, each within a fraction of the 7 cm spacing, its σ covering the error.
// The relief case above is where plane-to-plane does worse: 7.9 mm off with σ 6.3 mm (the σ
// honest because point-to-plane's answer is part of it), point-to-plane 3.0 mm.
TEST(FeatureRegistration, PlaneToPlaneFineIcpRegistersTheGate) {
  const Eigen::Matrix4d source_from_world = BlockPose();
  const io::PointCloud source = Transformed(Gate(0.07, true, 1), source_from_world);
  const io::PointCloud reference = Room(Gate(0.07, true, 2), 3);
  for (const ObjectiveResult& o : WithBothObjectives(source, reference, source_from_world.inverse())) {
    SCOPED_TRACE(o.objective);
    EXPECT_LT(o.error_m, 2e-3);
    EXPECT_LT(o.error_m, 2.0 * o.sigma_m);
  }
}

// RefineSimilarity: a source in a scale of its own, started 4 % off in scale, 1° and a few
// centimetres off in pose, comes to the scale and pose of an independent sample of the same
// surface; without the scale parameter a rigid fit could not.
TEST(FeatureRegistration, RefineSimilarityRecoversTheScale) {
  const io::PointCloud world = Gate(0.07, true, 1), reference = Gate(0.07, true, 2);
  const double block_scale = 0.37;  // block units per metre (a COLMAP model's own scale)
  Eigen::Matrix4d block_from_world = BlockPose();
  block_from_world.topLeftCorner<3, 3>() *= block_scale;
  block_from_world.topRightCorner<3, 1>() *= block_scale;
  const io::PointCloud source = Transformed(world, block_from_world);
  const Eigen::Matrix4d truth = block_from_world.inverse();
  Eigen::Matrix4d start = truth;
  start.topLeftCorner<3, 3>() = 1.04 * Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d(0.3, -0.2, 1).normalized()).toRotationMatrix() *
                                truth.topLeftCorner<3, 3>();
  start.topRightCorner<3, 1>() += Eigen::Vector3d(0.05, -0.04, 0.03);
  const SimilarityFit fit = RefineSimilarity(source, reference, start, 0.5, 0.1);
  EXPECT_NEAR(fit.scale, 1.0 / block_scale, 0.002 / block_scale);
  EXPECT_LT(TransformRmsOnCloud(source, fit.target_from_source, truth), 0.01);
  EXPECT_GT(fit.fitness, 0.9);
  EXPECT_GT(TransformRmsOnCloud(source, start, truth), 0.05);  // the start was centimetres to decimetres off
}

// RegisterCloudsOverScales: an object's reconstruction at 0.37 of its size (an SfM cloud in a
// scale of its own) against a metric model of its room: found at the trial scale nearest the
// truth and refined to it; a range that misses the scale fails and says so. With trial scales
// about 5 % either side of the truth no trial registers (a rigid pose at a scale that far off is
// refused by the checks): the failed trials whose pose fits are refined as similarities and the
// source registered again at the refined scale. Without that second pass this search fails.
TEST(FeatureRegistration, ScaleSearchFindsTheScaleOrFails) {
  const double block_scale = 0.37;
  Eigen::Matrix4d block_from_world = BlockPose();
  block_from_world.topLeftCorner<3, 3>() *= block_scale;
  block_from_world.topRightCorner<3, 1>() *= block_scale;
  const io::PointCloud source = Transformed(Gate(0.07, true, 1), block_from_world);
  const io::PointCloud reference = Room(Gate(0.07, true, 2), 3);
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  const ScaleSearchResult r = RegisterCloudsOverScales(source, reference, options, 2.3, 3.1, 1.07);
  ASSERT_TRUE(r.ok()) << r.reason;
  EXPECT_EQ(r.trials.size(), 5u);  // 2.3 · 1.07^k ≤ 3.1
  EXPECT_NEAR(r.scale, 1.0 / block_scale, 0.01 / block_scale);
  EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, block_from_world.inverse()), 0.02);
  EXPECT_GT(r.fitness, 0.5);

  const ScaleSearchResult wrong = RegisterCloudsOverScales(source, reference, options, 0.8, 0.9, 1.07);
  EXPECT_FALSE(wrong.ok());
  EXPECT_NE(wrong.reason.find("trial scales"), std::string::npos) << wrong.reason;
  EXPECT_THROW(RegisterCloudsOverScales(source, reference, options, 2.0, 1.0), InputError);

  const double truth = 1.0 / block_scale;  // 2.7027
  const ScaleSearchResult again = RegisterCloudsOverScales(source, reference, options, 0.95 * truth, 1.06 * truth, 1.11);
  ASSERT_EQ(again.trials.size(), 3u);  // 0.95 and 1.0545 × the truth, then the second pass
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_FALSE(again.trials[k].from_refinement);
    EXPECT_NE(again.trials[k].status, "ok") << "trial " << k << " registered: the case does not need the second pass";
  }
  EXPECT_TRUE(again.trials[2].from_refinement);
  EXPECT_EQ(again.trials[2].status, "ok");
  ASSERT_TRUE(again.ok()) << again.reason;
  EXPECT_NEAR(again.scale, truth, 0.01 * truth);
  EXPECT_LT(TransformRmsOnCloud(source, again.target_from_source, block_from_world.inverse()), 0.02);
}

TEST(FeatureRegistration, SymmetricObjectIsNotOkWithTheTurnedPose) {
  // Without its details the gate fits its reference equally well turned by 180° about z: the
  // result must say so (failed, ambiguous) — or, if only one pose was found, be the right one.
  const Eigen::Matrix4d source_from_world = BlockPose();
  const io::PointCloud source = Transformed(Gate(0.07, false, 1), source_from_world);
  const io::PointCloud reference = Gate(0.07, false, 2);
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  const CloudRegistrationResult r = RegisterClouds(source, reference, options);
  if (r.ok()) {
    EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, source_from_world.inverse()),
              0.02)
        << r.BriefReport();
  } else {
    EXPECT_NE(r.reason.find("ambiguous"), std::string::npos) << r.reason;
    EXPECT_LT(r.significance, options.min_significance);
  }
}

// The symmetric gate (source and reference independent samples) with the search cut to one
// hypothesis and no period shifts, its pose and its twin under the gate's symmetry: 180° about
// the vertical through (0, 0.25), (x, y, z) -> (-x, 0.5 - y, z).
struct SymmetricGateCase {
  io::PointCloud source = Transformed(Gate(0.07, false, 1), BlockPose());
  io::PointCloud reference = Gate(0.07, false, 2);
  Eigen::Matrix4d truth = BlockPose().inverse();
  Eigen::Matrix4d twin;
  CloudRegistrationOptions options;
  SymmetricGateCase() {
    Eigen::Matrix4d flip = Eigen::Matrix4d::Identity();
    flip(0, 0) = flip(1, 1) = -1.0;
    flip(1, 3) = 0.5;
    twin = flip * truth;
    options.descriptor = Descriptor::kFpfh;
    options.intensity_test = false;
    options.num_hypotheses = 1;
    options.use_max_clique = false;
    options.num_period_shifts = 0;
  }
  bool Near(const CloudRegistrationResult& r, const Eigen::Matrix4d& pose) const {
    for (const RegistrationHypothesis& h : r.hypotheses) {
      if (TransformRmsOnCloud(source, h.target_from_source, pose) < 0.03) return true;
    }
    return false;
  }
};

// Pseudo-symmetric turns of the best pose join the verification (Kim & Hilton's parts turned
// 180°): the symmetric gate has one finalist — the truth or its twin — and would be "ok"
// whichever it is. The turned best pose, placed and refined, adds the other, so both poses
// are finalists and the result is "ambiguous". Switched off, no such finalist.
TEST(FeatureRegistration, SymmetricTurnsJoinTheVerification) {
  SymmetricGateCase g;
  g.options.symmetry_turns = false;
  const CloudRegistrationResult off = RegisterClouds(g.source, g.reference, g.options);
  for (const RegistrationHypothesis& h : off.hypotheses) {
    EXPECT_NE(h.origin.rfind("symmetric turn", 0), 0u) << h.origin;
  }
  EXPECT_FALSE(g.Near(off, g.truth) && g.Near(off, g.twin)) << off.BriefReport();  // one pose
  g.options.symmetry_turns = true;
  const CloudRegistrationResult r = RegisterClouds(g.source, g.reference, g.options);
  int turned = 0;
  for (const RegistrationHypothesis& h : r.hypotheses) {
    turned += h.origin.rfind("symmetric turn", 0) == 0 ? 1 : 0;
  }
  EXPECT_GE(turned, 1) << r.BriefReport();
  EXPECT_TRUE(g.Near(r, g.truth) && g.Near(r, g.twin)) << r.BriefReport();
  ASSERT_FALSE(r.ok()) << r.BriefReport();
  EXPECT_NE(r.reason.find("ambiguous"), std::string::npos) << r.reason;
}

// The turned best pose is also placed where it was turned (about the registered source's
// centroid), not only by the descriptor matches' displacement vote: where the vote has no
// usable mode (here so few keypoints that no displacement gets 3 votes; on the full simulated
// gate the twin's matches voted along a line), the symmetric gate's other pose must still
// become a finalist and the result be refused. Without the centroid placement this case is
// reported "ok" with confidence 1 (checked by removing it).
TEST(FeatureRegistration, SymmetricTurnAboutTheCentroidWithoutAVote) {
  SymmetricGateCase g;
  g.options.min_keypoints = 5;  // 5 and 4 keypoints, 7 correspondences: no vote mode
  g.options.max_keypoints = 6;
  const CloudRegistrationResult r = RegisterClouds(g.source, g.reference, g.options);
  int about_centroid = 0;
  for (const RegistrationHypothesis& h : r.hypotheses) {
    const bool turn = h.origin.rfind("symmetric turn", 0) == 0;
    about_centroid += turn && h.origin.find("about the centroid") != std::string::npos ? 1 : 0;
  }
  EXPECT_GE(about_centroid, 1) << r.BriefReport();
  EXPECT_TRUE(g.Near(r, g.truth) && g.Near(r, g.twin)) << r.BriefReport();
  EXPECT_FALSE(r.ok()) << r.BriefReport();
}

// A part of the symmetric gate (its left half) registered onto the whole gate, levelled:
// the part's twin is its turn about the gate's axis, which passes through the whole gate's
// centroid, not the part's. With so few keypoints that no displacement gets 3 votes, the turn
// about the part's centroid lands metres off; the turn about the target's centroid must make
// the twin a finalist, and the result be refused. (The full simulated gate's plane-proxy part
// onto its stereo cloud, levelled, was reported ok at its twin, 5.95 m off, before this
// placement; without it this case is reported ok.) The turn −2.3 rad: at +2.3 rad, since
// each cloud is registered about its own centre, three correspondences vote for
// one displacement, so the vote places the turns and this path is not the one tested.
// The left half of the symmetric gate, turned by `angle` about up and placed; levelled, with
// so few keypoints (4–5) that the hypotheses are few.
SymmetricGateCase PartOfTheGate(double angle) {
  SymmetricGateCase g;
  io::PointCloud part;
  for (const Eigen::Vector3d& p : Gate(0.07, false, 1).points) {
    if (p.x() < 0.2) part.points.push_back(p);
  }
  Eigen::Matrix4d pose = BlockPose();  // without its tilt: turned about up only
  pose.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix4d flip = g.twin * g.truth.inverse();
  g.source = Transformed(part, pose);
  g.truth = pose.inverse();
  g.twin = flip * g.truth;
  g.options.gravity_aligned = true;
  g.options.min_keypoints = 4;  // so few correspondences that no vote mode
  g.options.max_keypoints = 5;
  return g;
}

TEST(FeatureRegistration, PartTurnedAboutTheTargetsCentroid) {
  SymmetricGateCase g = PartOfTheGate(-2.3);
  const CloudRegistrationResult r = RegisterClouds(g.source, g.reference, g.options);
  int about_target = 0;
  for (const RegistrationHypothesis& h : r.hypotheses) {
    about_target += h.origin.find("about the target's centroid") != std::string::npos ? 1 : 0;
  }
  EXPECT_GE(about_target, 1) << r.BriefReport();
  EXPECT_TRUE(g.Near(r, g.truth) && g.Near(r, g.twin)) << r.BriefReport();
  EXPECT_FALSE(r.ok()) << r.BriefReport();
}

// The same part turned +2.3 rad: the best hypothesis is neither pose (2.8 m from the truth,
// 1.5 m from the twin), its 180° turn lands on the twin and becomes the best; turned once,
// the twin was reported "ok". The new best is turned in its turn, which finds the truth: the
// result is ambiguous.
TEST(FeatureRegistration, ATurnThatBecomesTheBestIsTurnedAgain) {
  SymmetricGateCase g = PartOfTheGate(2.3);
  const CloudRegistrationResult r = RegisterClouds(g.source, g.reference, g.options);
  EXPECT_TRUE(g.Near(r, g.truth) && g.Near(r, g.twin)) << r.BriefReport();
  EXPECT_FALSE(r.ok()) << r.BriefReport();
}

// The part at the turns where a search without symmetric turns reports "ok" (+1.0 rad at the
// twin; the others right by luck, the twin never found): sac-ia's pose was neither, its 180° turn about the
// centroid 0.6 m off the truth, that one's turn the twin — and the turns stopped after two
// rounds, and the truth found in a third was taken for the same pose as the 0.6 m one (10 τ
// apart) and dropped. With the better-scoring pose kept and up to four rounds, the twin and
// the truth are both finalists at these turns, and the symmetric object is refused. At −0.6
// rad the local search moved the best onto the truth after the turns, whose turn of the pose
// before it missed the twin: a best the local search moved is turned again. (Of 31 turns
// from −3 to 3 rad all 31 are now refused; before: 4 right and 1 wrong "ok".)
TEST(FeatureRegistration, EverySymmetricTurnOfTheGatesPartIsRefused) {
  for (const double angle : {1.0, 1.2, 1.6, -2.8, -0.6}) {
    SymmetricGateCase g = PartOfTheGate(angle);
    const CloudRegistrationResult r = RegisterClouds(g.source, g.reference, g.options);
    EXPECT_FALSE(r.ok()) << angle << ": " << r.BriefReport();
    EXPECT_TRUE(g.Near(r, g.truth) && g.Near(r, g.twin)) << angle << ": " << r.BriefReport();
  }
}

// The symmetric gate with a texture (a brightness that is a smooth random function of the
// position on the gate, sampled with noise by each cloud): the shape cannot tell the pose
// from its 180° twin, the brightness can (the intensity test), so the result is ok and
// right; with the test off it is not ok with the twin.
io::PointCloud Textured(const io::PointCloud& gate, uint32_t seed) {
  std::mt19937 rng(1234);  // one texture for every sample
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> bumps;
  for (int k = 0; k < 80; ++k) bumps.emplace_back(-2.2 + 4.4 * u(rng), -0.1 + 0.7 * u(rng), 3.0 * u(rng));
  std::mt19937 sample(seed);
  std::normal_distribution<double> noise(0.0, 0.05);
  io::PointCloud out = gate;
  out.intensity.clear();
  for (const Eigen::Vector3d& p : gate.points) {
    double v = 0.0;
    for (const Eigen::Vector3d& b : bumps) v += std::exp(-(p - b).squaredNorm() / (2 * 0.25 * 0.25));
    out.intensity.push_back(static_cast<float>(v + noise(sample)));
  }
  return out;
}

TEST(FeatureRegistration, IntensitySettlesTheSymmetricTwin) {
  const Eigen::Matrix4d source_from_world = BlockPose();
  const io::PointCloud source = Transformed(Textured(Gate(0.07, false, 1), 5), source_from_world);
  const io::PointCloud reference = Textured(Gate(0.07, false, 2), 6);
  const Eigen::Matrix4d truth = source_from_world.inverse();
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  options.intensity_test = false;
  const CloudRegistrationResult shape = RegisterClouds(source, reference, options);
  EXPECT_FALSE(shape.intensity_tested);
  ASSERT_FALSE(shape.ok()) << shape.BriefReport();  // the tie the test is about
  EXPECT_NE(shape.reason.find("ambiguous"), std::string::npos) << shape.reason;
  options.intensity_test = true;
  const CloudRegistrationResult r = RegisterClouds(source, reference, options);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, truth), 0.02);
  EXPECT_TRUE(r.intensity_tested);
  EXPECT_GT(r.intensity_correlation, 0.5);
  EXPECT_GE(r.significance, options.min_significance);
}

TEST(FeatureRegistration, RepeatedBaysGetPeriodShiftFinalists) {
  // One gate against an arcade of four identical gates 6 m apart. The best pose moved by the
  // displacement modes of the descriptor matches must enter the verification as "period
  // shift" finalists, and an "ok" must put the gate exactly onto one of the bays. (Every bay
  // fits, so "ambiguous" would be the right verdict; it is not reached here: the strongest
  // modes are the posts' mirror matches at 3, 9 and 16 m, not the 6 m period.)
  const Eigen::Matrix4d source_from_world = BlockPose();
  const io::PointCloud source = Transformed(Gate(0.07, true, 1), source_from_world);
  io::PointCloud arcade;
  for (int bay = 0; bay < 4; ++bay) {
    const io::PointCloud gate = Gate(0.07, true, 10 + bay);
    for (const Eigen::Vector3d& p : gate.points) {
      arcade.points.push_back(p + Eigen::Vector3d(6.0 * bay, 0.0, 0.0));
    }
  }
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  const CloudRegistrationResult r = RegisterClouds(source, arcade, options);
  int shifted = 0;
  for (const RegistrationHypothesis& h : r.hypotheses) {
    shifted += h.origin.rfind("period shift", 0) == 0 ? 1 : 0;
  }
  EXPECT_GE(shifted, 1) << r.BriefReport();
  if (r.ok()) {
    double nearest_bay = std::numeric_limits<double>::infinity();
    for (int bay = 0; bay < 4; ++bay) {
      Eigen::Matrix4d truth = source_from_world.inverse();
      truth(0, 3) += 6.0 * bay;
      nearest_bay = std::min(nearest_bay, TransformRmsOnCloud(source, r.target_from_source, truth));
    }
    EXPECT_LT(nearest_bay, 0.02) << r.BriefReport();
  }
  // Switched off, no such finalist.
  options.num_period_shifts = 0;
  const CloudRegistrationResult off = RegisterClouds(source, arcade, options);
  for (const RegistrationHypothesis& h : off.hypotheses) {
    EXPECT_NE(h.origin.rfind("period shift", 0), 0u) << h.origin;
  }
}

TEST(FeatureRegistration, SearchWindowPicksTheBayNearTheApproximatePose) {
  // The arcade of four identical gates, the source already placed near bay 2 (0.3 m and 3°
  // off, as a setup would place it): with a 1.5 m / 10° search window the other bays are no
  // alternatives, the result is bay 2, and every hypothesis kept lies inside the window.
  io::PointCloud arcade, at_bay2;
  for (int bay = 0; bay < 4; ++bay) {
    const io::PointCloud gate = Gate(0.07, true, 10 + bay);
    for (const Eigen::Vector3d& p : gate.points) arcade.points.push_back(p + Eigen::Vector3d(6.0 * bay, 0.0, 0.0));
  }
  for (const Eigen::Vector3d& p : Gate(0.07, true, 1).points) at_bay2.points.push_back(p + Eigen::Vector3d(12.0, 0.0, 0.0));
  Eigen::Matrix4d off = Eigen::Matrix4d::Identity();
  off.topLeftCorner<3, 3>() = Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  off.topRightCorner<3, 1>() = Eigen::Vector3d(12.0, 0.0, 0.0) - off.topLeftCorner<3, 3>() * Eigen::Vector3d(12.0, 0.0, 0.0) +
                               Eigen::Vector3d(0.2, -0.2, 0.1);
  const io::PointCloud source = Transformed(at_bay2, off);
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  options.search_window_m = 1.5;
  options.search_window_deg = 10.0;
  const CloudRegistrationResult r = RegisterClouds(source, arcade, options);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  EXPECT_LT(TransformRmsOnCloud(source, r.target_from_source, off.inverse()), 0.02) << r.BriefReport();
  // Invalid windows are option errors.
  options.search_window_deg = 0.0;
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("search_window_deg"), std::string::npos) << error;
  // So is a scale-agreement fraction outside [0, 1].
  options.search_window_deg = 10.0;
  options.min_coarse_agreement = 1.5;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("min_coarse_agreement"), std::string::npos) << error;
}

// Ground and one wall: a strip of ground `length` × `width` m whose long side runs at 45° to
// a wall 0.2 m thick and 1.5 m high from x = wall_from to wall_to (along x, through the
// origin); with `cross_wall` > 0 a second wall of that length across its end (along y at
// x = wall_to: a corner). Independent random samples at `spacing` with Gaussian noise
// `noise_m`. Without the corner every shift along the wall leaves both surfaces on themselves:
// the scene does not determine it, and its direction is no principal axis of the points.
io::PointCloud GroundAndWall(double length, double width, double wall_from, double wall_to,
                             double cross_wall, double spacing, double noise_m, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::normal_distribution<double> noise(0.0, noise_m);
  io::PointCloud out;
  const int n = static_cast<int>(length * width / (spacing * spacing));
  const double c = std::cos(M_PI / 4), s = std::sin(M_PI / 4);
  for (int i = 0; i < n; ++i) {
    const double a = u(rng) * length, b = u(rng) * width;
    const Eigen::Vector3d p(c * a - s * b, s * a + c * b, noise(rng));
    // The ground under the walls is not seen.
    if (std::abs(p.y()) < 0.1 && p.x() > wall_from && p.x() < wall_to) continue;
    if (cross_wall > 0 && std::abs(p.x() - wall_to) < 0.1 && std::abs(p.y()) < 0.5 * cross_wall) {
      continue;
    }
    out.points.push_back(p);
  }
  io::PointCloud walls;
  SampleBox({wall_from, -0.1, 0.0}, {wall_to, 0.1, 1.5}, spacing, &rng, &walls);
  if (cross_wall > 0) {
    SampleBox({wall_to - 0.1, -0.5 * cross_wall, 0.0}, {wall_to + 0.1, 0.5 * cross_wall, 1.5},
              spacing, &rng, &walls);
  }
  for (Eigen::Vector3d p : walls.points) {
    if (p.z() <= 0.0) continue;  // bottom faces lie on the ground
    p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    out.points.push_back(p);
  }
  return out;
}

TEST(FeatureRegistration, SlideAlongAWallIsNotOk) {
  // A part of ground and wall against a larger survey of the same ground and a longer wall,
  // delivered 0.25 m off along the wall (an approximate pose; search window 0.2 m, so every
  // pose kept lies in one basin and no ambiguity test can speak). Nothing in the data fixes
  // the shift along the wall. The source's principal axes run at 45° to it, so each
  // principal-axis probe of the resolution test also moves the wall across itself and is told
  // apart: before the fit's own weak motions were probed too (probe_weak_motions false), this
  // was "ok" 0.19 m off with a stated resolution of 0.024 m. It must be refused: no
  // displacement along that motion up to R_s is told apart.
  const io::PointCloud target = GroundAndWall(16.0, 16.0, -8.0, 8.0, 0.0, 0.1, 0.005, 7);
  io::PointCloud source = GroundAndWall(10.0, 4.0, -3.0, 3.0, 0.0, 0.1, 0.005, 8);
  for (Eigen::Vector3d& p : source.points) p.x() -= 0.25;
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  truth(0, 3) = 0.25;
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  options.search_window_m = 0.2;
  options.search_window_deg = 5.0;
  const CloudRegistrationResult r = RegisterClouds(source, target, options);
  const double error = TransformRmsOnCloud(source, r.target_from_source, truth);
  EXPECT_EQ(r.status, "failed") << r.BriefReport() << "; error " << error << " m, resolution "
                                << r.resolution_m << " m";
  EXPECT_NE(r.reason.find("not determined"), std::string::npos) << r.reason;
  EXPECT_FALSE(std::isfinite(r.weak_motion_resolution_m));
  // The fit is nearly singular (its smallest eigenvalue in the RMS metric is from the
  // normals' noise only).
  EXPECT_LT(r.constraint_ratio, 0.01);

  // A corner (the wall stops at x = 2 m against a cross wall, in both clouds) fixes the shift:
  // ok, within the resolution it states, with a finite uncertainty inside the same bound and a
  // better-conditioned fit.
  const io::PointCloud target_corner = GroundAndWall(16.0, 16.0, -8.0, 2.0, 8.0, 0.1, 0.005, 7);
  io::PointCloud source_corner = GroundAndWall(10.0, 4.0, -3.0, 2.0, 4.0, 0.1, 0.005, 8);
  for (Eigen::Vector3d& p : source_corner.points) p.x() -= 0.25;
  options.search_window_m = 0.5;
  const CloudRegistrationResult e = RegisterClouds(source_corner, target_corner, options);
  ASSERT_TRUE(e.ok()) << e.BriefReport();
  EXPECT_TRUE(std::isfinite(e.weak_motion_resolution_m));
  EXPECT_LE(e.weak_motion_resolution_m, e.resolution_m);
  EXPECT_LT(TransformRmsOnCloud(source_corner, e.target_from_source, truth), e.resolution_m)
      << e.BriefReport();
  EXPECT_LE(options.resolution_t * e.sigma_rms_m,
            options.max_resolution_spacing * e.fine_spacing_m);
  EXPECT_GT(e.constraint_ratio, 10.0 * r.constraint_ratio);
  EXPECT_TRUE(e.covariance.allFinite());
  EXPECT_LE(e.weak_motion_resolution_m,
            options.max_weak_motion_resolution_spacing * e.fine_spacing_m);

  // "ok" needs the weak motion resolved within its bound, not only at some displacement: a
  // bound of 1/20 spacing (0.5 cm here, the clouds' noise) is not resolved, so the same
  // corner is refused, naming the motion and the larger δ it needed.
  options.max_weak_motion_resolution_spacing = 0.05;
  const CloudRegistrationResult tight = RegisterClouds(source_corner, target_corner, options);
  EXPECT_EQ(tight.status, "failed") << tight.BriefReport();
  EXPECT_NE(tight.reason.find("told apart by the fine verification only at"), std::string::npos)
      << tight.reason;
  EXPECT_GT(tight.weak_motion_resolution_m,
            options.max_weak_motion_resolution_spacing * tight.fine_spacing_m);
  EXPECT_TRUE(std::isfinite(tight.weak_motion_resolution_m));
  EXPECT_TRUE(tight.target_from_source.isApprox(e.target_from_source)) << "same pose, refused";
}

// Ground and a wall along x from x = −8 m to `wall_to`, ending against a cross wall (along y),
// as GroundAndWall but with the ground strip along the wall (x from x0 to x1, y from −2 to
// 2 m): the strip's long principal axis runs along the wall.
io::PointCloud StripWithCorner(double x0, double x1, double wall_to, double spacing,
                               double noise_m, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  io::PointCloud out;
  SampleBox({x0, -2.0, -0.1}, {x1, 2.0, 0.0}, spacing, &rng, &out);
  io::PointCloud ground;
  for (const Eigen::Vector3d& p : out.points) {
    if (p.z() < 0.0) continue;  // the top face only
    if (std::abs(p.y()) < 0.1 && p.x() < wall_to + 0.1) continue;  // under the walls
    ground.points.push_back(p + Eigen::Vector3d(0, 0, noise(rng)));
  }
  io::PointCloud walls;
  SampleBox({std::max(x0, -8.0), -0.1, 0.0}, {wall_to, 0.1, 1.5}, spacing, &rng, &walls);
  SampleBox({wall_to - 0.1, -1.5, 0.0}, {wall_to + 0.1, 1.5, 1.5}, spacing, &rng, &walls);
  for (Eigen::Vector3d p : walls.points) {
    if (p.z() <= 0.0) continue;
    ground.points.push_back(p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  return ground;
}

TEST(FeatureRegistration, LocalSearchLeavesASlideForTheBetterFit) {
  // A clean strip of ground and wall ending in a corner against a noisy survey of the same
  // (3 cm noise: a thick target, as a stereo reconstruction's), delivered 0.6 m off along the
  // wall (an approximate pose; the search window keeps the poses near it). Without the local
  // search the ICP stops 0.2 m short of the corner, where the fit slides along the wall:
  // "pose not resolved" (0.96 m). The local search moves the pose along the open directions
  // and reaches the better fit at the corner: ok at the truth.
  const double kOff = 0.6;
  const io::PointCloud target = StripWithCorner(-8.0, 4.0, 2.0, 0.1, 0.03, 7);
  io::PointCloud source = StripWithCorner(-4.0, 3.0, 2.0, 0.1, 0.005, 8);
  for (Eigen::Vector3d& p : source.points) p.x() -= kOff;
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  truth(0, 3) = kOff;
  CloudRegistrationOptions options;
  options.descriptor = Descriptor::kFpfh;
  options.search_window_m = kOff + 1.0;
  options.search_window_deg = 5.0;
  // The corner's descriptors would find it directly: starved here (3 matches, one SAC-IA
  // sample, one clique), so that the approximate pose is the hypothesis that counts.
  options.max_correspondences = 3;
  options.sac_ia_iterations = 1;
  options.num_cliques = 1;
  const CloudRegistrationResult r = RegisterClouds(source, target, options);
  const double error = TransformRmsOnCloud(source, r.target_from_source, truth);
  EXPECT_TRUE(r.ok()) << r.BriefReport() << "; error " << error;
  EXPECT_LT(error, 0.02) << r.BriefReport();
  options.local_search = false;
  const CloudRegistrationResult off = RegisterClouds(source, target, options);
  const double off_error = TransformRmsOnCloud(source, off.target_from_source, truth);
  EXPECT_FALSE(off.ok() && off_error < 0.02) << off.BriefReport() << "; error " << off_error;
}

TEST(FeatureRegistration, ErrorMapColoursByDistance) {
  io::PointCloud source, target;
  source.points = {{0, 0, 0}, {0, 0, 1}};
  target.points = {{0, 0, 0}};
  const io::PointCloud map = MakeErrorMap(source, target, Eigen::Matrix4d::Identity(), 1.0);
  ASSERT_EQ(map.size(), 2u);
  EXPECT_GT(map.colors[0][2], 100);  // blue at 0 ("jet")
  EXPECT_EQ(map.colors[0][0], 0);
  EXPECT_GT(map.colors[1][0], 100);  // red at max
  EXPECT_EQ(map.colors[1][2], 0);
  EXPECT_FLOAT_EQ(map.intensity[1], 1.0f);
}

}  // namespace
}  // namespace mmba::registration
