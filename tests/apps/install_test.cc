// The installed mmba (`cmake --install`) runs on its own: it loads the image-codec module
// from the install tree (bin/../lib/mmba), not from the build tree, and it states its version
// and commit on --version and in its JSON outputs.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/core/version.h"
#include "shell.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using mmba::test::RunResult;
using mmba::test::RunShell;

class InstallTest : public ::testing::Test {
 protected:
  void SetUp() override {
    prefix_ = fs::path(testing::TempDir()) / ("mmba_install_" + std::to_string(getpid()));
    fs::remove_all(prefix_);
    const RunResult install = RunShell(std::string(MMBA_CMAKE_COMMAND) + " --install " + MMBA_BINARY_DIR +
                                  " --prefix " + prefix_.string());
    ASSERT_EQ(install.exit_code, 0) << install.output;
    mmba_ = (prefix_ / "bin" / "mmba").string();
    ASSERT_TRUE(fs::is_regular_file(mmba_));
  }
  void TearDown() override { fs::remove_all(prefix_); }

  fs::path prefix_;
  std::string mmba_;
};

TEST_F(InstallTest, VersionNamesTheReleaseAndTheCommit) {
  const RunResult run = RunShell(mmba_ + " --version");
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_EQ(run.output, mmba::VersionLine() + "\n");
  EXPECT_THAT(run.output, ::testing::StartsWith(std::string("mmba ") + mmba::Version() + " (commit "));
}

// An image read by the installed binary loads the module installed beside it (the log says
// which), with MMBA_IMAGE_CODECS_MODULE unset.
TEST_F(InstallTest, ReadsImagesWithTheInstalledCodecModule) {
  const std::string kitti = std::string(MMBA_SOURCE_DIR) + "/data/kitti";
  if (!fs::exists(kitti + "/image_2/000000.png")) GTEST_SKIP() << "no KITTI sample";
  const std::string out = (prefix_ / "mi.json").string();
  const RunResult run = RunShell("env -u MMBA_IMAGE_CODECS_MODULE " + mmba_ + " register-mi --lidar " + kitti +
                            "/velodyne/000000.bin --image " + kitti + "/image_2/000000.png --kitti-calib " +
                            kitti + "/calib/000000.txt --output " + out + " --verbose");
  EXPECT_TRUE(run.exit_code == 0 || run.exit_code == 3) << run.output;  // registered or not: the image was read
  const std::string installed = (prefix_ / "lib" / "mmba").string();
  EXPECT_THAT(run.output, HasSubstr("image codecs: loading " + installed)) << run.output;
  EXPECT_TRUE(fs::exists(out));
}

TEST_F(InstallTest, JsonOutputsRecordVersionAndCommit) {
  const std::string out = (prefix_ / "net").string();
  const RunResult run =
      RunShell(mmba_ + " survey --input " + std::string(MMBA_SOURCE_DIR) + "/data/gama/gama-local.gkf --output " + out + " -q");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ifstream in(out + "/adjusted.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("mmba").at("version"), mmba::Version());
  EXPECT_EQ(j.at("mmba").at("commit"), mmba::GitCommit());
}

}  // namespace
