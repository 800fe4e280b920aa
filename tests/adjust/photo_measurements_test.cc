// The photo_measurements block end to end on DBAT's camcaldemo (data/dbat/camcaldemo): 21
// images of a calibration sheet oriented without COLMAP from its 4 fixed corner points, the
// camera self-calibrated from nominal values; and the bad inputs that must name the image and
// the point.
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "test_support.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing_support::ReadText;
using testing_support::RunProject;
using testing_support::ScratchRoot;

const fs::path kCamcal = fs::path(MMBA_SOURCE_DIR) / "data/dbat/camcaldemo";

TEST(PhotoMeasurements, CamcaldemoOrientsWithoutColmapAndSelfCalibrates) {
  const fs::path out = ScratchRoot("pm_camcal") / "out";
  fs::remove_all(out.parent_path());
  const AdjustOutcome outcome = RunProject((kCamcal / "project.yaml").string(), out.string());
  ASSERT_TRUE(outcome.ok) << outcome.status << ": " << outcome.reason;
  const nlohmann::json report = nlohmann::json::parse(ReadText(out / "report.json"));
  const nlohmann::json& pm = report["photo_measurements"];
  EXPECT_EQ(pm["initialisation"]["frame"], "control");
  EXPECT_EQ(pm["images"].size(), 21u);
  EXPECT_EQ(pm["points"], 100);         // DBAT: 96 object points + 4 control points
  EXPECT_EQ(pm["observations"], 2074);  // every measurement of markpts.txt
  // σ 0.1 px: DBAT's σ0 = 1.61 with its 8-parameter camera (K3, b1 too); the OPENCV camera
  // (k1, k2, p1, p2, fx ≠ fy) leaves a larger residual, and data snooping takes the worst.
  const double sigma0 = report["sigma0"]["aposteriori"];
  EXPECT_GT(sigma0, 1.0);
  EXPECT_LT(sigma0, 2.5);
  // The camera constant: DBAT's c = 7.457 mm = 2336.8 px (pitch 3.1911e-3 mm), ±0.33 px (1σ).
  const double fx = pm["camera"][0]["adjusted"];
  EXPECT_NEAR(fx, 2336.8, 3.0);
  const double cy = pm["camera"][3]["adjusted"];
  EXPECT_NEAR(cy, 2.61329 / 3.19110e-3, 3.0);  // DBAT's yp = 2.61329 mm from the top edge
  for (const auto& image : pm["images"]) {
    EXPECT_GT(image["observations"].get<int>(), 50);
    EXPECT_GT(image["sigma_centre_m"][0].get<double>(), 0.0);
  }
  EXPECT_THAT(ReadText(out / "c4040z_points.csv"), HasSubstr("1001,control (fixed),0,1,0,0,0,0"));
}

class PhotoMeasurementsBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ScratchRoot("pm_bad");
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    fs::copy_file(kCamcal / "c4040z_nominal_opencv.yaml", dir_ / "camera.yaml");
    fs::copy_file(kCamcal / "reference/camcal-fixed.txt", dir_ / "control.txt");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Project(const std::string& measurements) {
    std::ofstream(dir_ / "m.txt") << measurements;
    std::ofstream(dir_ / "p.yaml") << "mmba_project: 1\nframe: cartesian\n"
                                      "control: {file: control.txt, columns: [id, label, x, y, z], sigma_m: 0}\n"
                                      "sensors:\n  - {id: c, type: photo_measurements, camera: camera.yaml, "
                                      "measurements: [{file: m.txt, columns: [image, id, x, y], sigma_px: 0.1}]}\n";
    return (dir_ / "p.yaml").string();
  }
  fs::path dir_;
};

TEST_F(PhotoMeasurementsBadInput, OutsideTheImageNamesPointAndImage) {
  const std::string path = Project("1 1001 100 100\n1 1002 2300 100\n");
  try {
    RunProject(path, (dir_ / "out").string());
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("m.txt:2: field 'x': found '2300.000000 (point 1002, image 1)'"));
  }
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(PhotoMeasurementsBadInput, TooFewPointsIsAReportedFailure) {
  const AdjustOutcome outcome = RunProject(Project("1 1001 100 100\n1 1002 900 100\n2 1001 120 90\n"), (dir_ / "out").string());
  EXPECT_FALSE(outcome.ok);
  EXPECT_EQ(outcome.status, "failed");
  EXPECT_THAT(outcome.reason, HasSubstr("no image could be oriented"));
}

// DBAT's camcaldemo with only two of the sheet's four corners as control: they fix no datum
// (the rotation about their line is free) and, held, contradict the inner constraints of a
// block without control: an input error naming the control file, nothing written.
TEST(PhotoMeasurements, TwoControlPointsAreAnInputErrorNamingTheControlFile) {
  const fs::path dir = ScratchRoot("pm_two_control");
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "control.txt") << "# id, label, x, y, z\n1001,CP1,0,1,0\n1002,CP2,1,1,0\n";
  std::ofstream(dir / "p.yaml") << "mmba_project: 1\nframe: cartesian\n"
                                   "control: {file: control.txt, columns: [id, label, x, y, z], sigma_m: 0}\n"
                                   "sensors:\n  - {id: c, type: photo_measurements, camera: "
                                << (kCamcal / "c4040z_nominal.yaml").string() << ", measurements: [{file: "
                                << (kCamcal / "measurements/markpts.txt").string()
                                << ", columns: [image, id, x, y, sxy]}], refine: [c, xp, yp, K1, K2, P1, P2]}\n";
  try {
    RunProject((dir / "p.yaml").string(), (dir / "out").string());
    ADD_FAILURE() << "adjusted with two control points";
  } catch (const InputError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("control.txt:2: field 'control': found '2 control point(s) measured in "
                                                 "the images (1001, 1002)', expected 3 or more"));
  }
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mmba::adjust
