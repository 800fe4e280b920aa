// Two of DBAT's riva2014 PhotoModeler networks (data/dbat/riva2014, written from PhotoModeler's
// export files by convert_pmexport.py), adjusted from a nominal camera (focal length rounded to
// whole mm, principal point at the format centre, no distortion) with PhotoModeler's parameter
// set (c, xp, yp, b1, K1, K2, P1, P2), against PhotoModeler's own solution in the export
// (pm_solution.json):
//  - net2 (Canon, 5184 × 3456 px, 20 images of the calibration sheet, corners fixed): the
//    nominal camera (about 120 px of distortion at the corners) orients 17 images; the block is
//    initialised again with the camera refined on them, and then holds all 20;
//  - net4 (Canon, 10 images of a 3-D field, 66 control points weighted at 5 mm): PhotoModeler's
//    points are in a frame of their own (scale 7.74), compared after a similarity.
// The export prints the camera to 4-5 decimals and its camera σ are PhotoModeler's a-priori
// defaults, so each parameter is compared within k σ of mmba's σ plus half the last printed
// digit. Tolerances are the measured differences rounded up (docs/photogrammetry.md, "Five
// PhotoModeler networks (riva2014)").
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using testing_support::ReadCsvRows;
using testing_support::ReadText;
using testing_support::RunProject;
using testing_support::ScratchRoot;

const fs::path kRiva = fs::path(MMBA_SOURCE_DIR) / "data/dbat/riva2014";

Eigen::Vector3d Xyz(const std::map<std::string, std::string>& row) {
  return {std::stod(row.at("x_m")), std::stod(row.at("y_m")), std::stod(row.at("z_m"))};
}

Eigen::Vector3d Vec(const json& a) { return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}; }

struct RivaRun {
  json report, pm;
  std::map<std::string, Eigen::Vector3d> points, centres;
};

RivaRun Adjust(const std::string& net) {
  RivaRun run;
  const fs::path out = ScratchRoot("riva_" + net) / "out";
  fs::remove_all(out.parent_path());
  const AdjustOutcome outcome = RunProject((kRiva / net / "project.yaml").string(), out.string());
  EXPECT_TRUE(outcome.ok) << outcome.status << ": " << outcome.reason;
  if (outcome.ok) {
    run.report = json::parse(ReadText(out / "report.json"));
    for (const auto& row : ReadCsvRows(out / "pm_points.csv")) run.points[row.at("point")] = Xyz(row);
    for (const auto& row : ReadCsvRows(out / "pm_images.csv")) run.centres[row.at("image")] = Xyz(row);
  }
  run.pm = json::parse(ReadText(kRiva / net / "pm_solution.json"));
  fs::remove_all(out.parent_path());
  return run;
}

/// Each camera parameter in PhotoModeler's terms within k σ (mmba's) plus half the last digit
/// PhotoModeler printed.
void ExpectCamera(const RivaRun& run, double k) {
  std::map<std::string, std::pair<double, double>> cam;  // name -> (adjusted, σ)
  for (const json& p : run.report["photo_measurements"]["camera"]) cam[p["name"]] = {p["adjusted"], p["sigma"]};
  const double scale = 1.0 + cam["b1"].first;
  const double width_mm = run.pm["width"].get<double>() * cam["pixel_width_mm"].first;
  const std::map<std::string, std::pair<double, double>> ours = {
      {"c", cam["c"]}, {"Xp", {scale * cam["xp"].first, scale * cam["xp"].second}}, {"Yp", cam["yp"]},
      {"Fw", {width_mm * scale, width_mm * cam["b1"].second}}, {"K1", cam["K1"]}, {"K2", cam["K2"]},
      {"P1", cam["P1"]}, {"P2", cam["P2"]}};
  for (const auto& [name, value] : ours) {
    const double printed = run.pm["camera"][name];
    const double half_digit = 0.5 * std::pow(10.0, -run.pm["camera_decimals"][name].get<int>());
    ASSERT_GT(value.second, 0.0) << name;
    EXPECT_LT(std::abs(value.first - printed), k * value.second + half_digit)
        << name << ": mmba " << value.first << " ± " << value.second << ", PhotoModeler " << printed;
  }
}

/// RMS (m) of PhotoModeler's points and projection centres taken onto mmba's by the similarity
/// of the points; the similarity's scale.
struct Agreement {
  double points_rms = 0, centres_rms = 0, scale = 0;
};

