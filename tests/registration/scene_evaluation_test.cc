#include "mmba/registration/cloud/scene_evaluation.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::registration {
namespace {

namespace fs = std::filesystem;

std::string MatrixJson(const Eigen::Matrix4d& m) {
  std::ostringstream s;
  s.precision(17);
  s << "[";
  for (int r = 0; r < 4; ++r) {
    s << (r ? "," : "") << "[";
    for (int c = 0; c < 4; ++c) s << (c ? "," : "") << m(r, c);
    s << "]";
  }
  return s.str() + "]";
}

io::PointCloud Transformed(const io::PointCloud& c, const Eigen::Matrix4d& m) {
  io::PointCloud out = c;
  for (auto& p : out.points) p = m.topLeftCorner<3, 3>() * p + m.topRightCorner<3, 1>();
  for (auto& n : out.normals) n = m.topLeftCorner<3, 3>() * n;
  return out;
}

Eigen::Matrix4d Inverse(const Eigen::Matrix4d& m) {
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topLeftCorner<3, 3>() = m.topLeftCorner<3, 3>().transpose();
  out.topRightCorner<3, 1>() = -out.topLeftCorner<3, 3>() * m.topRightCorner<3, 1>();
  return out;
}

// A scene folder made from PCL's bunny views with known transforms (the layout of
// scene_evaluation.h): lidar = bun4; scan0 = bun0 in its own frame (PCL's bun0→bun4 truth);
// moved = bun4 in a rotated frame; scan0_part = half of bun0.
class SceneEvaluationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mmba_scene_eval_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "clouds");
    const std::string pcl = std::string(MMBA_SOURCE_DIR) + "/data/pointclouds/pcl_test/";
    const io::PointCloud bun0 = io::ReadPointCloud(pcl + "bun0.pcd");
    const io::PointCloud bun4 = io::ReadPointCloud(pcl + "bun4.pcd");
    Eigen::Matrix4d world_from_scan0;
    world_from_scan0 << 0.825336, 0, -0.564642, 0.037267, 0, 1, 0, 0, 0.564642, 0, 0.825336,
        0.038325, 0, 0, 0, 1;
    Eigen::Matrix4d world_from_moved = Eigen::Matrix4d::Identity();
    world_from_moved.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    world_from_moved.topRightCorner<3, 1>() = Eigen::Vector3d(1, 2, 3);
    io::WritePly(bun4, (dir_ / "clouds" / "lidar.ply").string());
    io::WritePly(bun0, (dir_ / "clouds" / "scan0.ply").string());
    io::WritePly(Transformed(bun4, Inverse(world_from_moved)),
                 (dir_ / "clouds" / "moved.ply").string());
    io::PointCloud part;
    for (size_t i = 0; i < bun0.size(); ++i) {
      if (bun0.points[i].x() < 0.0) {
        part.points.push_back(bun0.points[i]);
        part.normals.push_back(bun0.normals[i]);
      }
    }
    io::WritePly(part, (dir_ / "clouds" / "scan0_part.ply").string());
    std::ofstream(dir_ / "ground_truth.json")
        << "{\"world_from_lidar\": " << MatrixJson(Eigen::Matrix4d::Identity())
        << ", \"world_from_scan0\": " << MatrixJson(world_from_scan0)
        << ", \"world_from_scan0_part\": " << MatrixJson(world_from_scan0)
        << ", \"world_from_moved\": " << MatrixJson(world_from_moved) << "}\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SceneEvaluationTest, BothExperimentsAndTables) {
  SceneEvalOptions options;
  options.methods = {"fpfh", "mmba"};
  options.accurate_m = 0.005;
  const SceneEvaluation eval = EvaluateScene(dir_.string(), options);
  ASSERT_EQ(eval.modalities, (std::vector<std::string>{"moved", "scan0"}));
  // to-lidar: 2 modalities × 2 methods; cross-modal: scan0_part → {moved, lidar} × 2.
  ASSERT_EQ(eval.rows.size(), 8u);
  int ok_cross = 0;
  for (const EvalRow& r : eval.rows) {
    if (r.method != "mmba") continue;
    SCOPED_TRACE(r.source + " -> " + r.target);
    if (r.experiment == "to-lidar") {
      EXPECT_EQ(r.status, "ok") << r.reason;
    }
    // Never a wrong transform reported as ok (the half bunny against the re-framed bunny may
    // be reported ambiguous instead).
    if (r.status == "ok") {
      EXPECT_TRUE(r.success);
      EXPECT_LT(r.rms_m, 0.01);
      ok_cross += r.experiment == "cross-modal";
    } else {
      EXPECT_FALSE(r.reason.empty());
    }
  }
  EXPECT_GE(ok_cross, 1);
  const fs::path out = dir_ / "eval";
  WriteSceneEvaluation(eval, out.string());
  std::ifstream csv(out / "results.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("experiment,source,target,method,status,rms_m", 0), 0u);
  std::stringstream md;
  md << std::ifstream(out / "tables.md").rdbuf();
  EXPECT_NE(md.str().find("Table I"), std::string::npos);
  EXPECT_NE(md.str().find("| scan0_part |"), std::string::npos);
}

