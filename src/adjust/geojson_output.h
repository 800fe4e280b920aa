// GeoJSON (RFC 7946) of the adjustment's points and camera positions, for a GIS. Private to
// mmba_adjust.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

#include "internal.h"

namespace mmba::adjust::internal {

/// Writes to `stage`, for a project with geodesy (not `frame: cartesian`; nothing otherwise):
/// - points.geojson: the adjusted points of points.csv (surveyed points) and of each photo
///   measurements block, as Point features {id, role, sigma_east_m, sigma_north_m, sigma_up_m,
///   ellipse95_a_m, ellipse95_b_m, ellipse95_azimuth_deg}, each followed by its 95 % plan
///   confidence ellipse as a Polygon feature (feature: "ellipse95");
/// - cameras.geojson: the camera centres of poses.csv and of each photo measurements block as
///   Point features {id, sensor, sigma_east_m, sigma_north_m, sigma_up_m}.
/// Coordinates are WGS84 longitude, latitude (degrees) and ellipsoidal height (m), RFC 7946
/// §4 (no `crs` member); with a project `crs` on another datum, PROJ's transformation from
/// that datum to WGS84 (EPSG:4979) is applied. The ellipse: the point's plan covariance in
/// the world tangent plane, semi-axes sqrt(eigenvalue) × 2.4477 (sqrt of the χ²(2) 95 %
/// quantile 5.9915; Ghilani, Adjustment Computations, 5th ed., 2010, ch. 19, the error
/// ellipse's confidence factor), 72 vertices in the plane converted to longitude, latitude
/// (positions without height: a plan figure). Longitude and latitude are rounded to 1e-10 deg,
/// heights to 0.1 mm. Adds both files to `files`.
void WriteGeoJson(const JointState& s, const std::filesystem::path& stage, nlohmann::json* files);

}  // namespace mmba::adjust::internal
