#pragma once

// Shared pieces of the point-cloud readers (src/io_cloud/point_cloud_*.cc).

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>

#include "mmba/core/error.h"
#include "mmba/io_cloud/point_cloud.h"

namespace mmba::io::internal {

/// Scalar types of PLY and PCD fields.
enum class ScalarType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

size_t ScalarSize(ScalarType type);

/// Reads one scalar at `data` (no alignment needed), byte-swapping when `swap`.
double ReadScalar(const char* data, ScalarType type, bool swap);

/// True on a little-endian host.
inline bool HostIsLittleEndian() {
  const uint16_t probe = 1;
  uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

/// Appends points to a cloud, checking finiteness. `where` names the point for errors
/// (e.g. "file:12" or "file (byte 400)"); it is only built when needed.
class CloudBuilder {
 public:
  CloudBuilder(const std::string& file, const ReadOptions& options, bool normals,
               bool intensity, bool colors, size_t reserve, bool time = false);

  /// Index of the next point in the whole file (a streamed chunk starts past 0).
  void SetFirstIndex(size_t index) { seen_ = index; }

  /// Returns false if the point was skipped. `describe_location()` gives the error prefix.
  template <typename Describe>
  bool Add(const double xyz[3], const double* normal, float intensity, const uint8_t* rgb,
           Describe describe_location, double time = 0.0) {
    bool finite = std::isfinite(xyz[0]) && std::isfinite(xyz[1]) && std::isfinite(xyz[2]);
    if (finite && normal != nullptr) {
      finite = std::isfinite(normal[0]) && std::isfinite(normal[1]) && std::isfinite(normal[2]);
    }
    if (finite && has_intensity_) finite = std::isfinite(intensity);
    if (finite && has_time_) finite = std::isfinite(time);
    const size_t index = seen_++;
    if (!finite) {
      if (options_.skip_invalid_points) {
        ++skipped_;
        return false;
      }
      throw NonFiniteInput(InputError::Message(
          describe_location(), "point " + std::to_string(index) + ": " +
                                   NonFiniteFields(xyz, normal, intensity, time) +
                                   "; expected finite values (register-cloud --skip-invalid drops such points, "
                                   "e.g. the empty pixels of an organized depth-camera PCD)"));
    }
    cloud_.points.emplace_back(xyz[0], xyz[1], xyz[2]);
    if (has_normals_) cloud_.normals.emplace_back(normal[0], normal[1], normal[2]);
    if (has_intensity_) cloud_.intensity.push_back(intensity);
    if (has_colors_) cloud_.colors.push_back({rgb[0], rgb[1], rgb[2]});
    if (has_time_) cloud_.time.push_back(time);
    return true;
  }
  /// Names the non-finite fields of a point and their values, e.g. "non-finite z = nan".
  std::string NonFiniteFields(const double xyz[3], const double* normal, float intensity, double time) const {
    std::string out;
    auto name = [&out](const char* field, double v) {
      if (std::isfinite(v)) return;
      if (!out.empty()) out += ", ";
      out += std::string(field) + " = " + (std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf"));
    };
    name("x", xyz[0]);
    name("y", xyz[1]);
    name("z", xyz[2]);
    if (normal != nullptr) {
      name("nx", normal[0]);
      name("ny", normal[1]);
      name("nz", normal[2]);
    }
    if (has_intensity_) name("intensity", intensity);
    if (has_time_) name("time", time);
    return "non-finite " + out;
  }
  /// Keeps a ring (laser index) per point: AddRing after every Add that returned true.
  void EnableRing() { has_ring_ = true; cloud_.ring.reserve(cloud_.points.capacity()); }
  /// The ring of the point just added; InputError unless an integer in 0..65535.
  template <typename Describe>
  void AddRing(double ring, Describe describe_location) {
    if (!(ring >= 0.0 && ring <= 65535.0) || ring != std::floor(ring)) {
      throw InputError::Message(describe_location(), "ring " + std::to_string(ring) +
                                                         "; expected a laser index, an integer in 0..65535");
    }
    cloud_.ring.push_back(static_cast<uint16_t>(ring));
  }
  /// Counts a point that is dropped without a check (e.g. PCD NaN padding).
  void CountSkipped() { ++skipped_; }

  PointCloud Finish(const std::string& format, ReadStats* stats);

 private:
  std::string file_;
  ReadOptions options_;
  bool has_normals_, has_intensity_, has_colors_, has_time_;
  bool has_ring_ = false;
  size_t seen_ = 0;
  size_t skipped_ = 0;
  PointCloud cloud_;
};

std::string ToLower(std::string_view s);

/// A number written as text "nan" or "inf" in any case and sign (which the number parser
/// refuses): true with the value (NaN, +inf or -inf), so the finiteness check can name it.
inline bool NonFiniteText(std::string_view text, double* value) {
  const std::string lower = ToLower(text);
  if (lower.find("nan") != std::string::npos) {
    *value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (lower.find("inf") != std::string::npos) {
    *value = lower[0] == '-' ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  return false;
}

/// Streams a binary PLY from disk chunk by chunk (StreamPointCloud). Returns false, having
/// read nothing, when the file is not a binary PLY whose records up to the vertices have a
/// fixed size (the caller then reads it whole).
bool StreamBinaryPly(const std::string& path, size_t chunk_points, const ChunkConsumer& consume,
                     const ReadOptions& options, ReadStats* stats);

}  // namespace mmba::io::internal