// A row of a cell source → lidar (success below 3 m, accurate below 5 cm).
EvalRow MakeRow(const std::string& experiment, const std::string& source,
                const std::string& method, const std::string& status, double rms,
                double sigma = 0.01) {
  EvalRow r;
  r.sigma_rms_m = sigma;
  r.experiment = experiment;
  r.source = source;
  r.target = "lidar";
  r.method = method;
  r.status = status;
  r.rms_m = rms;
  r.success = rms < 3.0;
  r.accurate = rms < 0.05;
  return r;
}

// The summary picks, per cell, the method that reported ok closest to the truth, and counts
// cells registered, refused by every method, off, and wrong oks on their own.
TEST_F(SceneEvaluationTest, BestMethodPerCell) {
  SceneEvaluation eval;
  eval.dir = "scene";
  eval.success_threshold_m = 3.0;
  eval.accurate_m = 0.05;
  auto row = [](auto... args) { return MakeRow(args...); };
  // In d_part the wrong ok states the larger σ, so the ok chosen without the truth is right; in
  // a the closer ok states the larger σ, so the chosen one is the other (also accurate); in e
  // the chosen one is the inaccurate ok.
  eval.rows = {row("to-lidar", "a", "m1", "ok", 0.02, 0.005), row("to-lidar", "a", "m2", "ok", 0.01),
               row("to-lidar", "e", "m1", "ok", 0.02, 0.02), row("to-lidar", "e", "m2", "ok", 0.08, 0.01),
               row("cross-modal", "b_part", "m1", "failed", 0.01),  // right, but refused
               row("cross-modal", "b_part", "m2", "ok", 0.2),
               row("cross-modal", "c_part", "m1", "failed", 5.0),
               row("cross-modal", "c_part", "m2", "failed", 0.01),
               row("cross-modal", "d_part", "m1", "ok", 7.0, 0.5),  // a wrong ok
               row("cross-modal", "d_part", "m2", "ok", 0.03)};
  const fs::path out = dir_ / "summary";
  WriteSceneEvaluation(eval, out.string());
  std::stringstream md;
  md << std::ifstream(out / "tables.md").rdbuf();
  const std::string text = md.str();
  // Without a from-truth row the table has no reference column.
  EXPECT_EQ(text.find("from the truth"), std::string::npos) << text;
  EXPECT_NE(text.find("| to-lidar | a → lidar | m2 | 0.01 | m1 | 0.005 | 0.02 |"), std::string::npos) << text;
  EXPECT_NE(text.find("| to-lidar | e → lidar | m1 | 0.02 | m2 | 0.01 | 0.08 |"), std::string::npos) << text;
  EXPECT_NE(text.find("| cross-modal | d_part → lidar | m2 | 0.03 | m2 | 0.01 | 0.03 |"), std::string::npos) << text;
  EXPECT_NE(text.find("| cross-modal | c_part → lidar | – (every method failed) | – | – | – | – |"),
            std::string::npos) << text;
  EXPECT_NE(text.find("Registered with the best method (ok and RMS < 0.05 m): 3 of 5 cells; "
                      "every method failed: 1; best ok but RMS ≥ 0.05 m: 1 (b_part → lidar 0.2 m); "
                      "wrong ok (any method, RMS ≥ 3 m): 1.\nRegistered with the method chosen by "
                      "its stated σ (ok and RMS < 0.05 m): 2 of 5 cells."),
            std::string::npos) << text;
}

