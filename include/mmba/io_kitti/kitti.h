#pragma once

// KITTI calibration files (library mmba_io_kitti).
// KITTI velodyne scans are read by io::ReadPointCloud / ReadKittiBin (mmba_io_cloud).
// KITTI data is CC BY-NC-SA 3.0; see data/SOURCES.md.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io/pose_json.h"  // RigidFromRowMajor4x4, CheckRotation
#include "mmba/sensors/camera.h"

namespace mmba::io {

/// The matrices of a KITTI object/odometry calibration file ("KEY: v1 v2 ...").
struct KittiCalibration {
  Eigen::Matrix<double, 3, 4> p[4];               ///< P0..P3, rectified projections
  bool has_p[4] = {false, false, false, false};   ///< which of P0..P3 the file holds
  Eigen::Matrix3d r0_rect = Eigen::Matrix3d::Identity();  ///< R0_rect (or R_rect_00)
  Eigen::Matrix<double, 3, 4> tr_velo_to_cam;    ///< Tr_velo_to_cam (velo -> cam 0, unrect.)
  std::string path;                               ///< the file read (for messages)
};

/// Reads a KITTI calibration. Accepts the object format (P0..P3, R0_rect, Tr_velo_to_cam,
/// ...), the odometry format (P0..P3, Tr: velodyne → rectified camera 0, no R0_rect) and a raw
/// recording's two files — calib_cam_to_cam.txt (P_rect_0X, R_rect_00; its "calib_time:" date
/// is skipped) and calib_velo_to_cam.txt (R, T) — given as their folder or as either file (the
/// other is read from beside it). Required: the projection of `camera` (0..3; −1: all four;
/// the others are read when present, KittiCalibration::has_p), the velodyne-to-camera
/// transform, and the rectifying rotation except with the odometry format's Tr. Throws
/// InputError (file:line, field, value) for a malformed number, a wrong count, a key given
/// twice, a missing required key or file, or a non-orthonormal rotation.
KittiCalibration ReadKittiCalibration(const std::string& path_or_folder, int camera = 2);

/// A camera of KITTI as an mmba camera and its pose relative to the velodyne.
struct KittiCameraPose {
  sensors::Camera camera;  ///< PINHOLE fx, fy, cx, cy from the left 3×3 K of P_i
  Rigid3d cam_from_lidar;  ///< pose of that camera (its own frame, K's pixels)
};

/// Camera `index` (2 = left colour) of a calibration: PINHOLE from the left 3×3 K of P_i and
///   cam_from_lidar = [I | K⁻¹·P_i[:,3]] · R0_rect · Tr_velo_to_cam,
/// so that K · (cam_from_lidar · X) equals P_i · R0_rect · Tr_velo_to_cam · X.
/// Width and height are those of the image (KITTI does not store them in the calibration).
/// Throws InputError when K is singular or not upper triangular with zero skew, or when the
/// calibration does not hold P_index.
KittiCameraPose KittiCamera(const KittiCalibration& calibration, int index, uint64_t width,
                            uint64_t height, const std::string& source = "calibration");

}  // namespace mmba::io
