// Runs the mmba binary as a user would: exit codes, the one error line, files written.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/io/colmap_model.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/io_kitti/kitti.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/mi/image.h"
#include "mmba/registration/mi/mi_registration.h"
#include "../registration/mi/synthetic_scene.h"
#include "shell.h"

namespace mmba {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

using mmba::test::RunResult;

// `env_prefix`: e.g. "env -u X Y=1 " in front of the binary.
RunResult Mmba(const std::string& args, const std::string& env_prefix = "") {
  return mmba::test::RunShell(env_prefix + std::string(MMBA_EXECUTABLE) + " " + args);
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_ = fs::temp_directory_path() /
           ("mmba_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(tmp_);
    fs::create_directories(tmp_);
  }
  void TearDown() override { fs::remove_all(tmp_); }
  std::string Tmp(const std::string& name) const { return (tmp_ / name).string(); }
  fs::path tmp_;
};

const std::string kSource = MMBA_SOURCE_DIR;

// Where a register-mi run ended: its `key` (pose or correction) when ok; when failed that is
// null (a failed file holds no pose to be used by mistake) and the end is in
// failed_attempt_<key>.
nlohmann::json EndPose(const nlohmann::json& result, const std::string& key = "cam_from_lidar") {
  const bool ok = result["status"] == "ok";
  EXPECT_EQ(result[key].is_null(), !ok) << key << " of a result with status " << result["status"];
  EXPECT_EQ(result["failed_attempt_" + key].is_null(), ok) << key;
  return ok ? result[key] : result["failed_attempt_" + key];
}
const std::string kModel = kSource + "/data/colmap/balbianello/sparse";

TEST_F(CliTest, HelpListsCommands) {
  const RunResult run = Mmba("--help");
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("ba"));
  EXPECT_THAT(run.output, HasSubstr("bal"));
  EXPECT_EQ(Mmba("ba --help").exit_code, 0);
}