// The from-truth reference is never a cell's best method nor a wrong ok; its column tells the
// cells the data allow (ok and accurate from the truth) from those it does not register.
TEST_F(SceneEvaluationTest, TheReferenceFromTheTruthIsNoMethod) {
  SceneEvaluation eval;
  eval.dir = "scene";
  eval.success_threshold_m = 3.0;
  eval.accurate_m = 0.05;
  eval.truth_window_m = 0.5;
  eval.truth_window_deg = 5.0;
  auto row = [](const std::string& source, const std::string& method, const std::string& status,
                double rms) { return MakeRow("cross-modal", source, method, status, rms); };
  const double no_pose = std::numeric_limits<double>::quiet_NaN();
  eval.rows = {row("a_part", "m1", "ok", 0.02), row("a_part", kFromTruth, "ok", 0.001),
               // search-limited: refused by the method, the reference registers it
               row("b_part", "m1", "failed", 5.0), row("b_part", kFromTruth, "ok", 0.03),
               // data-limited: the reference's own optimum is 8 cm off (and its ok, 8 cm off,
               // counts as no wrong ok and no best method)
               row("c_part", "m1", "failed", 0.3), row("c_part", kFromTruth, "ok", 0.08),
               // check-limited: refused at the truth; and a reference without a pose
               row("d_part", "m1", "failed", 0.02), row("d_part", kFromTruth, "failed", 0.01),
               row("e_part", "m1", "failed", 1.0), row("e_part", kFromTruth, "failed", no_pose),
               row("f_part", kFromTruth, "ok", 7.0),
               // refused at the right pose: the reference registers it
               row("g_part", "m1", "failed", 0.02), row("g_part", "m2", "failed", 0.9),
               row("g_part", kFromTruth, "ok", 0.01)};
  eval.rows[11].reason = "ambiguous: a different pose fits almost as well";
  const fs::path out = dir_ / "reference";
  WriteSceneEvaluation(eval, out.string());
  std::stringstream md;
  md << std::ifstream(out / "tables.md").rdbuf();
  const std::string text = md.str();
  EXPECT_NE(text.find("| cross-modal | a_part → lidar | m1 | 0.02 | m1 | 0.01 | 0.02 | 0.001, ok |"),
            std::string::npos) << text;
  EXPECT_NE(text.find("| cross-modal | b_part → lidar | – (every method failed) | – | – | – | – | "
                      "0.03, ok |"),
            std::string::npos) << text;
  EXPECT_NE(text.find("| e_part → lidar | – (every method failed) | – | – | – | – | no pose, failed |"),
            std::string::npos) << text;
  EXPECT_NE(text.find("no pose (failed)"), std::string::npos) << text;  // its Table II cell
  EXPECT_NE(text.find("Registered with the best method (ok and RMS < 0.05 m): 1 of 7 cells; "
                      "every method failed: 6; best ok but RMS ≥ 0.05 m: 0; wrong ok (any "
                      "method, RMS ≥ 3 m): 0."),
            std::string::npos) << text;
  EXPECT_NE(text.find("From the truth (the reference, searched within 0.5 m / 5° of it): ok and "
                      "RMS < 0.05 m in 3 of 7 cells — what the data and the checks allow; of "
                      "those, registered with the best method: 1; not registered by any method "
                      "(search- or check-limited; 1 of them refused at a pose within 0.05 m): "
                      "b_part → lidar (closest: m1 5 m failed); g_part → lidar (closest: m1 "
                      "0.02 m failed, ambiguous). Not registered even from the truth (data- or "
                      "check-limited): c_part → lidar 0.08 m ok; d_part → lidar 0.01 m failed; "
                      "e_part → lidar no pose; f_part → lidar 7 m ok."),
            std::string::npos) << text;
}

TEST_F(SceneEvaluationTest, TheReferenceStartsAtTheTruth) {
  // scan0 is bun0 in its own frame, turned 34° from the LiDAR's: the reference moves it (and
  // its scanner) to the truth first, so it registers within the window and composes its
  // result with the truth.
  std::ofstream(dir_ / "clouds" / "scan0.viewpoints.txt") << "0 0 0.6\n";
  SceneEvalOptions options;
  options.methods = {kFromTruth};
  options.cross_modal = false;
  options.truth_window_m = 0.02;
  options.truth_window_deg = 2.0;
  const SceneEvaluation eval = EvaluateScene(dir_.string(), options);
  ASSERT_EQ(eval.rows.size(), 2u);
  for (const EvalRow& r : eval.rows) {
    SCOPED_TRACE(r.source);
    EXPECT_EQ(r.status, "ok") << r.reason;
    EXPECT_LT(r.rms_m, 0.002);
    EXPECT_EQ(r.visibility, r.source == "scan0");
  }
  options.truth_window_deg = 181.0;
  EXPECT_THROW(EvaluateScene(dir_.string(), options), InputError);
}

