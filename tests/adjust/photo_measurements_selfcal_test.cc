// Self-calibration of the PHOTOGRAMMETRIC camera on DBAT's camcaldemo (data/dbat/camcaldemo:
// 21 images of PhotoModeler's calibration sheet, 2074 measurements, σ 0.1 px) against the two
// reference calibrations of the same measurements, parameter by parameter within their σ:
//  - DBAT 0.9.2 (result/report.txt): c, px, py, as, K1–K3, P1, P2, the sheet's corners fixed;
//    mmba with the corners fixed (selfcal_fixed.yaml) and weighted at 1 mm
//    (selfcal_weighted.yaml);
//  - PhotoModeler 2012 (photomodeler/calibration_status_report.txt): focal length, Xp, Yp, Fw,
//    K1, K2, P1, P2, K3 not estimated (selfcal_photomodeler.yaml). PhotoModeler scales the whole
//    x coordinate by its format width, so its Xp = (1 + b1) · xp and Fw = W · pitch · (1 + b1)
//    (DBAT's lens model 5 reports the same px: 3.61687 = 1.00039 · 3.61546).
// And report.json's correlations of the refined parameters, with DBAT's "Correlations over
// 95%" (K2–K3: −97.9 %) flagged.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using testing_support::ReadText;
using testing_support::RunProject;
using testing_support::ScratchRoot;

const fs::path kCamcal = fs::path(MMBA_SOURCE_DIR) / "data/dbat/camcaldemo";

struct Reference {
  double value = 0.0;
  double sigma = 0.0;
};

/// The number after the last ':' of `line`.
double NumberAfterColon(const std::string& line) {
  std::istringstream in(line.substr(line.rfind(':') + 1));
  double x = std::nan("");
  in >> x;
  return x;
}

/// For each heading (the start of a trimmed line) the first "Value:" and "Deviation" lines
/// after it: DBAT's and PhotoModeler's report layouts.
std::map<std::string, Reference> ReadReport(const fs::path& file, const std::vector<std::string>& headings,
                                            const std::string& after) {
  std::istringstream in(ReadText(file));
  std::map<std::string, Reference> out;
  std::string line, current;
  bool started = after.empty();
  while (std::getline(in, line)) {
    const std::string trimmed = line.substr(std::min(line.size(), line.find_first_not_of(' ')));
    if (!started) {
      started = trimmed.rfind(after, 0) == 0;
      continue;
    }
    for (const std::string& h : headings) {
      if (trimmed.rfind(h, 0) == 0 && !out.count(h)) current = h;
    }
    if (current.empty()) continue;
    if (trimmed.rfind("Value:", 0) == 0) {
      std::istringstream v(trimmed.substr(6));
      v >> out[current].value;
    } else if (trimmed.rfind("Deviation:", 0) == 0) {
      out[current].sigma = NumberAfterColon(trimmed);  // "Deviation: 0.001 mm", "Deviation: Focal: 0.001 mm"
      current.clear();
    }
  }
  return out;
}

std::map<std::string, Reference> DbatCamera() {
  return ReadReport(kCamcal / "result/report.txt",
                    {"Camera Constant", "px -", "py -", "K1 -", "K2 -", "K3 -", "P1 -", "P2 -", "as -"}, "Camera1");
}

std::map<std::string, Reference> PhotoModelerCamera() {
  return ReadReport(kCamcal / "photomodeler/calibration_status_report.txt",
                    {"Focal Length", "Xp -", "Yp -", "Fw -", "K1 -", "K2 -", "P1 -", "P2 -"}, "Camera1");
}

/// report.json `photo_measurements.camera` by parameter name: (adjusted, σ).
std::map<std::string, Reference> MmbaCamera(const json& report) {
  std::map<std::string, Reference> out;
  for (const json& p : report["photo_measurements"]["camera"]) {
    out[p["name"]] = {p["adjusted"].get<double>(), p["sigma"].get<double>()};
  }
  return out;
}

json Adjust(const std::string& project, const std::string& scratch) {
  const fs::path out = ScratchRoot(scratch) / "out";
  fs::remove_all(out.parent_path());
  const AdjustOutcome outcome = RunProject((kCamcal / project).string(), out.string());
  EXPECT_TRUE(outcome.ok) << outcome.status << ": " << outcome.reason;
  const json report = outcome.ok ? json::parse(ReadText(out / "report.json")) : json::object();
  fs::remove_all(out.parent_path());
  return report;
}

/// Every DBAT parameter within DBAT's σ; with `sigma_tolerance` > 0 also mmba's σ within that
/// fraction of DBAT's.
void ExpectDbatAgreement(const json& report, double sigma_tolerance) {
  ASSERT_TRUE(report.contains("photo_measurements"));
  EXPECT_EQ(report["photo_measurements"]["observations"], 2074);  // all of them, as DBAT
  const auto dbat = DbatCamera();
  const auto mmba = MmbaCamera(report);
  const std::map<std::string, std::string> pairs = {{"Camera Constant", "c"}, {"px -", "xp"}, {"py -", "yp"},
                                                    {"K1 -", "K1"}, {"K2 -", "K2"}, {"K3 -", "K3"},
                                                    {"P1 -", "P1"}, {"P2 -", "P2"}, {"as -", "b1"}};
  ASSERT_EQ(dbat.size(), pairs.size());
  for (const auto& [heading, name] : pairs) {
    const Reference& d = dbat.at(heading);
    const Reference& m = mmba.at(name);
    ASSERT_GT(d.sigma, 0.0) << heading;
    EXPECT_LT(std::abs(m.value - d.value), d.sigma) << name << ": mmba " << m.value << " DBAT " << d.value << " ± " << d.sigma;
    if (sigma_tolerance > 0) {
      EXPECT_NEAR(m.sigma / d.sigma, 1.0, sigma_tolerance) << name << ": σ mmba " << m.sigma << " DBAT " << d.sigma;
    }
  }
}

