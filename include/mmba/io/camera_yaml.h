#pragma once

// The calibration YAML files of a project (docs/formats.md, "Calibration YAML"): a camera with
// its optional pose to the LiDAR, a multi-camera rig, a mobile LiDAR's mounting, and a pose
// {qvec_wxyz, tvec} inside any of them.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io/yaml_reader.h"
#include "mmba/sensors/camera.h"

namespace mmba::io {

/// The project's camera YAML (docs/formats.md, "Camera YAML"):
///   model: PINHOLE            # any mmba model name
///   width: 1242               # pixels
///   height: 375
///   params: [fx, fy, cx, cy]  # in the model's order
///   cam_from_lidar: [16 numbers, 4×4 row-major]   # optional
/// A PHOTOGRAMMETRIC camera has named fields in mm instead of `params` (calib/README.md):
///   c_mm, xp_mm, yp_mm, format_width_mm, format_height_mm (required), K1, K2, K3, P1, P2,
///   b1, b2 (0 when absent); the pixel pitch is format_width_mm / width, format_height_mm /
///   height.
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
/// A camera file of a project: DBAT's camera XML (io/dbat_camera.h) when `path` ends in
/// ".xml" (any case), the camera YAML otherwise. InputError as either reader.
CameraYaml ReadCameraFile(const std::string& path);

/// The rig YAML of a Ladybug-style multi-camera rig (docs/formats.md, "Rig YAML"), as
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

/// The mounting of a mobile LiDAR head on its vehicle (docs/formats.md, "Mobile LiDAR
/// mounting"; `mmba simulate` writes it): `body_from_lidar: {qvec_wxyz, tvec}` (required);
/// `beams`, `elevation_deg` and `rotation_hz` are allowed and ignored. InputError naming the
/// file, line and field otherwise. Used by `mmba adjust` and `register-mi --lidar-mount`.
Rigid3d ReadLidarMountYaml(const std::string& path);

/// A pose {qvec_wxyz: [w, x, y, z], tvec: [x, y, z]} in a YAML file read by `reader`;
/// InputError naming `field` unless 4 + 3 numbers and a unit quaternion (within 1e-3).
Rigid3d ReadYamlPose(const YamlReader& reader, const YAML::Node& node, const std::string& field);

}  // namespace mmba::io
