#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "mmba/geodesy/crs.h"
#include "mmba/geodesy/geodesy.h"

namespace mmba::geodesy {

/// The grid factors of a point and its elevation: a horizontal ground distance d at
/// ellipsoidal height h becomes the grid distance d · combined_scale, with
/// combined_scale = point_scale · R / (R + h), R = √(M·N) the Gaussian mean radius at the
/// point's latitude (Ghilani & Wolf, Elementary Surveying, 13th ed., 2012, Eq. (20.11), (20.12)).
struct PointFactors {
  double point_scale = 1.0;      ///< the projection's scale (GridFactors::point_scale)
  double elevation_factor = 1.0; ///< R / (R + h)
  double combined_scale = 1.0;   ///< point_scale · elevation_factor
  double convergence_deg = 0.0;  ///< grid north east of true north
};

/// A world frame tied to a CRS: the local tangent plane (east, north, up; metres) at `origin`
/// (geodetic on the CRS's own datum) on the CRS's ellipsoid. This is the conversion every
/// output in the project's CRS goes through (points and poses CSV, report.json, LAS, GeoJSON):
/// CrsFromWorld(point_in_world) gives (easting, northing, height) in the CRS's normalised axis
/// order (longitude, latitude in degrees, height for a geographic CRS); heights are the CRS's
/// (Crs::height_kind(): orthometric through the geoid grid when one is given).
/// WorldFromCrs ∘ CrsFromWorld is the identity to PROJ's round-trip precision (< 1e-6 m).
class CrsFrame {
 public:
  CrsFrame(std::shared_ptr<const Crs> crs, const Geodetic& origin);

  const Crs& crs() const { return *crs_; }
  const std::shared_ptr<const Crs>& crs_ptr() const { return crs_; }
  const LocalTangentPlane& plane() const { return plane_; }
  const Geodetic& origin() const { return plane_.origin(); }

  Eigen::Vector3d WorldFromCrs(const Eigen::Vector3d& xyz) const;
  Eigen::Vector3d CrsFromWorld(const Eigen::Vector3d& point_in_world) const;
  /// Geodetic on the CRS's datum, ellipsoidal height.
  Geodetic GeodeticFromWorld(const Eigen::Vector3d& point_in_world) const;
  /// The grid factors at a world point.
  PointFactors FactorsAtWorld(const Eigen::Vector3d& point_in_world) const;

 private:
  std::shared_ptr<const Crs> crs_;
  LocalTangentPlane plane_;
};

/// The grid factors at a geodetic point of `crs` (its ellipsoid's Gaussian mean radius).
PointFactors FactorsAt(const Crs& crs, const Geodetic& geodetic);

/// A tangent-plane origin for points given in `crs`: the geodetic position of the mean of their
/// CRS coordinates (height = their mean height, converted by the CRS: ellipsoidal). Throws
/// InputError (Crs's) when the mean is outside the CRS's domain; `points` must not be empty.
Geodetic OriginOfCrsPoints(const Crs& crs, const std::vector<Eigen::Vector3d>& points);

}  // namespace mmba::geodesy
