#include "mmba/geodesy/geodesy.h"

#include <gtest/gtest.h>

namespace mmba::geodesy {
namespace {

TEST(Geodesy, GeodeticEcefEnuRoundTrip) {
  const LocalTangentPlane plane({50.0870, 14.4208, 250.0});  // Prague
  for (double dlat : {-0.05, 0.0, 0.03}) {
    for (double dlon : {-0.04, 0.0, 0.06}) {
      for (double h : {-30.0, 0.0, 1200.0}) {
        const Geodetic g{50.0870 + dlat, 14.4208 + dlon, h};
        const Eigen::Vector3d ecef = EcefFromGeodetic(g);
        const Eigen::Vector3d enu = plane.EnuFromEcef(ecef);
        const Eigen::Vector3d ecef_back = plane.EcefFromEnu(enu);
        EXPECT_LT((ecef_back - ecef).norm(), 1e-9);
        EXPECT_LT((plane.EnuFromEcef(ecef_back) - enu).norm(), 1e-9);
        // Back to geodetic: ECEF coordinates of ~6.4e6 m carry a rounding of ~1e-9 m
        // (one ulp is 9.3e-10 m), so the full geodetic round trip is held to 3e-9 m.
        const Geodetic g_back = plane.GeodeticFromEnu(enu);
        const Eigen::Vector3d diff = EcefFromGeodetic(g_back) - ecef;
        EXPECT_LT(diff.norm(), 3e-9);
        EXPECT_NEAR(g_back.height_m, h, 3e-9);
      }
    }
  }
  // The origin maps to zero and "up" is the ellipsoid normal.
  EXPECT_LT(plane.EnuFromGeodetic(plane.origin()).norm(), 1e-9);
  const Eigen::Vector3d up = plane.EnuFromGeodetic({50.0870, 14.4208, 350.0});
  EXPECT_NEAR(up.z(), 100.0, 1e-9);
  EXPECT_NEAR(up.head<2>().norm(), 0.0, 1e-9);
}

TEST(Geodesy, UtmAgainstPublishedValue) {
  // AGI STK Connect manual, "Convert MapGridPoint": LatLon 33.5 74.75 -> 43S 476779 3706747
  // (rounded to the metre).
  const Utm utm = UtmFromGeodetic({33.5, 74.75, 0.0});
  EXPECT_EQ(utm.zone, 43);
  EXPECT_TRUE(utm.northp);
  EXPECT_NEAR(utm.easting_m, 476779.0, 0.6);
  EXPECT_NEAR(utm.northing_m, 3706747.0, 0.6);
  const Geodetic back = GeodeticFromUtm(utm);
  EXPECT_NEAR(back.latitude_deg, 33.5, 1e-10);
  EXPECT_NEAR(back.longitude_deg, 74.75, 1e-10);
}

TEST(Geodesy, TransverseMercatorRoundTripAndCentralMeridian) {
  const Eigen::Vector2d xy = TransverseMercatorFromGeodetic({45.0, 9.0, 0.0}, 9.0, 0.9996);
  EXPECT_NEAR(xy.x(), 0.0, 1e-6);  // on the central meridian
  const Geodetic g = GeodeticFromTransverseMercator(
      TransverseMercatorFromGeodetic({45.2, 10.1, 0.0}, 9.0, 0.9996), 9.0, 0.9996);
  EXPECT_NEAR(g.latitude_deg, 45.2, 1e-11);
  EXPECT_NEAR(g.longitude_deg, 10.1, 1e-11);
}

TEST(Geodesy, StationVerticalTiltsWithDistance) {
  const LocalTangentPlane plane({45.0, 9.0, 0.0});
  const Eigen::Matrix3d at_origin = plane.StationEnuFromWorld(Eigen::Vector3d::Zero());
  EXPECT_LT((at_origin - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // 5 km east: the plumb line tilts by about 5000/6.39e6 rad.
  const Eigen::Matrix3d far = plane.StationEnuFromWorld(Eigen::Vector3d(5000, 0, 0));
  const double tilt = std::acos(far(2, 2));
  EXPECT_NEAR(tilt, 5000.0 / 6.388e6, 2e-5 * tilt + 1e-6);
}

}  // namespace
}  // namespace mmba::geodesy