TEST_F(CliTest, BaAdjustsTheBundledModelAndKeepsItsFormat) {
  const RunResult run = Mmba("ba --input " + kModel + " --output " + Tmp("out") + " --json " +
                       Tmp("ba.json") + " --refine-focal --refine-extra --loss huber "
                       "--loss-scale 2 --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_THAT(run.output, HasSubstr("RMS reprojection error"));
  EXPECT_TRUE(fs::exists(Tmp("out/cameras.txt")));
  EXPECT_FALSE(fs::exists(Tmp("out/cameras.bin")));
  const io::ColmapModel adjusted = io::ReadColmapModel(Tmp("out"));
  EXPECT_EQ(adjusted.points3D.size(), 630u);
  std::ifstream json_file(Tmp("ba.json"));
  const nlohmann::json json = nlohmann::json::parse(json_file);
  EXPECT_EQ(json["status"], "converged");
  EXPECT_LT(json["final_rms_px"].get<double>(), 1.0);
  EXPECT_EQ(json["num_observations"], 2029);
}

TEST_F(CliTest, BaBinaryInBinaryOut) {
  io::WriteColmapModel(io::ReadColmapModel(kModel), Tmp("bin"), io::ColmapFormat::kBinary);
  const RunResult run = Mmba("ba --input " + Tmp("bin") + " --output " + Tmp("out") +
                             " --refine-focal --json " + Tmp("ba.json") + " -q");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(fs::exists(Tmp("out/points3D.bin")));
  // Without a robust loss the RMS can only go down.
  std::ifstream json_file(Tmp("ba.json"));
  const nlohmann::json json = nlohmann::json::parse(json_file);
  EXPECT_LE(json["final_rms_px"].get<double>(), json["initial_rms_px"].get<double>() + 1e-9);
}

TEST_F(CliTest, BadInputIsOneErrorLineExitTwoAndNothingWritten) {
  // A broken copy of the model: an image names a camera that does not exist.
  fs::create_directories(Tmp("broken"));
  for (const char* name : {"cameras.txt", "points3D.txt"}) {
    fs::copy_file(kModel + "/" + name, Tmp("broken/") + name);
  }
  std::ifstream in(kModel + "/images.txt");
  std::stringstream text;
  text << in.rdbuf();
  std::string images = text.str();
  const size_t line = images.find("\n5 ");  // image 5, camera id is the 9th field
  ASSERT_NE(line, std::string::npos);
  const size_t jpg = images.find(" BalbianelloMedium-5.jpg", line);
  const size_t camera = images.rfind(' ', jpg - 1);
  images.replace(camera + 1, jpg - camera - 1, "9");
  std::ofstream(Tmp("broken/images.txt")) << images;

  const RunResult run = Mmba("ba --input " + Tmp("broken") + " --output " + Tmp("out") + " --json " +
                       Tmp("ba.json"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.output, HasSubstr("mmba: error: "));
  EXPECT_THAT(run.output, HasSubstr("images.txt: image 5 ('BalbianelloMedium-5.jpg'): field "
                                    "'CAMERA_ID': found 9, expected the id of a camera"));
  EXPECT_FALSE(fs::exists(Tmp("out")));
  EXPECT_FALSE(fs::exists(Tmp("ba.json")));
}

// An output that names an input file (however spelled) or another output is bad input,
// refused before any work: exit 2 naming the option, the input byte for byte unchanged.
TEST_F(CliTest, OutputsNeverReplaceInputs) {
  const auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  for (const char* name : {"bun0.pcd", "bun4.pcd"}) {
    fs::copy_file(kSource + "/data/pointclouds/pcl_test/" + name, Tmp(name));
  }
  fs::copy_file(kSource + "/data/gama/gama-local.xml", Tmp("observations.csv"));
  fs::copy_file(kSource + "/data/bal/dubrovnik-3-7-pre.txt", Tmp("problem.txt"));
  fs::copy(kModel, Tmp("model"));
  const std::string images_before = bytes(Tmp("model/images.txt"));
  const std::string target_before = bytes(Tmp("bun4.pcd"));
  const std::string survey_before = bytes(Tmp("observations.csv"));
  const std::string bal_before = bytes(Tmp("problem.txt"));
  const std::string pair = "register-cloud --source " + Tmp("bun0.pcd") + " --target " + Tmp("bun4.pcd");
  for (const auto& [args, named] : std::vector<std::pair<std::string, std::string>>{
           {pair + " --output " + Tmp("bun4.pcd"), "--output: '" + Tmp("bun4.pcd") + "' is the input --target"},
           {pair + " --output " + tmp_.string() + "/./bun4.pcd", "is the input --target"},
           {pair + " --output " + Tmp("o.json") + " --error-map " + Tmp("bun0.pcd"),
            "--error-map: '" + Tmp("bun0.pcd") + "' is the input --source"},
           {pair + " --output " + Tmp("o.json") + " --error-map " + Tmp("o.json"),
            "is also given as --output"},
           {"register-mi --lidar " + Tmp("bun0.pcd") + " --image " + Tmp("bun4.pcd") +
                " --kitti-calib " + kSource + "/data/kitti/calib/000000.txt --output " + Tmp("bun0.pcd"),
            "is the input --lidar"},
           {"bal " + Tmp("problem.txt") + " --json " + Tmp("problem.txt"), "--json"},
           {"ba --input " + Tmp("model") + " --output " + Tmp("adjusted") + " --json " + Tmp("model/images.txt"),
            "--json: '" + Tmp("model/images.txt") + "' is the input --input"},
           {"survey --input " + Tmp("observations.csv") + " --output " + tmp_.string(),
            "--output: '" + tmp_.string() + "' holds the input --input"}}) {
    const RunResult run = Mmba(args);
    EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr(named)) << args;
    EXPECT_THAT(run.output, HasSubstr("mmba: error: "));
  }
  EXPECT_EQ(bytes(Tmp("bun4.pcd")), target_before);
  EXPECT_EQ(bytes(Tmp("observations.csv")), survey_before);
  EXPECT_EQ(bytes(Tmp("problem.txt")), bal_before);
  EXPECT_EQ(bytes(Tmp("model/images.txt")), images_before);
  EXPECT_FALSE(fs::exists(Tmp("adjusted")));
  EXPECT_FALSE(fs::exists(Tmp("o.json")));
  EXPECT_FALSE(fs::exists(Tmp("adjusted.json")));
}

// mmba re-executes itself once with glibc's huge-page malloc (core/huge_pages.h): the
// arguments (one with a space) and the exit code survive, MMBA_HUGE_PAGES=0 keeps the
// default allocator, and small named inputs skip it.
TEST_F(CliTest, HugePageReexecKeepsArgumentsAndExitCode) {
  const std::string args = "ba --input '" + Tmp("no such model") + "' --output " + Tmp("out") +
                           " --verbose";
  const RunResult on_clean = Mmba(args, "env -u GLIBC_TUNABLES MMBA_HUGE_PAGES=1 ");
  const RunResult plain = Mmba(args, "env -u GLIBC_TUNABLES MMBA_HUGE_PAGES=0 ");
  for (const RunResult* r : {&on_clean, &plain}) {
    EXPECT_EQ(r->exit_code, 2) << r->output;
    EXPECT_THAT(r->output, HasSubstr(Tmp("no such model")));
  }
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(thp, mode);
  if (!mode.empty() && mode.find("[never]") == std::string::npos) {
    EXPECT_THAT(on_clean.output, HasSubstr("glibc.malloc.hugetlb=1"));
  }
  EXPECT_THAT(plain.output, HasSubstr("GLIBC_TUNABLES=(not set)"));

  // register-cloud re-executes only for inputs of 16 MiB and more (apps/mmba.cc): not for
  // PCL's small bunny (and a missing target), but for a 17 MiB source (a sparse file of
  // zeros: a bad cloud). Both are bad input, exit 2.
  const std::string bunnies = "register-cloud --source " + kSource +
                              "/data/pointclouds/pcl_test/bun0.pcd --target " +
                              Tmp("missing.pcd") + " --output " + Tmp("r.json") + " --verbose";
  const RunResult small = Mmba(bunnies, "env -u GLIBC_TUNABLES MMBA_HUGE_PAGES=1 ");
  EXPECT_EQ(small.exit_code, 2) << small.output;
  EXPECT_THAT(small.output, HasSubstr("GLIBC_TUNABLES=(not set)"));
  {
    std::ofstream(Tmp("large.xyz")).put('\n');
  }
  fs::resize_file(Tmp("large.xyz"), 17u << 20);
  const RunResult large = Mmba("register-cloud --source=" + Tmp("large.xyz") + " --target " +
                                   kSource + "/data/pointclouds/pcl_test/bun4.pcd --output " +
                                   Tmp("r.json") + " --verbose",
                               "env -u GLIBC_TUNABLES MMBA_HUGE_PAGES=1 ");
  EXPECT_EQ(large.exit_code, 2) << large.output;
  if (!mode.empty() && mode.find("[never]") == std::string::npos) {
    EXPECT_THAT(large.output, HasSubstr("glibc.malloc.hugetlb=1"));
  }
  EXPECT_FALSE(fs::exists(Tmp("r.json")));
}

TEST_F(CliTest, OptionErrorsAreExitTwo) {
  EXPECT_EQ(Mmba("ba --input " + kModel).exit_code, 2);  // --output missing
  const RunResult loss = Mmba("ba --input " + kModel + " --output " + Tmp("o") + " --loss tukey");
  EXPECT_EQ(loss.exit_code, 2);
  EXPECT_THAT(loss.output, HasSubstr("--loss: found 'tukey', expected none, huber"));
  const RunResult scale = Mmba("ba --input " + kModel + " --output " + Tmp("o") + " --loss-scale -1");
  EXPECT_EQ(scale.exit_code, 2);
  const RunResult same = Mmba("ba --input " + kModel + " --output " + kModel);
  EXPECT_EQ(same.exit_code, 2);
  EXPECT_THAT(same.output, HasSubstr("never overwrites its inputs"));
  EXPECT_EQ(Mmba("bal " + Tmp("missing.txt")).exit_code, 2);
  EXPECT_EQ(Mmba("bal " + kSource + "/data/bal/dubrovnik-3-7-pre.txt --threads 0").exit_code, 2);
  EXPECT_FALSE(fs::exists(Tmp("o")));
  // register-eval --set: register-cloud's settings, refused before any registration.
  for (const auto& [flags, named] : std::vector<std::pair<std::string, std::string>>{
           {" --set colour=blue", "--set: unknown setting 'colour'"},
           {" --set icp_plane_to_plane=maybe", "--set: icp_plane_to_plane: found 'maybe', expected true or false"},
           {" --set icp_plane_distance_spacing=0", "--set: icp_plane_distance_spacing: found '0'"}}) {
    const RunResult bad = Mmba("register-eval --scene " + kSource + "/data --output " + Tmp("ev") + flags);
    EXPECT_EQ(bad.exit_code, 2) << flags;
    EXPECT_THAT(bad.output, HasSubstr(named));
  }
  EXPECT_FALSE(fs::exists(Tmp("ev")));
}

// register-cloud --scale-range: bad ranges are exit 2 naming the option, nothing written; a
// range that misses the scale of PCL's bun0 against bun4 is a reported failure (exit 3) with
// the trials in the JSON.
TEST_F(CliTest, RegisterCloudScaleRange) {
  const std::string pair = "register-cloud --source " + kSource + "/data/pointclouds/pcl_test/bun0.pcd --target " + kSource +
                           "/data/pointclouds/pcl_test/bun4.pcd --output " + Tmp("out.json");
  // Bad options: exit 2, the message naming the flag.
  for (const auto& [flags, named] : std::vector<std::pair<std::string, std::string>>{
           {" --scale-range 3 2", "--scale-range"},
           {" --scale-range 1 2 --scale-step 0.9", "--scale-step"},
           {" --normal-radius -1", "--normal-radius"},
           {" --min-fitness 1.5", "--min-fitness"},
           {" --error-map-max nan", "--error-map-max: found nan"},
           {" --set keypoint_threshold=0.9", "--set: keypoint_threshold: found '0.9', expected a number 0..1/3"},
           {" --set icp_iterations", "--set: found 'icp_iterations', expected NAME=VALUE"},
           {" --set colour=blue", "--set: unknown setting 'colour'"},
           {" --error-map-max -1", "--error-map-max"},
           {" --normal-orientation sideways", "--normal-orientation"}}) {
    const RunResult bad = Mmba(pair + flags);
    EXPECT_EQ(bad.exit_code, 2) << flags;
    EXPECT_THAT(bad.output, HasSubstr(named));
  }
  EXPECT_FALSE(fs::exists(Tmp("out.json")));
  // The paper's parameters by name: F_t and SAC-IA's samples, and the list in --help.
  const RunResult set = Mmba(pair + " --set keypoint_threshold=0.05 sac_ia_iterations=2000 -q");
  EXPECT_EQ(set.exit_code, 0) << set.output;
  EXPECT_THAT(Mmba("register-cloud --help").output, HasSubstr("keypoint_threshold = 0.1 (0..1/3): F_t"));
  fs::remove(Tmp("out.json"));
  const RunResult missed = Mmba(pair + " --scale-range 4 4.5 -q");
  EXPECT_EQ(missed.exit_code, 3) << missed.output;
  std::ifstream in(Tmp("out.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["status"], "failed");
  EXPECT_EQ(j["trials"].size(), 3u);  // 4, 4.2, 4.41
  // A failed result carries no transform to be taken for the answer, only its best attempt.
  EXPECT_TRUE(j["target_from_source"].is_null());
  EXPECT_EQ(j["failed_attempt_target_from_source"].size(), 4u);
}

// A cloud without points, in any format, as source or target, is bad input (exit 2, the error
// naming the file and saying it has no points) and nothing is written.
TEST_F(CliTest, RegisterCloudEmptyCloudIsBadInput) {
  const std::string bun4 = kSource + "/data/pointclouds/pcl_test/bun4.pcd";
  for (const std::string name : {"empty.xyz", "empty.ply"}) {
    std::ofstream(Tmp(name)) << (name == "empty.xyz" ? "# x y z\n"
                                                     : "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                                                       "property float y\nproperty float z\nend_header\n");
    for (const std::string role : {"source", "target"}) {
      const std::string source = role == "source" ? Tmp(name) : bun4;
      const std::string target = role == "target" ? Tmp(name) : bun4;
      const RunResult run =
          Mmba("register-cloud --source " + source + " --target " + target + " -q --output " + Tmp("out.json"));
      EXPECT_EQ(run.exit_code, 2) << name << " as " << role << ": " << run.output;
      EXPECT_THAT(run.output, HasSubstr("mmba: error: " + Tmp(name) + ": the --" + role + " cloud has no points"));
      EXPECT_FALSE(fs::exists(Tmp("out.json")));
    }
  }
  // Every point not finite and dropped by --skip-invalid: no points left, bad input too.
  std::ofstream(Tmp("all-nan.xyz")) << "1 nan 0\n";
  const RunResult none = Mmba("register-cloud --skip-invalid --source " + Tmp("all-nan.xyz") + " --target " + bun4 +
                              " -q --output " + Tmp("out.json"));
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_THAT(none.output, HasSubstr("the --source cloud has no points left (1 not finite, skipped)"));
  EXPECT_FALSE(fs::exists(Tmp("out.json")));
}

// A point that is not finite makes a reported failure, not a reading error.
TEST_F(CliTest, RegisterCloudNonFinitePointIsAFailureWithoutATransform) {
  // A NaN point (NaN/Inf points → status "failed" with a reason): exit 3, the JSON
  // written, the reason naming the file, line and field; --skip-invalid drops the point.
  std::ofstream(Tmp("nan.xyz")) << "0 0 0\n1 nan 0\n";
  const std::string bun4 = " --target " + kSource + "/data/pointclouds/pcl_test/bun4.pcd -q --output " + Tmp("out.json");
  const RunResult nan = Mmba("register-cloud --source " + Tmp("nan.xyz") + bun4);
  EXPECT_EQ(nan.exit_code, 3) << nan.output;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  EXPECT_EQ(j["status"], "failed");
  EXPECT_THAT(j["reason"].get<std::string>(),
              HasSubstr("a point is not finite: " + Tmp("nan.xyz") + ":2: point 1: non-finite y = nan"));
  EXPECT_TRUE(j["target_from_source"].is_null());
  const RunResult skipped = Mmba("register-cloud --skip-invalid --source " + Tmp("nan.xyz") + bun4);
  EXPECT_EQ(skipped.exit_code, 3) << skipped.output;  // one point left: too few, but read
  EXPECT_THAT(skipped.output, ::testing::Not(HasSubstr("not finite")));
}

// register-cloud's intensity test fields: PCL's bunnies carry no brightness, so the test
// cannot run (false / null), with or without --no-intensity (or --keep-blunders), and the
// registration is ok.
TEST_F(CliTest, RegisterCloudReportsTheIntensityTest) {
  const std::string pair = "register-cloud --source " + kSource +
                           "/data/pointclouds/pcl_test/bun0.pcd --target " + kSource +
                           "/data/pointclouds/pcl_test/bun4.pcd -q --output ";
  for (const std::string flag : {"", " --no-intensity", " --keep-blunders"}) {
    const RunResult run = Mmba(pair + Tmp("out.json") + flag);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    // The terminal summary says how sure the pose is.
    EXPECT_NE(run.output.find("resolved to "), std::string::npos) << run.output;
    std::ifstream in(Tmp("out.json"));
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["intensity_tested"], false);
    EXPECT_EQ(j["target_from_source"].size(), 4u);
    EXPECT_TRUE(j["failed_attempt_target_from_source"].is_null());
    EXPECT_TRUE(j["intensity_correlation"].is_null());
    EXPECT_TRUE(j["intensity_significance"].is_null());
    ASSERT_FALSE(j["hypotheses"].empty());
    EXPECT_TRUE(j["hypotheses"][0]["intensity_correlation"].is_null());
    // No scattered blunders in these clean scans: nothing removed, with or without the flag.
    EXPECT_EQ(j["blunders_removed"]["source"], 0) << j.dump();
    EXPECT_EQ(j["blunders_removed"]["target"], 0) << j.dump();
  }
  // The target with 5 % of its points scattered over three times its box: removed by default
  // (whatever the registration's verdict, the JSON says so), kept with --keep-blunders.
  io::PointCloud scattered = io::ReadPointCloud(kSource + "/data/pointclouds/pcl_test/bun4.pcd");
  Eigen::Vector3d lo = scattered.points[0], hi = lo;
  for (const Eigen::Vector3d& p : scattered.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const size_t count = scattered.size() / 20;
  for (size_t i = 0; i < count; ++i) {
    const double u = (i + 0.5) / count;  // a deterministic spread over the box
    scattered.points.push_back(lo - (hi - lo) + Eigen::Vector3d(u, std::fmod(7.31 * u, 1.0), std::fmod(3.77 * u, 1.0))
                                                     .cwiseProduct(3.0 * (hi - lo)));
  }
  io::WritePly(scattered, Tmp("bun4_scattered.ply"));
  const std::string blunders = "register-cloud --source " + kSource + "/data/pointclouds/pcl_test/bun0.pcd --target " +
                               Tmp("bun4_scattered.ply") + " -q --output " + Tmp("scattered.json");
  for (const bool keep : {false, true}) {
    const RunResult run = Mmba(blunders + (keep ? " --keep-blunders" : ""));
    ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;
    std::ifstream in(Tmp("scattered.json"));
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["blunders_removed"]["source"], 0) << j.dump();
    if (keep) {
      EXPECT_EQ(j["blunders_removed"]["target"], 0) << j.dump();
    } else {
      EXPECT_GE(j["blunders_removed"]["target"].get<size_t>(), count / 2) << j.dump();
      EXPECT_LE(j["blunders_removed"]["target"].get<size_t>(), count + scattered.size() / 100) << j.dump();
    }
  }
}

// register-mi with the cloud and the camera pose in map-grid coordinates (a georeferenced
// mobile-mapping cloud in UTM): the renderer's floats resolve 0.5 m there, so the command
// registers relative to the cloud's centroid rounded to whole km. The KITTI frame moved by a
// whole number of km must give the registration of the frame as delivered: the same status,
// correction and pixel offsets, and the same pose moved back into the grid.
// register-mi's documented command line on a simulated panorama: the simulator's camera YAML holds the true
// pose (--perturb starts from it moved), the mobile cloud's sidecar gives the scanner of each
// point (the incidence correction, without options), and a panorama is registered on
// perspective cuts (the default --view auto), the two that see the most LiDAR (--headings auto).
TEST_F(CliTest, RegisterMiOnASimulatedPanoramaWithTheIssuesCommandLine) {
  std::ofstream(Tmp("tiny.yaml")) << "scene: gate\nseed: 3\nphotos: {count: 2, width: 160, height: 120, focal_px: 140, "
                                     "tie_points: 100}\nspheres: {stations: 1, width: 1024}\nrig: {frames: 1, width: 48, "
                                     "focal_px: 20, panorama_width: 128}\nlidar: {static_scans: 1, azimuth_step_deg: 3, "
                                     "elevation_step_deg: 3, mobile_revolutions: 20}\nclouds: {surface_samples: 2000}\n";
  const RunResult sim = Mmba("simulate --scene " + Tmp("tiny.yaml") + " --out " + Tmp("sim") + " -q");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const std::string yaml = Tmp("sim/truth/cameras/spherical/S1_lower.yaml");
  ASSERT_TRUE(fs::exists(yaml));
  const RunResult run = Mmba("register-mi --lidar " + Tmp("sim/truth/mobile_lidar_true.ply") + " --image " +
                             Tmp("sim/images/spherical/S1_lower.png") + " --camera " + yaml +
                             " --perturb 0.05,-0.04,0.03,0.5,-0.4,0.3 --output " + Tmp("out.json"));
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;
  EXPECT_THAT(run.output, HasSubstr("the scanner's position from " + Tmp("sim/truth/mobile_lidar_true.scanner.yaml")));
  EXPECT_THAT(run.output, HasSubstr("--view auto: perspective cuts of the panorama"));
  EXPECT_THAT(run.output, HasSubstr("perspective cuts at headings"));
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  ASSERT_TRUE(out["incidence_correction"][0].is_object()) << out["incidence_correction"].dump();
  EXPECT_EQ(out["incidence_correction"][0]["scanner_from"], Tmp("sim/truth/mobile_lidar_true.scanner.yaml"));
  // The simulated intensity is Lambertian: the fitted exponent near 1.
  EXPECT_NEAR(out["incidence_correction"][0]["exponent"].get<double>(), 1.0, 0.2);
  // Two cuts, reported against the truth (the YAML's pose): the start is several pixels off.
  ASSERT_EQ(out["pixel_offset_vs_reference"].size(), 2u) << out.dump(1);
  for (const nlohmann::json& view : out["pixel_offset_vs_reference"]) {
    EXPECT_THAT(view["view"].get<std::string>(), HasSubstr("perspective_"));
    EXPECT_GT(view["before"]["median_px"].get<double>(), 2.0) << view.dump();
    if (out["status"] == "ok") {
      EXPECT_LT(view["after"]["median_px"].get<double>(), 1.0) << view.dump();
    }
  }
  // A failure is told on stderr (as register-cloud's), with its reason.
  if (run.exit_code == 3) {
    EXPECT_THAT(run.output, HasSubstr("mmba: failed: MI registration: failed ("));
  }
}

TEST_F(CliTest, RegisterMiInMapGridCoordinates) {
  const std::string kitti = kSource + "/data/kitti/";
  const std::string common = " --image " + kitti + "image_2/000000.png --kitti-calib " + kitti +
                             "calib/000000.txt --perturb 0.05,0,0,0,0.5,0 -q";
  const RunResult given = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin" + common +
                               " --output " + Tmp("given.json") + " --overlay " + Tmp("overlay.png"));
  ASSERT_TRUE(given.exit_code == 0 || given.exit_code == 3) << given.output;
  {
    // The overlay: a PNG of the photo's width and twice its height (start above, result below).
    auto png_size = [](const std::string& path) {
      std::ifstream png(path, std::ios::binary);
      unsigned char h[24] = {};
      png.read(reinterpret_cast<char*>(h), 24);
      EXPECT_TRUE(png.good() && std::string(reinterpret_cast<char*>(h) + 1, 3) == "PNG") << path;
      auto be32 = [&](int at) { return (h[at] << 24) | (h[at + 1] << 16) | (h[at + 2] << 8) | h[at + 3]; };
      return std::pair<int, int>(be32(16), be32(20));
    };
    const auto [w, h] = png_size(kitti + "image_2/000000.png");
    EXPECT_EQ(png_size(Tmp("overlay.png")), std::make_pair(w, 2 * h));
  }
  const nlohmann::json a = nlohmann::json::parse(std::ifstream(Tmp("given.json")));
  EXPECT_EQ(a["settings"]["sample_block_px"], 8);  // the default, recorded
  EXPECT_EQ(a["settings"]["covariance_pixel_floor"], true);
  ASSERT_TRUE(a["checks"].contains("covariance_floor_directions"));
  EXPECT_GE(a["checks"]["covariance_floor_directions"].get<int>(), 0);
  EXPECT_LE(a["checks"]["covariance_floor_directions"].get<int>(), 6);

  // A bad sample block: exit 2 naming the flag, no output written.
  const RunResult bad = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin" + common +
                             " --sample-block-px -1 --output " + Tmp("bad_block.json"));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("--sample-block-px"));
  EXPECT_FALSE(std::filesystem::exists(Tmp("bad_block.json")));

  // A thumbnail (here 200x100) is not an image of KITTI's camera 2: its frame does not hold
  // the calibration's principal point (604.1, 180.5). Exit 2 naming the image.
  registration::mi::WriteGrayPng(registration::mi::GrayImage(200, 100, 0.5f), Tmp("thumb.png"));
  const RunResult thumb = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin --image " + Tmp("thumb.png") +
                               " --kitti-calib " + kitti + "calib/000000.txt --output " + Tmp("thumb.json"));
  EXPECT_EQ(thumb.exit_code, 2) << thumb.output;
  EXPECT_THAT(thumb.output, HasSubstr(Tmp("thumb.png") + ": image is 200x100 but the principal point"));
  EXPECT_FALSE(std::filesystem::exists(Tmp("thumb.json")));

  // --initial as 4 rows of 4 numbers (numpy's tolist()): the calibration itself as the start
  // gives the registration of the default start (the calibration; the start's last bits differ
  // through the JSON round trip).
  {
    const Eigen::Matrix4d c =
        io::KittiCamera(io::ReadKittiCalibration(kitti + "calib/000000.txt"), 2, 1242, 375)
            .cam_from_lidar.ToMatrix4();
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) rows.push_back({c(r, 0), c(r, 1), c(r, 2), c(r, 3)});
    std::ofstream(Tmp("rows.json")) << nlohmann::json{{"cam_from_lidar", rows}}.dump();
    const RunResult from_rows = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin" + common +
                                     " --initial " + Tmp("rows.json") + " --output " + Tmp("rows_out.json"));
    EXPECT_EQ(from_rows.exit_code, given.exit_code) << from_rows.output;
    const nlohmann::json r = nlohmann::json::parse(std::ifstream(Tmp("rows_out.json")));
    EXPECT_EQ(r["status"], a["status"]);
    const nlohmann::json r_end = EndPose(r), a_end = EndPose(a);
    ASSERT_EQ(r_end.size(), 4u);
    for (int i = 0; i < 16; ++i) {
      EXPECT_NEAR(r_end[i / 4][i % 4].get<double>(), a_end[i / 4][i % 4].get<double>(), 1e-9) << i;
    }
    rows[2] = {1.0, 0.0};
    std::ofstream(Tmp("bad_rows.json")) << nlohmann::json{{"cam_from_lidar", rows}}.dump();
    const RunResult bad_rows = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin" + common +
                                    " --initial " + Tmp("bad_rows.json") + " --output " + Tmp("bad_rows_out.json"));
    EXPECT_EQ(bad_rows.exit_code, 2);
    EXPECT_THAT(bad_rows.output, HasSubstr("row 2 is [1.0,0.0], not 4 numbers"));
    EXPECT_FALSE(std::filesystem::exists(Tmp("bad_rows_out.json")));
  }

  const Eigen::Vector3d grid(512000.0, 5412000.0, 1000.0);  // whole km: the same floats
  io::PointCloud cloud = io::ReadPointCloud(kitti + "velodyne/000000.bin");
  for (Eigen::Vector3d& p : cloud.points) p += grid;
  io::WritePly(cloud, Tmp("grid.ply"));
  // The start of the grid run: the calibration's pose for grid points (--perturb moves both
  // runs' starts alike: a shift of the camera centre and a turn about it).
  const Eigen::Matrix4d calibration =
      io::KittiCamera(io::ReadKittiCalibration(kitti + "calib/000000.txt"), 2, 1242, 375)
          .cam_from_lidar.ToMatrix4();
  Eigen::Matrix4d lidar_from_grid = Eigen::Matrix4d::Identity();
  lidar_from_grid.topRightCorner<3, 1>() = -grid;
  const Eigen::Matrix4d cam_from_grid = calibration * lidar_from_grid;
  nlohmann::json pose = {{"cam_from_lidar", nlohmann::json::array()}};
  for (int i = 0; i < 16; ++i) pose["cam_from_lidar"].push_back(cam_from_grid(i / 4, i % 4));
  std::ofstream(Tmp("pose.json")) << pose.dump();
  // The KITTI scan's intensity is corrected for incidence with the scanner at its origin (by
  // default, --incidence-correction auto); the grid cloud's scanner is given in the grid.
  const std::string scanner = " --scanner-origin 512000,5412000,1000";
  const RunResult in_grid = Mmba("register-mi --lidar " + Tmp("grid.ply") + " --initial " +
                                 Tmp("pose.json") + scanner + common + " --output " + Tmp("grid.json"));
  EXPECT_EQ(in_grid.exit_code, given.exit_code) << in_grid.output;
  const nlohmann::json b = nlohmann::json::parse(std::ifstream(Tmp("grid.json")));
  EXPECT_EQ(b["status"], a["status"]);
  // KITTI's reflectance hardly depends on the incidence (the exponent fitted ~0.04): corrected
  // all the same, and alike in both runs.
  ASSERT_TRUE(a["incidence_correction"][0].is_object()) << a["incidence_correction"].dump();
  EXPECT_LT(a["incidence_correction"][0]["exponent"].get<double>(), 0.2);
  EXPECT_GT(a["incidence_correction"][0]["points"].get<int>(), 10000);
  EXPECT_NEAR(b["incidence_correction"][0]["exponent"].get<double>(),
              a["incidence_correction"][0]["exponent"].get<double>(), 1e-6);
  // The same scanner from a trajectory: the body 1.9 m below the grid origin and turned 90°
  // about z (a mounting lever (0, 0.5, 1.9) in the body frame puts the head at the origin),
  // every point measured at t = 0.5 s.
  std::ofstream(Tmp("trajectory.csv")) << "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n"
                                       << "0,512000.5,5412000,998.1,0.70710678118,0,0,0.70710678118\n"
                                       << "1,512000.5,5412000,998.1,0.70710678118,0,0,0.70710678118\n";
  std::ofstream(Tmp("mount.yaml")) << "body_from_lidar: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0.5, 1.9]}\n";
  cloud.time.assign(cloud.size(), 0.5);
  io::WritePly(cloud, Tmp("grid_timed.ply"));
  const RunResult on_trajectory =
      Mmba("register-mi --lidar " + Tmp("grid_timed.ply") + " --initial " + Tmp("pose.json") + " --trajectory " +
           Tmp("trajectory.csv") + " --lidar-mount " + Tmp("mount.yaml") + common + " --output " + Tmp("timed.json"));
  EXPECT_EQ(on_trajectory.exit_code, given.exit_code) << on_trajectory.output;
  const nlohmann::json t = nlohmann::json::parse(std::ifstream(Tmp("timed.json")));
  EXPECT_NEAR(t["incidence_correction"][0]["exponent"].get<double>(),
              b["incidence_correction"][0]["exponent"].get<double>(), 1e-6);
  EXPECT_EQ(t["incidence_correction"][0]["points"], b["incidence_correction"][0]["points"]);
  // Without the options, the cloud's sidecar CLOUD.scanner.yaml (as mmba simulate writes for a
  // mobile cloud) names the trajectory and the mounting, relative to its folder: the same
  // correction. A static scan's sidecar gives its origin.
  fs::create_directories(Tmp("side"));
  fs::copy_file(Tmp("grid_timed.ply"), Tmp("side/grid_timed.ply"));
  fs::copy_file(Tmp("grid.ply"), Tmp("side/grid.ply"));
  std::ofstream(Tmp("side/grid_timed.scanner.yaml")) << "trajectory: ../trajectory.csv\nlidar_mount: ../mount.yaml\n";
  std::ofstream(Tmp("side/grid.scanner.yaml")) << "scanner_origin: [512000, 5412000, 1000]\n";
  for (const std::string cloud_name : {"grid_timed", "grid"}) {
    const RunResult from_sidecar = Mmba("register-mi --lidar " + Tmp("side/" + cloud_name + ".ply") + " --initial " +
                                        Tmp("pose.json") + common + " --output " + Tmp("sidecar.json"));
    EXPECT_EQ(from_sidecar.exit_code, given.exit_code) << from_sidecar.output;
    const nlohmann::json sc = nlohmann::json::parse(std::ifstream(Tmp("sidecar.json")));
    ASSERT_TRUE(sc["incidence_correction"][0].is_object()) << cloud_name << ": " << sc["incidence_correction"].dump();
    EXPECT_NEAR(sc["incidence_correction"][0]["exponent"].get<double>(),
                t["incidence_correction"][0]["exponent"].get<double>(), 1e-6) << cloud_name;
    EXPECT_THAT(sc["incidence_correction"][0]["scanner_from"].get<std::string>(),
                HasSubstr(cloud_name + ".scanner.yaml"));
  }
  // A sidecar that names a missing file, or has an unknown key, is bad input naming it.
  for (const std::string& text : {std::string("trajectory: ../nowhere.csv\nlidar_mount: ../mount.yaml\n"),
                                  std::string("trajectory: ../trajectory.csv\n"),
                                  std::string("scanner_orign: [1, 2, 3]\n")}) {
    std::ofstream(Tmp("side/grid.scanner.yaml")) << text;
    const RunResult bad_sidecar = Mmba("register-mi --lidar " + Tmp("side/grid.ply") + " --initial " +
                                       Tmp("pose.json") + common + " --output " + Tmp("bad_sidecar.json"));
    EXPECT_EQ(bad_sidecar.exit_code, 2) << text << bad_sidecar.output;
    EXPECT_THAT(bad_sidecar.output, HasSubstr("grid.scanner.yaml")) << text;
    EXPECT_FALSE(fs::exists(Tmp("bad_sidecar.json"))) << text;
  }
  // Nor is it read where nothing is corrected (a depth image).
  const RunResult depth = Mmba("register-mi --lidar " + Tmp("side/grid.ply") + " --initial " + Tmp("pose.json") +
                               common + " --representation depth --output " + Tmp("depth.json"));
  EXPECT_NE(depth.exit_code, 2) << depth.output;
  EXPECT_TRUE(fs::exists(Tmp("depth.json"))) << depth.output;
  // Bad incidence options: exit 2 naming the option or the file, nothing written (late.csv:
  // a trajectory that starts after the points were measured).
  std::ofstream(Tmp("late.csv")) << "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n10,0,0,0,1,0,0,0\n11,0,0,0,1,0,0,0\n";
  const std::string grid_run = "register-mi --lidar " + Tmp("grid.ply") + " --initial " + Tmp("pose.json") + common;
  for (const auto& [flags, named] : std::vector<std::pair<std::string, std::string>>{
           {" --incidence-correction sometimes", "--incidence-correction"},
           {" --scanner-origin 1,2", "--scanner-origin"},
           {" --trajectory " + Tmp("trajectory.csv"), "--trajectory and --lidar-mount go together"},
           {" --incidence-correction on", "on needs the scanner's position"},
           {" --trajectory " + Tmp("trajectory.csv") + " --lidar-mount " + Tmp("mount.yaml"), "has no per-point time"}}) {
    const RunResult bad_incidence = Mmba(grid_run + flags + " --output " + Tmp("bad_incidence.json"));
    EXPECT_EQ(bad_incidence.exit_code, 2) << flags << ": " << bad_incidence.output;
    EXPECT_THAT(bad_incidence.output, HasSubstr(named)) << flags;
    EXPECT_FALSE(std::filesystem::exists(Tmp("bad_incidence.json"))) << flags;
  }
  const RunResult late = Mmba("register-mi --lidar " + Tmp("grid_timed.ply") + " --initial " + Tmp("pose.json") +
                              " --trajectory " + Tmp("late.csv") + " --lidar-mount " + Tmp("mount.yaml") + common +
                              " --output " + Tmp("late.json"));
  EXPECT_EQ(late.exit_code, 2) << late.output;
  EXPECT_THAT(late.output, HasSubstr("are not within the --trajectory"));
  EXPECT_FALSE(std::filesystem::exists(Tmp("late.json")));
  const nlohmann::json a_correction = EndPose(a, "correction"), b_correction = EndPose(b, "correction");
  for (const char* k : {"tx", "ty", "tz"}) {
    EXPECT_NEAR(b_correction[k].get<double>(), a_correction[k].get<double>(), 1e-4) << k;
  }
  for (const char* k : {"roll", "pitch", "yaw"}) {
    EXPECT_NEAR(b_correction[k].get<double>(), a_correction[k].get<double>(), 1e-3) << k;
  }
  EXPECT_NEAR(b["pixel_offset_vs_reference"][0]["after"]["median_px"].get<double>(),
              a["pixel_offset_vs_reference"][0]["after"]["median_px"].get<double>(), 0.01);
  Eigen::Matrix4d pa, pb;
  const nlohmann::json a_end = EndPose(a), b_end = EndPose(b);
  for (int i = 0; i < 16; ++i) {
    pa(i / 4, i % 4) = a_end[i / 4][i % 4];
    pb(i / 4, i % 4) = b_end[i / 4][i % 4];
  }
  // The grid result is the delivered frame's result expressed for grid points.
  EXPECT_LT((pb - pa * lidar_from_grid).cwiseAbs().maxCoeff(), 1e-3) << pb;
}

