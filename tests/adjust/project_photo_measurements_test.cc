// The project keys of photogrammetric networks: frame: cartesian, control, check_points,
// scale_bars and the photo_measurements sensor; every bad input one InputError naming the
// file, line and key.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/io_project/project.h"

namespace mmba::adjust {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class PhotoMeasurementsProject : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) / ("mmba_pm_project_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "camera.yaml") << "model: OPENCV\nwidth: 2272\nheight: 1704\n"
                                           "params: [2340, 2340, 1136, 852, 0, 0, 0, 0]\n";
    std::ofstream(dir_ / "markpts.txt") << "1 2 100 200\n";
    std::ofstream(dir_ / "control.txt") << "1001,CP1,0,1,0\n";
    std::ofstream(dir_ / "gnss.csv") << "id,kind\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& text) {
    const fs::path path = dir_ / "project.yaml";
    std::ofstream(path) << "mmba_project: 1\n" << text;
    return path.string();
  }
  std::string Error(const std::string& text) {
    try {
      LoadProject(Write(text));
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  }

  fs::path dir_;
  const std::string sensor_ =
      "sensors:\n"
      "  - id: cam\n"
      "    type: photo_measurements\n"
      "    camera: camera.yaml\n"
      "    measurements:\n"
      "      - {file: markpts.txt, columns: [image, id, x, y], sigma_px: 0.5}\n";
};

TEST_F(PhotoMeasurementsProject, ReadsTheKeys) {
  const Project p = LoadProject(Write("frame: cartesian\n"
                                      "control: {file: control.txt, columns: [id, label, x, y, z], sigma_m: 0}\n"
                                      "check_points: [1004]\n"
                                      "scale_bars: [{from: 1001, to: 1002, distance_m: 1.0, sigma_m: 0.0001}]\n" +
                                      sensor_ + "    refine: [focal, principal_point, k1, k2]\n"));
  EXPECT_EQ(p.frame, WorldFrame::kCartesian);
  ASSERT_TRUE(p.control);
  EXPECT_EQ(p.control->sigma_m, 0.0);
  EXPECT_EQ(p.control->line, 3);
  ASSERT_EQ(p.scale_bars.size(), 1u);
  EXPECT_EQ(p.scale_bars[0].to, "1002");
  ASSERT_EQ(p.photo_measurements.size(), 1u);
  const PhotoMeasurements& m = p.photo_measurements[0];
  EXPECT_EQ(m.measurements[0].columns, (std::vector<std::string>{"image", "id", "x", "y"}));
  EXPECT_DOUBLE_EQ(m.measurements[0].sigma_px, 0.5);
  // OPENCV: fx fy cx cy k1 k2 p1 p2 → focal 0 1, principal point 2 3, k1 4, k2 5.
  EXPECT_EQ(m.free_intrinsics, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  const Project held = LoadProject(Write("frame: cartesian\n" + sensor_ + "    refine: []\n"));
  EXPECT_TRUE(held.photo_measurements[0].free_intrinsics.empty());
  const Project all = LoadProject(Write("frame: cartesian\n" + sensor_));
  EXPECT_EQ(all.photo_measurements[0].free_intrinsics.size(), 8u);
}

TEST_F(PhotoMeasurementsProject, BadInputNamesLineAndKey) {
  EXPECT_THAT(Error(sensor_), HasSubstr("field 'origin': found 'nothing', expected the key to be present (or frame: cartesian"));
  EXPECT_THAT(Error("frame: cartesian\ncontrol: {file: control.txt, columns: [id, label, x, y, z]}\n" + sensor_),
              HasSubstr("project.yaml:3: field 'control.sigma_m': found 'nothing', expected σ of the control in metres"));
  EXPECT_THAT(Error("frame: cartesian\ncontrol: {file: control.txt, columns: [id, name, x, y, z], sigma_m: 0}\n" + sensor_),
              HasSubstr("project.yaml:3: field 'control.columns': found 'name (unknown column)', expected one of id, x, y, z"));
  EXPECT_THAT(Error("frame: cartesian\n" + sensor_ + "    refine: [focal, k4]\n"),
              HasSubstr("field 'sensors[0].refine[1]': found 'k4', expected one of focal, principal_point, distortion, fx, "
                        "fy, cx, cy, k1, k2, p1, p2 (camera model OPENCV)"));
  EXPECT_THAT(Error("frame: cartesian\nsensors:\n  - {id: c, type: photo_measurements, camera: camera.yaml, measurements: "
                    "[{file: markpts.txt, columns: [image, id, x, y, z], sigma_px: 1}]}\n"),
              HasSubstr("project.yaml:4: field 'sensors[0].measurements[0].columns': found 'z (unknown column)'"));
  EXPECT_THAT(Error("frame: cartesian\nsensors:\n  - {id: c, type: photo_measurements, camera: camera.yaml, measurements: "
                    "[{file: markpts.txt, columns: [image, id, x, y]}]}\n"),
              HasSubstr("field 'sensors[0].measurements[0].sigma_px': found 'nothing'"));
  EXPECT_THAT(Error("frame: cartesian\ncheck_points: [1]\n" + sensor_),
              HasSubstr("field 'check_points': found 'none', expected a total_station sensor, a control file or a gcp_list that surveys them"));
  EXPECT_THAT(Error("frame: cartesian\nscale_bars: [{from: a, to: a, distance_m: 1, sigma_m: 0.001}]\n" + sensor_),
              HasSubstr("field 'scale_bars[0].to': found 'a', expected a point other than 'from'"));
  EXPECT_THAT(Error("frame: cartesian\nscale_bars: [{from: a, to: b, distance_m: 1, sigma_m: 5}]\n" + sensor_),
              HasSubstr("field 'scale_bars[0].sigma_m'"));
  EXPECT_THAT(Error("frame: cartesian\n" + sensor_ + "  - {id: g, type: gnss, file: gnss.csv}\n"),
              HasSubstr("field 'frame': found 'cartesian', expected local_tangent_plane with an origin"));
  EXPECT_THAT(Error("frame: polar\n" + sensor_), HasSubstr("field 'frame': found 'polar', expected cartesian"));
}

}  // namespace
}  // namespace mmba::adjust
