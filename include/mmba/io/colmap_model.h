#pragma once

// COLMAP sparse models (cameras, images, points3D) in COLMAP's text and binary formats
// (https://colmap.github.io/format.html), read and written exactly: text -> binary -> text
// reproduces the text that text -> text gives. Writes are atomic (all three files appear
// together or not at all).

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/ids.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/sensors/camera.h"

namespace mmba::io {

struct ColmapTrackElement {
  ImageId image_id;
  uint32_t point2D_idx = 0;
};

struct ColmapImage {
  ImageId image_id;
  CameraId camera_id;
  std::string name;
  Rigid3d cam_from_world;                     ///< COLMAP qvec (w, x, y, z), tvec
  std::vector<Eigen::Vector2d> points2D;      ///< pixels, COLMAP convention
  std::vector<Point3DId> point3D_ids;         ///< invalid Id = not triangulated (-1)
};

struct ColmapPoint3D {
  Point3DId point3D_id;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();  ///< point_in_world
  std::array<uint8_t, 3> color{0, 0, 0};
  double error = -1.0;                            ///< mean reprojection error, px
  std::vector<ColmapTrackElement> track;
};

/// A whole model, keyed and sorted by id.
struct ColmapModel {
  std::map<CameraId, sensors::Camera> cameras;
  std::map<ImageId, ColmapImage> images;
  std::map<Point3DId, ColmapPoint3D> points3D;

  size_t NumObservations() const;
};

enum class ColmapFormat { kText, kBinary };

/// Largest image width or height (pixels) the camera readers accept: a gigapixel panorama is
/// about 200,000 px wide, while a corrupt size (2^40) would overflow pixel counts downstream.
constexpr uint64_t kMaxImageSidePx = 1000000;

/// Which format a model folder holds (cameras.bin or cameras.txt). Throws InputError when
/// the folder is missing or holds neither.
ColmapFormat DetectColmapFormat(const std::string& dir);

/// Reads and validates a model (format detected): ids unique and non-negative, camera
/// models known with the right parameter count, image sizes in 1..kMaxImageSidePx, image
/// names UTF-8 text, finite numbers, every image names an
/// existing camera, every track an existing image and point2D index, and the points2D ↔
/// track cross references agree. Throws InputError (file:line or byte offset).
ColmapModel ReadColmapModel(const std::string& dir, ColmapFormat* format = nullptr);
ColmapModel ReadColmapText(const std::string& dir);
ColmapModel ReadColmapBinary(const std::string& dir);

/// Writes cameras, images and points3D in `format` into `dir` (created if needed),
/// atomically.
void WriteColmapModel(const ColmapModel& model, const std::string& dir, ColmapFormat format);

}  // namespace mmba::io