// --rig: the rig's own cameras as the views of one rig pose (rig_from_lidar), each image
// found from the frame's pattern by the camera's name. Two cameras 0.35 m either side of the
// rig's origin, turned ±12° (a fisheye and a pinhole), on the synthetic street of the MI tests,
// from the paper's typical 0.1 m / 1° off.
TEST_F(CliTest, RegisterMiRigRegistersTheRigPoseFromItsCameras) {
  namespace mit = registration::mi::testing;
  const Rigid3d truth = mit::StreetCamFromLidar(Eigen::Vector3d(0.5, 0.3, 0.2), 4.0);
  io::WritePly(mit::StreetCloud(0.06), Tmp("street.ply"));
  sensors::Camera fisheye;
  fisheye.model_id = sensors::CameraModelId::kOpenCVFisheye;
  fisheye.width = 320;
  fisheye.height = 240;
  fisheye.params = {170, 170, 160, 120, 0.03, -0.01, 0.0, 0.0};
  const sensors::Camera pinhole = mit::StreetCamera();
  const std::vector<std::string> names = {"left", "right"};
  const std::vector<sensors::Camera> cameras = {fisheye, pinhole};
  const std::vector<Rigid3d> cam_from_rig = {
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(-12 * M_PI / 180, Eigen::Vector3d::UnitY())),
              Eigen::Vector3d(-0.35, 0.02, 0.05)),
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(12 * M_PI / 180, Eigen::Vector3d::UnitY())),
              Eigen::Vector3d(0.35, -0.02, -0.05))};
  std::ofstream rig(Tmp("rig.yaml"));
  rig.precision(17);
  rig << "cameras:\n";
  for (size_t k = 0; k < 2; ++k) {
    registration::mi::WriteGrayPng(mit::StreetPhoto(cameras[k], cam_from_rig[k] * truth),
                                   Tmp("f_" + names[k] + ".png"));
    const Eigen::Quaterniond q = cam_from_rig[k].rotation;
    const Eigen::Vector3d t = cam_from_rig[k].translation;
    rig << "  - name: " << names[k] << "\n    model: " << cameras[k].ModelName() << "\n    width: "
        << cameras[k].width << "\n    height: " << cameras[k].height << "\n    params: [";
    for (size_t i = 0; i < cameras[k].params.size(); ++i) rig << (i ? ", " : "") << cameras[k].params[i];
    rig << "]\n    cam_from_rig: {qvec_wxyz: [" << q.w() << ", " << q.x() << ", " << q.y() << ", " << q.z()
        << "], tvec: [" << t.x() << ", " << t.y() << ", " << t.z() << "]}\n";
  }
  rig.close();
  const Eigen::Matrix4d m = truth.ToMatrix4();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  std::ofstream(Tmp("pose.json")) << nlohmann::json{{"rig_from_lidar", rows}}.dump();

  const std::string common = "register-mi --rig " + Tmp("rig.yaml") + " --lidar " + Tmp("street.ply") +
                             " --initial " + Tmp("pose.json") + " -q";
  const RunResult run = Mmba(common + " --image " + Tmp("f_{camera}.png") +
                             " --perturb 0.1,-0.08,0.06,1,-0.8,0.9 --output " + Tmp("out.json"));
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  EXPECT_EQ(out["status"], "ok") << out["reason"];
  EXPECT_FALSE(out.contains("cam_from_lidar"));  // the pose is the rig's, not a camera's
  EXPECT_FALSE(out.contains("failed_attempt_cam_from_lidar"));
  EXPECT_TRUE(out["failed_attempt_rig_from_lidar"].is_null());
  ASSERT_EQ(out["rig_from_lidar"].size(), 4u);
  Eigen::Matrix4d estimate;
  for (int i = 0; i < 16; ++i) estimate(i / 4, i % 4) = out["rig_from_lidar"][i / 4][i % 4].get<double>();
  const Eigen::Matrix3d dr = estimate.topLeftCorner<3, 3>() * m.topLeftCorner<3, 3>().transpose();
  EXPECT_LT(Eigen::AngleAxisd(dr).angle() * 180 / M_PI, 0.2);
  EXPECT_LT((estimate.topRightCorner<3, 1>() - m.topRightCorner<3, 1>()).norm(), 0.05);
  ASSERT_EQ(out["cameras"].size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(out["cameras"][k]["name"], names[k]);
    EXPECT_EQ(out["cameras"][k]["used"], true);
    const Eigen::Matrix4d expected = cam_from_rig[k].ToMatrix4() * estimate;
    for (int i = 0; i < 16; ++i) {
      EXPECT_NEAR(out["cameras"][k]["cam_from_lidar"][i / 4][i % 4].get<double>(), expected(i / 4, i % 4), 1e-9);
    }
  }
  ASSERT_EQ(out["pixel_offset_vs_reference"].size(), 2u);
  for (const nlohmann::json& view : out["pixel_offset_vs_reference"]) {
    EXPECT_GT(view["before"]["median_px"].get<double>(), 3.0) << view["view"];
    EXPECT_LT(view["after"]["median_px"].get<double>(), 1.0) << view["view"];
  }

  // The metric conditioned on which way the surfaces face (--orientation-classes) registers
  // the same rig from the same start (this street has no sun shading to undo: it must not
  // hurt); it is refused with --surface-classes, with another representation, and beyond 13
  // sectors (16 classes).
  const RunResult classed = Mmba(common + " --image " + Tmp("f_{camera}.png") +
                                 " --perturb 0.1,-0.08,0.06,1,-0.8,0.9 --orientation-classes 4 --output " +
                                 Tmp("classed.json"));
  EXPECT_EQ(classed.exit_code, 0) << classed.output;
  const nlohmann::json by_class = nlohmann::json::parse(std::ifstream(Tmp("classed.json")));
  EXPECT_EQ(by_class["status"], "ok") << by_class["reason"];
  EXPECT_EQ(by_class["settings"]["orientation_classes"], 4);
  for (const nlohmann::json& view : by_class["pixel_offset_vs_reference"]) {
    EXPECT_LT(view["after"]["median_px"].get<double>(), 1.0) << view["view"];
  }
  for (const auto& [extra, expected] :
       std::vector<std::pair<std::string, std::string>>{{" --surface-classes true", "--surface-classes"},
                                                        {" --representation depth", "--representation intensity"},
                                                        {"", "--orientation-classes"}}) {
    const std::string sectors = extra.empty() ? "14" : "4";
    const RunResult refused = Mmba(common + " --image " + Tmp("f_{camera}.png") + " --orientation-classes " +
                                   sectors + extra + " --output " + Tmp("bad0.json"));
    EXPECT_EQ(refused.exit_code, 2) << extra;
    EXPECT_THAT(refused.output, HasSubstr(expected)) << refused.output;
    EXPECT_FALSE(fs::exists(Tmp("bad0.json")));
  }

  // Featureless photos (one grey, as an overexposed frame): failed, exit 3, and no pose in
  // the file to be used by mistake: the rig's and every camera's are null.
  for (size_t k = 0; k < 2; ++k) {
    registration::mi::WriteGrayPng(registration::mi::GrayImage(cameras[k].width, cameras[k].height, 0.97f),
                                   Tmp("grey_" + names[k] + ".png"));
  }
  const RunResult grey = Mmba(common + " --image " + Tmp("grey_{camera}.png") + " --output " + Tmp("grey.json"));
  EXPECT_EQ(grey.exit_code, 3) << grey.output;
  const nlohmann::json refused_rig = nlohmann::json::parse(std::ifstream(Tmp("grey.json")));
  EXPECT_EQ(refused_rig["status"], "failed");
  EXPECT_TRUE(refused_rig["rig_from_lidar"].is_null()) << refused_rig["rig_from_lidar"];
  EXPECT_FALSE(refused_rig.contains("cam_from_lidar"));
  for (const nlohmann::json& camera : refused_rig["cameras"]) EXPECT_TRUE(camera["cam_from_lidar"].is_null());

  // Bad input: exit 2, one error naming what is wrong, nothing written.
  const RunResult no_pattern = Mmba(common + " --image " + Tmp("f_left.png") + " --output " + Tmp("bad1.json"));
  EXPECT_EQ(no_pattern.exit_code, 2);
  EXPECT_THAT(no_pattern.output, HasSubstr("{camera}"));
  fs::copy_file(Tmp("f_left.png"), Tmp("g_left.png"));
  const RunResult missing = Mmba(common + " --image " + Tmp("g_{camera}.png") + " --output " + Tmp("bad2.json"));
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.output, HasSubstr("g_right.png"));
  const RunResult both = Mmba(common + " --camera " + Tmp("rig.yaml") + " --image " + Tmp("f_{camera}.png") +
                              " --output " + Tmp("bad3.json"));
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_THAT(both.output, HasSubstr("--rig"));
  std::ofstream(Tmp("bad_rig.yaml")) << "cameras:\n  - name: left\n    model: OPENCV_FISHEYE\n    width: 320\n";
  const RunResult bad_rig = Mmba("register-mi --rig " + Tmp("bad_rig.yaml") + " --lidar " + Tmp("street.ply") +
                                 " --image " + Tmp("f_{camera}.png") + " --initial " + Tmp("pose.json") +
                                 " --output " + Tmp("bad4.json"));
  EXPECT_EQ(bad_rig.exit_code, 2);
  EXPECT_THAT(bad_rig.output, HasSubstr("cameras[0]"));
  for (const char* name : {"bad1.json", "bad2.json", "bad3.json", "bad4.json"}) {
    EXPECT_FALSE(fs::exists(Tmp(name))) << name;
  }
}

