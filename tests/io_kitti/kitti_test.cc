#include "mmba/io/kitti.h"

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

std::string Fixture(const std::string& name) {
  return std::string(MMBA_SOURCE_DIR) + "/tests/io_kitti/data/" + name;
}

// The convention: K · (cam_from_lidar · X) == P2 · R0_rect · Tr_velo_to_cam · X.
void ExpectPixelConvention(const KittiCalibration& calibration, const KittiCameraPose& pose) {
  Eigen::Matrix4d rect = Eigen::Matrix4d::Identity(), velo = Eigen::Matrix4d::Identity();
  rect.topLeftCorner<3, 3>() = calibration.r0_rect;
  velo.topRows<3>() = calibration.tr_velo_to_cam;
  const Eigen::Matrix<double, 3, 4> projection = calibration.p[2] * rect * velo;
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(10, 2, -1), Eigen::Vector3d(25, -6, 1.5),
                                   Eigen::Vector3d(5, 0.3, -1.6)}) {
    const Eigen::Vector3d expected_h = projection * x.homogeneous();
    const Eigen::Vector2d expected = expected_h.hnormalized();
    const std::optional<Eigen::Vector2d> pixel = pose.camera.ImgFromCam(pose.cam_from_lidar * x);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_LT((*pixel - expected).norm(), 1e-3) << x.transpose();
  }
}

TEST(KittiCalibration, ReadsTheObjectFormatAndBuildsCamera2) {
  const KittiCalibration calibration = ReadKittiCalibration(Fixture("calib_ok.txt"));
  EXPECT_DOUBLE_EQ(calibration.p[2](0, 3), 45.0);
  EXPECT_DOUBLE_EQ(calibration.r0_rect(0, 1), 0.01745240643728351);
  EXPECT_DOUBLE_EQ(calibration.tr_velo_to_cam(2, 3), -0.33);
  const KittiCameraPose pose = KittiCamera(calibration, 2, 1242, 375);
  EXPECT_EQ(pose.camera.ModelName(), "PINHOLE");
  EXPECT_EQ(pose.camera.params, (std::vector<double>{700, 700, 600, 180}));
  // K⁻¹ · P2[:,3] = (45/700 − 600·0.005/700, −0.3/700 − 180·0.005/700, 0.005) is the shift
  // from the rectified camera 0 to camera 2; the camera-0 origin maps to it.
  ExpectPixelConvention(calibration, pose);
}

TEST(KittiCalibration, RealSampleFollowsTheConvention) {
  const std::string path = std::string(MMBA_SOURCE_DIR) + "/data/kitti/calib/000000.txt";
  if (!std::filesystem::exists(path)) {
    GTEST_SKIP() << "KITTI sample absent (data/kitti, CC BY-NC-SA); skipping";
  }
  const KittiCalibration calibration = ReadKittiCalibration(path);
  ExpectPixelConvention(calibration, KittiCamera(calibration, 2, 1242, 375));
}

