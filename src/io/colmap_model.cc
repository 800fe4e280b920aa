#include "mmba/io/colmap_model.h"

#include <cstring>
#include <filesystem>
#include <iomanip>
#include <set>
#include <sstream>

#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/core/utf8.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace fs = std::filesystem;
namespace {

constexpr uint64_t kInvalidPoint3D = std::numeric_limits<uint64_t>::max();

// images.txt writes all the keypoints of an image on one line (~40 bytes a keypoint) and
// points3D.txt a whole track on one: this bound allows some 6 million per line.
constexpr size_t kMaxPoints2DLineBytes = size_t{256} << 20;

std::string Join(const std::string& dir, const std::string& name) {
  return (fs::path(dir) / name).string();
}

// ---------------------------------------------------------------------------------------
// Text

bool IsSkippable(std::string_view line) {
  size_t i = 0;
  while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
  return i == line.size() || line[i] == '#';
}

sensors::Camera ParseCameraFields(const std::string& file, int64_t line_no,
                                  const std::string& model_name, int64_t camera_id,
                                  uint64_t width, uint64_t height,
                                  const std::vector<double>& params) {
  sensors::Camera camera;
  camera.camera_id = CameraId(static_cast<uint64_t>(camera_id));
  camera.model_id = sensors::CameraModelFromName(model_name);
  if (camera.model_id == sensors::CameraModelId::kInvalid) {
    throw InputError(file, line_no, "MODEL", model_name,
                     "one of " + sensors::KnownCameraModelNames());
  }
  const int expected = sensors::CameraModelNumParams(camera.model_id);
  if (static_cast<int>(params.size()) != expected) {
    throw InputError(file, line_no, "PARAMS[]", std::to_string(params.size()) + " values",
                     std::to_string(expected) + " values for " + model_name + " (" +
                         sensors::CameraModelParamsInfo(camera.model_id) + ")");
  }
  if (width == 0 || height == 0 || width > kMaxImageSidePx || height > kMaxImageSidePx) {
    throw InputError(file, line_no, "WIDTH/HEIGHT",
                     std::to_string(width) + "x" + std::to_string(height),
                     "an image size of 1 to " + std::to_string(kMaxImageSidePx) + " px a side");
  }
  camera.width = width;
  camera.height = height;
  camera.params = params;
  return camera;
}

// Calls on_record(tokens, cursor) for each line of the text file `path` that is neither
// blank nor a comment, once it has at least `min_tokens` tokens (`fields` names them).
template <typename OnRecord>
void ForEachTextRecord(const std::string& path, size_t max_line_bytes, size_t min_tokens,
                       const std::string& fields, OnRecord on_record) {
  const std::string text = ReadWholeFile(path);
  LineCursor cursor(text, path, max_line_bytes);
  std::string_view line;
  while (cursor.Next(&line)) {
    if (IsSkippable(line)) continue;
    TokenLine tokens(path, cursor.line_number(), line);
    tokens.ExpectAtLeast(min_tokens, fields);
    on_record(tokens, cursor);
  }
}

// Adds `value` under `key`; a key already present fails at the line of `tokens`, naming
// `field` = id.
template <typename Map, typename Key, typename Value>
void EmplaceUnique(Map* map, const Key& key, Value&& value, const TokenLine& tokens,
                   const char* field, uint64_t id) {
  if (!map->emplace(key, std::forward<Value>(value)).second) {
    tokens.Fail(field, std::to_string(id), "a unique id (it appears twice)");
  }
}

void ReadCamerasText(const std::string& path, ColmapModel* model) {
  ForEachTextRecord(path, kMaxLineBytes, 4, "CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]",
                    [&](const TokenLine& tokens, LineCursor& cursor) {
    const uint64_t id = tokens.UInt(0, "CAMERA_ID");
    const std::string& model_name = tokens.Str(1, "MODEL");
    const uint64_t width = tokens.UInt(2, "WIDTH");
    const uint64_t height = tokens.UInt(3, "HEIGHT");
    std::vector<double> params;
    for (size_t i = 4; i < tokens.size(); ++i) {
      params.push_back(tokens.Double(i, "PARAMS[" + std::to_string(i - 4) + "]"));
    }
    if (id > std::numeric_limits<uint32_t>::max()) {
      tokens.Fail("CAMERA_ID", std::to_string(id), "an id < 2^32");
    }
    sensors::Camera camera = ParseCameraFields(path, cursor.line_number(), model_name,
                                               static_cast<int64_t>(id), width, height, params);
    EmplaceUnique(&model->cameras, camera.camera_id, camera, tokens, "CAMERA_ID", id);
  });
}

void ReadImagesText(const std::string& path, ColmapModel* model) {
  ForEachTextRecord(path, kMaxPoints2DLineBytes, 10, "IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME",
                    [&](const TokenLine& tokens, LineCursor& cursor) {
    ColmapImage image;
    const uint64_t id = tokens.UInt(0, "IMAGE_ID");
    if (id > std::numeric_limits<uint32_t>::max()) {
      tokens.Fail("IMAGE_ID", std::to_string(id), "an id < 2^32");
    }
    image.image_id = ImageId(id);
    const double qw = tokens.Double(1, "QW");
    const double qx = tokens.Double(2, "QX");
    const double qy = tokens.Double(3, "QY");
    const double qz = tokens.Double(4, "QZ");
    const Eigen::Quaterniond q(qw, qx, qy, qz);
    if (!(q.norm() > 1e-12)) tokens.Fail("QW QX QY QZ", "a zero quaternion", "a rotation");
    // Keep the stored coefficients exactly as read (no normalisation) for exact round trips.
    image.cam_from_world.rotation = q;
    image.cam_from_world.translation =
        Eigen::Vector3d(tokens.Double(5, "TX"), tokens.Double(6, "TY"), tokens.Double(7, "TZ"));
    image.camera_id = CameraId(tokens.UInt(8, "CAMERA_ID"));
    // The name is the rest of the line (COLMAP names may not contain spaces, but keep them).
    image.name = tokens.Name(9, "NAME");
    for (size_t i = 10; i < tokens.size(); ++i) image.name += " " + tokens.Name(i, "NAME");

    // The next line holds the 2-D points, even when empty.
    std::string_view points_line;
    if (!cursor.Next(&points_line)) {
      throw InputError(path, cursor.line_number() + 1, "POINTS2D[]", "end of file",
                       "a line of (X, Y, POINT3D_ID) triples after image " +
                           std::to_string(id));
    }
    TokenLine points(path, cursor.line_number(), points_line);
    if (points.size() % 3 != 0) {
      points.Fail("POINTS2D[]", std::to_string(points.size()) + " values",
                  "a multiple of 3 values (X Y POINT3D_ID)");
    }
    const size_t n = points.size() / 3;
    image.points2D.reserve(n);
    image.point3D_ids.reserve(n);
    for (size_t k = 0; k < n; ++k) {
      const std::string idx = "[" + std::to_string(k) + "]";
      image.points2D.emplace_back(points.Double(3 * k, "POINTS2D" + idx + ".X"),
                                  points.Double(3 * k + 1, "POINTS2D" + idx + ".Y"));
      const int64_t point3D_id = points.Int(3 * k + 2, "POINTS2D" + idx + ".POINT3D_ID");
      if (point3D_id < -1) {
        points.Fail("POINTS2D" + idx + ".POINT3D_ID", std::to_string(point3D_id),
                    "-1 (none) or a non-negative id");
      }
      image.point3D_ids.push_back(point3D_id == -1 ? Point3DId()
                                                   : Point3DId(static_cast<uint64_t>(point3D_id)));
    }
    const ImageId image_id = image.image_id;
    EmplaceUnique(&model->images, image_id, std::move(image), tokens, "IMAGE_ID", id);
  });
}

void ReadPoints3DText(const std::string& path, ColmapModel* model) {
  ForEachTextRecord(path, kMaxPoints2DLineBytes, 8, "POINT3D_ID X Y Z R G B ERROR TRACK[]",
                    [&](const TokenLine& tokens, LineCursor&) {
    ColmapPoint3D point;
    const uint64_t id = tokens.UInt(0, "POINT3D_ID");
    point.point3D_id = Point3DId(id);
    point.xyz = Eigen::Vector3d(tokens.Double(1, "X"), tokens.Double(2, "Y"),
                                tokens.Double(3, "Z"));
    const char* rgb[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      const uint64_t v = tokens.UInt(4 + c, rgb[c]);
      if (v > 255) tokens.Fail(rgb[c], std::to_string(v), "an integer 0..255");
      point.color[c] = static_cast<uint8_t>(v);
    }
    point.error = tokens.Double(7, "ERROR");
    if ((tokens.size() - 8) % 2 != 0) {
      tokens.Fail("TRACK[]", std::to_string(tokens.size() - 8) + " values",
                  "pairs of IMAGE_ID POINT2D_IDX");
    }
    for (size_t k = 8; k + 1 < tokens.size(); k += 2) {
      const std::string idx = "TRACK[" + std::to_string((k - 8) / 2) + "]";
      ColmapTrackElement element;
      element.image_id = ImageId(tokens.UInt(k, idx + ".IMAGE_ID"));
      const uint64_t p2d = tokens.UInt(k + 1, idx + ".POINT2D_IDX");
      if (p2d > std::numeric_limits<uint32_t>::max()) {
        tokens.Fail(idx + ".POINT2D_IDX", std::to_string(p2d), "an index < 2^32");
      }
      element.point2D_idx = static_cast<uint32_t>(p2d);
      point.track.push_back(element);
    }
    const Point3DId point3D_id = point.point3D_id;
    EmplaceUnique(&model->points3D, point3D_id, std::move(point), tokens, "POINT3D_ID", id);
  });
}

// ---------------------------------------------------------------------------------------
// Binary (little endian, as COLMAP writes on every platform it supports)

class BinaryCursor {
 public:
  BinaryCursor(std::string path, std::string data) : path_(std::move(path)), data_(std::move(data)) {}

