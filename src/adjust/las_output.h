// LAS 1.4 copies of the adjustment's output clouds (io_cloud/las_writer.h) in the project's
// output CRS, written beside each PLY with the same stem. Private to mmba_adjust.
//
// The output CRS of a cloud:
// - with `crs`: the project's CRS (geodesy::CrsFrame::CrsFromWorld, as points.csv's CRS
//   columns), its OGC WKT 1 in the LAS CRS record; heights the CRS's (Crs::height_kind);
// - without `crs` (a WGS84 origin): WGS 84 / UTM in the origin's zone (EPSG:326zz north,
//   327zz south; UPS EPSG:32661/32761 at the poles) for every point, also across a zone
//   border, with ellipsoidal heights (WGS84) as z;
// - with `frame: cartesian`: the world frame as it is, without a CRS record.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "internal.h"
#include "mmba/io_cloud/las_writer.h"
#include "mmba/io_cloud/point_cloud.h"

namespace mmba::adjust::internal {

/// World coordinates → the project's output CRS for clouds.
class LasOutputFrame {
 public:
  explicit LasOutputFrame(const JointState& s);

  /// The point in the output CRS (easting, northing, height; a geographic CRS: longitude,
  /// latitude in degrees, height).
  Eigen::Vector3d FromWorld(const Eigen::Vector3d& point_in_world) const;
  /// `cloud` with its points in the output CRS (attributes unchanged).
  io::PointCloud FromWorld(const io::PointCloud& cloud) const;
  /// The writer's options: 1 mm resolution, the CRS's WKT 1 ("" in a local frame); a geographic
  /// CRS stores degrees at 1e-8 deg (about 1 mm).
  io::LasWriteOptions Options() const;
  /// For report.json `files`: "EPSG:25832 (ETRS89 / UTM zone 32N), heights as given".
  const std::string& Description() const { return description_; }

 private:
  const JointState* s_;
  std::optional<geodesy::CrsFrame> crs_;
  int utm_zone_ = -1;  ///< without crs: the origin's UTM zone (0 = UPS)
  bool local_ = false;
  bool geographic_ = false;
  std::string wkt_;
  std::string description_;
};

/// `ply_path` with the extension .las.
std::filesystem::path LasBeside(const std::filesystem::path& ply_path);

/// Writes `cloud_in_world` (points in the world frame) as LAS 1.4 beside `ply_path` in the
/// output CRS, with the named `extra` fields. Returns the file name.
std::string WriteLasBeside(const JointState& s, const io::PointCloud& cloud_in_world, const std::filesystem::path& ply_path,
                           const std::vector<io::LasExtraField>& extra = {});

/// An error map's LAS: the points of `error_map` (intensity = signed distance, m) with the
/// distance as the float32 extra field `distance_m` and no intensity.
std::string WriteErrorMapLas(const JointState& s, const io::PointCloud& error_map, const std::filesystem::path& ply_path,
                             const std::string& description);

/// report.json `files` entry of a LAS beside a PLY: `what` and the CRS.
nlohmann::json LasFileEntry(const JointState& s, const std::string& ply_name, const std::string& what);

}  // namespace mmba::adjust::internal
