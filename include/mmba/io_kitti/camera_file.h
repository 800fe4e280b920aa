#pragma once

// The camera and start-pose files `mmba register-mi` accepts, chosen by file type (library
// mmba_io_kitti):
//   --camera   FILE.yaml / .yml        mmba camera YAML (io/camera_yaml.h)
//              calib.txt (a .txt)      OpenCalib calib.txt: K, D and T (io_kitti/opencalib.h);
//                                      a .txt whose first key is model:, width:, … is a YAML
//              NAME-intrinsic.json     OpenCalib intrinsic JSON (no pose)
//   --initial  POSE.json               mmba pose JSON (io/pose_json.h)
//              calib.txt (any .txt)    OpenCalib calib.txt's T
//              NAME-extrinsic.json     OpenCalib extrinsic JSON
// and the check that an image agrees with its camera.

#include <cstdint>
#include <string>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io/camera_yaml.h"
#include "mmba/sensors/camera.h"

namespace mmba::io {

/// True when `path` is an OpenCalib file by its type: a .txt file (not a camera YAML), or a
/// .json file holding OpenCalib's one sensor object with param.cam_K or param.sensor_calib (a
/// file that is not valid JSON is not: the pose JSON reader names its problem). InputError
/// for a missing file.
bool IsOpenCalibFile(const std::string& path);

/// The camera (and its cam_from_lidar where the file has one) of a camera file of any kind
/// above, for the image `image_path` of `image_width` × `image_height` pixels, checked against
/// it with CheckImageAgainstCamera. OpenCalib files give the camera the image's size (calib.txt
/// states none; OpenCalib's tools do not read the JSON's img_dist_w/h). A JSON's stated size
/// that differs from the image's is reported in `*note` (if given) naming both; else it is
/// cleared. InputError as the readers throw, and as the check throws.
CameraYaml ReadCameraFile(const std::string& path, const std::string& image_path, uint64_t image_width,
                          uint64_t image_height, std::string* note = nullptr);

/// The start pose under `key` ("cam_from_lidar") of a pose file of any kind above. OpenCalib
/// files hold a camera's pose to the LiDAR only: with another key (rig_from_lidar), or an
/// intrinsic JSON, InputError naming the file and what it holds.
Rigid3d ReadStartPoseFile(const std::string& path, const std::string& key);

/// InputError naming the image (file and size) and the calibration (file and size) unless an
/// image of image_width × image_height pixels fits `camera` from `calibration_path`:
///   - when `size_stated` (a camera YAML, a COLMAP camera, a rig's camera): the sizes equal;
///   - else (KITTI, OpenCalib: the size is the image's): the principal point lies within 20 %
///     of the image's size from its centre (|2 cx − W| ≤ 0.2 W and |2 cy − H| ≤ 0.2 H), which
///     a crop, a thumbnail, another camera's image or a panorama does not.
void CheckImageAgainstCamera(const std::string& image_path, uint64_t image_width, uint64_t image_height,
                             const std::string& calibration_path, const sensors::Camera& camera, bool size_stated);

}  // namespace mmba::io