// --probe DIR (the paper's Figs. 3 and 11): probe.csv holds MI, NMI and joint entropy for each
// of the six parameters at ±2 units in 0.1 steps around the start (41 each, metres and
// degrees, named per row), and one PNG per parameter.
TEST_F(CliTest, RegisterMiProbeWritesEachParameterAtTwoUnitsInTenthSteps) {
  const std::string kitti = kSource + "/data/kitti/";
  const RunResult run = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin --image " + kitti +
                             "image_2/000000.png --kitti-calib " + kitti + "calib/000000.txt --probe " +
                             Tmp("probe") + " --probe-level 2 --restarts 0 --halves false -q --output " +
                             Tmp("out.json"));
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;
  std::ifstream csv(Tmp("probe") + "/probe.csv");
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "parameter,offset,mi_bits,nmi,nid,joint_entropy_bits,samples,lidar_samples,offset_unit");
  std::map<std::string, std::vector<double>> offsets;
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    std::stringstream row(line);
    for (std::string v; std::getline(row, v, ',');) f.push_back(v);
    ASSERT_EQ(f.size(), 9u) << line;
    EXPECT_EQ(f[8], f[0] == "tx" || f[0] == "ty" || f[0] == "tz" ? "m" : "deg") << line;
    EXPECT_GT(std::stod(f[2]), 0.0) << line;  // MI in bits
    offsets[f[0]].push_back(std::stod(f[1]));
  }
  ASSERT_EQ(offsets.size(), 6u);
  for (const auto& [name, values] : offsets) {
    ASSERT_EQ(values.size(), 41u) << name;
    EXPECT_NEAR(values.front(), -2.0, 1e-9) << name;
    EXPECT_NEAR(values.back(), 2.0, 1e-9) << name;
    EXPECT_NEAR(values[21] - values[20], 0.1, 1e-9) << name;
    EXPECT_TRUE(fs::exists(Tmp("probe") + "/probe_" + name + ".png")) << name;
  }
}