TEST(PhotogrammetricSelfCalibration, SheetFixedAgreesWithDbatWithinItsSigma) {
  const json report = Adjust("selfcal_fixed.yaml", "selfcal_fixed");
  ExpectDbatAgreement(report, 0.05);
  // The same model, observations, unknowns and datum as DBAT (redundancy 3725). DBAT's residual
  // lives in the corrected image plane, mmba's in pixels (tests/io/dbat_camera_test.cc: at
  // DBAT's solution the pixel residuals' RMS per point is 0.2085 px where DBAT's image-plane
  // σ0 is 1.6148): mmba minimises the pixel residuals, so its point RMS is at most 0.2085 px
  // and its σ0 about 3.5 % below DBAT's.
  EXPECT_EQ(report["sigma0"]["dof"], 3725);
  const double sigma0 = report["sigma0"]["aposteriori"];
  EXPECT_GT(sigma0, 0.95 * 1.6148);
  EXPECT_LT(sigma0, 0.98 * 1.6148);
  const double rms = report["groups"][0]["rms"];
  EXPECT_LE(rms, 0.2085);
  EXPECT_GT(rms, 0.2075);
}

TEST(PhotogrammetricSelfCalibration, SheetWeightedAgreesWithDbatWithinItsSigma) {
  const json report = Adjust("selfcal_weighted.yaml", "selfcal_weighted");
  // The corners move (RMS 0.4 mm of their 1 mm σ) and the residuals shrink (σ0 1.37): the
  // camera's σ are 12 % below DBAT's (fixed corners), its values within DBAT's σ.
  ExpectDbatAgreement(report, 0.0);
  EXPECT_EQ(report["photo_measurements"]["datum"], "control: 0 fixed, 4 weighted points");
}

TEST(PhotogrammetricSelfCalibration, PhotoModelerParameterSetAgreesWithPhotoModelerWithinItsSigma) {
  const json report = Adjust("selfcal_photomodeler.yaml", "selfcal_pm");
  ASSERT_TRUE(report.contains("photo_measurements"));
  const auto pm = PhotoModelerCamera();
  const auto mmba = MmbaCamera(report);
  ASSERT_EQ(pm.size(), 8u);
  EXPECT_EQ(mmba.at("K3").value, 0.0);  // not estimated, as in PhotoModeler
  // Without K3 no pair of the refined parameters is correlated above 95 %.
  EXPECT_TRUE(report["photo_measurements"]["camera_correlations"]["high"].empty());
  EXPECT_EQ(report["photo_measurements"]["camera_correlations"]["parameters"].size(), 8u);
  const double scale = 1.0 + mmba.at("b1").value;
  const std::map<std::string, double> ours = {
      {"Focal Length", mmba.at("c").value}, {"Xp -", scale * mmba.at("xp").value}, {"Yp -", mmba.at("yp").value},
      {"Fw -", 2272 * mmba.at("pixel_width_mm").value * scale}, {"K1 -", mmba.at("K1").value},
      {"K2 -", mmba.at("K2").value}, {"P1 -", mmba.at("P1").value}, {"P2 -", mmba.at("P2").value}};
  for (const auto& [heading, value] : ours) {
    const Reference& r = pm.at(heading);
    ASSERT_GT(r.sigma, 0.0) << heading;
    EXPECT_LT(std::abs(value - r.value), r.sigma) << heading << ": mmba " << value << " PhotoModeler " << r.value << " ± " << r.sigma;
  }
}

TEST(PhotogrammetricSelfCalibration, ReportsTheCorrelationsAndFlagsThoseAbove95Percent) {
  const json report = Adjust("selfcal_fixed.yaml", "selfcal_rho");
  ASSERT_TRUE(report.contains("photo_measurements"));
  const json& rho = report["photo_measurements"]["camera_correlations"];
  const std::vector<std::string> refined = {"c", "xp", "yp", "K1", "K2", "K3", "P1", "P2", "b1"};
  ASSERT_EQ(rho["parameters"].get<std::vector<std::string>>(), refined);
  ASSERT_EQ(rho["matrix"].size(), refined.size());
  for (size_t i = 0; i < refined.size(); ++i) {
    EXPECT_NEAR(rho["matrix"][i][i].get<double>(), 1.0, 1e-9);
    for (size_t j = 0; j < refined.size(); ++j) {
      EXPECT_NEAR(rho["matrix"][i][j].get<double>(), rho["matrix"][j][i].get<double>(), 1e-9);
    }
  }
  // DBAT's report: K2–K3 −97.9 %, no other pair over 95 % (mmba −97.8 %: its residuals are in
  // pixels, DBAT's in the image plane, so the two solutions and covariances differ slightly).
  ASSERT_EQ(rho["high"].size(), 1u);
  EXPECT_EQ(rho["high"][0]["a"], "K2");
  EXPECT_EQ(rho["high"][0]["b"], "K3");
  EXPECT_NEAR(rho["high"][0]["rho"].get<double>(), -0.979, 0.002);
  bool warned = false;
  for (const json& w : report["warnings"]) warned |= w.get<std::string>().find("K2 and K3 correlated") != std::string::npos;
  EXPECT_TRUE(warned);
  for (const json& p : report["photo_measurements"]["camera"]) {
    const bool expected = std::find(refined.begin(), refined.end(), p["name"].get<std::string>()) != refined.end();
    EXPECT_EQ(p["refined"].get<bool>(), expected) << p["name"];
  }
}

}  // namespace
}  // namespace mmba::adjust
