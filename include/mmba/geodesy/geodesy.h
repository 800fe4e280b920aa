#pragma once

#include <string>

#include <Eigen/Core>

namespace mmba::geodesy {

/// WGS84 geodetic coordinates: latitude and longitude in degrees, ellipsoidal height in m.
struct Geodetic {
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double height_m = 0.0;
};

/// An ellipsoid by semi-major axis `a_m` (metres) and flattening `f`; WGS84 by default.
struct Ellipsoid {
  double a_m = 6378137.0;
  double f = 1.0 / 298.257223563;
};

/// A UTM / UPS coordinate: zone (0 = UPS), hemisphere, easting and northing in metres.
struct Utm {
  int zone = 0;
  bool northp = true;
  double easting_m = 0.0;
  double northing_m = 0.0;
};

/// Geodetic (WGS84) -> Earth-centred, Earth-fixed (metres). GeographicLib::Geocentric.
Eigen::Vector3d EcefFromGeodetic(const Geodetic& geodetic);
/// ECEF (metres) -> geodetic (WGS84).
Geodetic GeodeticFromEcef(const Eigen::Vector3d& point_in_ecef);

/// Geodetic -> UTM/UPS in the standard zone (or `zone` >= 1 to force one).
Utm UtmFromGeodetic(const Geodetic& geodetic, int zone = -1);
/// UTM/UPS -> geodetic (height is left 0).
Geodetic GeodeticFromUtm(const Utm& utm);

/// Transverse Mercator with an arbitrary central meridian `lon0_deg` and scale `k0`
/// (false easting/northing not applied). Returns (x east, y north) in metres.
Eigen::Vector2d TransverseMercatorFromGeodetic(const Geodetic& geodetic, double lon0_deg,
                                               double k0);
Geodetic GeodeticFromTransverseMercator(const Eigen::Vector2d& xy, double lon0_deg, double k0);

/// A local tangent plane (east, north, up; metres) at a geodetic origin: the project's world
/// frame (DESIGN.md). Rotation `enu_from_ecef` = R, point_in_enu = R·(p_ecef − origin_ecef).
/// Geodetic coordinates and ECEF are on `ellipsoid` (WGS84 unless a project's CRS names
/// another datum, e.g. Bessel 1841 for a Gauss–Krüger grid).
class LocalTangentPlane {
 public:
  explicit LocalTangentPlane(const Geodetic& origin, const Ellipsoid& ellipsoid = Ellipsoid());

  const Geodetic& origin() const { return origin_; }
  const Ellipsoid& ellipsoid() const { return ellipsoid_; }
  const Eigen::Vector3d& origin_in_ecef() const { return origin_in_ecef_; }
  const Eigen::Matrix3d& enu_from_ecef_rotation() const { return enu_from_ecef_; }

  Eigen::Vector3d EnuFromEcef(const Eigen::Vector3d& point_in_ecef) const;
  Eigen::Vector3d EcefFromEnu(const Eigen::Vector3d& point_in_enu) const;
  Eigen::Vector3d EnuFromGeodetic(const Geodetic& geodetic) const;
  Geodetic GeodeticFromEnu(const Eigen::Vector3d& point_in_enu) const;

  /// Rotation from this plane's ENU axes to the local vertical (ENU) frame of a station at
  /// `station_in_enu`: a network several km wide keeps each station's own plumb line
  /// (ellipsoid normal; deflections of the vertical ignored).
  Eigen::Matrix3d StationEnuFromWorld(const Eigen::Vector3d& station_in_enu) const;

 private:
  Geodetic origin_;
  Ellipsoid ellipsoid_;
  Eigen::Vector3d origin_in_ecef_;
  Eigen::Matrix3d enu_from_ecef_;
};

/// Radius of curvature (m) of the WGS84 normal section at `latitude_deg` in the direction
/// `azimuth_rad` (Euler: 1/R = cos²α/M + sin²α/N).
double NormalSectionRadius(double latitude_deg, double azimuth_rad);

/// Rotation ENU-at-(lat, lon) from ECEF (the standard one, e.g. Hofmann-Wellenhof et al.,
/// GNSS, 2008, Eq. (10.14)).
Eigen::Matrix3d EnuFromEcefRotation(double latitude_deg, double longitude_deg);

}  // namespace mmba::geodesy