// register-mi refuses, before any work, numbers that are not finite (CLI11 reads "nan" and
// "inf") and outputs it could not write: exit 2, one line naming the option or file, nothing
// written. The output check is the shared one (RefuseToOverwriteInputs), so bal has it too.
TEST_F(CliTest, RegisterMiRefusesNonFiniteNumbersAndUnwritableOutputsBeforeAnyWork) {
  const std::string kitti = kSource + "/data/kitti/";
  const std::string frame = "register-mi --lidar " + kitti + "velodyne/000000.bin --image " + kitti +
                            "image_2/000000.png --kitti-calib " + kitti + "calib/000000.txt";
  fs::create_directories(Tmp("adir"));
  std::ofstream(Tmp("afile")) << "a file\n";
  {
    // The calibration's pose with one number beyond a double's range.
    std::ofstream(Tmp("pose_inf.json"))
        << "{\"cam_from_lidar\": [0, -1, 0, 1e400, 0, 0, -1, 0,\n 1, 0, 0, 0, 0, 0, 0, 1]}\n";
  }
  // A pipe (as /dev/null is a device): a file renamed over it would replace it.
  ASSERT_EQ(mkfifo(Tmp("apipe").c_str(), 0600), 0);
  const std::string out = " --output " + Tmp("out.json");
  for (const auto& [flags, named] : std::vector<std::pair<std::string, std::string>>{
           {out + " --overlay " + Tmp("apipe"), "--overlay: cannot write '" + Tmp("apipe") +
                                                    "': it is a device, pipe or socket, not a regular file"},
           {" --perturb nan,0,0,0,0,0" + out, "--perturb: found 'nan', expected a finite number"},
           {" --perturb 0,0,0,0,0,inf" + out, "--perturb: found 'inf', expected a finite number"},
           {" --max-range-m inf" + out, "--max-range-m: found 'inf', expected a finite number"},
           {" --point-radius-m nan" + out, "--point-radius-m: found 'nan'"},
           {" --surface-voxel-m nan" + out, "--surface-voxel-m: found 'nan'"},
           {" --max-sigma-px nan" + out, "--max-sigma-px: found 'nan'"},
           {" --scanner-origin 0,nan,0" + out, "--scanner-origin: found 'nan'"},
           {" --output " + Tmp("adir"), "--output: cannot write '" + Tmp("adir") + "': it is an existing folder; "
                                        "expected a file to write"},
           {" --output " + Tmp("afile") + "/out.json", "is a file, not a folder; expected a file to write"},
           {" --output /proc/nope/out.json", "--output: cannot write '/proc/nope/out.json': cannot create a folder in '/proc'"},
           {out + " --overlay /proc/nope/o.png", "--overlay: cannot write '/proc/nope/o.png'"},
           {out + " --lidar-image " + Tmp("adir"), "--lidar-image: cannot write"},
           {out + " --probe " + Tmp("afile"), "--probe: cannot write '" + Tmp("afile") +
                                                  "': it is an existing file, not a folder; expected a folder"},
           {out + " --initial " + Tmp("pose_inf.json"),
            Tmp("pose_inf.json") + ":1: field 'cam_from_lidar': found '1e400', expected a finite number"}}) {
    const RunResult run = Mmba(frame + flags);
    EXPECT_EQ(run.exit_code, 2) << flags << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr("mmba: error: ")) << flags;
    EXPECT_THAT(run.output, HasSubstr(named)) << flags;
    EXPECT_THAT(run.output, ::testing::Not(HasSubstr("registration"))) << flags;  // no work done
    EXPECT_FALSE(fs::exists(Tmp("out.json"))) << flags;
  }
  EXPECT_TRUE(fs::is_empty(Tmp("adir")));
  EXPECT_TRUE(fs::is_fifo(Tmp("apipe")));
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp_), fs::directory_iterator()), 4);  // adir, afile, apipe, pose_inf.json
  const RunResult bal = Mmba("bal " + kSource + "/data/bal/dubrovnik-3-7-pre.txt --json " + Tmp("adir"));
  EXPECT_EQ(bal.exit_code, 2) << bal.output;
  EXPECT_THAT(bal.output, HasSubstr("--json: cannot write '" + Tmp("adir") + "': it is an existing folder"));
}

