#pragma once

// Where to put the origin when computing with a point set in floats.

#include <vector>

#include <Eigen/Core>

namespace mmba {

/// The centre of `points` robust to blunders: the median of each coordinate over at most
/// 100,000 evenly strided points (one point a million km away moves a centroid by a
/// million km / n, the median not at all). Zero for no points; non-finite input can give a
/// non-finite centre.
Eigen::Vector3d MedianCentre(const std::vector<Eigen::Vector3d>& points);

/// A local origin for computing with `points` in floats: their MedianCentre rounded to whole
/// kilometres. Clouds in map-grid coordinates (UTM, national grids: 10^5–10^7 m, where a
/// float resolves only 0.01–0.5 m) keep about 0.1 mm within a kilometre of it; the origin of
/// a cloud whose centre is within 500 m of (0, 0, 0) is exactly 0. Non-finite input gives a
/// non-finite origin.
Eigen::Vector3d LocalOrigin(const std::vector<Eigen::Vector3d>& points);

}  // namespace mmba
