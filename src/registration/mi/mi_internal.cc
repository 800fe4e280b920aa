#include "registration/mi/mi_internal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace mmba::registration::mi {

namespace internal {

Vector6d PerParameter(double shift_m, double angle_deg) {
  Vector6d v;
  v << shift_m, shift_m, shift_m, angle_deg, angle_deg, angle_deg;
  return v;
}

Vector6d BoundVector(const RegistrationOptions& options) {
  return PerParameter(options.bound_translation_m, options.bound_rotation_deg);
}

std::string Fixed(double v, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << v;
  return out.str();
}

// One render buffer per thread, reused between evaluations.
LidarImage& ThreadBuffer() {
  thread_local LidarImage buffer;
  return buffer;
}

// Pixel difference a − b; across the ±180° seam of a panorama the shorter way round.
Eigen::Vector2d PixelDifference(const View& view, const Eigen::Vector2d& a,
                                const Eigen::Vector2d& b) {
  Eigen::Vector2d d = a - b;
  if (view.camera.IsSpherical()) {
    const double period = 2 * M_PI * view.camera.params[0];
    d.x() -= period * std::round(d.x() / period);
  }
  return d;
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

double MeanOf(const std::vector<double>& values) {
  return values.empty() ? 0.0
                        : std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

double MedianSqrtOf(std::vector<double> squares) {
  for (double& v : squares) v = std::sqrt(v);
  return Median(std::move(squares));
}

}  // namespace internal

}  // namespace mmba::registration::mi
