#include "mmba/geodesy/geodesy.h"

#include <cmath>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/TransverseMercator.hpp>
#include <GeographicLib/UTMUPS.hpp>

namespace mmba::geodesy {

namespace {
const GeographicLib::Geocentric& Wgs84() { return GeographicLib::Geocentric::WGS84(); }
constexpr double kDegToRad = M_PI / 180.0;
}  // namespace

Eigen::Vector3d EcefFromGeodetic(const Geodetic& g) {
  Eigen::Vector3d p;
  Wgs84().Forward(g.latitude_deg, g.longitude_deg, g.height_m, p.x(), p.y(), p.z());
  return p;
}

Geodetic GeodeticFromEcef(const Eigen::Vector3d& p) {
  Geodetic g;
  Wgs84().Reverse(p.x(), p.y(), p.z(), g.latitude_deg, g.longitude_deg, g.height_m);
  return g;
}

Utm UtmFromGeodetic(const Geodetic& g, int zone) {
  Utm u;
  double gamma = 0.0, k = 0.0;
  GeographicLib::UTMUPS::Forward(g.latitude_deg, g.longitude_deg, u.zone, u.northp,
                                 u.easting_m, u.northing_m, gamma, k,
                                 zone >= 1 ? zone : GeographicLib::UTMUPS::STANDARD);
  return u;
}

Geodetic GeodeticFromUtm(const Utm& u) {
  Geodetic g;
  GeographicLib::UTMUPS::Reverse(u.zone, u.northp, u.easting_m, u.northing_m, g.latitude_deg,
                                 g.longitude_deg);
  return g;
}

Eigen::Vector2d TransverseMercatorFromGeodetic(const Geodetic& g, double lon0_deg, double k0) {
  const GeographicLib::TransverseMercator tm(GeographicLib::Constants::WGS84_a(),
                                             GeographicLib::Constants::WGS84_f(), k0);
  Eigen::Vector2d xy;
  tm.Forward(lon0_deg, g.latitude_deg, g.longitude_deg, xy.x(), xy.y());
  return xy;
}

Geodetic GeodeticFromTransverseMercator(const Eigen::Vector2d& xy, double lon0_deg, double k0) {
  const GeographicLib::TransverseMercator tm(GeographicLib::Constants::WGS84_a(),
                                             GeographicLib::Constants::WGS84_f(), k0);
  Geodetic g;
  tm.Reverse(lon0_deg, xy.x(), xy.y(), g.latitude_deg, g.longitude_deg);
  return g;
}

double NormalSectionRadius(double latitude_deg, double azimuth_rad) {
  const double a = GeographicLib::Constants::WGS84_a();
  const double f = GeographicLib::Constants::WGS84_f();
  const double e2 = f * (2 - f);
  const double s = std::sin(latitude_deg * kDegToRad);
  const double w = std::sqrt(1 - e2 * s * s);
  const double n = a / w;                     // prime vertical
  const double m = a * (1 - e2) / (w * w * w);  // meridian
  const double c = std::cos(azimuth_rad), sn = std::sin(azimuth_rad);
  return 1.0 / (c * c / m + sn * sn / n);
}

Eigen::Matrix3d EnuFromEcefRotation(double latitude_deg, double longitude_deg) {
  const double phi = latitude_deg * kDegToRad;
  const double lam = longitude_deg * kDegToRad;
  const double sp = std::sin(phi), cp = std::cos(phi);
  const double sl = std::sin(lam), cl = std::cos(lam);
  Eigen::Matrix3d r;
  r << -sl, cl, 0.0,            //
      -sp * cl, -sp * sl, cp,   //
      cp * cl, cp * sl, sp;
  return r;
}

namespace {
GeographicLib::Geocentric GeocentricOf(const Ellipsoid& e) {
  return GeographicLib::Geocentric(e.a_m, e.f);
}
}  // namespace

LocalTangentPlane::LocalTangentPlane(const Geodetic& origin, const Ellipsoid& ellipsoid)
    : origin_(origin),
      ellipsoid_(ellipsoid),
      enu_from_ecef_(EnuFromEcefRotation(origin.latitude_deg, origin.longitude_deg)) {
  GeocentricOf(ellipsoid_).Forward(origin.latitude_deg, origin.longitude_deg, origin.height_m,
                                   origin_in_ecef_.x(), origin_in_ecef_.y(),
                                   origin_in_ecef_.z());
}

Eigen::Vector3d LocalTangentPlane::EnuFromEcef(const Eigen::Vector3d& p) const {
  return enu_from_ecef_ * (p - origin_in_ecef_);
}

Eigen::Vector3d LocalTangentPlane::EcefFromEnu(const Eigen::Vector3d& p) const {
  return enu_from_ecef_.transpose() * p + origin_in_ecef_;
}

Eigen::Vector3d LocalTangentPlane::EnuFromGeodetic(const Geodetic& g) const {
  Eigen::Vector3d ecef;
  GeocentricOf(ellipsoid_).Forward(g.latitude_deg, g.longitude_deg, g.height_m, ecef.x(),
                                   ecef.y(), ecef.z());
  return EnuFromEcef(ecef);
}

Geodetic LocalTangentPlane::GeodeticFromEnu(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d ecef = EcefFromEnu(p);
  Geodetic g;
  GeocentricOf(ellipsoid_).Reverse(ecef.x(), ecef.y(), ecef.z(), g.latitude_deg,
                                   g.longitude_deg, g.height_m);
  return g;
}

Eigen::Matrix3d LocalTangentPlane::StationEnuFromWorld(const Eigen::Vector3d& station) const {
  const Geodetic g = GeodeticFromEnu(station);
  return EnuFromEcefRotation(g.latitude_deg, g.longitude_deg) * enu_from_ecef_.transpose();
}

}  // namespace mmba::geodesy
