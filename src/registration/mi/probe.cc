#include "mmba/registration/mi/mi_registration.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "registration/mi/mi_internal.h"

namespace mmba::registration::mi {

std::vector<ProbeSample> Probe(const FrameSetEvaluator& evaluator, const Rigid3d& pose,
                               double range, double step, int level) {
  std::vector<ProbeSample> samples;
  const int n = static_cast<int>(std::lround(range / step));
  for (int axis = 0; axis < 6; ++axis) {
    for (int k = -n; k <= n; ++k) {
      Vector6d y = Vector6d::Zero();
      y[axis] = k * step;
      ProbeSample sample;
      sample.axis = axis;
      sample.offset = k * step;
      sample.metric = evaluator.Evaluate(ApplyCorrection(pose, y), level);
      samples.push_back(sample);
    }
  }
  return samples;
}

PixelOffsetStats PixelOffsets(const LidarPoints& points, const View& view,
                              const Rigid3d& cam_from_lidar_reference,
                              const Rigid3d& cam_from_lidar_estimate,
                              const RenderOptions& render) {
  PixelOffsetStats stats;
  const Eigen::Matrix3d view_r = view.view_from_cam;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = points.points_in_lidar[i].cast<double>();
    const Eigen::Vector3d a = view_r * (cam_from_lidar_reference * p) + view.view_from_cam_t;
    const double range = a.norm();
    if (range < render.min_range_m || range > render.max_range_m) continue;
    if (!view.camera.IsSpherical() && a.z() <= 0) continue;
    const std::optional<Eigen::Vector2d> xa = view.camera.ImgFromCam(a);
    if (!xa || (*xa)[0] < 0 || (*xa)[1] < 0 || (*xa)[0] >= view.camera.width ||
        (*xa)[1] >= view.camera.height) {
      continue;
    }
    const Eigen::Vector3d b = view_r * (cam_from_lidar_estimate * p) + view.view_from_cam_t;
    if (!view.camera.IsSpherical() && b.z() <= 0) continue;
    const std::optional<Eigen::Vector2d> xb = view.camera.ImgFromCam(b);
    if (!xb) continue;
    double d = (*xa - *xb).norm();
    if (view.camera.IsSpherical()) {
      // Across the ±180° seam the shorter way round counts.
      const double period = 2 * M_PI * view.camera.params[0];
      const double dx = std::abs((*xa)[0] - (*xb)[0]);
      d = std::hypot(std::min(dx, period - dx), (*xa)[1] - (*xb)[1]);
    }
    stats.offsets_px.push_back(d);
  }
  stats.points = stats.offsets_px.size();
  if (stats.points == 0) return stats;
  std::vector<double> sorted = stats.offsets_px;
  std::sort(sorted.begin(), sorted.end());
  stats.median_px = sorted[sorted.size() / 2];
  stats.p90_px = sorted[std::min(sorted.size() - 1, sorted.size() * 9 / 10)];
  stats.max_px = sorted.back();
  stats.mean_px = std::accumulate(sorted.begin(), sorted.end(), 0.0) / sorted.size();
  return stats;
}

}  // namespace mmba::registration::mi