Agreement Compare(const RivaRun& run) {
  std::vector<Eigen::Vector3d> from, to;
  for (const json& p : run.pm["points"]) {
    const auto it = run.points.find(std::to_string(p["id"].get<int>()));
    if (it != run.points.end()) from.push_back(Vec(p["xyz"])), to.push_back(it->second);
  }
  EXPECT_EQ(from.size(), run.pm["points"].size());
  Eigen::Matrix3Xd a(3, from.size()), b(3, from.size());
  for (size_t i = 0; i < from.size(); ++i) a.col(i) = from[i], b.col(i) = to[i];
  const Eigen::Matrix4d m = Eigen::umeyama(a, b, true);
  const auto move = [&](const Eigen::Vector3d& x) -> Eigen::Vector3d {
    return m.topLeftCorner<3, 3>() * x + m.topRightCorner<3, 1>();
  };
  Agreement out;
  out.scale = m.topLeftCorner<3, 3>().col(0).norm();
  for (size_t i = 0; i < from.size(); ++i) out.points_rms += (move(from[i]) - to[i]).squaredNorm();
  out.points_rms = std::sqrt(out.points_rms / from.size());
  size_t n = 0;
  for (const json& image : run.pm["images"]) {
    const auto it = run.centres.find(std::to_string(image["id"].get<int>()));
    if (it == run.centres.end()) continue;
    out.centres_rms += (move(Vec(image["center"])) - it->second).squaredNorm();
    ++n;
  }
  EXPECT_EQ(n, run.pm["images"].size());
  out.centres_rms = std::sqrt(out.centres_rms / std::max<size_t>(n, 1));
  return out;
}

TEST(RivaPhotoModelerNetworks, Net2SheetFromRefinedStartCameraAgreesWithPhotoModeler) {
  const RivaRun run = Adjust("net2");
  ASSERT_TRUE(run.report.contains("photo_measurements"));
  EXPECT_EQ(run.report["photo_measurements"]["observations"], 1918);  // every mark
  EXPECT_EQ(run.centres.size(), 20u);
  EXPECT_EQ(run.points.size(), 100u);
  const std::string steps = run.report["photo_measurements"]["initialisation"]["steps"][0];
  EXPECT_EQ(steps.rfind("the start camera refined on a first block", 0), 0u) << steps;
  const double sigma0 = run.report["sigma0"]["aposteriori"];  // measured 1.128 (σ 1 px per mark)
  EXPECT_GT(sigma0, 1.10);
  EXPECT_LT(sigma0, 1.16);
  ExpectCamera(run, 1.0);  // measured: every parameter within 0.71 σ (or PM's rounding)
  const Agreement agree = Compare(run);
  EXPECT_NEAR(agree.scale, 1.0, 2e-5);        // both on the fixed corners: 0.999995
  EXPECT_LT(agree.points_rms, 0.05e-3);       // measured 0.014 mm (PM's point σ about 0.16 mm)
  EXPECT_LT(agree.centres_rms, 1.0e-3);       // measured 0.55 mm
}

TEST(RivaPhotoModelerNetworks, Net4ThreeDimensionalFieldAgreesWithPhotoModelerAfterSimilarity) {
  const RivaRun run = Adjust("net4");
  ASSERT_TRUE(run.report.contains("photo_measurements"));
  EXPECT_EQ(run.report["photo_measurements"]["observations"], 535);
  EXPECT_EQ(run.centres.size(), 10u);
  EXPECT_EQ(run.points.size(), 66u);
  const double sigma0 = run.report["sigma0"]["aposteriori"];  // measured 0.139 (σ 1 px per mark)
  EXPECT_GT(sigma0, 0.13);
  EXPECT_LT(sigma0, 0.15);
  ExpectCamera(run, 2.5);  // measured: Yp 2.13 σ, c 1.20 σ, the others within 0.9 σ or PM's rounding
  const Agreement agree = Compare(run);
  EXPECT_NEAR(agree.scale, run.pm["control_fit"]["scale"].get<double>(), 1e-4);  // 7.738655 and 7.73865
  EXPECT_LT(agree.points_rms, 1.0e-3);   // measured 0.72 mm (PM's point σ, scaled, about 0.30 mm)
  EXPECT_LT(agree.centres_rms, 6.0e-3);  // measured 4.2 mm
  // The control file against mmba's points (weighted at 5 mm): RMS measured 1.18 mm, below
  // PhotoModeler's points on the same control after their similarity (1.68 mm).
  double sum = 0;
  size_t n = 0;
  std::istringstream control(ReadText(kRiva / "net4/control.txt"));
  for (std::string line; std::getline(control, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream s(line);
    std::string id, x, y, z;
    std::getline(s, id, ','), std::getline(s, x, ','), std::getline(s, y, ','), std::getline(s, z, ',');
    ASSERT_TRUE(run.points.count(id)) << id;
    sum += (run.points.at(id) - Eigen::Vector3d(std::stod(x), std::stod(y), std::stod(z))).squaredNorm();
    ++n;
  }
  ASSERT_EQ(n, 66u);
  EXPECT_LT(std::sqrt(sum / n), 1.5e-3);
  EXPECT_LT(std::sqrt(sum / n), run.pm["control_fit"]["rms_m"].get<double>());
}

}  // namespace
}  // namespace mmba::adjust