  template <typename T>
  T Read(const std::string& field) {
    if (data_.size() - offset_ < sizeof(T)) {
      throw InputError::AtByte(path_, offset_, field,
                               "end of file (" + std::to_string(data_.size() - offset_) +
                                   " bytes left)",
                               std::to_string(sizeof(T)) + " more bytes (file truncated?)");
    }
    T value;
    std::memcpy(&value, data_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }

  double ReadFinite(const std::string& field) {
    const uint64_t at = offset_;
    const double v = Read<double>(field);
    if (!std::isfinite(v)) {
      std::ostringstream s;
      s << v;
      throw InputError::AtByte(path_, at, field, s.str(), "a finite number");
    }
    return v;
  }

  std::string ReadString(const std::string& field) {
    const size_t end = data_.find('\0', offset_);
    if (end == std::string::npos) {
      throw InputError::AtByte(path_, offset_, field, "end of file",
                               "a NUL-terminated string (file truncated?)");
    }
    std::string s = data_.substr(offset_, end - offset_);
    offset_ = end + 1;
    return s;
  }

  /// Fails unless `count` records of at least `min_record_bytes` can still follow.
  void CheckCount(uint64_t count, size_t min_record_bytes, const std::string& field,
                  uint64_t at) const {
    const uint64_t remaining = data_.size() - offset_;
    if (min_record_bytes > 0 && count > remaining / min_record_bytes) {
      throw InputError::AtByte(path_, at, field, std::to_string(count),
                               "at most " + std::to_string(remaining / min_record_bytes) +
                                   " records in the " + std::to_string(remaining) +
                                   " bytes that follow (wrong count or truncated file)");
    }
  }

  /// A record count (`field`, uint64), checked by CheckCount against the bytes that follow.
  uint64_t ReadCount(const std::string& field, size_t min_record_bytes) {
    const uint64_t at = offset_;
    const uint64_t count = Read<uint64_t>(field);
    CheckCount(count, min_record_bytes, field, at);
    return count;
  }

  void ExpectEnd() const {
    if (offset_ != data_.size()) {
      throw InputError::AtByte(path_, offset_, "end of file",
                               std::to_string(data_.size() - offset_) + " extra bytes",
                               "no data after the last record");
    }
  }

  uint64_t offset() const { return offset_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string data_;
  uint64_t offset_ = 0;
};

// Adds `value` under `key`; a key already present fails at byte `record_at` of `path`,
// naming `field` = id.
template <typename Map, typename Key, typename Value>
void EmplaceUniqueAt(Map* map, const Key& key, Value&& value, const std::string& path,
                     uint64_t record_at, const char* field, uint64_t id) {
  if (!map->emplace(key, std::forward<Value>(value)).second) {
    throw InputError::AtByte(path, record_at, field, std::to_string(id),
                             "a unique id (it appears twice)");
  }
}

void ReadCamerasBinary(const std::string& path, ColmapModel* model) {
  BinaryCursor in(path, ReadWholeFile(path));
  const uint64_t num_cameras = in.ReadCount("num_cameras", 4 + 4 + 8 + 8);
  for (uint64_t i = 0; i < num_cameras; ++i) {
    const uint64_t record_at = in.offset();
    const uint32_t camera_id = in.Read<uint32_t>("camera_id");
    const uint64_t model_at = in.offset();
    const int32_t model_int = in.Read<int32_t>("model_id");
    const uint64_t width = in.Read<uint64_t>("width");
    const uint64_t height = in.Read<uint64_t>("height");
    sensors::Camera camera;
    camera.camera_id = CameraId(camera_id);
    camera.model_id = sensors::CameraModelFromInt(model_int);
    if (camera.model_id == sensors::CameraModelId::kInvalid) {
      throw InputError::AtByte(path, model_at, "model_id", std::to_string(model_int),
                               "a known model id (" + sensors::KnownCameraModelNames() + ")");
    }
    if (width == 0 || height == 0 || width > kMaxImageSidePx || height > kMaxImageSidePx) {
      throw InputError::AtByte(path, record_at, "width/height",
                               std::to_string(width) + "x" + std::to_string(height),
                               "an image size of 1 to " + std::to_string(kMaxImageSidePx) + " px a side");
    }
    camera.width = width;
    camera.height = height;
    const int num_params = sensors::CameraModelNumParams(camera.model_id);
    for (int k = 0; k < num_params; ++k) {
      camera.params.push_back(in.ReadFinite("params[" + std::to_string(k) + "]"));
    }
    EmplaceUniqueAt(&model->cameras, camera.camera_id, camera, path, record_at, "camera_id",
                    camera_id);
  }
  in.ExpectEnd();
}

void ReadImagesBinary(const std::string& path, ColmapModel* model) {
  BinaryCursor in(path, ReadWholeFile(path));
  const uint64_t num_images = in.ReadCount("num_reg_images", 4 + 7 * 8 + 4 + 1 + 8);
  for (uint64_t i = 0; i < num_images; ++i) {
    const uint64_t record_at = in.offset();
    ColmapImage image;
    image.image_id = ImageId(in.Read<uint32_t>("image_id"));
    const double qw = in.ReadFinite("qvec.w");
    const double qx = in.ReadFinite("qvec.x");
    const double qy = in.ReadFinite("qvec.y");
    const double qz = in.ReadFinite("qvec.z");
    const Eigen::Quaterniond q(qw, qx, qy, qz);
    if (!(q.norm() > 1e-12)) {
      throw InputError::AtByte(path, record_at + 4, "qvec", "a zero quaternion", "a rotation");
    }
    image.cam_from_world.rotation = q;
    for (int k = 0; k < 3; ++k) {
      image.cam_from_world.translation[k] = in.ReadFinite("tvec[" + std::to_string(k) + "]");
    }
    image.camera_id = CameraId(in.Read<uint32_t>("camera_id"));
    const uint64_t name_at = in.offset();
    image.name = in.ReadString("name");
    if (const size_t bad = InvalidUtf8Offset(image.name); bad != std::string::npos) {
      throw InputError::AtByte(path, name_at + bad, "name", "invalid UTF-8 at byte " + std::to_string(bad) + " of the name",
                               "UTF-8 text");
    }
    const uint64_t points_at = in.offset();
    const uint64_t num_points2D = in.Read<uint64_t>("num_points2D");
    in.CheckCount(num_points2D, 8 + 8 + 8, "num_points2D", points_at);
    image.points2D.reserve(num_points2D);
    image.point3D_ids.reserve(num_points2D);
    for (uint64_t k = 0; k < num_points2D; ++k) {
      const double x = in.ReadFinite("points2D.x");
      const double y = in.ReadFinite("points2D.y");
      const uint64_t id = in.Read<uint64_t>("points2D.point3D_id");
      image.points2D.emplace_back(x, y);
      image.point3D_ids.push_back(id == kInvalidPoint3D ? Point3DId() : Point3DId(id));
    }
    const ImageId image_id = image.image_id;
    EmplaceUniqueAt(&model->images, image_id, std::move(image), path, record_at, "image_id",
                    image_id.value);
  }
  in.ExpectEnd();
}

void ReadPoints3DBinary(const std::string& path, ColmapModel* model) {
  BinaryCursor in(path, ReadWholeFile(path));
  const uint64_t num_points = in.ReadCount("num_points3D", 8 + 3 * 8 + 3 + 8 + 8);
  for (uint64_t i = 0; i < num_points; ++i) {
    const uint64_t record_at = in.offset();
    ColmapPoint3D point;
    const uint64_t id = in.Read<uint64_t>("point3D_id");
    if (id == kInvalidPoint3D) {
      throw InputError::AtByte(path, record_at, "point3D_id", "-1", "a non-negative id");
    }
    point.point3D_id = Point3DId(id);
    for (int k = 0; k < 3; ++k) point.xyz[k] = in.ReadFinite("xyz");
    for (int k = 0; k < 3; ++k) point.color[k] = in.Read<uint8_t>("rgb");
    point.error = in.ReadFinite("error");
    const uint64_t track_at = in.offset();
    const uint64_t track_length = in.Read<uint64_t>("track_length");
    in.CheckCount(track_length, 8, "track_length", track_at);
    point.track.reserve(track_length);
    for (uint64_t k = 0; k < track_length; ++k) {
      ColmapTrackElement element;
      element.image_id = ImageId(in.Read<uint32_t>("track.image_id"));
      element.point2D_idx = in.Read<uint32_t>("track.point2D_idx");
      point.track.push_back(element);
    }
    const Point3DId point3D_id = point.point3D_id;
    EmplaceUniqueAt(&model->points3D, point3D_id, std::move(point), path, record_at,
                    "point3D_id", id);
  }
  in.ExpectEnd();
}

// ---------------------------------------------------------------------------------------
// Validation of cross references (the same for both formats).

void Validate(const std::string& dir, ColmapFormat format, const ColmapModel& model) {
  const std::string ext = format == ColmapFormat::kText ? ".txt" : ".bin";
  const std::string images_file = Join(dir, "images" + ext);
  const std::string points_file = Join(dir, "points3D" + ext);
  for (const auto& [image_id, image] : model.images) {
    if (!model.cameras.count(image.camera_id)) {
      throw InputError::Message(
          images_file, "image " + std::to_string(image_id.value) + " ('" + image.name +
                           "'): field 'CAMERA_ID': found " +
                           std::to_string(image.camera_id.value) +
                           ", expected the id of a camera in cameras" + ext);
    }
    for (size_t k = 0; k < image.point3D_ids.size(); ++k) {
      const Point3DId id = image.point3D_ids[k];
      if (id.IsValid() && !model.points3D.count(id)) {
        throw InputError::Message(
            images_file, "image " + std::to_string(image_id.value) + ", point2D " +
                             std::to_string(k) + ": field 'POINT3D_ID': found " +
                             std::to_string(id.value) + ", expected -1 or a point of points3D" +
                             ext);
      }
    }
  }
  for (const auto& [point_id, point] : model.points3D) {
    const std::string where = "point " + std::to_string(point_id.value);
    for (const ColmapTrackElement& element : point.track) {
      const auto it = model.images.find(element.image_id);
      if (it == model.images.end()) {
        throw InputError::Message(points_file,
                                  where + ": field 'TRACK.IMAGE_ID': found " +
                                      std::to_string(element.image_id.value) +
                                      ", expected the id of an image in images" + ext);
      }
      if (element.point2D_idx >= it->second.points2D.size()) {
        throw InputError::Message(
            points_file, where + ": field 'TRACK.POINT2D_IDX': found " +
                             std::to_string(element.point2D_idx) + ", expected an index < " +
                             std::to_string(it->second.points2D.size()) + " (points of image " +
                             std::to_string(element.image_id.value) + ")");
      }
      if (it->second.point3D_ids[element.point2D_idx] != point_id) {
        throw InputError::Message(
            points_file, where + ": track element (image " +
                             std::to_string(element.image_id.value) + ", point2D " +
                             std::to_string(element.point2D_idx) +
                             "): that point2D names point3D " +
                             (it->second.point3D_ids[element.point2D_idx].IsValid()
                                  ? std::to_string(it->second.point3D_ids[element.point2D_idx].value)
                                  : std::string("-1")) +
                             " in images" + ext + ", expected " +
                             std::to_string(point_id.value));
      }
    }
  }
}

// ---------------------------------------------------------------------------------------
// Writers

void WriteCamerasText(const ColmapModel& model, std::ostream& out) {
  out << "# Camera list with one line of data per camera:\n";
  out << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  out << "# Number of cameras: " << model.cameras.size() << "\n";
  out << std::setprecision(17);
  for (const auto& [id, camera] : model.cameras) {
    out << id.value << " " << camera.ModelName() << " " << camera.width << " " << camera.height;
    for (double p : camera.params) out << " " << p;
    out << "\n";
  }
}

void WriteImagesText(const ColmapModel& model, std::ostream& out) {
  size_t num_observations = 0;
  for (const auto& [id, image] : model.images) {
    for (const Point3DId& p : image.point3D_ids) num_observations += p.IsValid() ? 1 : 0;
  }
  out << "# Image list with two lines of data per image:\n";
  out << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n";
  out << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  out << "# Number of images: " << model.images.size()
      << ", mean observations per image: "
      << (model.images.empty() ? 0.0
                               : static_cast<double>(num_observations) / model.images.size())
      << "\n";
  out << std::setprecision(17);
  for (const auto& [id, image] : model.images) {
    const Eigen::Quaterniond& q = image.cam_from_world.rotation;
    const Eigen::Vector3d& t = image.cam_from_world.translation;
    out << id.value << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " "
        << t.x() << " " << t.y() << " " << t.z() << " " << image.camera_id.value << " "
        << image.name << "\n";
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      if (k > 0) out << " ";
      out << image.points2D[k].x() << " " << image.points2D[k].y() << " ";
      if (image.point3D_ids[k].IsValid()) {
        out << image.point3D_ids[k].value;
      } else {
        out << -1;
      }
    }
    out << "\n";
  }
}

void WritePoints3DText(const ColmapModel& model, std::ostream& out) {
  double mean_track = 0.0;
  for (const auto& [id, point] : model.points3D) mean_track += point.track.size();
  if (!model.points3D.empty()) mean_track /= model.points3D.size();
  out << "# 3D point list with one line of data per point:\n";
  out << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n";
  out << "# Number of points: " << model.points3D.size()
      << ", mean track length: " << mean_track << "\n";
  out << std::setprecision(17);
  for (const auto& [id, point] : model.points3D) {
    out << id.value << " " << point.xyz.x() << " " << point.xyz.y() << " " << point.xyz.z()
        << " " << static_cast<int>(point.color[0]) << " " << static_cast<int>(point.color[1])
        << " " << static_cast<int>(point.color[2]) << " " << point.error;
    for (const ColmapTrackElement& element : point.track) {
      out << " " << element.image_id.value << " " << element.point2D_idx;
    }
    out << "\n";
  }
}

template <typename T>
void WriteBinary(std::ostream& out, const T& value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

void WriteCamerasBinary(const ColmapModel& model, std::ostream& out) {
  WriteBinary<uint64_t>(out, model.cameras.size());
  for (const auto& [id, camera] : model.cameras) {
    WriteBinary<uint32_t>(out, static_cast<uint32_t>(id.value));
    WriteBinary<int32_t>(out, static_cast<int32_t>(camera.model_id));
    WriteBinary<uint64_t>(out, camera.width);
    WriteBinary<uint64_t>(out, camera.height);
    for (double p : camera.params) WriteBinary<double>(out, p);
  }
}

void WriteImagesBinary(const ColmapModel& model, std::ostream& out) {
  WriteBinary<uint64_t>(out, model.images.size());
  for (const auto& [id, image] : model.images) {
    WriteBinary<uint32_t>(out, static_cast<uint32_t>(id.value));
    const Eigen::Quaterniond& q = image.cam_from_world.rotation;
    for (double v : {q.w(), q.x(), q.y(), q.z()}) WriteBinary<double>(out, v);
    for (int k = 0; k < 3; ++k) WriteBinary<double>(out, image.cam_from_world.translation[k]);
    WriteBinary<uint32_t>(out, static_cast<uint32_t>(image.camera_id.value));
    out.write(image.name.c_str(), image.name.size() + 1);
    WriteBinary<uint64_t>(out, image.points2D.size());
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      WriteBinary<double>(out, image.points2D[k].x());
      WriteBinary<double>(out, image.points2D[k].y());
      WriteBinary<uint64_t>(out, image.point3D_ids[k].IsValid() ? image.point3D_ids[k].value
                                                                : kInvalidPoint3D);
    }
  }
}

void WritePoints3DBinary(const ColmapModel& model, std::ostream& out) {
  WriteBinary<uint64_t>(out, model.points3D.size());
  for (const auto& [id, point] : model.points3D) {
    WriteBinary<uint64_t>(out, id.value);
    for (int k = 0; k < 3; ++k) WriteBinary<double>(out, point.xyz[k]);
    for (int k = 0; k < 3; ++k) WriteBinary<uint8_t>(out, point.color[k]);
    WriteBinary<double>(out, point.error);
    WriteBinary<uint64_t>(out, point.track.size());
    for (const ColmapTrackElement& element : point.track) {
      WriteBinary<uint32_t>(out, static_cast<uint32_t>(element.image_id.value));
      WriteBinary<uint32_t>(out, element.point2D_idx);
    }
  }
}

}  // namespace

size_t ColmapModel::NumObservations() const {
  size_t n = 0;
  for (const auto& [id, point] : points3D) n += point.track.size();
  return n;
}

ColmapFormat DetectColmapFormat(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError::Message(dir, "model folder not found (expected a folder holding "
                                   "cameras, images and points3D .txt or .bin)");
  }
  const bool has_bin = fs::exists(Join(dir, "cameras.bin"), ec);
  const bool has_txt = fs::exists(Join(dir, "cameras.txt"), ec);
  if (has_bin) return ColmapFormat::kBinary;
  if (has_txt) return ColmapFormat::kText;
  throw InputError::Message(dir, "holds neither cameras.bin nor cameras.txt: not a COLMAP "
                                 "sparse model folder");
}

