#pragma once

// Relative precision between neighbouring points: the σ of the coordinate difference
// Δ = x_j − x_i from the joint covariance, C_Δ = C_ii + C_jj − C_ij − C_ijᵀ (propagation of
// the covariance of a linear function; Ghilani 2017, ch. 6, and the relative error ellipses of
// ch. 19), its 95 % relative ellipse and the σ of the distance, σ_d² = uᵀ C_Δ u with
// u = Δ/|Δ| (horizontal). Pairs: each point with its k nearest neighbours in plan.
// Lengths in metres; axes east, north, up; covariances row-major 3×3.

#include <array>
#include <cstddef>
#include <utility>
#include <vector>

namespace mmba::report {

/// Unique pairs (i < j) joining each point to its `k` nearest neighbours by horizontal
/// distance, in order of i then j. Points with non-finite E or N are left out.
std::vector<std::pair<size_t, size_t>> NeighbourPairs(const std::vector<std::array<double, 3>>& xyz, int k);

/// Semi-axes a >= b and the azimuth of a (degrees from north towards east) of the ellipse of
/// a 2×2 covariance [qee qen; qen qnn], scaled by `scale`.
struct Ellipse2d {
  double a = 0.0, b = 0.0, azimuth_deg = 0.0;
};
Ellipse2d EllipseOf(double qee, double qen, double qnn, double scale);

struct RelativePrecision {
  double distance_m = 0.0;        ///< horizontal distance
  double sigma_distance_m = 0.0;  ///< σ of the horizontal distance
  std::array<double, 3> sigma{};  ///< σ of ΔE, ΔN, ΔU
  Ellipse2d ellipse95;            ///< 95 % relative confidence ellipse of (ΔE, ΔN)
};

/// The relative precision of x_j − x_i from C_ii, C_jj and C_ij = Cov(x_i, x_j).
RelativePrecision RelativePrecisionOf(const std::array<double, 3>& xi, const std::array<double, 3>& xj,
                                      const std::array<double, 9>& cov_ii, const std::array<double, 9>& cov_jj,
                                      const std::array<double, 9>& cov_ij);

}  // namespace mmba::report
