#pragma once

// OpenCalib's calibration files (PJLab-ADG/SensorsCalibration), library mmba_io_kitti:
//
//   calib.txt (lidar2camera/auto_calib_v2.0, read there by include/dataloader.hpp
//   DataLoader::LoadCalibFile):
//     K: fx 0 cx 0 fy cy 0 0 1          3×3 row-major (or 3×4: a projection P = [K | p])
//     D: k1 k2 p1 p2 [k3]                OpenCV's order (cv::undistort in its Util::UndistImg)
//     T: r11 r12 r13 tx r21 … tz         3×4 (or 4×4) row-major, LiDAR → camera:
//                                        pixel = K · T · X_lidar (src/calibration.cpp,
//                                        Calibrator::ProjectOnImage)
//   NAME-intrinsic.json (lidar2camera/manual_calib, read by include/intrinsic_param.hpp
//   LoadIntrinsic): {NAME: {param: {img_dist_w, img_dist_h, cam_K: {data: [[3],[3],[3]]},
//   cam_dist: {data: [[k1, k2, p1, p2, …]]}}}}; LoadIntrinsic reads only cam_K and cam_dist.
//   NAME-extrinsic.json (include/extrinsic_param.hpp): {NAME: {param: {sensor_calib: {data:
//   4 rows of 4}}}}, LiDAR → camera as T above (run_lidar2camera.cpp projects with it).
//
// K is in OpenCV's pixel convention (the centre of the top-left pixel at (0, 0):
// ProjectOnImage rounds K·T·X to the pixel index); mmba's is COLMAP's ((0.5, 0.5)), so the
// camera made here has cx + 0.5, cy + 0.5.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"

namespace mmba::io {

/// Intrinsics as OpenCalib stores them (OpenCV's pixel convention).
struct OpenCalibIntrinsics {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();  ///< [fx 0 cx; 0 fy cy; 0 0 1], pixels
  std::vector<double> distortion;                   ///< k1 k2 p1 p2 [k3 [k4 k5 k6]]
  uint64_t width = 0, height = 0;                   ///< img_dist_w/h of the JSON; 0 if not stated
  std::string path;                                 ///< the file read (for messages)
};

/// An OpenCalib calib.txt: intrinsics and the LiDAR-to-camera extrinsic.
struct OpenCalibTxt {
  OpenCalibIntrinsics intrinsics;
  Rigid3d cam_from_lidar;  ///< T (with a 3×4 K: [I | K⁻¹·p] · T, so K·cam_from_lidar = P·T)
};

/// Reads calib.txt. Each of K, D and T once, in any order ("K:" or "K"); blank lines and lines
/// starting with '#' are skipped. Throws InputError naming the file, the line, the key and the
/// value for: a missing key, an unknown key, a key given twice, a wrong count of numbers (K 9
/// or 12, D 4, 5 or 8, T 12 or 16), a word that is not a number, K not of the form
/// [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0, a 4×4 T whose last row is not (0 0 0 1), and a
/// rotation that is not orthonormal with det +1 within 1e-4.
OpenCalibTxt ReadOpenCalibTxt(const std::string& path);

/// Reads an OpenCalib intrinsic JSON (the single top-level object, whatever its name).
/// InputError naming the file and the field (e.g. "center_camera-intrinsic.param.cam_K.data")
/// for invalid JSON, a missing field, a wrong count or a K as above.
OpenCalibIntrinsics ReadOpenCalibIntrinsicJson(const std::string& path);

/// Reads an OpenCalib extrinsic JSON: cam_from_lidar from param.sensor_calib.data (4×4).
/// InputError naming the file and field as above, and for a last row other than (0 0 0 1) or a
/// rotation that is not orthonormal within 1e-4.
Rigid3d ReadOpenCalibExtrinsicJson(const std::string& path);

/// The mmba camera of `intrinsics` for an image of width × height: OPENCV (fx, fy, cx + 0.5,
/// cy + 0.5, k1, k2, p1, p2) when k3..k6 are absent or zero, FULL_OPENCV otherwise.
sensors::Camera CameraFromOpenCalib(const OpenCalibIntrinsics& intrinsics, uint64_t width, uint64_t height);

/// The kind of an OpenCalib JSON file, from its content: "intrinsic" (param.cam_K),
/// "extrinsic" (param.sensor_calib), or "" when it is not one (e.g. an mmba pose JSON).
/// InputError for a file that is not JSON.
std::string OpenCalibJsonKind(const std::string& path);

}  // namespace mmba::io
