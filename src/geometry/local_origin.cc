#include "mmba/geometry/local_origin.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace mmba {

Eigen::Vector3d MedianCentre(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  if (points.empty()) return centre;
  const size_t step = std::max<size_t>(1, points.size() / 100000);
  std::vector<double> v;
  v.reserve(points.size() / step + 1);
  for (int axis = 0; axis < 3; ++axis) {
    v.clear();
    bool finite = true;
    for (size_t i = 0; i < points.size(); i += step) {
      v.push_back(points[i](axis));
      finite = finite && std::isfinite(v.back());
    }
    if (!finite) {  // nth_element on NaN is undefined: the non-finite value is the answer
      centre(axis) = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), middle, v.end());
    centre(axis) = *middle;
  }
  return centre;
}

Eigen::Vector3d LocalOrigin(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return Eigen::Vector3d::Zero();
  return (MedianCentre(points) / 1000.0).array().round().matrix() * 1000.0;
}

}  // namespace mmba