// --metric is recorded in OUT.json's settings, and the console line gives the metric's values
// as OUT.json holds them: NID itself (minimised), not the −NID the search maximises.
TEST_F(CliTest, RegisterMiReportsTheMetricAsOutJsonHoldsIt) {
  const std::string kitti = kSource + "/data/kitti/";
  const RunResult run = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin --image " + kitti +
                             "image_2/000000.png --kitti-calib " + kitti + "calib/000000.txt --metric nid "
                             "--restarts 0 --halves false -q --output " + Tmp("nid.json"));
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;
  const nlohmann::json json = nlohmann::json::parse(std::ifstream(Tmp("nid.json")));
  EXPECT_EQ(json["settings"]["metric"], "nid");
  const double before = json["metric_before"], after = json["metric_after"];
  EXPECT_GT(before, 0.0);  // NID is in 0..1
  EXPECT_LT(before, 1.0);
  char expected[128];
  std::snprintf(expected, sizeof(expected), "nid %.5f -> %.5f (minimised)", before, after);
  EXPECT_THAT(run.output, HasSubstr(expected));
}

// Bad KITTI input is refused before any work, exit 2 naming what is wrong: a calibration
// without R0_rect or with a key twice, or without the P of the camera asked for; --view
// equirect (like perspective and cube) with a pinhole camera; an image whose size does not fit
// the calibration's principal point (here KITTI's image at twice its size: 2484x750 for
// cx ~ 604, cy ~ 181); --representation points with an explicit --region overlap.
TEST_F(CliTest, RegisterMiRefusesMismatchedKittiInput) {
  const std::string kitti = kSource + "/data/kitti/";
  const std::string data = kSource + "/tests/io_kitti/data/";
  const std::string cloud = "register-mi --lidar " + kitti + "velodyne/000000.bin";
  const std::string frame = cloud + " --image " + kitti + "image_2/000000.png";
  const std::string calib = " --kitti-calib " + kitti + "calib/000000.txt";
  const std::string out = " --output " + Tmp("out.json");
  registration::mi::WriteGrayPng(registration::mi::GrayImage(2484, 750, 0.5f), Tmp("big.png"));
  for (const auto& [flags, named] : std::vector<std::pair<std::string, std::string>>{
           {frame + " --kitti-calib " + data + "calib_missing_r0.txt" + out,
            data + "calib_missing_r0.txt: missing calibration key R0_rect"},
           {frame + " --kitti-calib " + data + "calib_duplicate_p2.txt" + out,
            data + "calib_duplicate_p2.txt:4: field 'P2': found 'a second 'P2:' line"},
           {frame + " --kitti-calib " + data + "calib_only_p2.txt --kitti-camera 3" + out,
            data + "calib_only_p2.txt: missing calibration key P3 or P_rect_03"},
           {frame + calib + " --kitti-camera 4" + out, "--kitti-camera: found 4, expected a KITTI camera index 0..3"},
           {frame + calib + " --view equirect" + out,
            "--view: found 'equirect' but the camera of " + kitti + "calib/000000.txt is PINHOLE"},
           {frame + calib + " --view cube" + out, "--view: found 'cube' but the camera"},
           {cloud + " --image " + Tmp("big.png") + calib + out,
            Tmp("big.png") + ": image is 2484x750 but the principal point of KITTI camera 2"},
           {frame + calib + " --representation points --region overlap" + out,
            "--region: overlap with --representation points has a constant LiDAR image"}}) {
    const RunResult run = Mmba(flags);
    EXPECT_EQ(run.exit_code, 2) << flags << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr(named)) << flags;
    EXPECT_FALSE(fs::exists(Tmp("out.json"))) << flags;
  }
  const RunResult big = Mmba(cloud + " --image " + Tmp("big.png") + calib + out);
  EXPECT_THAT(big.output, HasSubstr("expected an image of about 1208x361"));
}

// Only P2 in the calibration serves camera 2. --representation points without --region is
// compared over the whole image (recorded in settings); a cloud without intensity is refused
// with a hint that leads to a representation that runs.
TEST_F(CliTest, RegisterMiRunsOnlyP2AndPointsOverTheWholeImage) {
  const std::string kitti = kSource + "/data/kitti/";
  const std::string data = kSource + "/tests/io_kitti/data/";
  const std::string frame = "register-mi --lidar " + kitti + "velodyne/000000.bin --image " + kitti + "image_2/000000.png";
  const std::string calib = " --kitti-calib " + kitti + "calib/000000.txt";
  const std::string out = " --output " + Tmp("out.json");
  const RunResult only_p2 = Mmba(frame + " --kitti-calib " + data + "calib_only_p2.txt --restarts 0 "
                                 "--halves false -q" + out);
  EXPECT_TRUE(only_p2.exit_code == 0 || only_p2.exit_code == 3) << only_p2.output;
  fs::remove(Tmp("out.json"));
  // Points without --region: the whole image, said so in settings.
  const RunResult points = Mmba(frame + calib + " --representation points --restarts 0 --halves false -q" + out);
  ASSERT_TRUE(points.exit_code == 0 || points.exit_code == 3) << points.output;
  const nlohmann::json json = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  EXPECT_EQ(json["settings"]["representation"], "points");
  EXPECT_EQ(json["settings"]["region"], "whole");
  EXPECT_THAT(json["settings"]["region_note"].get<std::string>(), HasSubstr("default for --representation points"));
  // A cloud without intensity: the hint leads to a representation that runs.
  io::PointCloud xyz = io::ReadPointCloud(kitti + "velodyne/000000.bin");
  xyz.intensity.clear();
  io::WritePly(xyz, Tmp("xyz.ply"));
  const RunResult no_intensity = Mmba("register-mi --lidar " + Tmp("xyz.ply") + " --image " + kitti +
                                      "image_2/000000.png" + calib + " --output " + Tmp("xyz.json"));
  EXPECT_EQ(no_intensity.exit_code, 2) << no_intensity.output;
  EXPECT_THAT(no_intensity.output,
              HasSubstr("cloud has no intensity, which --representation intensity (the default) needs; use "
                        "--representation depth or points"));
  EXPECT_FALSE(fs::exists(Tmp("xyz.json")));
}

// One absurd point (1e12 m away, a glitch of a scanner's record) and one without a return
// (NaN) change nothing: points beyond --max-range-m of every camera and non-finite ones are
// dropped before the cloud is used (before the map-grid origin, the incidence fit, the
// surface classes), and OUT.json counts them.
TEST_F(CliTest, RegisterMiIgnoresAFarOutlierPoint) {
  const std::string kitti = kSource + "/data/kitti/";
  io::PointCloud cloud = io::ReadPointCloud(kitti + "velodyne/000000.bin");
  io::WritePly(cloud, Tmp("clean.ply"));
  cloud.points.push_back(Eigen::Vector3d(1e12, 2e11, 5e10));
  cloud.intensity.push_back(0.5f);
  // ... and a point without a return (NaN), as some scanners write them: dropped and counted.
  cloud.points.push_back(Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  cloud.intensity.push_back(0.5f);
  io::WritePly(cloud, Tmp("outlier.ply"));
  const std::string common = " --image " + kitti + "image_2/000000.png --kitti-calib " + kitti +
                             "calib/000000.txt --scanner-origin 0,0,0 --perturb 0.05,0,0,0,0.5,0 "
                             "--restarts 0 --halves false -q";
  const RunResult clean = Mmba("register-mi --lidar " + Tmp("clean.ply") + common + " --output " + Tmp("clean.json"));
  const RunResult outlier = Mmba("register-mi --lidar " + Tmp("outlier.ply") + common + " --output " + Tmp("outlier.json"));
  ASSERT_TRUE(clean.exit_code == 0 || clean.exit_code == 3) << clean.output;
  EXPECT_EQ(outlier.exit_code, clean.exit_code) << outlier.output;
  const nlohmann::json a = nlohmann::json::parse(std::ifstream(Tmp("clean.json")));
  const nlohmann::json b = nlohmann::json::parse(std::ifstream(Tmp("outlier.json")));
  EXPECT_EQ(b["status"], a["status"]);
  EXPECT_EQ(b["reason"], a["reason"]);
  EXPECT_EQ(EndPose(b), EndPose(a));
  EXPECT_EQ(EndPose(b, "correction"), EndPose(a, "correction"));
  EXPECT_EQ(b["metric_after"], a["metric_after"]);
  EXPECT_EQ(b["incidence_correction"][0]["exponent"], a["incidence_correction"][0]["exponent"]);
  EXPECT_EQ(a["clouds"][0]["points_beyond_range"], 0);
  EXPECT_EQ(b["clouds"][0]["points_beyond_range"], 1);
  EXPECT_EQ(a["clouds"][0]["points_not_finite"], 0);
  EXPECT_EQ(b["clouds"][0]["points_not_finite"], 1);
  EXPECT_EQ(b["clouds"][0]["points_read"].get<size_t>(), a["clouds"][0]["points_read"].get<size_t>() + 2);

  // A cloud whose intensity is one value (a LAS file without measured intensity holds 0):
  // nothing to register the intensity by; exit 2 naming the cloud, nothing written.
  std::fill(cloud.intensity.begin(), cloud.intensity.end(), 0.0f);
  io::WritePly(cloud, Tmp("flat.ply"));
  const RunResult flat = Mmba("register-mi --lidar " + Tmp("flat.ply") + common + " --output " + Tmp("flat.json"));
  EXPECT_EQ(flat.exit_code, 2) << flat.output;
  EXPECT_THAT(flat.output, HasSubstr(Tmp("flat.ply") + ": every point's intensity is 0: no intensity to register by"));
  EXPECT_FALSE(fs::exists(Tmp("flat.json")));
}

// A cloud in millimetres against one in metres: failed (exit 3), and the reason says what
// is wrong (the units) and what to do (--scale-range), not to enlarge the normal radius.
TEST_F(CliTest, RegisterCloudNamesMillimetresAgainstMetres) {
  const std::string pcl = kSource + "/data/pointclouds/pcl_test/";
  io::PointCloud bun0 = io::ReadPointCloud(pcl + "bun0.pcd");
  for (Eigen::Vector3d& p : bun0.points) p *= 1000.0;
  io::WritePly(bun0, Tmp("bun0_mm.ply"));
  const RunResult run = Mmba("register-cloud --source " + Tmp("bun0_mm.ply") + " --target " + pcl +
                             "bun4.pcd --output " + Tmp("mm.json") + " -q");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(Tmp("mm.json")));
  EXPECT_EQ(out["status"], "failed");
  EXPECT_THAT(out["reason"].get<std::string>(), HasSubstr("target cloud thins to only"));
  EXPECT_THAT(out["reason"].get<std::string>(), HasSubstr("different units (millimetres against metres)"));
  EXPECT_THAT(out["reason"].get<std::string>(), HasSubstr("--scale-range"));
}

