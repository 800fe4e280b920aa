#pragma once

// Point clouds as mmba reads and writes them. Readers (all in library mmba_io_cloud, no PCL):
//   PLY  ascii / binary_little_endian / binary_big_endian; vertex properties x y z (any
//        numeric type), optional nx ny nz (or normal_x …), intensity / scalar_intensity /
//        reflectance, red green blue (or diffuse_red …); other elements are skipped.
//   PCD  v0.7 ascii / binary / binary_compressed (LZF, io_cloud/lzf.h); fields x y z,
//        normal_x…, intensity (or i / reflectivity / reflectance, any type and size), ring (or
//        laser_id, an integer type), rgb / rgba (packed); other fields (a timestamp, …) are
//        skipped. VIEWPOINT is not applied (as PCL's loadPCDFile).
//   XYZ  text (.xyz .txt .csv .pts): whitespace or comma separated; an optional first line
//        of column names (x y z nx ny nz intensity r g b …); without names the column count
//        decides: 3 = xyz, 4 = xyz intensity, 6 = xyz rgb if the 3 extra values are integers
//        in 0..255 else xyz normal, 7 = xyz intensity rgb, 9 = xyz rgb normal.
//        Lines starting with '#' or '//' are comments; a first line holding one integer
//        (PTS point count) is skipped.
//   LAS  1.2–1.4 uncompressed, point data formats 0–3 and 6–8, with scale and offset
//        (a small reader written here: Debian packages no LAS library). LAZ is refused.
//        ReadLas also returns the WKT CRS and named extra-byte fields (LasInfo); the LAS 1.4
//        writer is io_cloud/las_writer.h.
//   BIN  KITTI velodyne (.bin): float32 little-endian x y z reflectance per point.
//        nuScenes (.pcd.bin): float32 little-endian x y z intensity ring per point.
// Non-finite coordinates are an InputError unless ReadOptions::skip_invalid_points, which
// drops them (PCD's organised clouds mark missing returns with NaN x y z).

#include <array>
#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/local_origin.h"

namespace mmba::io {

/// A point cloud in one frame. Optional attributes are either empty or have one entry per
/// point.
struct PointCloud {
  std::vector<Eigen::Vector3d> points;              ///< metres
  std::vector<Eigen::Vector3d> normals;             ///< unit, optional
  std::vector<float> intensity;                     ///< optional (LiDAR reflectance, 0..1 or raw)
  std::vector<std::array<uint8_t, 3>> colors;       ///< optional RGB
  /// Optional acquisition time per point [s] (PLY `time` / `gps_time` / `timestamp`, LAS
  /// GPS time): what a mobile-mapping cloud needs to be re-georeferenced along its trajectory.
  std::vector<double> time;
  /// Optional laser (beam) index per point: PCD `ring` / `laser_id`, nuScenes' fifth value.
  std::vector<uint16_t> ring;

