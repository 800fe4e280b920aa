#pragma once

// LAS 1.4 writer (ASPRS LAS Specification 1.4 R15): point data record format 6, or 7 when the
// cloud has colours; coordinates as int32 with a scale (0.001 m) and an offset chosen from the
// data; the CRS as an OGC Coordinate System WKT VLR ("LASF_Projection", record 2112) with
// global encoding bit 4 set; named per-point scalars (a signed distance `distance_m`, a σ) as
// extra bytes described by an Extra Bytes VLR ("LASF_Spec", record 4). ReadLas
// (io_cloud/point_cloud.h) reads all of it back. io_cloud does not depend on geodesy: the
// caller passes the WKT (geodesy::Crs::wkt1()).
//
// What each point record holds: X Y Z, intensity (see LasWriteOptions::intensity_scale),
// return 1 of 1 (global encoding bit 3, synthetic return numbers, is set), classification 0
// (never classified), scan angle 0, point source 0, GPS time from PointCloud::time (0 without
// one), RGB (format 7: the 8-bit colour times 257, so 255 is 65535), then the extra fields.

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/io_cloud/point_cloud.h"

namespace mmba::io {

/// How WriteLas and LasStreamWriter encode a cloud.
struct LasWriteOptions {
  /// Coordinate resolution [m], the same for x, y and z; > 0. 0.001 keeps survey millimetres
  /// and spans ±2147 km around the offset (int32).
  double scale_m = 0.001;
  /// x y z offset [m]; empty: the minimum of the (first written) points rounded down to a
  /// whole metre, so the coordinates stored are small non-negative integers.
  std::optional<Eigen::Vector3d> offset_m;
  /// OGC WKT 1 of the cloud's CRS (geodesy::Crs::wkt1()); empty: no CRS record (a local frame).
  std::string crs_wkt;
  /// Stored intensity = round(intensity × intensity_scale) clamped to 0..65535. 0 chooses:
  /// 65535 when every intensity is within 0..1 (a reflectance, as KITTI's), else 1 (raw
  /// counts kept as they are, as ReadLas returns them). LasStreamWriter chooses from `like`.
  double intensity_scale = 0.0;
  /// Global encoding bit 0: PointCloud::time is Adjusted Standard GPS Time (GPS seconds since
  /// 1980-01-06 minus 1e9). false: GPS week time (seconds of the GPS week), or a time of the
  /// cloud's own whose epoch LAS cannot state.
  bool adjusted_standard_gps_time = false;

  /// False (with `error` naming the field, its value and the limit) when an option is invalid.
  bool Check(std::string* error) const;
};

/// Writes `cloud` with the named `extra` fields (each with one value per point) as LAS 1.4
/// to `path`, atomically (temporary + rename). Throws std::invalid_argument when an attribute
/// or extra field does not have one entry per point, an extra field's name is empty, longer
/// than 32 characters or repeated, the options fail Check(), or a point lies outside the
/// int32 range around the offset; std::runtime_error when the disk refuses.
void WriteLas(const PointCloud& cloud, const std::string& path, const LasWriteOptions& options = {},
              const std::vector<LasExtraField>& extra = {});

/// LAS 1.4 written in pieces, for clouds streamed chunk by chunk (mobile LiDAR): the
/// constructor writes a provisional header and the VLRs, Append writes point records, Finish
/// seeks back to the start and writes the header with the final counts and bounds. The stream
/// must be seekable (a file, as WriteFileAtomically's); the offset is taken from the first
/// chunk unless LasWriteOptions::offset_m gives it.
class LasStreamWriter {
 public:
  /// `like` says which attributes every chunk has (colours → format 7; time; intensity), and
  /// `extra_layout` the extra fields' names, descriptions and types (its values are unused).
  /// Same std::invalid_argument cases as WriteLas.
  LasStreamWriter(std::ostream* out, const PointCloud& like, const LasWriteOptions& options = {},
                  const std::vector<LasExtraField>& extra_layout = {});

  /// Writes the records of `chunk`; `extra` holds the same fields as the layout, in its order,
  /// each with one value per point of the chunk.
  void Append(const PointCloud& chunk, const std::vector<LasExtraField>& extra = {});

  /// Rewrites the header (counts, bounds, offset) and leaves the stream at its end.
  void Finish();

  uint64_t num_points() const { return num_points_; }

 private:
  void WriteHeader();

  std::ostream* out_;
  LasWriteOptions options_;
  bool has_colors_, has_time_, has_intensity_;
  std::vector<LasExtraField> layout_;
  double intensity_scale_ = 1.0;
  Eigen::Vector3d offset_ = Eigen::Vector3d::Zero();
  bool offset_set_ = false;
  uint32_t offset_to_points_ = 0;
  uint16_t record_length_ = 0;
  uint32_t num_vlrs_ = 0;
  uint64_t num_points_ = 0;
  Eigen::Vector3d min_, max_;
};

}  // namespace mmba::io
