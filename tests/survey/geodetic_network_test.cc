// A georeferenced network 6 km wide (WGS84, origin in the Alps): error-free observations
// made in each station's own local vertical with GeographicLib are adjusted back to the
// truth within 1 mm when the network is geodetic (station verticals + Earth curvature);
// the same observations adjusted in one plane miss by decimetres.
#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "mmba/geodesy/geodesy.h"
#include "mmba/io_survey/survey_csv.h"
#include "mmba/survey/adjust.h"

namespace mmba::survey {
namespace {

struct Truth {
  std::string csv;
  std::vector<geodesy::Geodetic> points;
};

Truth MakeNetwork() {
  const geodesy::Geodetic origin{46.80, 8.20, 600.0};
  const geodesy::LocalTangentPlane plane(origin);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3000.0, 3000.0), uh(400.0, 900.0);
  Truth t;
  std::ostringstream csv;
  csv << std::setprecision(15);
  csv << "param,origin,46.80,8.20,600.0\nparam,sigma-apr,1\nparam,axes-xy,en\n";
  const int n = 10;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d enu(u(rng), u(rng), 0.0);
    geodesy::Geodetic g = plane.GeodeticFromEnu(enu);
    g.height_m = uh(rng);
    t.points.push_back(g);
    const bool fixed = i < 2;
    // Approximate values 0.2 m off for the adjusted points.
    const double off = fixed ? 0.0 : 0.2 / 111000.0;
    csv << "gpoint,P" << i << "," << g.latitude_deg + off << "," << g.longitude_deg - off << ","
        << g.height_m + (fixed ? 0.0 : 0.15) << "," << (fixed ? "xyz" : "") << ","
        << (fixed ? "" : "xyz") << "\n";
  }
  for (int s = 0; s < n; ++s) {
    const Eigen::Vector3d ecef_s = geodesy::EcefFromGeodetic(t.points[s]);
    const Eigen::Matrix3d r =
        geodesy::EnuFromEcefRotation(t.points[s].latitude_deg, t.points[s].longitude_deg);
    csv << "set,P" << s << "\n";
    for (int k = 0; k < n; ++k) {
      if (k == s) continue;
      const Eigen::Vector3d d = r * (geodesy::EcefFromGeodetic(t.points[k]) - ecef_s);
      const double azimuth = std::atan2(d.x(), d.y());
      const double direction_gon = std::fmod(azimuth * 200.0 / M_PI + 400.0, 400.0);
      csv << "direction,P" << s << ",P" << k << "," << direction_gon << ",3\n";
    }
    for (int k = 0; k < n; ++k) {
      if (k == s) continue;
      const Eigen::Vector3d d = r * (geodesy::EcefFromGeodetic(t.points[k]) - ecef_s);
      csv << "s-distance,P" << s << ",P" << k << "," << d.norm() << ",1\n";
      csv << "z-angle,P" << s << ",P" << k << ","
          << std::atan2(d.head<2>().norm(), d.z()) * 200.0 / M_PI << ",5\n";
      if (k == s + 1) {
        csv << "dh,P" << s << ",P" << k << "," << t.points[k].height_m - t.points[s].height_m
            << ",1\n";
      }
    }
  }
  t.csv = csv.str();
  return t;
}

double MaxError(const SurveyNetwork& net, const Truth& t) {
  const geodesy::LocalTangentPlane plane(net.origin);
  double worst = 0.0;
  for (size_t i = 0; i < t.points.size(); ++i) {
    const Eigen::Vector3d truth = plane.EnuFromGeodetic(t.points[i]);
    worst = std::max(worst, (net.Find("P" + std::to_string(i))->coords - truth).norm());
  }
  return worst;
}

TEST(GeodeticNetwork, StationVerticalsRecoverTheTruth) {
  const Truth t = MakeNetwork();
  SurveyNetwork net = io::ParseSurveyCsv(t.csv, "geodetic.csv");
  ASSERT_TRUE(net.geodetic);
  const SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged) << adj.reason;
  EXPECT_LT(MaxError(net, t), 1e-3);
  EXPECT_LT(adj.statistics.sigma0_ratio, 0.1);  // error-free observations fit

  // The same network treated as a plane (no station verticals, no curvature) does not fit.
  SurveyNetwork flat = io::ParseSurveyCsv(t.csv, "geodetic.csv");
  flat.geodetic = false;
  const SurveyAdjustment flat_adj = AdjustNetwork(&flat, SurveyAdjustOptions());
  ASSERT_TRUE(flat_adj.converged);
  EXPECT_GT(MaxError(flat, t), 0.05);
  GTEST_LOG_(INFO) << "max error: geodetic " << MaxError(net, t) * 1000 << " mm (sigma0 ratio "
                   << adj.statistics.sigma0_ratio << "), plane " << MaxError(flat, t) * 1000
                   << " mm (sigma0 ratio " << flat_adj.statistics.sigma0_ratio << ")";
  EXPECT_GT(flat_adj.statistics.sigma0_ratio, 10.0);
}

TEST(GeodeticNetwork, NormalSectionRadius) {
  // At 45°: M = 6367381.8 m, N = 6388838.3 m (WGS84).
  EXPECT_NEAR(geodesy::NormalSectionRadius(45.0, 0.0), 6367381.8, 0.5);
  EXPECT_NEAR(geodesy::NormalSectionRadius(45.0, M_PI / 2), 6388838.3, 0.5);
}

}  // namespace
}  // namespace mmba::survey