// Several frames (--list, paths relative to the list file's folder): each frame in frames[]
// by its index, image and cloud; the frame taken from elsewhere (turned 1.6 degrees) is
// "rejected" with the reason in units, the others "used". Bad lists name the list file and
// line.
TEST_F(CliTest, RegisterMiListNamesItsFramesAndItsErrors) {
  namespace mit = registration::mi::testing;
  const Rigid3d truth = mit::StreetCamFromLidar(Eigen::Vector3d(0.5, 0.3, 0.2), 4.0);
  fs::create_directories(Tmp("frames"));
  io::WritePly(mit::StreetCloud(0.06), Tmp("street.ply"));
  io::CameraYaml camera;
  camera.camera = mit::StreetCamera();
  camera.cam_from_lidar = truth;
  io::WriteCameraYaml(camera, Tmp("camera.yaml"));
  registration::mi::Vector6d elsewhere;
  elsewhere << 0.0, 0.0, 0.0, 0.0, 0.0, 1.6;
  registration::mi::WriteGrayPng(mit::StreetPhoto(camera.camera, truth, 11), Tmp("frames/f0.png"));
  registration::mi::WriteGrayPng(mit::StreetPhoto(camera.camera, truth, 12), Tmp("frames/f1.png"));
  registration::mi::WriteGrayPng(
      mit::StreetPhoto(camera.camera, registration::mi::ApplyCorrection(truth, elsewhere), 13), Tmp("frames/f2.png"));
  // Frame 1's cloud has blanks in its path: in double quotes.
  fs::create_directories(Tmp("frames/my scans"));
  fs::copy_file(Tmp("street.ply"), Tmp("frames/my scans/street 1.ply"));
  std::ofstream(Tmp("frames/list.txt")) << "# image lidar\nf0.png ../street.ply\n\nf1.png \"my scans/street 1.ply\"\nf2.png "
                                        << Tmp("street.ply") << "\n";
  const std::string common = "register-mi --camera " + Tmp("camera.yaml") + " --region overlap -q";
  const RunResult run = Mmba(common + " --list " + Tmp("frames/list.txt") +
                             " --perturb 0.05,-0.05,0.05,0.5,-0.5,0.5 --output " + Tmp("out.json"));
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  ASSERT_EQ(out["frames"].size(), 3u) << out.dump(1);
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& f = out["frames"][i];
    EXPECT_EQ(f["index"], i);
    EXPECT_EQ(f["image"], Tmp("frames") + "/f" + std::to_string(i) + ".png");
    EXPECT_EQ(fs::canonical(f["lidar"].get<std::string>()),
              fs::canonical(Tmp(i == 1 ? "frames/my scans/street 1.ply" : "street.ply")));
    EXPECT_EQ(f["status"], i < 2 ? "used" : "rejected") << f.dump();
  }
  EXPECT_EQ(out["frames"][0]["reason"], "");
  EXPECT_THAT(out["frames"][2]["reason"].get<std::string>(),
              ::testing::MatchesRegex(".*off the median by -?[0-9.]+ (m|deg) \\(limit [0-9.]+ (m|deg)\\)"));
  ASSERT_EQ(out["rejected_frames"].size(), 1u);
  EXPECT_EQ(out["rejected_frames"][0]["index"], 2);
  EXPECT_EQ(out["rejected_frames"][0]["reason"], out["frames"][2]["reason"]);

  // One image given for two frames (against two clouds): the frames are still told apart.
  std::ofstream(Tmp("frames/shared.txt")) << "f0.png ../street.ply\nf0.png \"my scans/street 1.ply\"\nf2.png ../street.ply\n";
  const RunResult shared = Mmba(common + " --list " + Tmp("frames/shared.txt") +
                                " --perturb 0.05,-0.05,0.05,0.5,-0.5,0.5 --output " + Tmp("shared.json"));
  ASSERT_TRUE(shared.exit_code == 0 || shared.exit_code == 3) << shared.output;
  const nlohmann::json two = nlohmann::json::parse(std::ifstream(Tmp("shared.json")));
  ASSERT_EQ(two["frames"].size(), 3u) << two.dump(1);
  EXPECT_EQ(two["frames"][1]["frame"], Tmp("frames") + "/f0.png #1");
  for (int i = 0; i < 3; ++i) EXPECT_EQ(two["frames"][i]["status"], i < 2 ? "used" : "rejected") << i;
  ASSERT_EQ(two["rejected_frames"].size(), 1u);
  EXPECT_EQ(two["rejected_frames"][0]["index"], 2);

  std::ofstream(Tmp("frames/missing.txt")) << "f0.png ../street.ply\n# next\nf9.png ../street.ply\n";
  std::ofstream(Tmp("frames/empty.txt")) << "# nothing\n\n";
  std::ofstream(Tmp("frames/blanks.txt")) << "f0.png my scans/street 1.ply\n";
  std::ofstream(Tmp("frames/open.txt")) << "\n\"f0.png ../street.ply\n";
  for (const auto& [list, named] : std::vector<std::pair<std::string, std::string>>{
           {Tmp("frames/blanks.txt"), Tmp("frames/blanks.txt") + ":1: found 4 values, expected 2: IMAGE LIDAR (a path "
                                                                 "with blanks in double quotes"},
           {Tmp("frames/open.txt"), Tmp("frames/open.txt") + ":2: a '\"' is not closed"},
           {Tmp("frames/missing.txt"), Tmp("frames/missing.txt") + ":3: image file not found: '" + Tmp("frames") +
                                           "/f9.png' (a relative path in a list is relative to the list file's folder)"},
           {Tmp("frames/empty.txt"), Tmp("frames/empty.txt") + ": no frames in the list"}}) {
    const RunResult bad = Mmba(common + " --list " + list + " --output " + Tmp("bad.json"));
    EXPECT_EQ(bad.exit_code, 2) << bad.output;
    EXPECT_THAT(bad.output, HasSubstr(named));
    EXPECT_FALSE(fs::exists(Tmp("bad.json")));
  }
}

// A registration that fails before its covariance and checks (a black photo) writes them as
// null — not an all-zero covariance that reads as a perfectly known pose, nor 0/false checks.
TEST_F(CliTest, RegisterMiWritesWhatWasNotMeasuredAsNull) {
  const std::string kitti = kSource + "/data/kitti/";
  registration::mi::WriteGrayPng(registration::mi::GrayImage(1242, 375, 0.0f), Tmp("black.png"));
  const RunResult run = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin --image " + Tmp("black.png") +
                             " --kitti-calib " + kitti + "calib/000000.txt -q --output " + Tmp("out.json"));
  EXPECT_EQ(run.exit_code, 3) << run.output;
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  EXPECT_EQ(out["covariance_valid"], false);
  EXPECT_TRUE(out["covariance"].is_null()) << out["covariance"];
  EXPECT_TRUE(out["covariance_laplace"].is_null());
  for (const char* key : {"mi_bits", "mi_shuffled_bits", "mi_significance", "effective_samples", "axis_scans_passed",
                          "sigma_px", "weak_directions", "restarts", "restart_spread_px", "restart_rms_px",
                          "halves_spread_px", "sigma_px_calibrated"}) {
    EXPECT_TRUE(out["checks"][key].is_null()) << key << ": " << out["checks"][key];
  }
}

// --initial with a KITTI calibration: the pixel offsets of the start and of the result are
// reported against the calibration's own pose (here a failure on a black photo, whose result
// is its start, 0.1 m to the camera's right of the calibration).
TEST_F(CliTest, RegisterMiReportsOffsetsAgainstTheCalibrationForAnInitialPose) {
  const std::string kitti = kSource + "/data/kitti/";
  registration::mi::WriteGrayPng(registration::mi::GrayImage(1242, 375, 0.0f), Tmp("black.png"));
  const io::KittiCameraPose calibration =
      io::KittiCamera(io::ReadKittiCalibration(kitti + "calib/000000.txt"), 2, 1242, 375);
  Rigid3d moved = calibration.cam_from_lidar;
  moved.translation.x() += 0.1;  // the camera frame's x: right, a shift of the image
  const Eigen::Matrix4d m = moved.ToMatrix4();
  nlohmann::json pose;
  for (int r = 0; r < 4; ++r) pose["cam_from_lidar"].push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  std::ofstream(Tmp("initial.json")) << pose.dump();
  const RunResult run = Mmba("register-mi --lidar " + kitti + "velodyne/000000.bin --image " + Tmp("black.png") +
                             " --kitti-calib " + kitti + "calib/000000.txt --initial " + Tmp("initial.json") +
                             " -q --output " + Tmp("out.json"));
  EXPECT_EQ(run.exit_code, 3) << run.output;
  const nlohmann::json out = nlohmann::json::parse(std::ifstream(Tmp("out.json")));
  ASSERT_EQ(out["pixel_offset_vs_calibration"].size(), 1u) << out.dump();
  const nlohmann::json& before = out["pixel_offset_vs_calibration"][0]["before"];
  EXPECT_GT(before["points"], 1000);
  // 0.1 m sideways is fx · 0.1 / depth: about 7 px at KITTI's median depth of some 10 m.
  EXPECT_GT(before["median_px"], 2.0);
  EXPECT_LT(before["median_px"], 30.0);
  EXPECT_EQ(out["pixel_offset_vs_calibration"][0]["after"]["median_px"], before["median_px"]);
  EXPECT_FALSE(out.contains("pixel_offset_vs_reference"));
}

TEST_F(CliTest, NonConvergenceIsExitThreeAndNoModel) {
  fs::create_directories(Tmp("in"));
  io::ColmapModel model = io::ReadColmapModel(kModel);
  // Push every point off by a metre so that one iteration cannot converge.
  for (auto& [id, point] : model.points3D) point.xyz += Eigen::Vector3d(0.3, -0.2, 0.5);
  io::WriteColmapModel(model, Tmp("in"), io::ColmapFormat::kText);
  const RunResult run = Mmba("ba --input " + Tmp("in") + " --output " + Tmp("out") +
                       " --max-iterations 1 --json " + Tmp("ba.json") + " -q");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_THAT(run.output, HasSubstr("no model written"));
  EXPECT_FALSE(fs::exists(Tmp("out")));
  std::ifstream json_file(Tmp("ba.json"));
  EXPECT_EQ(nlohmann::json::parse(json_file)["status"], "no_convergence");
}

