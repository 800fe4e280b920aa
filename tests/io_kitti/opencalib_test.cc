// OpenCalib's calib.txt and intrinsic/extrinsic JSON on the provider's files (data/lidar_camera/
// pjlab) and on broken fixtures (tests/data/opencalib); the camera and start-pose dispatch by
// file type and the image-size check.

#include "mmba/io_kitti/opencalib.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/io_kitti/camera_file.h"
#include "mmba/io_kitti/kitti.h"

namespace mmba::io {
namespace {

namespace fs = std::filesystem;

const std::string kPjlab = std::string(MMBA_SOURCE_DIR) + "/data/lidar_camera/pjlab/";
const std::string kOurs = kPjlab + "ours_1/calib.txt";
const std::string kIntrinsic = kPjlab + "manual_calib/center_camera-intrinsic.json";
const std::string kExtrinsic = kPjlab + "manual_calib/top_center_lidar-to-center_camera-extrinsic.json";

std::string Fixture(const std::string& name) { return std::string(MMBA_SOURCE_DIR) + "/tests/data/opencalib/" + name; }

template <typename F>
void ExpectInputError(F f, std::initializer_list<std::string> fragments) {
  try {
    f();
    FAIL() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << "message '" << e.what() << "' lacks '" << fragment << "'";
    }
  }
}

// OpenCV's projection (cv::projectPoints' model, pixel centres at integers) of a point in the
// camera frame with K and k1 k2 p1 p2, written out by hand.
Eigen::Vector2d OpenCvPixel(const Eigen::Matrix3d& k, const std::vector<double>& d, const Eigen::Vector3d& x_cam) {
  const double x = x_cam.x() / x_cam.z(), y = x_cam.y() / x_cam.z();
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {k(0, 0) * xd + k(0, 2), k(1, 1) * yd + k(1, 2)};
}

TEST(OpenCalibTxt, OursCalibTxtAsWritten) {
  if (!fs::exists(kOurs)) GTEST_SKIP() << kOurs << " absent";
  const OpenCalibTxt txt = ReadOpenCalibTxt(kOurs);
  Eigen::Matrix3d k;
  k << 2152.8, 0, 971.3, 0, 2155.5, 605.9, 0, 0, 1;
  EXPECT_EQ(txt.intrinsics.k, k);
  EXPECT_EQ(txt.intrinsics.distortion, (std::vector<double>{-0.1192, 0.162, 0.00073985, 0.0014}));
  Eigen::Matrix<double, 3, 4> t;
  t << 0.0188623, -0.999822, -9.36529e-05, -0.0323222, 0.0288601, 0.000638227, -0.999583, -0.396685, 0.999405,
      0.0188516, 0.028867, -0.0869361;
  EXPECT_LT((txt.cam_from_lidar.ToMatrix3x4() - t).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_EQ(txt.cam_from_lidar.translation, Eigen::Vector3d(-0.0323222, -0.396685, -0.0869361));
  // The LiDAR's x axis (forward) is the camera's z (forward): T is LiDAR → camera.
  EXPECT_GT((txt.cam_from_lidar.rotation * Eigen::Vector3d::UnitX()).z(), 0.99);

  // The camera: OPENCV with the centre moved by half a pixel, projecting as OpenCV does.
  const sensors::Camera camera = CameraFromOpenCalib(txt.intrinsics, 1920, 1200);
  EXPECT_EQ(camera.ModelName(), "OPENCV");
  EXPECT_EQ(camera.params, (std::vector<double>{2152.8, 2155.5, 971.8, 606.4, -0.1192, 0.162, 0.00073985, 0.0014}));
  for (const Eigen::Vector3d& x_lidar : {Eigen::Vector3d(20, 3, -1), Eigen::Vector3d(8, -2.5, 0.4),
                                         Eigen::Vector3d(40, 12, 2)}) {
    const Eigen::Vector3d x_cam = txt.cam_from_lidar * x_lidar;
    const std::optional<Eigen::Vector2d> mmba = camera.ImgFromCam(x_cam);
    ASSERT_TRUE(mmba.has_value());
    const Eigen::Vector2d opencv = OpenCvPixel(k, txt.intrinsics.distortion, x_cam);
    EXPECT_LT((*mmba - Eigen::Vector2d(0.5, 0.5) - opencv).norm(), 1e-9) << x_lidar.transpose();
  }
}

TEST(OpenCalibJson, ManualCalibIntrinsicAndExtrinsic) {
  if (!fs::exists(kIntrinsic)) GTEST_SKIP() << kIntrinsic << " absent";
  EXPECT_EQ(OpenCalibJsonKind(kIntrinsic), "intrinsic");
  EXPECT_EQ(OpenCalibJsonKind(kExtrinsic), "extrinsic");
  const OpenCalibIntrinsics intrinsics = ReadOpenCalibIntrinsicJson(kIntrinsic);
  Eigen::Matrix3d k;
  k << 2109.75, 0, 949.828, 0, 2071.72, 576.237, 0, 0, 1;
  EXPECT_EQ(intrinsics.k, k);
  EXPECT_EQ(intrinsics.distortion, (std::vector<double>{-0.10814499855041504, 0.1386680006980896,
                                                        -0.0037975700106471777, -0.004841269925236702}));
  EXPECT_EQ(intrinsics.width, 1920u);
  EXPECT_EQ(intrinsics.height, 1080u);
  const Rigid3d cam_from_lidar = ReadOpenCalibExtrinsicJson(kExtrinsic);
  Eigen::Matrix<double, 3, 4> t;
  t << 0.0125908, -0.999895, -0.00713773, -0.0322306, 0.0119283, 0.00728786, -0.999902, -0.352079, 0.99985,
      0.0125045, 0.0120187, -0.574468;
  EXPECT_LT((cam_from_lidar.ToMatrix3x4() - t).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_GT((cam_from_lidar.rotation * Eigen::Vector3d::UnitX()).z(), 0.99);
  // The start pose of --initial from either OpenCalib file equals the reader's.
  EXPECT_EQ(ReadStartPoseFile(kExtrinsic, "cam_from_lidar").ToMatrix4(), cam_from_lidar.ToMatrix4());
  EXPECT_EQ(ReadStartPoseFile(kOurs, "cam_from_lidar").ToMatrix4(), ReadOpenCalibTxt(kOurs).cam_from_lidar.ToMatrix4());
}

// A calib.txt holding KITTI frame 000000's P2 (3×4) and R0_rect·Tr_velo_to_cam gives the same
// cam_from_lidar as the KITTI reader, and the same camera but for OpenCV's half-pixel shift.
TEST(OpenCalibTxt, KittiProjectionAsCalibTxt) {
  const std::string kitti_path = std::string(MMBA_SOURCE_DIR) + "/data/kitti/calib/000000.txt";
  if (!fs::exists(kitti_path)) GTEST_SKIP() << kitti_path << " absent";
  const KittiCalibration kitti = ReadKittiCalibration(kitti_path, 2);
  const KittiCameraPose kitti_pose = KittiCamera(kitti, 2, 1242, 375);
  Eigen::Matrix4d rect = Eigen::Matrix4d::Identity(), velo = Eigen::Matrix4d::Identity();
  rect.topLeftCorner<3, 3>() = kitti.r0_rect;
  velo.topRows<3>() = kitti.tr_velo_to_cam;
  const Eigen::Matrix4d t = rect * velo;
  const std::string path = (fs::temp_directory_path() / "mmba_opencalib_kitti_calib.txt").string();
  {
    std::ofstream out(path);
    out.precision(17);
    out << "K:";
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 4; ++c) out << " " << kitti.p[2](r, c);
    out << "\nD: 0 0 0 0\nT:";
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 4; ++c) out << " " << t(r, c);
    out << "\n";
  }
  const OpenCalibTxt txt = ReadOpenCalibTxt(path);
  fs::remove(path);
  EXPECT_LT((txt.cam_from_lidar.ToMatrix4() - kitti_pose.cam_from_lidar.ToMatrix4()).cwiseAbs().maxCoeff(), 1e-6);
  const sensors::Camera camera = CameraFromOpenCalib(txt.intrinsics, 1242, 375);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(camera.params[i], kitti_pose.camera.params[i] + (i >= 2 ? 0.5 : 0.0), 1e-9) << i;
  }
}

