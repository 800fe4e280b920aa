#pragma once

// KITTI calibration files and the project's own camera YAML (library mmba_io_kitti).
// KITTI velodyne scans are read by io::ReadPointCloud / ReadKittiBin (mmba_io_cloud).
// KITTI data is CC BY-NC-SA 3.0; see data/SOURCES.md.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io/pose_json.h"  // RigidFromRowMajor4x4, CheckRotation
#include "mmba/io/yaml_reader.h"
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

/// The project's camera YAML (schema in calib/README.md, section "Camera YAML"):
///   model: PINHOLE            # any mmba model name
///   width: 1242               # pixels
///   height: 375
///   params: [fx, fy, cx, cy]  # in the model's order
///   cam_from_lidar: [16 numbers, 4×4 row-major]   # optional
struct CameraYaml {
  sensors::Camera camera;
  std::optional<Rigid3d> cam_from_lidar;
};
/// Throws InputError naming the file, the line, the field and the value on any problem: an
/// unknown key or a key given twice, a missing key, a size outside 1..kMaxImageSidePx, a
/// wrong parameter count, a pose that is not rigid.
CameraYaml ReadCameraYaml(const std::string& path);
/// Writes the same schema atomically.
void WriteCameraYaml(const CameraYaml& camera_yaml, const std::string& path);

/// The rig YAML of a Ladybug-style multi-camera rig (calib/README.md, `camera_rig`), as
/// `mmba register-mi --rig` reads it:
///   body_from_rig: {qvec_wxyz: [...], tvec: [...]}    # optional (mmba adjust requires it)
///   rig_from_lidar: [16 numbers, 4×4 row-major]        # optional: the start pose
///   cameras:
///     - {name: cam0, model: OPENCV_FISHEYE, width: 320, height: 400, params: [...],
///        cam_from_rig: {qvec_wxyz: [...], tvec: [...]}}
/// The rig calibration `mmba adjust` writes (with `sigma`, `cam_from_rig_tvec_sigma`) reads
/// too; a `beams` key is ignored.
struct RigYaml {
  std::optional<Rigid3d> body_from_rig;  ///< lever arm and boresight on the vehicle (mmba adjust)
  std::vector<std::string> names;
  std::vector<sensors::Camera> cameras;
  std::vector<Rigid3d> cam_from_rig;
  std::optional<Rigid3d> rig_from_lidar;
};
/// Throws InputError naming the file, line, field and value on any problem (unknown keys,
/// a camera without its model, size, params or cam_from_rig, duplicate names, no cameras).
/// Used by `register-mi --rig` and by `mmba adjust`'s camera_rig sensor.
RigYaml ReadRigYaml(const std::string& path);

/// The mounting of a mobile LiDAR head on its vehicle (calib/README.md, the mobile LiDAR
/// calibration `mmba simulate` writes): `body_from_lidar: {qvec_wxyz, tvec}` (required);
/// `beams`, `elevation_deg` and `rotation_hz` are allowed and ignored. InputError naming the
/// file, line and field otherwise. Used by `mmba adjust` and `register-mi --lidar-mount`.
Rigid3d ReadLidarMountYaml(const std::string& path);

/// A pose {qvec_wxyz: [w, x, y, z], tvec: [x, y, z]} in a YAML file read by `reader`;
/// InputError naming `field` unless 4 + 3 numbers and a unit quaternion (within 1e-3).
Rigid3d ReadYamlPose(const YamlReader& reader, const YAML::Node& node, const std::string& field);


}  // namespace mmba::io
