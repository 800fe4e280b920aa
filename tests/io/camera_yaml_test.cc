#include "mmba/io/camera_yaml.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

std::string Fixture(const std::string& name) {
  return std::string(MMBA_SOURCE_DIR) + "/tests/io/data/" + name;
}

TEST(CameraYaml, ReadsAndRoundTrips) {
  const CameraYaml camera = ReadCameraYaml(Fixture("camera_ok.yaml"));
  EXPECT_EQ(camera.camera.ModelName(), "PINHOLE");
  EXPECT_EQ(camera.camera.width, 1242u);
  EXPECT_DOUBLE_EQ(camera.camera.params[3], 180.5066);
  ASSERT_TRUE(camera.cam_from_lidar.has_value());
  EXPECT_NEAR(camera.cam_from_lidar->translation.z(), -0.27, 1e-12);
  const std::string out =
      (std::filesystem::temp_directory_path() / "mmba_camera_roundtrip.yaml").string();
  WriteCameraYaml(camera, out);
  const CameraYaml again = ReadCameraYaml(out);
  EXPECT_EQ(again.camera.params, camera.camera.params);
  EXPECT_LT((again.cam_from_lidar->ToMatrix4() - camera.cam_from_lidar->ToMatrix4()).norm(),
            1e-12);
  std::filesystem::remove(out);
}

// cam_from_lidar may also be written as 4 rows of 4 numbers (as numpy's tolist() gives it).
TEST(CameraYaml, PoseAsFourRows) {
  const std::string dir = std::filesystem::temp_directory_path().string();
  const std::string rows = dir + "/mmba_camera_rows.yaml", bad = dir + "/mmba_camera_bad_row.yaml";
  const std::string head =
      "model: PINHOLE\nwidth: 1242\nheight: 375\nparams: [707.0493, 707.0493, 604.0814, 180.5066]\n";
  std::ofstream(rows) << head
                      << "cam_from_lidar:\n  - [0, -1, 0, 0.06]\n  - [0, 0, -1, -0.08]\n"
                         "  - [1, 0, 0, -0.27]\n  - [0, 0, 0, 1]\n";
  std::ofstream(bad) << head << "cam_from_lidar: [[0, -1, 0, 0.06], [0, 0, -1], [1, 0, 0, -0.27], [0, 0, 0, 1]]\n";
  const CameraYaml flat = ReadCameraYaml(Fixture("camera_ok.yaml"));
  const CameraYaml four = ReadCameraYaml(rows);
  ASSERT_TRUE(four.cam_from_lidar.has_value());
  EXPECT_EQ(four.cam_from_lidar->ToMatrix4(), flat.cam_from_lidar->ToMatrix4());
  try {
    ReadCameraYaml(bad);
    FAIL() << "no error for a row of 3";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'cam_from_lidar[1]': found '3 numbers'"), std::string::npos)
        << e.what();
  }
  std::filesystem::remove(rows);
  std::filesystem::remove(bad);
}

TEST(CameraYaml, BrokenFilesNameTheField) {
  auto expect = [](const std::string& file, const std::string& needle) {
    try {
      ReadCameraYaml(Fixture(file));
      FAIL() << "no error for " << file;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect("camera_bad_model.yaml", "camera_bad_model.yaml:1: field 'model': found 'PINHOLLE'");
  expect("camera_bad_params.yaml", "field 'params': found '3 values', expected a list of 4");
  expect("camera_bad_pose.yaml", "last row is (0 0 1 1)");
}

// The camera YAML refuses what the project file refuses: an unknown key (a typo would leave
// a setting silently unread), a key given twice (which one was meant?), and a size that no
// image has.
TEST(CameraYaml, UnknownOrRepeatedKeysAndHugeSizesAreRefused) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("mmba_camera_keys_" + std::to_string(::getpid()) + ".yaml")).string();
  const std::string params = "params: [707.0493, 707.0493, 604.0814, 180.5066]\n";
  auto error_of = [&](const std::string& text) -> std::string {
    std::ofstream(path) << text;
    try {
      ReadCameraYaml(path);
    } catch (const InputError& e) {
      return e.what();
    }
    return "ok";
  };
  EXPECT_EQ(error_of("model: PINHOLE\nwidth: 1242\nheight: 375\n" + params), "ok");
  EXPECT_NE(error_of("model: PINHOLE\nwidth: 1242\nheight: 375\nwidht: 1300\n" + params)
                .find(":4: field 'widht': found 'widht (unknown key)', expected one of K1, K2, K3, P1, P2, b1, b2, c_mm, "
                      "cam_from_lidar, format_height_mm, format_width_mm, height, model, params, width, xp_mm, yp_mm"),
            std::string::npos);
  EXPECT_NE(error_of("model: PINHOLE\nwidth: 1242\nheight: 375\n" + params + "width: 1300\n")
                .find(":5: field 'width': found 'the key a second time (first on line 2)', expected each key once"),
            std::string::npos);
  EXPECT_NE(error_of("model: PINHOLE\nwidth: 1099511627776\nheight: 375\n" + params)
                .find(":2: field 'width': found '1099511627776', expected a whole number of pixels in 1..1000000"),
            std::string::npos);
  EXPECT_NE(error_of("model: PINHOLE\nwidth: 1242\n" + params).find("field 'height': found 'nothing', expected the key to be present"),
            std::string::npos);
  std::filesystem::remove(path);
}

