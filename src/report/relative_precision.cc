// Relative precision between neighbouring points (relative_precision.h).
#include "mmba/report/relative_precision.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "report/html_internal.h"

namespace mmba::report {

std::vector<std::pair<size_t, size_t>> NeighbourPairs(const std::vector<std::array<double, 3>>& xyz, int k) {
  std::set<std::pair<size_t, size_t>> pairs;
  for (size_t i = 0; i < xyz.size(); ++i) {
    if (!std::isfinite(xyz[i][0] + xyz[i][1])) continue;
    std::vector<std::pair<double, size_t>> by_distance;
    for (size_t j = 0; j < xyz.size(); ++j) {
      if (j == i || !std::isfinite(xyz[j][0] + xyz[j][1])) continue;
      by_distance.push_back({std::hypot(xyz[j][0] - xyz[i][0], xyz[j][1] - xyz[i][1]), j});
    }
    const size_t take = std::min(by_distance.size(), static_cast<size_t>(std::max(0, k)));
    std::partial_sort(by_distance.begin(), by_distance.begin() + take, by_distance.end());
    for (size_t m = 0; m < take; ++m) pairs.insert({std::min(i, by_distance[m].second), std::max(i, by_distance[m].second)});
  }
  return {pairs.begin(), pairs.end()};
}

Ellipse2d EllipseOf(double qee, double qen, double qnn, double scale) {
  const double mean = 0.5 * (qee + qnn);
  const double radius = std::hypot(0.5 * (qee - qnn), qen);
  Ellipse2d e;
  e.a = scale * std::sqrt(std::max(0.0, mean + radius));
  e.b = scale * std::sqrt(std::max(0.0, mean - radius));
  // Azimuth of the major axis from north towards east: tan 2θ = 2 q_en / (q_nn − q_ee).
  double azimuth = 0.5 * std::atan2(2.0 * qen, qnn - qee) * 180.0 / M_PI;
  if (azimuth < 0.0) azimuth += 180.0;
  e.azimuth_deg = azimuth;
  return e;
}

RelativePrecision RelativePrecisionOf(const std::array<double, 3>& xi, const std::array<double, 3>& xj,
                                      const std::array<double, 9>& cov_ii, const std::array<double, 9>& cov_jj,
                                      const std::array<double, 9>& cov_ij) {
  // C_Δ = C_ii + C_jj − C_ij − C_ijᵀ.
  std::array<double, 9> c{};
  for (int r = 0; r < 3; ++r) {
    for (int s = 0; s < 3; ++s) c[3 * r + s] = cov_ii[3 * r + s] + cov_jj[3 * r + s] - cov_ij[3 * r + s] - cov_ij[3 * s + r];
  }
  RelativePrecision out;
  for (int k = 0; k < 3; ++k) out.sigma[k] = std::sqrt(std::max(0.0, c[4 * k]));
  const double de = xj[0] - xi[0], dn = xj[1] - xi[1];
  out.distance_m = std::hypot(de, dn);
  if (out.distance_m > 0.0) {
    const double ue = de / out.distance_m, un = dn / out.distance_m;
    out.sigma_distance_m = std::sqrt(std::max(0.0, ue * ue * c[0] + 2.0 * ue * un * c[1] + un * un * c[4]));
  } else {
    out.sigma_distance_m = NAN;
  }
  out.ellipse95 = EllipseOf(c[0], c[1], c[4], internal::k95Ellipse2d);
  return out;
}

}  // namespace mmba::report
