// GNSS control of a project: a control id (or a photo's antenna position) given twice, in
// one GNSS file or across two, is an InputError naming both rows.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "mmba/adjust/adjust.h"
#include "mmba/core/error.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;

class GnssControlTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("mmba_gnss_control_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // A plane network of four points in the local tangent plane at the origin (axes en).
    std::ofstream(dir_ / "network.csv") << "param,axes-xy,en\n"
                                        << "point,M1,0,0,0,xyz,\n"
                                        << "point,M2,100,0,0,xyz,\n"
                                        << "point,M3,0,100,0,,xyz\n"
                                        << "distance,M1,M3,100.001,2\n"
                                        << "distance,M2,M3,141.422,2\n"
                                        << "dh,M1,M3,0.001,2\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// Writes project.yaml with one gnss sensor per file and returns the InputError message
  /// of the adjustment (empty when none).
  std::string Error(const std::vector<std::string>& gnss_files) {
    std::ofstream yaml(dir_ / "project.yaml");
    yaml << "mmba_project: 1\nname: t\norigin: {latitude_deg: 45, longitude_deg: 7, height_m: 300}\n"
         << "sensors:\n  - {id: ts, type: total_station, file: network.csv}\n";
    for (size_t i = 0; i < gnss_files.size(); ++i) {
      yaml << "  - {id: g" << i << ", type: gnss, file: " << gnss_files[i] << "}\n";
    }
    yaml.close();
    try {
      AdjustOptions options;
      options.output_dir = (dir_ / "out").string();
      options.log_progress = false;
      RunAdjustment(LoadProject((dir_ / "project.yaml").string()), options);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

  static std::string Row(const std::string& id, const std::string& kind, double north_deg) {
    return id + "," + kind + "," + std::to_string(45.0 + north_deg) + ",7,300,0.01,0.01,0.02\n";
  }

  fs::path dir_;
  const std::string header_ =
      "id,kind,latitude_deg,longitude_deg,height_m,sigma_east_m,sigma_north_m,sigma_up_m\n";
};

TEST_F(GnssControlTest, ADuplicateControlIdNamesBothRows) {
  std::ofstream(dir_ / "gnss.csv") << header_ << Row("M1", "control", 0) << Row("M2", "control", 0.0001)
                                   << Row("M1", "control", 0.00001);
  const std::string e = Error({"gnss.csv"});
  EXPECT_NE(e.find("gnss.csv:4"), std::string::npos) << e;
  EXPECT_NE(e.find("'M1'"), std::string::npos) << e;
  EXPECT_NE(e.find("gnss.csv:2"), std::string::npos) << e;
}

TEST_F(GnssControlTest, ADuplicateAcrossTwoFilesNamesBothFiles) {
  std::ofstream(dir_ / "a.csv") << header_ << Row("M2", "control", 0.0001);
  std::ofstream(dir_ / "b.csv") << header_ << Row("M1", "control", 0) << Row("M2", "control", 0.0001);
  const std::string e = Error({"a.csv", "b.csv"});
  EXPECT_NE(e.find("b.csv:3"), std::string::npos) << e;
  EXPECT_NE(e.find("a.csv:2"), std::string::npos) << e;
  // The same id as a control mark and as a photo's antenna position is not a duplicate.
  std::ofstream(dir_ / "c.csv") << header_ << Row("M1", "control", 0) << Row("M1", "camera", 0);
  EXPECT_EQ(Error({"c.csv"}).find("each"), std::string::npos);
}

}  // namespace
}  // namespace mmba::adjust