TEST_F(CliTest, BaModelWithoutObservationsIsBadInput) {
  fs::create_directories(Tmp("empty"));
  std::ofstream(Tmp("empty/cameras.txt")) << "1 PINHOLE 640 480 500 500 320 240\n";
  std::ofstream(Tmp("empty/images.txt")) << "1 1 0 0 0 0 0 0 1 a.jpg\n\n2 1 0 0 0 1 0 0 1 b.jpg\n\n";
  std::ofstream(Tmp("empty/points3D.txt")) << "";
  const RunResult run = Mmba("ba --input " + Tmp("empty") + " --output " + Tmp("out"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("the model has no observations"));
  EXPECT_FALSE(fs::exists(Tmp("out")));
}

TEST_F(CliTest, BalWritesTheCostsCeresDefines) {
  const RunResult run = Mmba("bal " + kSource + "/data/bal/dubrovnik-3-7-pre.txt --json " +
                       Tmp("bal.json") + " -q");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ifstream json_file(Tmp("bal.json"));
  const nlohmann::json json = nlohmann::json::parse(json_file);
  for (const char* key : {"initial_cost", "final_cost", "iterations", "solve_seconds",
                          "num_residuals"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
  EXPECT_EQ(json["num_residuals"], 38);
  EXPECT_LT(json["final_cost"].get<double>(), json["initial_cost"].get<double>());
}

TEST_F(CliTest, BalBadInputNamesTheLine) {
  std::ofstream(Tmp("bad.txt")) << "1 1 1\n0 0 1.5 x\n0\n0\n0\n0\n0\n0\n500\n0\n0\n0.1 0.2 -5\n";
  const RunResult run = Mmba("bal " + Tmp("bad.txt"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.output, HasSubstr("bad.txt:2: field 'observation[0].y': found 'x', expected "
                                    "a finite number"));
}

TEST_F(CliTest, AdjustBadProjectIsExitTwoNamingTheKey) {
  std::ofstream(Tmp("project.yaml"))
      << "mmba_project: 1\norigin: {latitude_deg: 45, longitude_deg: 9, height_m: 200}\nsensors:\n"
      << "  - {id: photos, type: photo_collection, images: " << kSource << "/data/colmap/balbianello/images, "
      << "colmap_model: " << kModel << ", sigma_px: 0}\n";
  const RunResult run = Mmba("adjust " + Tmp("project.yaml") + " --output " + Tmp("out"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("sensors[0].sigma_px"));
  EXPECT_THAT(run.output, HasSubstr("project.yaml:4"));
  EXPECT_FALSE(fs::exists(Tmp("out")));
}

TEST_F(CliTest, AdjustWithoutOverlapIsExitThreeAndKeepsTheEarlierOutput) {
  fs::create_directories(Tmp("out"));
  std::ofstream(Tmp("out/.mmba-output")) << "mmba output folder, written by mmba adjust\n";
  std::ofstream(Tmp("out/report.json")) << "{\"earlier\": true}\n";
  std::ofstream(Tmp("project.yaml"))
      << "mmba_project: 1\norigin: {latitude_deg: 45, longitude_deg: 9, height_m: 200}\nsensors:\n"
      << "  - {id: photos, type: photo_collection, images: " << kSource << "/data/colmap/balbianello/images, "
      << "colmap_model: " << kModel << "}\n"
      << "  - {id: ts, type: total_station, file: " << kSource << "/data/gama/gama-local.gkf}\n";
  const RunResult run = Mmba("adjust " + Tmp("project.yaml") + " --output " + Tmp("out") + " -q");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_THAT(run.output, HasSubstr("no overlap"));
  std::ifstream earlier(Tmp("out/report.json"));
  EXPECT_TRUE(nlohmann::json::parse(earlier)["earlier"].get<bool>());
}

// ---- Output folders (core/output_folder.h): replaced whole, and only when mmba wrote them.

// A project whose adjustment fails (no overlap) but that loads: the output checks come first.
void WriteNoOverlapProject(const fs::path& path) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << "mmba_project: 1\norigin: {latitude_deg: 45, longitude_deg: 9, height_m: 200}\nsensors:\n"
                      << "  - {id: photos, type: photo_collection, images: " << kSource
                      << "/data/colmap/balbianello/images, colmap_model: " << kModel << "}\n"
                      << "  - {id: ts, type: total_station, file: " << kSource << "/data/gama/gama-local.gkf}\n";
}

// --output naming the folder that holds the project (and other user files): refused before
// any work, exit 2, everything in it kept.
TEST_F(CliTest, AdjustIntoTheFolderHoldingTheProjectIsRefusedAndDeletesNothing) {
  WriteNoOverlapProject(tmp_ / "parent" / "project" / "project.yaml");
  std::ofstream(Tmp("parent/notes.txt")) << "mine\n";
  const RunResult run = Mmba("adjust " + Tmp("parent/project/project.yaml") + " --output " + Tmp("parent"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("mmba: error: --output: '" + Tmp("parent") +
                                    "' holds the input the project file ('" + Tmp("parent/project/project.yaml") +
                                    "'); mmba replaces its output folder whole"));
  EXPECT_TRUE(fs::exists(Tmp("parent/project/project.yaml")));
  EXPECT_TRUE(fs::exists(Tmp("parent/notes.txt")));
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp_), fs::directory_iterator()), 1);  // no staging, no lock
}

// Every command writing a folder refuses a non-empty folder it did not write, before any work.
TEST_F(CliTest, AFolderOfUserDataIsRefusedByEveryCommandWritingAFolder) {
  fs::create_directories(Tmp("data"));
  std::ofstream(Tmp("data/notes.txt")) << "mine\n";
  WriteNoOverlapProject(tmp_ / "project.yaml");
  const std::string kitti = kSource + "/data/kitti/";
  for (const std::string& args :
       {"survey --input " + kSource + "/data/gama/gama-local.gkf --output " + Tmp("data"),
        "ba --input " + kModel + " --output " + Tmp("data"),
        "adjust " + Tmp("project.yaml") + " --output " + Tmp("data"),
        "simulate --out " + Tmp("data"),
        "register-eval --scene " + tmp_.string() + " --output " + Tmp("data"),
        "register-mi --lidar " + kitti + "velodyne/000000.bin --image " + kitti + "image_2/000000.png --kitti-calib " +
            kitti + "calib/000000.txt --output " + Tmp("mi.json") + " --probe " + Tmp("data")}) {
    const RunResult run = Mmba(args + " -q");
    EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr("'" + Tmp("data") + "' is a folder mmba did not write (it holds 1 entry and "
                                      "no .mmba-output); mmba replaces its output folder whole and never deletes "
                                      "what it did not write"))
        << args;
    EXPECT_EQ(std::distance(fs::directory_iterator(Tmp("data")), fs::directory_iterator()), 1) << args;
    EXPECT_FALSE(fs::exists(Tmp("mi.json"))) << args;
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp_), fs::directory_iterator()), 2);  // data, project.yaml
}

// A folder mmba wrote is replaced whole on a re-run: a file added to it since is gone, the
// marker stays; a stale staging folder of a killed run beside it is removed.
TEST_F(CliTest, AFolderMmbaWroteIsReplacedWholeOnARerun) {
  const std::string survey = "survey --input " + kSource + "/data/gama/gama-local.gkf -q --output " + Tmp("out");
  ASSERT_EQ(Mmba(survey).exit_code, 0);
  EXPECT_THAT(ReadAll(Tmp("out/.mmba-output")), HasSubstr("written by mmba survey"));
  std::ofstream(Tmp("out/added.txt")) << "added since\n";
  std::ofstream(Tmp("out/report.md.tmp-999999999")) << "a killed run's half file\n";
  fs::create_directories(Tmp("out.mmba-staging-k1ll3d"));
  std::ofstream(Tmp("out.mmba-staging-k1ll3d/.mmba-output")) << "mmba\n";
  std::ofstream(Tmp("out.mmba-staging-k1ll3d/adjusted.json")) << "{}\n";
  const RunResult run = Mmba(survey);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(Tmp("out"))) names.insert(entry.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{".mmba-output", "adjusted.json", "observations.csv", "report.md"}));
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp_), fs::directory_iterator()), 1);  // out only
}

// An mmba output folder holding an input of the run (ba on a model inside it) is refused: the
// swap would delete the input.
TEST_F(CliTest, AnOutputFolderHoldingAnInputIsRefused) {
  fs::create_directories(Tmp("run"));
  std::ofstream(Tmp("run/.mmba-output")) << "mmba output folder, written by mmba adjust\n";
  fs::create_directories(Tmp("run/colmap"));
  fs::copy(kModel, Tmp("run/colmap/photos"), fs::copy_options::recursive);
  const RunResult run = Mmba("ba --input " + Tmp("run/colmap/photos") + " --output " + Tmp("run") + " -q");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("--output: '" + Tmp("run") + "' holds the input --input ('" +
                                    Tmp("run/colmap/photos") + "')"));
  EXPECT_TRUE(fs::exists(Tmp("run/colmap/photos/images.txt")));
  const RunResult same = Mmba("ba --input " + Tmp("run/colmap/photos") + " --output " + Tmp("run/colmap/photos/"));
  EXPECT_EQ(same.exit_code, 2) << same.output;
  EXPECT_THAT(same.output, HasSubstr("is the input --input; mmba never overwrites its inputs"));
}

TEST_F(CliTest, BaOutputNamingAnExistingFileIsExitTwo) {
  std::ofstream(Tmp("model.txt")) << "mine\n";
  const RunResult run = Mmba("ba --input " + kModel + " --output " + Tmp("model.txt"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("mmba: error: --output: cannot write '" + Tmp("model.txt") +
                                    "': it is an existing file, not a folder; expected a folder to write into"));
  EXPECT_EQ(ReadAll(Tmp("model.txt")), "mine\n");
}

// A second run into an output another mmba is writing (the lock held here, as that run holds
// it) exits 2 at once, writing nothing.
TEST_F(CliTest, AnOutputInUseByAnotherRunIsExitTwo) {
  const int fd = ::open(Tmp("out.mmba-lock").c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  const RunResult run = Mmba("survey --input " + kSource + "/data/gama/gama-local.gkf --output " + Tmp("out"));
  ::close(fd);
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_THAT(run.output, HasSubstr("mmba: error: --output: '" + Tmp("out") + "' is in use by another mmba run"));
  EXPECT_FALSE(fs::exists(Tmp("out")));
}

// register-cloud's JSON and error map are one result: a failed run removes the error map of an
// earlier run (no new JSON beside an old map), and a killed run's temporary goes.
TEST_F(CliTest, RegisterCloudNeverLeavesAnEarlierErrorMapBesideItsJson) {
  std::ofstream(Tmp("one-point.xyz")) << "0 0 0\n";  // too few points: a failed registration
  std::ofstream(Tmp("out.json")) << "{\"earlier\": true}\n";
  std::ofstream(Tmp("map.ply")) << "the earlier run's error map\n";
  std::ofstream(Tmp("out.json.tmp-999999999")) << "a killed run's half file\n";
  const RunResult run = Mmba("register-cloud --source " + Tmp("one-point.xyz") + " --target " + kSource +
                             "/data/pointclouds/pcl_test/bun4.pcd -q --output " + Tmp("out.json") + " --error-map " +
                             Tmp("map.ply"));
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(Tmp("out.json")))["status"], "failed");
  EXPECT_FALSE(fs::exists(Tmp("map.ply")));
  EXPECT_FALSE(fs::exists(Tmp("out.json.tmp-999999999")));
}

}  // namespace
}  // namespace mmba