// The rig YAML of --rig: the simulator's/adjust's camera_rig schema, an optional start pose.
TEST(RigYaml, ReadsCamerasAndTheStartPose) {
  const std::string dir = std::filesystem::temp_directory_path().string();
  const std::string good = dir + "/mmba_rig_ok.yaml";
  const std::string camera =
      "    model: OPENCV_FISHEYE\n    width: 320\n    height: 400\n"
      "    params: [130, 130, 160, 200, 0.02, -0.005, 0.001, 0]\n";
  std::ofstream(good) << "body_from_rig: {qvec_wxyz: [-0.5, 0.5, -0.5, 0.5], tvec: [0.2, 0, 2.3]}\n"
                         "rig_from_lidar:\n  - [0, -1, 0, 0.1]\n  - [0, 0, -1, 0.2]\n  - [1, 0, 0, 0.3]\n  - [0, 0, 0, 1]\n"
                         "cameras:\n  - name: cam0\n" << camera
                      << "    cam_from_rig: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0, -0.06]}\n"
                         "    sigma: [0.1, 0.1, 0.1, 0.1, 0, 0, 0, 0]\n"
                         "  - name: cam1\n" << camera
                      << "    cam_from_rig: {qvec_wxyz: [0.8090169943749473, 0, -0.587785252292473, 0], tvec: [0, 0, -0.06]}\n";
  const RigYaml rig = ReadRigYaml(good);
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.names, (std::vector<std::string>{"cam0", "cam1"}));
  EXPECT_EQ(rig.cameras[1].width, 320u);
  EXPECT_DOUBLE_EQ(rig.cameras[1].params[4], 0.02);
  EXPECT_NEAR(rig.cam_from_rig[1].translation.z(), -0.06, 1e-12);
  EXPECT_NEAR(rig.cam_from_rig[1].rotation.angularDistance(Eigen::Quaterniond::Identity()) * 180 / M_PI, 72.0, 1e-9);
  ASSERT_TRUE(rig.rig_from_lidar.has_value());
  EXPECT_NEAR(rig.rig_from_lidar->translation.y(), 0.2, 1e-12);

  auto expect = [&](const std::string& text, const std::string& needle) {
    const std::string path = dir + "/mmba_rig_bad.yaml";
    std::ofstream(path) << text;
    try {
      ReadRigYaml(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
    std::filesystem::remove(path);
  };
  const std::string pose = "    cam_from_rig: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0, 0]}\n";
  expect("cameras:\n  - name: a\n" + camera + pose + "  - name: a\n" + camera + pose, "cameras[1].name");
  expect("cameras:\n  - name: a\n" + camera, "cameras[0].cam_from_rig");
  expect("cameras:\n  - name: a\n" + camera + pose + "    focal: 3\n", "focal");
  expect("cameras:\n  - name: a\n    model: OPENCV_FISHEYE\n    width: 320\n    height: 400\n"
         "    params: [130, 130, 160]\n" + pose, "cameras[0].params");
  expect("rig_from_lidar: [1, 0, 0]\ncameras:\n  - name: a\n" + camera + pose, "rig_from_lidar");
  expect("body_from_rig: {qvec_wxyz: [1, 0, 0, 0], tvec: [0, 0, 0]}\n", "cameras");
  std::filesystem::remove(good);
}

// PHOTOGRAMMETRIC has named fields in mm; the pitch is format / size. Written and read back.
TEST(CameraYaml, PhotogrammetricNamedFieldsRoundTrip) {
  const CameraYaml camera = ReadCameraYaml(Fixture("camera_photogrammetric_ok.yaml"));
  ASSERT_EQ(camera.camera.model_id, sensors::CameraModelId::kPhotogrammetric);
  const std::vector<double>& p = camera.camera.params;
  ASSERT_EQ(p.size(), 12u);
  EXPECT_EQ(p[0], 7.457);
  EXPECT_EQ(p[2], 2.61329);
  EXPECT_EQ(p[3], 4.58861e-3);
  EXPECT_EQ(p[8], 3.89598e-4);
  EXPECT_EQ(p[9], 0.0);  // b2 absent
  EXPECT_DOUBLE_EQ(p[10], 7.250187 / 2272);
  EXPECT_DOUBLE_EQ(p[11], 5.43764 / 1704);
  const std::string out = (std::filesystem::temp_directory_path() /
                           ("mmba_photo_" + std::to_string(::getpid()) + ".yaml")).string();
  WriteCameraYaml(camera, out);
  const CameraYaml again = ReadCameraYaml(out);
  std::filesystem::remove(out);
  ASSERT_EQ(again.camera.params.size(), 12u);
  for (size_t i = 0; i < 12; ++i) EXPECT_NEAR(again.camera.params[i], p[i], 1e-15 * std::abs(p[i])) << i;
  EXPECT_EQ(again.camera.width, 2272u);
}

TEST(CameraYaml, PhotogrammetricBrokenFilesNameTheField) {
  auto expect = [](const std::string& file, const std::string& needle) {
    try {
      ReadCameraYaml(Fixture(file));
      FAIL() << "no error for " << file;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect("camera_photogrammetric_no_c.yaml", "field 'c_mm': found 'nothing', expected the key to be present");
  expect("camera_photogrammetric_params.yaml", "camera_photogrammetric_params.yaml:4: field 'params'");
  expect("camera_photogrammetric_params.yaml", "expected the named fields of PHOTOGRAMMETRIC");
  expect("camera_pinhole_named.yaml", "camera_pinhole_named.yaml:5: field 'K1'");
}

}  // namespace
}  // namespace mmba::io