  size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_intensity() const { return !intensity.empty(); }
  bool has_colors() const { return !colors.empty(); }
  bool has_time() const { return !time.empty(); }
  bool has_ring() const { return !ring.empty(); }
};

/// How readers treat doubtful content.
struct ReadOptions {
  /// false: a point with a NaN/Inf coordinate (or normal) is an InputError naming where it
  /// is. true: such points are dropped (counted in ReadStats::num_skipped).
  bool skip_invalid_points = false;
};

/// What a reader found, for logging.
struct ReadStats {
  std::string format;         ///< "ply-ascii", "ply-binary-le", "pcd-binary-compressed", "las-1.4-fmt6", …
  size_t num_read = 0;        ///< points kept
  size_t num_skipped = 0;     ///< points dropped by skip_invalid_points
};

/// `cloud` without the points marked in `marked` (one flag per point; every per-point
/// attribute kept in step).
PointCloud WithoutMarked(const PointCloud& cloud, const std::vector<char>& marked);

/// MedianCentre and LocalOrigin of a point set (geometry/local_origin.h).
using mmba::LocalOrigin;
using mmba::MedianCentre;

/// Reads a cloud, choosing the reader from the extension (.ply, .pcd, .xyz/.txt/.csv/.pts,
/// .las, .pcd.bin = nuScenes, any other .bin = KITTI velodyne). Throws InputError naming the
/// file (and line or byte) on bad input: missing file, bad header, truncated data,
/// non-finite values (unless skipped).
PointCloud ReadPointCloud(const std::string& path);
PointCloud ReadPointCloud(const std::string& path, const ReadOptions& options,
                          ReadStats* stats = nullptr);

PointCloud ReadPly(const std::string& path);
PointCloud ReadPly(const std::string& path, const ReadOptions& options,
                   ReadStats* stats = nullptr);
PointCloud ReadPcd(const std::string& path, const ReadOptions& options = {},
                   ReadStats* stats = nullptr);
PointCloud ReadXyz(const std::string& path, const ReadOptions& options = {},
                   ReadStats* stats = nullptr);
/// A named per-point scalar of a LAS file, described in its Extra Bytes VLR (user id
/// "LASF_Spec", record id 4; LAS 1.4 R15, Table 24): a signed distance `distance_m`, a σ.
struct LasExtraField {
  std::string name;            ///< at most 32 characters, e.g. "distance_m"
  std::string description;     ///< at most 32 characters, e.g. "signed distance to the mesh"
  bool is_double = false;      ///< stored as float64 (data type 10), else float32 (type 9)
  std::vector<double> values;  ///< one per point (scale and offset of the descriptor applied)
};

/// What a LAS file holds besides a PointCloud's attributes.
struct LasInfo {
  /// OGC WKT of the "LASF_Projection" record 2112 (VLR or EVLR); empty when there is none.
  std::string crs_wkt;
  /// The extra-byte fields of a numeric type (1–10) in record order, values kept in step with
  /// the points read (skipped points dropped). Undocumented bytes (type 0) are not returned.
  std::vector<LasExtraField> extra_fields;
  std::string system_identifier;    ///< header bytes 26–57, trailing NULs removed
  std::string generating_software;  ///< header bytes 58–89, trailing NULs removed
  uint16_t global_encoding = 0;     ///< header bytes 6–7 (bit 4: the CRS is WKT)
  int point_format = 0;             ///< point data record format, 0–3 or 6–8
  Eigen::Vector3d scale = Eigen::Vector3d::Zero();   ///< x y z scale factors [m]
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< x y z offsets [m]

  /// The extra field named `name`, or nullptr.
  const LasExtraField* Field(const std::string& name) const;
};

/// LAS: intensity is the raw 16-bit value; 16-bit colours are reduced to 8 bits (>> 8)
/// unless every stored value is <= 255 (writers that store 8-bit colour in 16-bit fields).
/// `info`, when given, receives the CRS WKT, the named extra-byte fields and the header's
/// identification (io_cloud/las_writer.h writes them).
PointCloud ReadLas(const std::string& path, const ReadOptions& options = {},
                   ReadStats* stats = nullptr, LasInfo* info = nullptr);
PointCloud ReadKittiBin(const std::string& path, const ReadOptions& options = {},
                        ReadStats* stats = nullptr);
/// nuScenes LiDAR sweep (`*.pcd.bin`): 5 float32 per point, x y z intensity ring index; the
/// ring goes to PointCloud::ring. InputError naming the file and its size unless the size is
/// a multiple of 20 bytes, or when a ring is not an integer in 0..65535.
PointCloud ReadNuScenesBin(const std::string& path, const ReadOptions& options = {},
                           ReadStats* stats = nullptr);

/// Called with consecutive chunks of a cloud: `first_index` is the index of the chunk's first
/// point in the file, `total` the number of points the file declares.
using ChunkConsumer = std::function<void(const PointCloud& chunk, size_t first_index, size_t total)>;

/// Reads a cloud in chunks of at most `chunk_points` points, in file order. Binary PLY with a
/// fixed-size vertex record is read from disk one chunk at a time (memory bounded by the
/// chunk, whatever the file's size); every other format is read whole first and then handed
/// over in chunks. Same errors as ReadPointCloud; `stats` as for the whole file.
void StreamPointCloud(const std::string& path, size_t chunk_points, const ChunkConsumer& consume,
                      const ReadOptions& options = {}, ReadStats* stats = nullptr);

/// The PLY header WritePly writes for `n` points with the attributes `like` has (its points
/// are not written), and the binary records of `chunk`: a cloud written in pieces is
/// WritePlyHeader(out, n, like) followed by AppendPlyRecords(out, chunk) for chunks totalling n.
void WritePlyHeader(std::ostream& out, size_t n, const PointCloud& like);
void AppendPlyRecords(std::ostream& out, const PointCloud& chunk);

/// Writes PLY (binary little endian unless `ascii`), with every attribute the cloud has,
/// atomically (temp + rename). Coordinates are written as `double x y z` (survey
/// coordinates lose millimetres in float32), normals as `float nx ny nz`, intensity as
/// `float intensity`, colours as `uchar red green blue`.
void WritePly(const PointCloud& cloud, const std::string& path, bool ascii = false);

}  // namespace mmba::io
