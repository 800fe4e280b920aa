// Camera and start-pose files chosen by type (include/mmba/io_kitti/camera_file.h).

#include "mmba/io_kitti/camera_file.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/io/pose_json.h"
#include "mmba/io/text_reader.h"
#include "mmba/io_kitti/opencalib.h"

namespace mmba::io {
namespace {

std::string Extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::string SizeText(uint64_t width, uint64_t height) { return std::to_string(width) + "x" + std::to_string(height); }

// OpenCalibJsonKind, or "" for a file that is not valid JSON: the pose JSON reader then names
// the problem with its line.
std::string JsonKindOrNone(const std::string& path) {
  try {
    return OpenCalibJsonKind(path);
  } catch (const InputError&) {
    return "";
  }
}

// A .txt file whose first key is one of the camera YAML's (model:, width:, …): a camera YAML
// under another name, read as such.
bool TxtIsCameraYaml(const std::string& path) {
  std::istringstream text(ReadWholeFile(path));
  std::string word;
  while (text >> word) {
    if (word[0] == '#') {
      std::getline(text, word);
      continue;
    }
    return word == "model:" || word == "width:" || word == "height:" || word == "params:" ||
           word == "cam_from_lidar:";
  }
  return false;
}

}  // namespace

bool IsOpenCalibFile(const std::string& path) {
  const std::string ext = Extension(path);
  if (ext == ".txt") return !TxtIsCameraYaml(path);
  return ext == ".json" && !JsonKindOrNone(path).empty();
}

void CheckImageAgainstCamera(const std::string& image_path, uint64_t image_width, uint64_t image_height,
                             const std::string& calibration_path, const sensors::Camera& camera, bool size_stated) {
  const std::string image = image_path + " is " + SizeText(image_width, image_height);
  if (size_stated) {
    if (camera.width == image_width && camera.height == image_height) return;
    throw InputError::Message(image_path, "image is " + SizeText(image_width, image_height) + " but the camera of " +
                                              calibration_path + " is " + SizeText(camera.width, camera.height) +
                                              "; expected the image the calibration was made for");
  }
  if (camera.params.size() < 4) return;  // no principal point (not a perspective model)
  const double cx = camera.params[2], cy = camera.params[3];
  const double w = static_cast<double>(image_width), h = static_cast<double>(image_height);
  if (std::abs(2 * cx - w) <= 0.2 * w && std::abs(2 * cy - h) <= 0.2 * h) return;
  std::ostringstream why;
  why << "image is " << SizeText(image_width, image_height) << " but the principal point in " << calibration_path
      << " is (" << cx << ", " << cy << "): expected an image of about " << std::lround(2 * cx) << "x"
      << std::lround(2 * cy) << " (2 cx x 2 cy, within 20 %)";
  throw InputError::Message(image_path, why.str());
}

CameraYaml ReadCameraFile(const std::string& path, const std::string& image_path, uint64_t image_width,
                          uint64_t image_height, std::string* note) {
  if (note != nullptr) note->clear();
  CameraYaml out;
  const std::string ext = Extension(path);
  if (ext == ".txt" && !TxtIsCameraYaml(path)) {
    const OpenCalibTxt txt = ReadOpenCalibTxt(path);
    out.camera = CameraFromOpenCalib(txt.intrinsics, image_width, image_height);
    out.cam_from_lidar = txt.cam_from_lidar;
  } else if (ext == ".json") {
    const std::string kind = OpenCalibJsonKind(path);
    if (kind != "intrinsic") {
      throw InputError::Message(path, kind == "extrinsic"
                                          ? "an OpenCalib extrinsic JSON holds no camera; expected the intrinsic JSON "
                                            "(NAME-intrinsic.json) here, the extrinsic one as --initial"
                                          : "not an OpenCalib intrinsic JSON (no param.cam_K); expected a camera YAML, "
                                            "an OpenCalib calib.txt or NAME-intrinsic.json");
    }
    const OpenCalibIntrinsics intrinsics = ReadOpenCalibIntrinsicJson(path);
    out.camera = CameraFromOpenCalib(intrinsics, image_width, image_height);
    if (note != nullptr && intrinsics.width != 0 && intrinsics.height != 0 &&
        (intrinsics.width != image_width || intrinsics.height != image_height)) {
      *note = path + " states img_dist " + SizeText(intrinsics.width, intrinsics.height) + " but " + image_path +
              " is " + SizeText(image_width, image_height) + "; the image's size is used (OpenCalib's tools do not "
              "read img_dist_w/h)";
    }
  } else {
    out = ReadCameraYaml(path);
    CheckImageAgainstCamera(image_path, image_width, image_height, path, out.camera, true);
    return out;
  }
  CheckImageAgainstCamera(image_path, image_width, image_height, path, out.camera, false);
  return out;
}

Rigid3d ReadStartPoseFile(const std::string& path, const std::string& key) {
  const std::string ext = Extension(path);
  const std::string kind = ext == ".json" ? JsonKindOrNone(path) : (ext == ".txt" && !TxtIsCameraYaml(path) ? "txt" : "");
  if (kind.empty()) return ReadPoseJson(path, key);
  if (key != "cam_from_lidar") {
    throw InputError::Message(path, "an OpenCalib file holds a camera's pose to the LiDAR, not " + key +
                                        "; expected a pose JSON with \"" + key + "\"");
  }
  if (kind == "txt") return ReadOpenCalibTxt(path).cam_from_lidar;
  if (kind == "intrinsic") {
    throw InputError::Message(path, "an OpenCalib intrinsic JSON holds no pose; expected the extrinsic JSON "
                                    "(NAME-to-CAMERA-extrinsic.json), a calib.txt or a pose JSON");
  }
  return ReadOpenCalibExtrinsicJson(path);
}

}  // namespace mmba::io
