// `mmba register-mi` with the geometric term (--set edges=on) on bad input, through the binary
// with real data (KITTI 000000, pjlab manual_calib): a LiDAR without intensity (the geometric
// term alone), an image of another scene, a black image, intrinsics that disagree with the
// image, malformed calibration files. Each ends "failed" with its reason (exit 3) or exit 2
// naming the file, nothing written. The runs use the geometric term alone (edge_mi=false,
// about 1 s each) unless MI is what is checked.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/mi/image.h"
#include "shell.h"

namespace mmba {
namespace {
namespace fs = std::filesystem;
namespace mi = registration::mi;
using ::testing::HasSubstr;
using test::RunResult;

const std::string kSource = MMBA_SOURCE_DIR;
const std::string kKitti = kSource + "/data/kitti/";
const std::string kPjlab = kSource + "/data/lidar_camera/pjlab/manual_calib/";

RunResult Mmba(const std::string& args) { return test::RunShell(std::string(MMBA_EXECUTABLE) + " " + args); }

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class RegisterMiInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_ = fs::temp_directory_path() /
           ("mmba_rmi_input_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(tmp_);
    fs::create_directories(tmp_);
  }
  void TearDown() override { fs::remove_all(tmp_); }
  std::string Tmp(const std::string& name) const { return (tmp_ / name).string(); }
  // KITTI 000000's cloud and camera 2 with `image`, the geometric term alone.
  std::string KittiRun(const std::string& lidar, const std::string& image) const {
    return "register-mi --lidar " + lidar + " --image " + image + " --kitti-calib " + kKitti +
           "calib/000000.txt --set edges=on edge_mi=false -q";
  }
  fs::path tmp_;
};

nlohmann::json ReadJson(const std::string& path) { return nlohmann::json::parse(std::ifstream(path)); }

// A cloud without intensity (no field, or one value in every point) is registered by its
// depth edges alone with --set edges=on: it runs (ok or failed with a reason), its edges are
// depth edges only, its LiDAR image is the depth; without the geometric term it is refused
// (exit 2) with the hint that leads to it.
TEST_F(RegisterMiInputTest, LidarWithoutIntensityGivesTheGeometricTermAlone) {
  io::PointCloud cloud = io::ReadPointCloud(kKitti + "velodyne/000000.bin");
  const std::vector<float> intensity = cloud.intensity;
  cloud.intensity.clear();
  io::WritePly(cloud, Tmp("xyz.ply"));
  cloud.intensity.assign(intensity.size(), 0.0f);
  io::WritePly(cloud, Tmp("flat.ply"));
  const std::string image = kKitti + "image_2/000000.png";
  for (const char* name : {"xyz", "flat"}) {
    // With MI asked for (edge_mi's default): there is none to add.
    const std::string run_args = "register-mi --lidar " + Tmp(std::string(name) + ".ply") + " --image " + image +
                                 " --kitti-calib " + kKitti + "calib/000000.txt --set edges=on --perturb "
                                 "0.03,0,0,0,0.3,0 --output " + Tmp(std::string(name) + ".json");
    const RunResult run = Mmba(run_args);
    ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;
    EXPECT_THAT(run.output, HasSubstr("the geometric term alone (depth edges, no MI)")) << run.output;
    const nlohmann::json out = ReadJson(Tmp(std::string(name) + ".json"));
    EXPECT_EQ(out["settings"]["representation"], "depth");
    EXPECT_GT(out["edges"]["depth_points"].get<int>(), 300);
    EXPECT_EQ(out["edges"]["intensity_points"], 0);
    EXPECT_EQ(out["edges"]["mi_weight"], 0.0);
    if (out["status"] != "ok") EXPECT_FALSE(out["reason"].get<std::string>().empty());
  }
  const RunResult refused = Mmba("register-mi --lidar " + Tmp("xyz.ply") + " --image " + image + " --kitti-calib " +
                                 kKitti + "calib/000000.txt --output " + Tmp("refused.json"));
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr(Tmp("xyz.ply") + ": cloud has no intensity"));
  EXPECT_THAT(refused.output, HasSubstr("or --set edges=on (the geometric term alone)"));
  EXPECT_FALSE(fs::exists(Tmp("refused.json")));
}

// The KITTI sweep against a photo of another vehicle's street (pjlab manual_calib, scaled by
// 3/4 and cut to KITTI's 1242x375) and against a black photo: failed with the reason, no pose
// in the file to be used by mistake.
TEST_F(RegisterMiInputTest, AnotherSceneAndABlackImageFail) {
  const mi::GrayImage pjlab = mi::ReadGrayImage(kPjlab + "0.png");
  mi::GrayImage other(1242, 375);
  const int x0 = (pjlab.width * 3 / 4 - 1242) / 2, y0 = (pjlab.height * 3 / 4 - 375) / 2;
  for (int r = 0; r < other.height; ++r) {
    for (int c = 0; c < other.width; ++c) {
      float v = 0;
      pjlab.Sample((x0 + c + 0.5) * 4.0 / 3.0, (y0 + r + 0.5) * 4.0 / 3.0, &v);
      other.at(c, r) = v;
    }
  }
  mi::WriteGrayPng(other, Tmp("other.png"));
  mi::WriteGrayPng(mi::GrayImage(1242, 375, 0.0f), Tmp("black.png"));
  for (const auto& [name, reason] : std::vector<std::pair<std::string, std::string>>{
           {"other", ""}, {"black", "LiDAR edges do not meet image edges: edge score 0.000"}}) {
    const RunResult run = Mmba(KittiRun(kKitti + "velodyne/000000.bin", Tmp(name + ".png")) + " --output " +
                               Tmp(name + ".json"));
    EXPECT_EQ(run.exit_code, 3) << name << ": " << run.output;
    EXPECT_THAT(run.output, HasSubstr("mmba: failed: ")) << name;
    const nlohmann::json out = ReadJson(Tmp(name + ".json"));
    EXPECT_EQ(out["status"], "failed") << name;
    EXPECT_THAT(out["reason"].get<std::string>(), HasSubstr(reason)) << name;
    EXPECT_FALSE(out["reason"].get<std::string>().empty()) << name;
    EXPECT_TRUE(out["cam_from_lidar"].is_null()) << name;
  }
}