ColmapModel ReadColmapText(const std::string& dir) {
  ColmapModel model;
  ReadCamerasText(Join(dir, "cameras.txt"), &model);
  ReadImagesText(Join(dir, "images.txt"), &model);
  ReadPoints3DText(Join(dir, "points3D.txt"), &model);
  Validate(dir, ColmapFormat::kText, model);
  return model;
}

ColmapModel ReadColmapBinary(const std::string& dir) {
  ColmapModel model;
  ReadCamerasBinary(Join(dir, "cameras.bin"), &model);
  ReadImagesBinary(Join(dir, "images.bin"), &model);
  ReadPoints3DBinary(Join(dir, "points3D.bin"), &model);
  Validate(dir, ColmapFormat::kBinary, model);
  return model;
}

ColmapModel ReadColmapModel(const std::string& dir, ColmapFormat* format) {
  const ColmapFormat detected = DetectColmapFormat(dir);
  if (format) *format = detected;
  return detected == ColmapFormat::kText ? ReadColmapText(dir) : ReadColmapBinary(dir);
}

void WriteColmapModel(const ColmapModel& model, const std::string& dir, ColmapFormat format) {
  AtomicFileSet files;
  if (format == ColmapFormat::kText) {
    files.Add(Join(dir, "cameras.txt"), [&](std::ostream& o) { WriteCamerasText(model, o); });
    files.Add(Join(dir, "images.txt"), [&](std::ostream& o) { WriteImagesText(model, o); });
    files.Add(Join(dir, "points3D.txt"), [&](std::ostream& o) { WritePoints3DText(model, o); });
  } else {
    files.Add(Join(dir, "cameras.bin"), [&](std::ostream& o) { WriteCamerasBinary(model, o); },
              true);
    files.Add(Join(dir, "images.bin"), [&](std::ostream& o) { WriteImagesBinary(model, o); },
              true);
    files.Add(Join(dir, "points3D.bin"),
              [&](std::ostream& o) { WritePoints3DBinary(model, o); }, true);
  }
  files.Commit();
}

}  // namespace mmba::io
