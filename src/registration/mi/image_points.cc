#include "registration/mi/mi_internal.h"

#include <array>
#include <cmath>
#include <optional>

namespace mmba::registration::mi {

namespace internal {

// Per point of `sample`: the squared pixel distance between poses a and b, in pixels² of the
// frame's image.
std::vector<double> PixelDisplacements2(const FrameSetEvaluator& evaluator,
                                        const std::vector<FrameSetEvaluator::VisiblePoint>& sample,
                                        const Rigid3d& a, const Rigid3d& b) {
  std::vector<double> d2;
  for (const FrameSetEvaluator::VisiblePoint& point : sample) {
    Eigen::Vector2d pa, pb;
    if (!evaluator.Project(point, a, &pa) || !evaluator.Project(point, b, &pb)) continue;
    const View& view = evaluator.frames()[point.frame].views[point.view];
    d2.push_back(std::pow(view.image_pixels_per_pixel, 2) *
                 PixelDifference(view, pa, pb).squaredNorm());
  }
  return d2;
}

// Up to `max_points` of the frames' cloud points, within range, that project into their own
// image at `cam_from_lidar` (frames whose views are cuts, View::image_camera; none otherwise),
// an even subsample in cloud order.
std::vector<ImagePoint> SampleImagePoints(const std::vector<Frame>& frames,
                                          const Rigid3d& cam_from_lidar,
                                          const RenderOptions& render, size_t max_points) {
  std::vector<ImagePoint> all;
  for (const Frame& frame : frames) {
    if (frame.views.empty() || !frame.views.front().image_camera) continue;
    const sensors::Camera* camera = &*frame.views.front().image_camera;
    const LidarPoints& points = *frame.points;
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = points.points_in_lidar[i].cast<double>();
      const Eigen::Vector3d c = cam_from_lidar * p;
      const double range = c.norm();
      if (range < render.min_range_m || range > render.max_range_m) continue;
      if (!camera->IsSpherical() && c.z() <= 0) continue;
      const std::optional<Eigen::Vector2d> xy = camera->ImgFromCam(c);
      if (!xy || (*xy)[0] < 0 || (*xy)[1] < 0 || (*xy)[0] >= camera->width ||
          (*xy)[1] >= camera->height) {
        continue;
      }
      all.push_back({camera, p});
    }
  }
  if (all.size() <= max_points) return all;
  std::vector<ImagePoint> sample;
  const double stride = static_cast<double>(all.size()) / max_points;
  for (double k = 0; k < all.size() && sample.size() < max_points; k += stride) {
    sample.push_back(all[static_cast<size_t>(k)]);
  }
  return sample;
}

// Pixel of an image point at a pose; false when it does not project.
bool ProjectImagePoint(const ImagePoint& point, const Rigid3d& cam_from_lidar,
                       Eigen::Vector2d* xy) {
  const Eigen::Vector3d c = cam_from_lidar * point.point_in_lidar;
  if (!point.camera->IsSpherical() && c.z() <= 0) return false;
  const std::optional<Eigen::Vector2d> projected = point.camera->ImgFromCam(c);
  if (!projected) return false;
  *xy = *projected;
  return true;
}

// a − b in the image's pixels; across a panorama's ±180° seam the shorter way round.
Eigen::Vector2d ImagePixelDifference(const sensors::Camera& camera, const Eigen::Vector2d& a,
                                     const Eigen::Vector2d& b) {
  Eigen::Vector2d d = a - b;
  if (camera.IsSpherical()) {
    const double period = 2 * M_PI * camera.params[0];
    d.x() -= period * std::round(d.x() / period);
  }
  return d;
}

// Per image point: squared pixel distance between poses a and b.
std::vector<double> ImageDisplacements2(const std::vector<ImagePoint>& sample, const Rigid3d& a,
                                        const Rigid3d& b) {
  std::vector<double> d2;
  for (const ImagePoint& point : sample) {
    Eigen::Vector2d pa, pb;
    if (!ProjectImagePoint(point, a, &pa) || !ProjectImagePoint(point, b, &pb)) continue;
    d2.push_back(ImagePixelDifference(*point.camera, pa, pb).squaredNorm());
  }
  return d2;
}

// Per image point: trace(J Σ Jᵀ) at correction x (J by central differences), pixels².
std::vector<double> ImagePredictedVariances(const std::vector<ImagePoint>& sample,
                                            const Rigid3d& start, const Vector6d& x,
                                            const Eigen::Matrix<double, 6, 6>& covariance) {
  Vector6d h;
  h << 1e-3, 1e-3, 1e-3, 1e-2, 1e-2, 1e-2;
  std::array<Rigid3d, 12> poses;
  for (int k = 0; k < 12; ++k) {
    Vector6d y = x;
    y[k / 2] += (k % 2 == 0 ? 1.0 : -1.0) * h[k / 2];
    poses[k] = ApplyCorrection(start, y);
  }
  std::vector<double> variances;
  for (const ImagePoint& point : sample) {
    Eigen::Matrix<double, 2, 6> jacobian;
    bool ok = true;
    for (int k = 0; k < 6 && ok; ++k) {
      Eigen::Vector2d pa, pb;
      ok = ProjectImagePoint(point, poses[2 * k], &pa) &&
           ProjectImagePoint(point, poses[2 * k + 1], &pb);
      if (ok) jacobian.col(k) = ImagePixelDifference(*point.camera, pa, pb) / (2 * h[k]);
    }
    if (ok) variances.push_back((jacobian * covariance * jacobian.transpose()).trace());
  }
  return variances;
}

}  // namespace internal

}  // namespace mmba::registration::mi
