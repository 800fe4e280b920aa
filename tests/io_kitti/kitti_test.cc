#include "mmba/io_kitti/kitti.h"

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

// The convention of KittiCamera: K · (cam_from_lidar · X) == P2 · R0_rect · Tr_velo_to_cam · X.
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

}  // namespace
}  // namespace mmba::io