TEST(OpenCalibTxt, BrokenFixtures) {
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("missing_k.txt")); }, {"missing_k.txt", "'K'", "(missing)"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("missing_t.txt")); }, {"missing_t.txt", "'T'", "(missing)"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("k_eight_numbers.txt")); },
                   {"k_eight_numbers.txt:1", "'K'", "8 numbers", "9 or 12 numbers"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("d_two_numbers.txt")); },
                   {"d_two_numbers.txt:2", "'D'", "2 numbers", "4, 5 or 8 numbers"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("d_not_a_number.txt")); },
                   {"d_not_a_number.txt:2", "D[3]", "O.0014"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("k_twice.txt")); }, {"k_twice.txt:2", "second 'K:'", "line 1"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("k_zero_focal.txt")); },
                   {"k_zero_focal.txt:1", "'K'", "[0 0 971.3", "fx, fy > 0"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("t_not_rotation.txt")); },
                   {"t_not_rotation.txt:3", "'T'", "rotation", "orthonormal"});
  ExpectInputError([] { ReadOpenCalibTxt(Fixture("kitti_calib_as_opencalib.txt")); },
                   {"kitti_calib_as_opencalib.txt:1", "P0", "--kitti-calib"});
}

TEST(OpenCalibJson, BrokenFixtures) {
  ExpectInputError([] { ReadOpenCalibIntrinsicJson(Fixture("intrinsic_missing_cam_k.json")); },
                   {"intrinsic_missing_cam_k.json", "center_camera-intrinsic.param.cam_K", "(missing)"});
  ExpectInputError([] { ReadOpenCalibIntrinsicJson(Fixture("intrinsic_short_row.json")); },
                   {"intrinsic_short_row.json", "cam_K.data", "row 1 = [0,2071.72]", "3 rows of 3 numbers"});
  ExpectInputError([] { ReadOpenCalibIntrinsicJson(Fixture("intrinsic_truncated.json")); },
                   {"intrinsic_truncated.json", "valid JSON"});
  ExpectInputError([] { ReadOpenCalibExtrinsicJson(Fixture("extrinsic_not_rotation.json")); },
                   {"extrinsic_not_rotation.json", "sensor_calib.data", "orthonormal"});
  ExpectInputError([] { ReadOpenCalibExtrinsicJson(Fixture("extrinsic_last_row.json")); },
                   {"extrinsic_last_row.json", "last row is (0 0 1 1)", "(0 0 0 1)"});
}

