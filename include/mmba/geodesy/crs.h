#pragma once

#include <memory>
#include <string>

#include <Eigen/Core>

#include "mmba/geodesy/geodesy.h"

namespace mmba::geodesy {

/// What the third coordinate of a CRS is.
enum class HeightKind {
  kEllipsoidal,  ///< a 3-D geographic or geocentric CRS: h above the datum's ellipsoid
  kOrthometric,  ///< a compound CRS with a vertical (gravity-related) part: H above the geoid
  kAsGiven,      ///< a 2-D CRS: the height is whatever the user's numbers are
};

/// "ellipsoidal", "orthometric", "as given".
std::string HeightKindName(HeightKind kind);

/// The projection's local distortion at a point (PROJ's proj_factors; Snyder, Map Projections —
/// A Working Manual, USGS PP 1395, 1987, Eq. (4-2), (4-3)): a short grid distance is the
/// ellipsoidal distance times `point_scale` (the meridional scale h; a conformal grid's k = h),
/// and grid north is `convergence_deg` east of true north. A geographic CRS (or a projection
/// PROJ cannot write as a PROJ string): 1 and 0.
struct GridFactors {
  double point_scale = 1.0;
  double convergence_deg = 0.0;
};

/// A coordinate reference system known to PROJ (`EPSG:25832`, `EPSG:2154+5720`, a PROJ string
/// or WKT), with the conversions between its coordinates and geodetic coordinates on ITS OWN
/// datum. No datum shift is applied: the project's world frame is a local tangent plane on the
/// CRS's own ellipsoid (`ellipsoid()`), so CRS → world → CRS is exact and rigid whatever the
/// datum (ETRS89 on GRS80, a Bessel-based grid, NAD83 ...).
///
/// Coordinates are in the CRS's normalised axis order (easting, northing, height; for a
/// geographic CRS longitude, latitude in degrees, height), whatever order the EPSG definition
/// declares (PROJ's proj_normalize_for_visualization).
///
/// Heights: with a compound CRS (orthometric heights H) and a geoid grid (PROJ-readable, e.g.
/// GTX or GeoTIFF, giving the undulation N in metres), h = H + N(φ, λ). Without a grid, H is
/// used as h: the geoid undulation is taken as constant over the site, and its variation
/// across the site (typically under 1 cm per km) is the error this leaves.
class Crs {
 public:
  /// Parses `definition`; `where` names the field for errors (e.g. "project.yaml: crs").
  /// `geoid_grid` is a file path or "" (none). Throws InputError when PROJ does not know the
  /// CRS, when it is geocentric, or when the grid cannot be opened.
  Crs(const std::string& definition, const std::string& where,
      const std::string& geoid_grid = "");
  ~Crs();
  Crs(Crs&&) noexcept;
  Crs& operator=(Crs&&) noexcept;

  /// The definition as the user gave it.
  const std::string& definition() const;
  /// "EPSG:25832" when PROJ identifies an authority code (for a compound CRS "EPSG:h+v"),
  /// otherwise "".
  const std::string& identifier() const;
  /// PROJ's name, e.g. "ETRS89 / UTM zone 32N".
  const std::string& name() const;
  /// WKT2:2019 of the CRS, for JSON and reports.
  const std::string& wkt() const;
  /// OGC WKT 1 (GDAL flavour), as LAS 1.4's OGC coordinate system WKT record holds it.
  const std::string& wkt1() const;
  HeightKind height_kind() const;
  bool is_geographic() const;
  /// The ellipsoid of the CRS's datum.
  const Ellipsoid& ellipsoid() const;
  /// The geoid grid file or "".
  const std::string& geoid_grid() const;

  /// CRS coordinates → geodetic (latitude, longitude in degrees, ellipsoidal height in metres)
  /// on the CRS's own datum.
  Geodetic GeodeticFromCrs(const Eigen::Vector3d& xyz) const;
  /// The inverse of GeodeticFromCrs.
  Eigen::Vector3d CrsFromGeodetic(const Geodetic& geodetic) const;
  /// The grid's scale and meridian convergence at `geodetic` (on the CRS's datum).
  GridFactors Factors(const Geodetic& geodetic) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mmba::geodesy