TEST(PlacedAtTruth, MovesPointsNormalsAndSensors) {
  // The reference's start: a sensor left in the source's frame would look at the placed cloud
  // from somewhere else, and the free-space test would judge the truth by the wrong rays.
  io::PointCloud source;
  source.points = {{1, 0, 0}, {0, 2, 0}};
  source.normals = {{0, 0, 1}, {1, 0, 0}};
  Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
  truth.topLeftCorner<3, 3>() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).matrix();
  truth.topRightCorner<3, 1>() = Eigen::Vector3d(10, 20, 30);
  std::vector<Eigen::Vector3d> sensors = {{0, 0, 5}, {3, 0, 0}};
  const io::PointCloud placed = PlacedAtTruth(source, truth, &sensors);
  ASSERT_EQ(placed.size(), 2u);
  EXPECT_TRUE(placed.points[0].isApprox(Eigen::Vector3d(10, 21, 30)));
  EXPECT_TRUE(placed.points[1].isApprox(Eigen::Vector3d(8, 20, 30)));
  EXPECT_TRUE(placed.normals[0].isApprox(Eigen::Vector3d(0, 0, 1)));
  EXPECT_TRUE(placed.normals[1].isApprox(Eigen::Vector3d(0, 1, 0)));
  ASSERT_EQ(sensors.size(), 2u);
  EXPECT_TRUE(sensors[0].isApprox(Eigen::Vector3d(10, 20, 35)));
  EXPECT_TRUE(sensors[1].isApprox(Eigen::Vector3d(10, 23, 30)));
  EXPECT_TRUE(source.points[0].isApprox(Eigen::Vector3d(1, 0, 0)));  // the input is a copy
}

TEST_F(SceneEvaluationTest, CellsSelectsRegistrations) {
  // --cells: only the named source:target cells run (both experiments); a cell the scene does
  // not have is an input error naming it.
  SceneEvalOptions options;
  options.methods = {"fpfh"};
  options.cells = {"scan0_part:lidar", "moved:lidar"};
  const SceneEvaluation eval = EvaluateScene(dir_.string(), options);
  ASSERT_EQ(eval.rows.size(), 2u);
  EXPECT_EQ(eval.rows[0].source + ":" + eval.rows[0].target, "moved:lidar");
  EXPECT_EQ(eval.rows[1].source + ":" + eval.rows[1].target, "scan0_part:lidar");
  options.cells = {"scan0:moved"};  // a full cloud is registered to the LiDAR only
  try {
    EvaluateScene(dir_.string(), options);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scan0:moved"), std::string::npos) << e.what();
  }
}

TEST_F(SceneEvaluationTest, BadFolders) {
  std::ofstream(dir_ / "ground_truth.json") << "{\"world_from_lidar\": [[1,0,0,0]]}";
  EXPECT_THROW(EvaluateScene(dir_.string(), {}), InputError);
  std::ofstream(dir_ / "ground_truth.json") << "{\"world_from_lidar\": ";
  EXPECT_THROW(EvaluateScene(dir_.string(), {}), InputError);
  EXPECT_THROW(EvaluateScene((dir_ / "missing").string(), {}), InputError);
  std::ofstream(dir_ / "ground_truth.json")
      << "{\"world_from_lidar\": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}";
  try {
    EvaluateScene(dir_.string(), {});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rigid"), std::string::npos) << e.what();
  }
}

TEST_F(SceneEvaluationTest, ViewpointSidecarsEnableTheVisibilityTest) {
  // clouds/scan0.viewpoints.txt serves scan0 and, having none of its own, scan0_part.
  std::ofstream(dir_ / "clouds" / "scan0.viewpoints.txt")
      << "# the scanner\n0.0, 0.1, 0.5\n\n-0.2 0.1 0.4  # a second station\n";
  const std::vector<Eigen::Vector3d> v =
      ReadViewpoints((dir_ / "clouds" / "scan0.viewpoints.txt").string());
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[1], Eigen::Vector3d(-0.2, 0.1, 0.4));
  SceneEvalOptions options;
  options.methods = {"mmba"};
  const SceneEvaluation eval = EvaluateScene(dir_.string(), options);
  for (const EvalRow& r : eval.rows) {
    SCOPED_TRACE(r.source + " -> " + r.target);
    EXPECT_EQ(r.visibility, r.source == "scan0" || r.source == "scan0_part");
    if (r.status == "ok") {
      EXPECT_LT(r.rms_m, 0.01);  // never a wrong ok
    }
  }
  options.use_viewpoints = false;
  options.cross_modal = false;
  for (const EvalRow& r : EvaluateScene(dir_.string(), options).rows) EXPECT_FALSE(r.visibility);
  // Bad lines name the file, the line and the field.
  for (const char* bad : {"1 2\n", "1 2 z\n", "1 2 nan\n", "0 0 0\n1 2 3 4\n"}) {
    SCOPED_TRACE(bad);
    std::ofstream(dir_ / "clouds" / "scan0.viewpoints.txt") << bad;
    try {
      ReadViewpoints((dir_ / "clouds" / "scan0.viewpoints.txt").string());
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("scan0.viewpoints.txt"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace mmba::registration