TEST(CameraFile, ChosenByTypeAndCheckedAgainstTheImage) {
  if (!fs::exists(kOurs)) GTEST_SKIP() << kOurs << " absent";
  const std::string image = "ours_1/calib.jpg";
  EXPECT_TRUE(IsOpenCalibFile(kOurs));
  EXPECT_TRUE(IsOpenCalibFile(kIntrinsic));
  const CameraYaml from_txt = ReadCameraFile(kOurs, image, 1920, 1200);
  EXPECT_EQ(from_txt.camera.width, 1920u);
  ASSERT_TRUE(from_txt.cam_from_lidar.has_value());
  std::string note;
  const CameraYaml from_json = ReadCameraFile(kIntrinsic, "manual_calib/0.png", 1920, 1200, &note);
  EXPECT_EQ(from_json.camera.height, 1200u);
  EXPECT_FALSE(from_json.cam_from_lidar.has_value());
  EXPECT_NE(note.find("img_dist 1920x1080"), std::string::npos) << note;
  EXPECT_NE(note.find("manual_calib/0.png is 1920x1200"), std::string::npos) << note;
  // KITTI's 1242x375 image with this camera's calibration: refused, naming both.
  ExpectInputError([&] { ReadCameraFile(kOurs, "image_2/000000.png", 1242, 375); },
                   {"image_2/000000.png", "1242x375", kOurs, "(971.8, 606.4)", "about 1944x1213"});
  ExpectInputError([&] { ReadCameraFile(kIntrinsic, "small.png", 960, 600); }, {"small.png", "960x600", kIntrinsic});
  // An extrinsic JSON is not a camera, an intrinsic JSON not a pose; a rig pose is not OpenCalib's.
  ExpectInputError([&] { ReadCameraFile(kExtrinsic, image, 1920, 1200); }, {kExtrinsic, "extrinsic", "--initial"});
  ExpectInputError([&] { ReadStartPoseFile(kIntrinsic, "cam_from_lidar"); }, {kIntrinsic, "no pose"});
  ExpectInputError([&] { ReadStartPoseFile(kOurs, "rig_from_lidar"); }, {kOurs, "rig_from_lidar"});
  // A camera YAML states its size: any other image size is refused, naming both.
  sensors::Camera yaml_camera;
  yaml_camera.width = 1242;
  yaml_camera.height = 375;
  yaml_camera.params = {700, 700, 621, 187.5};
  ExpectInputError([&] { CheckImageAgainstCamera("a.png", 1240, 375, "cam.yaml", yaml_camera, true); },
                   {"a.png", "image is 1240x375", "cam.yaml is 1242x375"});
  EXPECT_NO_THROW(CheckImageAgainstCamera("a.png", 1242, 375, "cam.yaml", yaml_camera, true));
}

// A pose JSON that is not valid JSON is left to the pose reader, which names the line and the
// number (1e400 overflows a double); an mmba pose JSON is not OpenCalib's.
TEST(CameraFile, PoseJsonIsReadByThePoseReader) {
  const fs::path dir = fs::temp_directory_path() / "mmba_opencalib_pose_json";
  fs::create_directories(dir);
  const std::string overflow = (dir / "pose_inf.json").string();
  std::ofstream(overflow) << "{\"cam_from_lidar\": [1e400, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}\n";
  const std::string pose = (dir / "pose.json").string();
  std::ofstream(pose) << "{\"cam_from_lidar\": [1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}\n";
  EXPECT_FALSE(IsOpenCalibFile(overflow));
  EXPECT_FALSE(IsOpenCalibFile(pose));
  ExpectInputError([&] { ReadStartPoseFile(overflow, "cam_from_lidar"); }, {"pose_inf.json:1", "1e400"});
  EXPECT_EQ(ReadStartPoseFile(pose, "cam_from_lidar").translation, Eigen::Vector3d(0.5, 0, 0));
  // A camera YAML saved as .txt is read as the YAML it is.
  const std::string yaml_txt = (dir / "camera.txt").string();
  std::ofstream(yaml_txt) << "# a camera\nmodel: PINHOLE\nwidth: 1242\nheight: 375\nparams: [700, 700, 621, 187.5]\n";
  EXPECT_FALSE(IsOpenCalibFile(yaml_txt));
  EXPECT_EQ(ReadCameraFile(yaml_txt, "a.png", 1242, 375).camera.ModelName(), "PINHOLE");
  ExpectInputError([&] { ReadCameraFile(yaml_txt, "a.png", 1920, 1200); }, {"a.png", "1920x1200", "camera.txt is 1242x375"});
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mmba::io
