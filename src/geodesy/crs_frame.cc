#include "mmba/geodesy/crs_frame.h"

#include <cmath>
#include <utility>

namespace mmba::geodesy {

CrsFrame::CrsFrame(std::shared_ptr<const Crs> crs, const Geodetic& origin)
    : crs_(std::move(crs)), plane_(origin, crs_->ellipsoid()) {}

Eigen::Vector3d CrsFrame::WorldFromCrs(const Eigen::Vector3d& xyz) const {
  return plane_.EnuFromGeodetic(crs_->GeodeticFromCrs(xyz));
}

Eigen::Vector3d CrsFrame::CrsFromWorld(const Eigen::Vector3d& point_in_world) const {
  return crs_->CrsFromGeodetic(plane_.GeodeticFromEnu(point_in_world));
}

Geodetic CrsFrame::GeodeticFromWorld(const Eigen::Vector3d& point_in_world) const {
  return plane_.GeodeticFromEnu(point_in_world);
}

PointFactors CrsFrame::FactorsAtWorld(const Eigen::Vector3d& point_in_world) const {
  return FactorsAt(*crs_, GeodeticFromWorld(point_in_world));
}

PointFactors FactorsAt(const Crs& crs, const Geodetic& geodetic) {
  const GridFactors grid = crs.Factors(geodetic);
  const Ellipsoid& e = crs.ellipsoid();
  const double e2 = e.f * (2 - e.f);
  const double s = std::sin(geodetic.latitude_deg * M_PI / 180.0);
  const double w = std::sqrt(1 - e2 * s * s);
  const double n = e.a_m / w;                     // prime vertical radius
  const double m = e.a_m * (1 - e2) / (w * w * w);  // meridian radius
  const double r = std::sqrt(m * n);
  PointFactors out;
  out.point_scale = grid.point_scale;
  out.elevation_factor = r / (r + geodetic.height_m);
  out.combined_scale = out.point_scale * out.elevation_factor;
  out.convergence_deg = grid.convergence_deg;
  return out;
}

Geodetic OriginOfCrsPoints(const Crs& crs, const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  return crs.GeodeticFromCrs(mean);
}

}  // namespace mmba::geodesy
