// project.yaml validation: every bad input is one InputError naming the file, line and key.
#include "mmba/io_project/project.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;

class ProjectTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) / ("mmba_project_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "images");
    fs::create_directories(dir_ / "model");
    std::ofstream(dir_ / "network.xml") << "<gama-local/>\n";
    std::ofstream(dir_ / "gnss.csv") << "id,kind\n";
    std::ofstream(dir_ / "lidar.ply") << "ply\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& sensors, const std::string& extra = "") {
    const fs::path path = dir_ / "project.yaml";
    std::ofstream(path) << "mmba_project: 1\nname: t\norigin: {latitude_deg: 45, longitude_deg: 7, height_m: 300}\n"
                        << extra << "sensors:\n" << sensors;
    return path.string();
  }

  // The message of the InputError LoadProject throws (fails the test if none).
  std::string Error(const std::string& path) {
    try {
      LoadProject(path);
    } catch (const InputError& e) {
      return e.what();
    }
    ADD_FAILURE() << "no InputError";
    return "";
  }

  fs::path dir_;
  const std::string photos_ = "  - {id: p, type: photo_collection, images: images, colmap_model: model, sigma_px: 0.7}\n";
  const std::string ts_ = "  - {id: ts, type: total_station, file: network.xml}\n";
};

TEST_F(ProjectTest, ReadsAValidProject) {
  const Project p = LoadProject(Write(photos_ + ts_ +
                                          "  - {id: g, type: gnss, file: gnss.csv, loss: {type: cauchy, scale: 2}}\n"
                                          "  - {id: l, type: lidar_static, reference_cloud: lidar.ply, range_sigma_m: 0.004}\n",
                                      "check_points: [T3]\nadjustment: {outer_iterations: 2, variance_components: false}\n"));
  ASSERT_EQ(p.photos.size(), 1u);
  EXPECT_DOUBLE_EQ(p.photos[0].sigma_px, 0.7);
  EXPECT_EQ(p.photos[0].colmap_model, (dir_ / "model").string());
  EXPECT_EQ(p.total_stations.size(), 1u);
  EXPECT_EQ(p.gnss[0].loss.type, LossType::kCauchy);
  EXPECT_DOUBLE_EQ(p.lidar_static[0].range_sigma_m, 0.004);
  EXPECT_EQ(p.check_points, std::vector<std::string>{"T3"});
  EXPECT_EQ(p.settings.outer_iterations, 2);
  EXPECT_FALSE(p.settings.variance_components);
  EXPECT_DOUBLE_EQ(p.origin.latitude_deg, 45.0);
}

// The mobile LiDAR's range limit: by default (or `auto`) the first gate over tan(attitude σ);
// an explicit value, or 0 for none.
TEST_F(ProjectTest, MobileRangeLimitFollowsTheGateAndTheAttitudeSigma) {
  const std::string static_lidar = "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n";
  const auto mobile = [&](const std::string& keys) {
    return LoadProject(Write(photos_ + ts_ + static_lidar + "  - {id: m, type: lidar_mobile, cloud: lidar.ply, trajectory: gnss.csv, "
                                                  "calibration: gnss.csv" + keys + "}\n")).lidar_mobile.at(0);
  };
  EXPECT_NEAR(MobileMaxRange(mobile("")), 0.5 / std::tan(M_PI / 180.0), 1e-9);  // 28.6 m
  EXPECT_NEAR(MobileMaxRange(mobile(", max_range_m: auto")), 28.645, 1e-3);
  EXPECT_NEAR(MobileMaxRange(mobile(", max_distance_m: 1.0, trajectory_sigma_deg: 0.5")), 1.0 / std::tan(M_PI / 360.0), 1e-9);
  EXPECT_DOUBLE_EQ(MobileMaxRange(mobile(", max_range_m: 40")), 40.0);
  EXPECT_DOUBLE_EQ(MobileMaxRange(mobile(", max_range_m: 0")), 0.0);
}

