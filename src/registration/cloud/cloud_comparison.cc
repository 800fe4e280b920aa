// Measures of a registered pair: distances to the target, the error map (Kim & Hilton
// Fig. 6), free-space violations, the RMS between two transforms, spacing and extent.

#include "mmba/registration/cloud/feature_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "mmba/geometry/point_index.h"
#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/free_space.h"
#include "registration/cloud/verification.h"

namespace mmba::registration {

using internal::Apply;
using internal::MedianSpacing;
using internal::TargetCrop;

double EstimatePointSpacing(const io::PointCloud& cloud, size_t max_samples) {
  return MedianSpacing(cloud.points, max_samples);
}

double FreeSpaceViolation(const io::PointCloud& source, const io::PointCloud& target,
                          const std::vector<Eigen::Vector3d>& source_viewpoints,
                          const std::vector<Eigen::Vector3d>& target_viewpoints,
                          const Eigen::Matrix4d& target_from_source, double margin) {
  if (source.empty() || target.empty()) return 0.0;
  TargetCrop crop;
  crop.level.points = target.points;
  crop.index = std::make_unique<PointIndex>(crop.level.points);
  const PointIndex src_index(source.points);
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : source.points) box.extend(p);
  const internal::FreeSpace src_free(source.points, source_viewpoints,
                                     EstimatePointSpacing(source));
  const internal::FreeSpace tgt_free(target.points, target_viewpoints,
                                     EstimatePointSpacing(target));
  const std::vector<bool> v = FreeSpaceViolations(source.points, src_index, &src_free, box, crop,
                                                  &tgt_free, target_from_source, margin, margin);
  return static_cast<double>(std::count(v.begin(), v.end(), true)) / source.size();
}

std::vector<double> DistancesToTarget(const io::PointCloud& source, const io::PointCloud& target,
                                      const Eigen::Matrix4d& target_from_source) {
  PointIndex index(target.points);
  std::vector<double> out(source.size(), std::numeric_limits<double>::infinity());
  int i_near;
  double sq;
  for (size_t i = 0; i < source.size(); ++i) {
    if (index.Nearest(Apply(target_from_source, source.points[i]), &i_near, &sq)) {
      out[i] = std::sqrt(sq);
    }
  }
  return out;
}

io::PointCloud MakeErrorMap(const io::PointCloud& source, const io::PointCloud& target,
                            const Eigen::Matrix4d& target_from_source, double max_m) {
  const std::vector<double> d = DistancesToTarget(source, target, target_from_source);
  io::PointCloud out;
  out.points.reserve(source.size());
  out.colors.reserve(source.size());
  out.intensity.reserve(source.size());
  for (size_t i = 0; i < source.size(); ++i) {
    out.points.push_back(Apply(target_from_source, source.points[i]));
    // Blue → cyan → green → yellow → red ("jet"), as the error maps of Kim & Hilton Fig. 6.
    const double t = max_m > 0 ? std::clamp(d[i] / max_m, 0.0, 1.0) : 0.0;
    auto channel = [t](double centre) {
      return static_cast<uint8_t>(255.0 * std::clamp(1.5 - std::abs(4.0 * t - centre), 0.0, 1.0));
    };
    out.colors.push_back({channel(3.0), channel(2.0), channel(1.0)});
    out.intensity.push_back(static_cast<float>(d[i]));
  }
  return out;
}

double RobustExtent(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d span;
  std::vector<double> v(points.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (size_t i = 0; i < points.size(); ++i) v[i] = points[i](axis);
    const size_t lo = v.size() / 20, hi = v.size() - 1 - v.size() / 20;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(lo), v.end());
    const double a = v[lo];
    std::nth_element(v.begin(), v.begin() + static_cast<long>(hi), v.end());
    span(axis) = v[hi] - a;
  }
  return span.norm();
}

double TransformRmsOnCloud(const io::PointCloud& cloud, const Eigen::Matrix4d& a,
                           const Eigen::Matrix4d& b) {
  if (cloud.empty()) return 0.0;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : cloud.points) sum += (Apply(a, p) - Apply(b, p)).squaredNorm();
  return std::sqrt(sum / static_cast<double>(cloud.size()));
}

}  // namespace mmba::registration