// Intrinsics that disagree with the image (a camera YAML of 1242x375 for a 1920x1200 photo;
// KITTI's calibration, whose principal point is (604, 180), for the same photo): exit 2 naming
// the image and the calibration, nothing written.
TEST_F(RegisterMiInputTest, IntrinsicsThatDisagreeWithTheImageNameBoth) {
  std::ofstream(Tmp("camera.yaml")) << "model: PINHOLE\nwidth: 1242\nheight: 375\nparams: [707.05, 707.05, 604.6, 181.0]\n"
                                       "cam_from_lidar: [0,-1,0,0, 0,0,-1,0, 1,0,0,0, 0,0,0,1]\n";
  const std::string photo = kPjlab + "0.png";
  const RunResult yaml = Mmba("register-mi --lidar " + kPjlab + "0.pcd --image " + photo + " --camera " +
                              Tmp("camera.yaml") + " --set edges=on --output " + Tmp("yaml.json"));
  EXPECT_EQ(yaml.exit_code, 2) << yaml.output;
  EXPECT_THAT(yaml.output, HasSubstr(photo));
  EXPECT_THAT(yaml.output, HasSubstr("1920x1200"));
  EXPECT_THAT(yaml.output, HasSubstr("1242x375"));
  EXPECT_FALSE(fs::exists(Tmp("yaml.json")));
  const RunResult kitti = Mmba(KittiRun(kKitti + "velodyne/000000.bin", photo) + " --output " + Tmp("kitti.json"));
  EXPECT_EQ(kitti.exit_code, 2) << kitti.output;
  EXPECT_THAT(kitti.output, HasSubstr(photo + ": image is 1920x1200 but the principal point"));
  EXPECT_FALSE(fs::exists(Tmp("kitti.json")));
}

// Malformed calibration files, each through the command: exit 2, the error names the file
// (and, where it has one, the line or the field), nothing written.
TEST_F(RegisterMiInputTest, MalformedCalibrationFilesAreNamed) {
  // KITTI: P2 with 11 numbers.
  std::string kitti = ReadAll(kKitti + "calib/000000.txt");
  const size_t p2 = kitti.find("P2: ");
  const size_t end = kitti.find('\n', p2);
  kitti.replace(kitti.rfind(' ', end - 2), end - kitti.rfind(' ', end - 2), "");
  std::ofstream(Tmp("kitti.txt")) << kitti;
  // OpenCalib intrinsic JSON cut off; extrinsic JSON with a 3x3 matrix; calib.txt with a word
  // among K's numbers; a camera YAML without params.
  const std::string intrinsic = ReadAll(kPjlab + "center_camera-intrinsic.json");
  std::ofstream(Tmp("cut-intrinsic.json")) << intrinsic.substr(0, intrinsic.size() / 2);
  nlohmann::json extrinsic = ReadJson(kPjlab + "top_center_lidar-to-center_camera-extrinsic.json");
  nlohmann::json& data = extrinsic["top_center_lidar-to-center_camera-extrinsic"]["param"]["sensor_calib"]["data"];
  data.erase(3);
  for (nlohmann::json& row : data) row.erase(3);
  std::ofstream(Tmp("bad-extrinsic.json")) << extrinsic.dump(2);
  std::ofstream(Tmp("calib.txt")) << "K: 2152.8 0 971.3 0 2155.5 six 0 0 1\nD: -0.1192 0.162 0.00073985 0.0014\n"
                                     "T: 0.0188623 -0.999822 -9.36529e-05 -0.0323222 0.0288601 0.000638227 "
                                     "-0.999583 -0.396685 0.999405 0.0188516 0.028867 -0.0869361\n";
  std::ofstream(Tmp("noparams.yaml")) << "model: OPENCV\nwidth: 1920\nheight: 1200\n";
  const std::string pjlab = "register-mi --lidar " + kPjlab + "0.pcd --image " + kPjlab + "0.png --set edges=on";
  const std::string extrinsic_file = " --initial " + kPjlab + "top_center_lidar-to-center_camera-extrinsic.json";
  for (const auto& [args, named] : std::vector<std::pair<std::string, std::string>>{
           {"register-mi --lidar " + kKitti + "velodyne/000000.bin --image " + kKitti +
                "image_2/000000.png --set edges=on --kitti-calib " + Tmp("kitti.txt"),
            Tmp("kitti.txt")},
           {pjlab + " --camera " + Tmp("cut-intrinsic.json") + extrinsic_file, Tmp("cut-intrinsic.json")},
           {pjlab + " --camera " + kPjlab + "center_camera-intrinsic.json --initial " + Tmp("bad-extrinsic.json"),
            Tmp("bad-extrinsic.json")},
           {pjlab + " --camera " + Tmp("calib.txt") + " --initial " + Tmp("calib.txt"), Tmp("calib.txt")},
           {pjlab + " --camera " + Tmp("noparams.yaml") + extrinsic_file, Tmp("noparams.yaml")}}) {
    const RunResult run = Mmba(args + " --output " + Tmp("out.json"));
    EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.output;
    EXPECT_THAT(run.output, HasSubstr("mmba: error: " + named)) << args;
    EXPECT_FALSE(fs::exists(Tmp("out.json"))) << args;
  }
}

}  // namespace
}  // namespace mmba
