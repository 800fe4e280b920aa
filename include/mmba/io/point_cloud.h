#pragma once

// Point clouds as mmba reads and writes them. Readers: PLY (ASCII / binary little and big
// endian), PCD (through PCL, in the registration module's io), XYZ text, LAS 1.2–1.4.
// OWNED BY the registration work (issue 5): this header fixes the struct and the PLY
// functions every module uses; implementation in src/io/point_cloud*.cc.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace mmba::io {

/// A point cloud in one frame. Optional attributes are either empty or have one entry per
/// point.
struct PointCloud {
  std::vector<Eigen::Vector3d> points;              ///< metres
  std::vector<Eigen::Vector3d> normals;             ///< unit, optional
  std::vector<float> intensity;                     ///< optional (LiDAR reflectance, 0..1 or raw)
  std::vector<std::array<uint8_t, 3>> colors;       ///< optional RGB

  size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_intensity() const { return !intensity.empty(); }
  bool has_colors() const { return !colors.empty(); }
};

/// Reads a cloud, choosing the reader from the extension (.ply, .xyz/.txt/.csv, .las, .bin
/// = KITTI velodyne). Throws InputError naming the file (and line or byte) on bad input.
PointCloud ReadPointCloud(const std::string& path);

PointCloud ReadPly(const std::string& path);
/// Writes PLY (binary little endian unless `ascii`), with every attribute the cloud has,
/// atomically (temp + rename). Intensity is written as property `float intensity`.
void WritePly(const PointCloud& cloud, const std::string& path, bool ascii = false);

}  // namespace mmba::io