void ExpectInputError(const std::string& file, const std::string& needle) {
  try {
    ReadKittiCalibration(Fixture(file));
    FAIL() << "no error for " << file;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(KittiCalibration, BrokenFilesNameTheFileLineAndField) {
  ExpectInputError("calib_missing_p2.txt", "missing calibration key P2");
  ExpectInputError("calib_bad_number.txt", "calib_bad_number.txt:3: field 'P2[3]'");
  ExpectInputError("calib_short_row.txt", ":6: field 'Tr_velo_to_cam': found '11 numbers'");
  ExpectInputError("calib_not_rotation.txt", "field 'Tr_velo_to_cam'");
  ExpectInputError("does_not_exist.txt", "file not found");
}

// A raw recording's calibration (the date folder's calib_cam_to_cam.txt with its text
// "calib_time:" line, and calib_velo_to_cam.txt's R and T): the same matrices as the object
// format's calib_ok.txt, given the folder or either file.
TEST(KittiCalibration, ReadsARawRecordingsTwoFiles) {
  const KittiCalibration object = ReadKittiCalibration(Fixture("calib_ok.txt"));
  for (const std::string& given : {Fixture("raw"), Fixture("raw/calib_cam_to_cam.txt"), Fixture("raw/calib_velo_to_cam.txt")}) {
    const KittiCalibration raw = ReadKittiCalibration(given);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(raw.p[i], object.p[i]) << given << " P" << i;
    EXPECT_EQ(raw.r0_rect, object.r0_rect) << given;
    EXPECT_EQ(raw.tr_velo_to_cam, object.tr_velo_to_cam) << given;
    ExpectPixelConvention(raw, KittiCamera(raw, 2, 1242, 375));
  }
  // Without calib_velo_to_cam.txt next to it: the missing file is named.
  ExpectInputError("raw_without_velo/calib_cam_to_cam.txt", "calib_velo_to_cam.txt");
  ExpectInputError("raw_without_velo", "calib_velo_to_cam.txt");
}

// R0_rect goes with the object format's Tr_velo_to_cam: a file without it is refused, not
// read with the identity (only the odometry format's Tr has none). A key given twice is
// refused naming both lines. Only the projection of the camera used is required.
TEST(KittiCalibration, RequiresR0RectOnceEachKeyAndOnlyTheCameraUsed) {
  ExpectInputError("calib_missing_r0.txt", "missing calibration key R0_rect or R_rect_00 or R_rect");
  ExpectInputError("calib_duplicate_p2.txt",
                   "calib_duplicate_p2.txt:4: field 'P2': found 'a second 'P2:' line (the first on line 3)', "
                   "expected each key once");
  const KittiCalibration object = ReadKittiCalibration(Fixture("calib_ok.txt"));
  const KittiCalibration odometry = ReadKittiCalibration(Fixture("calib_odometry.txt"));
  // The tracking benchmark's file: R_rect and Tr_velo_cam without a colon, the same numbers.
  const KittiCalibration tracking = ReadKittiCalibration(Fixture("calib_tracking.txt"));
  EXPECT_EQ(tracking.r0_rect, object.r0_rect);
  EXPECT_EQ(tracking.tr_velo_to_cam, object.tr_velo_to_cam);
  EXPECT_EQ(KittiCamera(tracking, 2, 1242, 375).cam_from_lidar.ToMatrix4(),
            KittiCamera(object, 2, 1242, 375).cam_from_lidar.ToMatrix4());
  // A line of numbers without a key is refused, naming it.
  ExpectInputError("calib_no_key.txt", "calib_no_key.txt:2: field 'key': found '0.5'");
  EXPECT_EQ(odometry.r0_rect, Eigen::Matrix3d::Identity());
  EXPECT_EQ(odometry.tr_velo_to_cam, object.tr_velo_to_cam);
  const KittiCalibration only_p2 = ReadKittiCalibration(Fixture("calib_only_p2.txt"));
  EXPECT_TRUE(only_p2.has_p[2]);
  EXPECT_FALSE(only_p2.has_p[0]);
  EXPECT_EQ(only_p2.p[2], object.p[2]);
  EXPECT_EQ(KittiCamera(only_p2, 2, 1242, 375).cam_from_lidar.ToMatrix4(),
            KittiCamera(object, 2, 1242, 375).cam_from_lidar.ToMatrix4());
  // Camera 3 asked of a file without P3: at reading, and at KittiCamera (naming the file).
  try {
    ReadKittiCalibration(Fixture("calib_only_p2.txt"), 3);
    FAIL() << "no error for camera 3";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("calib_only_p2.txt: missing calibration key P3 or P_rect_03"),
              std::string::npos)
        << e.what();
  }
  try {
    KittiCamera(only_p2, 0, 1242, 375);
    FAIL() << "no error for camera 0";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("calib_only_p2.txt: missing calibration key P0 or P_rect_00"),
              std::string::npos)
        << e.what();
  }
  // All four asked for (camera −1), as before.
  EXPECT_THROW(ReadKittiCalibration(Fixture("calib_only_p2.txt"), -1), InputError);
  EXPECT_TRUE(ReadKittiCalibration(Fixture("calib_ok.txt"), -1).has_p[3]);
}

TEST(KittiCalibration, SingularKIsRejected) {
  KittiCalibration calibration = ReadKittiCalibration(Fixture("calib_ok.txt"));
  calibration.p[2](0, 0) = 0;
  EXPECT_THROW(KittiCamera(calibration, 2, 1242, 375), InputError);
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
                .find(":4: field 'widht': found 'widht (unknown key)', expected one of cam_from_lidar, height, model, params, width"),
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

// A file of another kind named as a KITTI calibration is not quoted back.
TEST(KittiCalibration, AFileOfAnotherKindIsNotQuoted) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("mmba_calib_other_" + std::to_string(::getpid()) + ".txt")).string();
  for (const std::string text : {"root:x:0:0:root:/root:/bin/bash\n", "secret words here\n"}) {
    std::ofstream(path) << text;
    try {
      ReadKittiCalibration(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(":1: field '"), std::string::npos) << what;
      EXPECT_NE(what.find("(KITTI calibration format)"), std::string::npos) << what;
      EXPECT_EQ(what.find("root"), std::string::npos) << what;
      EXPECT_EQ(what.find("secret"), std::string::npos) << what;
      EXPECT_EQ(what.find("words"), std::string::npos) << what;
    }
  }
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

}  // namespace
}  // namespace mmba::io