// The rig's MI against the mobile LiDAR corrects the intensity for incidence unless told not to.
TEST_F(ProjectTest, RigIncidenceCorrectionIsOnUnlessSwitchedOff) {
  const auto rig = [&](const std::string& keys) {
    return LoadProject(Write(photos_ + ts_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, "
                                             "observations: gnss.csv, frames_file: gnss.csv, trajectory: gnss.csv, tie_block: p" + keys + "}\n"))
        .rigs.at(0);
  };
  EXPECT_TRUE(rig("").mi_incidence_correction);
  EXPECT_FALSE(rig(", mi_incidence_correction: false").mi_incidence_correction);
  EXPECT_TRUE(rig(", mi_incidence_correction: true").mi_incidence_correction);
}

TEST_F(ProjectTest, NamesTheKeyOfEveryProblem) {
  struct Case {
    std::string sensors, extra, expect;
  };
  const std::vector<Case> cases = {
      {photos_ + "  - {id: x, type: laser, file: a}\n", "", "sensors[1].type"},
      {photos_ + "  - {id: p, type: total_station, file: network.xml}\n", "", "used twice"},
      {"  - {id: p, type: photo_collection, images: nowhere}\n", "", "sensors[0].images"},
      {"  - {id: p, type: photo_collection, images: images, colour: red}\n", "", "colour (unknown key)"},
      {"  - {id: p, type: photo_collection, images: images, sigma_px: -1}\n", "", "sensors[0].sigma_px"},
      {"  - {id: p, type: photo_collection, images: images, sigma_px: abc}\n", "", "a number"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply, range_sigma_m: 3}\n", "", "m (metres)"},
      {ts_, "check_points: [T1, T1]\n", "check_points[1]"},
      {photos_, "check_points: [T1]\n", "total_station"},
      {ts_, "adjustment: {outer_iterations: 0}\n", "adjustment.outer_iterations"},
      {"  - {id: p, type: photo_collection, images: images, refine: [focus]}\n", "", "refine[0]"},
      {"  - {id: p, type: photo_collection, images: images, gnss_lever_arm_m: [0, 0.1]}\n", "", "sensors[0].gnss_lever_arm_m"},
      {"  - {id: p, type: photo_collection, images: images, gnss_lever_arm_m: [0, 0, 120]}\n", "", "within 10 m"},
      {"  - {id: p, type: photo_collection, images: images, register_to_lidar: true}\n" + ts_, "", "register_to_lidar"},
      {"  - {id: p, type: photo_collection, images: images, registration_window_m: -2}\n", "", "sensors[0].registration_window_m"},
      {"  - {id: p, type: photo_collection, images: images, lidar_scale_range: [3, 2]}\n", "", "sensors[0].lidar_scale_range"},
      {"  - {id: p, type: photo_collection, images: images, lidar_scale_range: [0, 2]}\n", "", "0 < min < max"},
      {"  - {id: p, type: photo_collection}\n", "", "sensors[0].images"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply, scans_levelled: perhaps}\n", "",
       "sensors[1].scans_levelled"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply, scans: [{file: lidar.ply, approximate: true}]}\n",
       "", "sensors[1].scans[0].approximate"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply, scans: [{file: lidar.ply, world_from_scan: "
             "{qvec_wxyz: [2, 0, 0, 0], tvec: [0, 0, 0]}}]}\n", "", "a unit quaternion"},
      {photos_ + "  - {id: s, type: spherical_stereo, images: images, calibration: gnss.csv, observations: gnss.csv}\n", "",
       "sensors[1].stations_file"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n"
             "  - {id: m, type: lidar_mobile, cloud: lidar.ply, trajectory: gnss.csv, calibration: gnss.csv, "
             "trajectory_correlation_s: -5}\n", "", "sensors[2].trajectory_correlation_s"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n"
             "  - {id: m, type: lidar_mobile, cloud: lidar.ply, trajectory: gnss.csv, calibration: gnss.csv, "
             "smoothness_sigma_deg: -0.1}\n", "", "0 (off)"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n"
             "  - {id: m, type: lidar_mobile, cloud: lidar.ply, trajectory: gnss.csv, calibration: gnss.csv, "
             "max_range_m: -40}\n", "", "sensors[2].max_range_m"},
      {ts_ + "  - {id: l, type: lidar_static, reference_cloud: lidar.ply}\n"
             "  - {id: m, type: lidar_mobile, cloud: lidar.ply, trajectory: gnss.csv, calibration: gnss.csv, "
             "max_range_m: far}\n", "", "0 (no limit) or auto"},
      {photos_ + "  - {id: s, type: spherical_stereo, images: images, calibration: gnss.csv, observations: gnss.csv, "
                 "stations_file: gnss.csv, tie_block: q}\n", "", "tie_block"},
      // MI registration: a static LiDAR to register to, a rig's panoramas, a usable value.
      {"  - {id: p, type: photo_collection, images: images, mi_register: true}\n" + ts_, "", "mi_register"},
      {"  - {id: p, type: photo_collection, images: images, mi_register: []}\n" + ts_, "", "sensors[0].mi_register"},
      {"  - {id: p, type: photo_collection, images: images, mi_register: maybe}\n" + ts_, "", "sensors[0].mi_register"},
      {photos_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, mi_register: [f1]}\n", "",
       "sensors[1].panoramas"},
      {photos_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, mi_lidar: sideways}\n", "",
       "sensors[1].mi_lidar"},
      {photos_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, mi_views: fisheyes}\n", "",
       "panoramas or cameras"},
      {photos_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, mi_incidence_correction: maybe}\n",
       "", "sensors[1].mi_incidence_correction"},
      {"  - {id: p, type: photo_collection, images: images, mi_orientation_classes: 14}\n" + ts_, "",
       "sensors[0].mi_orientation_classes"},
      {photos_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, mi_orientation_classes: -1}\n",
       "", "0 (the plain metric) to 13 azimuth sectors"},
      // Against the mobile LiDAR: one must carry the rig.
      {photos_ + "  - {id: r, type: camera_rig, images: images, calibration: gnss.csv, observations: gnss.csv, "
                 "frames_file: gnss.csv, trajectory: gnss.csv, tie_block: p, panoramas: images, mi_register: true, "
                 "mi_lidar: mobile}\n", "", "a lidar_mobile sensor with rig: r"},
  };
  for (const Case& c : cases) {
    const std::string message = Error(Write(c.sensors, c.extra));
    EXPECT_NE(message.find(c.expect), std::string::npos) << "expected '" << c.expect << "' in: " << message;
    EXPECT_NE(message.find("project.yaml"), std::string::npos) << message;
  }
}

TEST_F(ProjectTest, RejectsAMissingOriginOrFile) {
  const fs::path path = dir_ / "project.yaml";
  std::ofstream(path) << "mmba_project: 1\nsensors:\n" << ts_;
  EXPECT_NE(Error(path.string()).find("origin"), std::string::npos);
  std::ofstream(path) << "mmba_project: 2\norigin: {latitude_deg: 95, longitude_deg: 7, height_m: 1}\nsensors:\n" << ts_;
  EXPECT_NE(Error(path.string()).find("mmba_project"), std::string::npos);
  EXPECT_NE(Error((dir_ / "none.yaml").string()).find("not found"), std::string::npos);
  std::ofstream(path) << "mmba_project: 1\norigin: {latitude_deg: 95, longitude_deg: 7, height_m: 1}\nsensors:\n" << ts_;
  EXPECT_NE(Error(path.string()).find("origin.latitude_deg"), std::string::npos);
}

}  // namespace
}  // namespace mmba::adjust
