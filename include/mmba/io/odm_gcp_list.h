// OpenDroneMap's ground-control file `gcp_list.txt`: control points with their image
// measurements in one file (ODM documentation, "Ground Control Points"; OpenDroneMap's
// opendm/gcp.py reads it the same way).
//
//   <projection>                 first non-comment line: EPSG:nnnn, a PROJ string, or
//                                "WGS84 UTM <zone><N|S>"
//   geo_x geo_y geo_z im_x im_y image_name [gcp_name] [extra ...]
//
// Fields are separated by blanks or tabs; '#' starts a comment. geo_x, geo_y, geo_z are in the
// projection's axis order as ODM uses it (easting, northing, height; for EPSG:4326 longitude,
// latitude in degrees, height). A control point is named by gcp_name; without one, ODM
// identifies a point by its coordinates, and so does this reader (ids gcp1, gcp2, ... in the
// order of first appearance).
//
// Pixels: ODM hands im_x, im_y to OpenSfM, whose normalised coordinates put the centre of the
// top-left pixel at (0, 0) (OpenCV). mmba's convention puts it at (0.5, 0.5), so 0.5 px is added
// to each coordinate.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace mmba::io {

struct GcpObservation {
  std::string point_id;                            ///< gcp_name, or gcpN (by coordinates)
  Eigen::Vector3d geo = Eigen::Vector3d::Zero();   ///< geo_x geo_y geo_z as written
  Eigen::Vector2d xy_px = Eigen::Vector2d::Zero(); ///< mmba pixels (im_x + 0.5, im_y + 0.5)
  std::string image;                               ///< image_name as written
  int64_t line = 0;
};

struct GcpList {
  std::string file;
  /// The projection line as a CRS definition PROJ reads: EPSG:nnnn or the PROJ string as
  /// written; "WGS84 UTM 32N" becomes "EPSG:32632" ("... S": EPSG:327zz).
  std::string crs;
  int64_t crs_line = 0;
  std::vector<GcpObservation> observations;
};

/// Reads `path`. InputError naming file:line and the field for a missing projection line, an
/// unreadable "WGS84 UTM" zone, a line with fewer than 6 fields, a value that is not a finite
/// number, a pixel coordinate < -0.5, a point named twice with different coordinates (both
/// lines named), and the same point measured twice in one image.
GcpList ReadOdmGcpList(const std::string& path);

}  // namespace mmba::io
