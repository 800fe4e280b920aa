// Runs the mmba binary as a user would: exit codes, the one error line, files written.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/io/colmap_model.h"

namespace mmba {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

RunResult Mmba(const std::string& args) {
  RunResult run;
  const std::string command = std::string(MMBA_EXECUTABLE) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  char buffer[4096];
  while (fgets(buffer, sizeof(buffer), pipe)) run.output += buffer;
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
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
}

// register-cloud --scale-range: bad ranges are exit 2 naming the option, nothing written; a
// range that misses the scale of PCL's bun0 against bun4 is a reported failure (exit 3) with
// the trials in the JSON.
TEST_F(CliTest, RegisterCloudScaleRange) {
  const std::string pair = "register-cloud --source " + kSource + "/data/pointclouds/pcl_test/bun0.pcd --target " + kSource +
                           "/data/pointclouds/pcl_test/bun4.pcd --output " + Tmp("out.json");
  const RunResult reversed = Mmba(pair + " --scale-range 3 2");
  EXPECT_EQ(reversed.exit_code, 2);
  EXPECT_THAT(reversed.output, HasSubstr("--scale-range"));
  const RunResult step = Mmba(pair + " --scale-range 1 2 --scale-step 0.9");
  EXPECT_EQ(step.exit_code, 2);
  EXPECT_THAT(step.output, HasSubstr("--scale-step"));
  EXPECT_FALSE(fs::exists(Tmp("out.json")));
  const RunResult missed = Mmba(pair + " --scale-range 4 4.5 -q");
  EXPECT_EQ(missed.exit_code, 3) << missed.output;
  std::ifstream in(Tmp("out.json"));
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["status"], "failed");
  EXPECT_EQ(j["trials"].size(), 3u);  // 4, 4.2, 4.41
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

}  // namespace
}  // namespace mmba
