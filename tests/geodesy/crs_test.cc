#include "mmba/geodesy/crs.h"

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/geodesy/crs_frame.h"

namespace mmba::geodesy {
namespace {

// Reference values: pyproj 3.4.1 on PROJ 9.1.1 (Debian), Transformer.from_crs(crs, its
// geographic CRS, always_xy=True).
TEST(Crs, EtrsUtmToItsGeographicCrs) {
  const Crs crs("EPSG:25832", "test: crs");
  EXPECT_EQ(crs.identifier(), "EPSG:25832");
  EXPECT_EQ(crs.name(), "ETRS89 / UTM zone 32N");
  EXPECT_EQ(crs.height_kind(), HeightKind::kAsGiven);
  EXPECT_FALSE(crs.is_geographic());
  EXPECT_NEAR(crs.ellipsoid().a_m, 6378137.0, 1e-9);
  EXPECT_NEAR(1.0 / crs.ellipsoid().f, 298.257222101, 1e-9);  // GRS80
  const Geodetic g = crs.GeodeticFromCrs({500000.0, 5500000.0, 100.0});
  EXPECT_NEAR(g.longitude_deg, 9.0, 1e-10);
  EXPECT_NEAR(g.latitude_deg, 49.6525429236, 1e-10);
  EXPECT_DOUBLE_EQ(g.height_m, 100.0);
  const Eigen::Vector3d back = crs.CrsFromGeodetic(g);
  EXPECT_NEAR((back - Eigen::Vector3d(500000.0, 5500000.0, 100.0)).norm(), 0.0, 1e-6);
  EXPECT_NE(crs.wkt().find("ETRS89 / UTM zone 32N"), std::string::npos);
  EXPECT_EQ(crs.wkt1().rfind("PROJCS[", 0), 0u);
}

TEST(Crs, LambertAndUtmHandValues) {
  // Lambert-93's false origin (700 000, 6 600 000) is at 3° E, 46.5° N by definition.
  const Geodetic l93 = Crs("EPSG:2154", "t").GeodeticFromCrs({700000.0, 6600000.0, 50.0});
  EXPECT_NEAR(l93.longitude_deg, 3.0, 1e-10);
  EXPECT_NEAR(l93.latitude_deg, 46.5, 1e-10);
  const Geodetic utm = Crs("EPSG:32633", "t").GeodeticFromCrs({400000.0, 5000000.0, 0.0});
  EXPECT_NEAR(utm.longitude_deg, 13.7279670397, 1e-10);
  EXPECT_NEAR(utm.latitude_deg, 45.1463928762, 1e-10);
  const Eigen::Vector3d xy = Crs("EPSG:32632", "t").CrsFromGeodetic({48.0, 9.0, 0.0});
  EXPECT_NEAR(xy.x(), 500000.0, 1e-4);
  EXPECT_NEAR(xy.y(), 5316300.2245, 1e-4);
}

TEST(Crs, GeographicCrsTakesLongitudeFirst) {
  const Crs crs("EPSG:4326", "t");
  EXPECT_TRUE(crs.is_geographic());
  const Geodetic g = crs.GeodeticFromCrs({9.5, 47.25, 3.0});
  EXPECT_DOUBLE_EQ(g.longitude_deg, 9.5);
  EXPECT_DOUBLE_EQ(g.latitude_deg, 47.25);
  EXPECT_EQ(Crs("EPSG:4979", "t").height_kind(), HeightKind::kEllipsoidal);
}

TEST(Crs, BesselGridKeepsItsOwnDatum) {
  const Crs crs("EPSG:31467", "t");  // DHDN / 3-degree Gauss-Kruger zone 3
  EXPECT_NEAR(crs.ellipsoid().a_m, 6377397.155, 1e-6);
  EXPECT_NEAR(1.0 / crs.ellipsoid().f, 299.1528128, 1e-7);
  const Geodetic g = crs.GeodeticFromCrs({3500000.0, 5500000.0, 0.0});
  EXPECT_NEAR(g.longitude_deg, 9.0, 1e-10);
  EXPECT_NEAR(g.latitude_deg, 49.6378160941, 1e-10);
  // CRS → world (a tangent plane on Bessel) → CRS is exact, and the world frame is metric:
  // two points 1 km apart along the central meridian's grid north are 1 km / k apart (k is
  // the grid scale there, 1 for Gauss–Krüger on its central meridian, to 1e-5 over 1 km).
  const LocalTangentPlane plane(g, crs.ellipsoid());
  const Eigen::Vector3d a = plane.EnuFromGeodetic(g);
  const Eigen::Vector3d b =
      plane.EnuFromGeodetic(crs.GeodeticFromCrs({3500000.0, 5501000.0, 0.0}));
  EXPECT_NEAR(a.norm(), 0.0, 1e-6);
  EXPECT_NEAR((b - a).norm(), 1000.0, 0.1);
  const Eigen::Vector3d back = crs.CrsFromGeodetic(plane.GeodeticFromEnu(b));
  EXPECT_NEAR((back - Eigen::Vector3d(3500000.0, 5501000.0, 0.0)).norm(), 0.0, 1e-6);
}

TEST(Crs, CompoundCrsHasOrthometricHeights) {
  const Crs crs("EPSG:25832+7837", "t");
  EXPECT_EQ(crs.identifier(), "EPSG:25832+7837");
  EXPECT_EQ(crs.height_kind(), HeightKind::kOrthometric);
  EXPECT_EQ(HeightKindName(crs.height_kind()), "orthometric");
  // Without a geoid grid, H is used as h.
  EXPECT_DOUBLE_EQ(crs.GeodeticFromCrs({500000.0, 5500000.0, 100.0}).height_m, 100.0);
}

void WriteBigEndian(std::ofstream& out, const void* value, int size) {
  const auto* bytes = static_cast<const unsigned char*>(value);
  for (int i = size - 1; i >= 0; --i) out.put(static_cast<char>(bytes[i]));
}

// A GTX geoid grid (NOAA VDatum format: big-endian lower-left latitude, longitude, spacing in
// degrees, rows, columns, then float32 undulations row by row from the south).
std::string WriteConstantGeoid(float undulation_m) {
  const std::string path = testing::TempDir() + "/constant_geoid.gtx";
  std::ofstream out(path, std::ios::binary);
  const double header[4] = {40.0, 0.0, 1.0, 1.0};
  for (double v : header) WriteBigEndian(out, &v, 8);
  const int32_t rows = 21, cols = 21;
  WriteBigEndian(out, &rows, 4);
  WriteBigEndian(out, &cols, 4);
  for (int i = 0; i < rows * cols; ++i) WriteBigEndian(out, &undulation_m, 4);
  return path;
}

TEST(Crs, GeoidGridTurnsOrthometricIntoEllipsoidalHeights) {
  const std::string grid = WriteConstantGeoid(47.25f);
  const Crs crs("EPSG:25832+7837", "t", grid);
  const Geodetic g = crs.GeodeticFromCrs({500000.0, 5500000.0, 100.0});
  EXPECT_NEAR(g.height_m, 147.25, 1e-6);
  EXPECT_NEAR(crs.CrsFromGeodetic(g).z(), 100.0, 1e-6);
}

std::string ErrorOf(const std::string& definition, const std::string& grid = "") {
  try {
    Crs crs(definition, "project.yaml: crs", grid);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Crs, BadDefinitionsNameTheValue) {
  const std::string unknown = ErrorOf("EPSG:999999");
  EXPECT_NE(unknown.find("project.yaml: crs"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("'EPSG:999999' is not a coordinate reference system"),
            std::string::npos) << unknown;
  EXPECT_NE(ErrorOf("EPSG:4978").find("geocentric"), std::string::npos);
  EXPECT_NE(ErrorOf("no such thing").find("'no such thing'"), std::string::npos);
  const std::string grid = ErrorOf("EPSG:25832+7837", "/nonexistent/geoid.gtx");
  EXPECT_NE(grid.find("geoid grid '/nonexistent/geoid.gtx' cannot be opened"),
            std::string::npos) << grid;
  EXPECT_NE(ErrorOf("EPSG:4979", WriteConstantGeoid(1.0f)).find("ellipsoidal heights"),
            std::string::npos);
}

TEST(Crs, OutsideTheGridIsAnError) {
  const Crs crs("EPSG:25832+7837", "t", WriteConstantGeoid(1.0f));
  // 500 km E, 9 000 km N is near 81° N, north of the 40°–60° N grid.
  EXPECT_THROW(crs.GeodeticFromCrs({500000.0, 9000000.0, 0.0}), InputError);
}

// Reference: pyproj 3.4.1 Proj(CRS.from_epsg(code)).get_factors(lon, lat).
TEST(Crs, GridFactorsAsPyproj) {
  struct Case { const char* code; double lon, lat, scale, convergence; };
  const Case cases[] = {{"EPSG:25832", 9.3, 49.7, 0.9996057483247974, 0.22880138103944606},
                        {"EPSG:2154", 3.9, 46.9, 0.9990730496094041, 0.6530469885481185},
                        {"EPSG:31467", 9.4, 49.6, 1.0000102654746417, 0.3046174194936913}};
  for (const Case& c : cases) {
    const GridFactors f = Crs(c.code, "t").Factors({c.lat, c.lon, 0.0});
    EXPECT_NEAR(f.point_scale, c.scale, 1e-10) << c.code;  // PROJ's numerical derivatives
    EXPECT_NEAR(f.convergence_deg, c.convergence, 1e-9) << c.code;
  }
  const GridFactors geographic = Crs("EPSG:4326", "t").Factors({49.7, 9.3, 0.0});
  EXPECT_EQ(geographic.point_scale, 1.0);
  EXPECT_EQ(geographic.convergence_deg, 0.0);
}

TEST(CrsFrame, WorldAndCrsRoundTripAndCombinedScale) {
  auto crs = std::make_shared<const Crs>("EPSG:25832", "t");
  const Geodetic origin = OriginOfCrsPoints(*crs, {{480000.0, 5500000.0, 90.0}, {482000.0, 5502000.0, 110.0}});
  const CrsFrame frame(crs, origin);
  EXPECT_NEAR(frame.WorldFromCrs({481000.0, 5501000.0, 100.0}).norm(), 0.0, 1e-6);
  const Eigen::Vector3d a(-700.0, 400.0, 25.0), b(650.0, -300.0, -5.0);
  for (const Eigen::Vector3d& p : {a, b}) {
    EXPECT_NEAR((frame.WorldFromCrs(frame.CrsFromWorld(p)) - p).norm(), 0.0, 1e-7);
  }
  // A grid distance is the horizontal ground distance times the combined scale (short line,
  // both ends at the same height; the factor taken at the midpoint).
  const Eigen::Vector3d p(100.0, 200.0, 300.0), q(400.0, 600.0, 300.0);
  const double ground = (q - p).head<2>().norm();
  const double grid = (frame.CrsFromWorld(q) - frame.CrsFromWorld(p)).head<2>().norm();
  const PointFactors f = frame.FactorsAtWorld(0.5 * (p + q));
  const double height = frame.GeodeticFromWorld(0.5 * (p + q)).height_m;
  EXPECT_NEAR(f.elevation_factor, 1.0 - height / 6.38e6, 2e-7);
  EXPECT_NEAR(grid / ground, f.combined_scale, 2e-7);
}

}  // namespace
}  // namespace mmba::geodesy

