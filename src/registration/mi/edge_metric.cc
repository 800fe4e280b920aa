// Levinson & Thrun's objective J_C = Σ_f Σ_p X_p^f D_{i,j}^f (RSS 2013, Eq. (1)) over frames
// sharing one cam_from_lidar, on a coarse-to-fine stack of edge images.

#include <algorithm>
#include <cmath>

#include "mmba/core/parallel_for.h"
#include "mmba/registration/mi/edges.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {

namespace {

// The view pixel of a point at a pose, or false when behind the view or outside its image.
bool ProjectToView(const View& view, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                   const Eigen::Vector3f& point, double margin_px, Eigen::Vector2d* pixel) {
  const Eigen::Vector3d p = rotation * point.cast<double>() + translation;
  if (!view.camera.IsSpherical() && p.z() <= 0.1) return false;
  const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p);
  if (!xy) return false;
  if ((*xy)[0] < -margin_px || (*xy)[1] < -margin_px || (*xy)[0] > view.camera.width + margin_px ||
      (*xy)[1] > view.camera.height + margin_px) {
    return false;
  }
  *pixel = *xy;
  return true;
}

void ViewPose(const View& view, const Rigid3d& cam_from_lidar, Eigen::Matrix3d* rotation,
              Eigen::Vector3d* translation) {
  *rotation = view.view_from_cam * cam_from_lidar.rotation.toRotationMatrix();
  *translation = view.view_from_cam * cam_from_lidar.translation + view.view_from_cam_t;
}

}  // namespace

EdgeMetric::EdgeMetric(const std::vector<Frame>& frames, const Rigid3d& cam_from_lidar_start,
                       const EdgeOptions& options, double margin_deg)
    : frames_(frames) {
  frame_points_.resize(frames.size());
  parts_.resize(frames.size());
  view_of_.resize(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    first_view_.push_back(images_.size());
    for (const View& view : frames[f].views) {
      images_.emplace_back(options.levels);
      const size_t v = images_.size() - 1;
      ParallelFor(options.levels, 2, [&](int level) { images_[v][level] = EdgeLevelImage(view.image, options, level); });
    }
    // The edge points about the cloud's origin (the LiDAR's centre for a sweep in its own
    // frame), kept where they reach a view from inside the bounds around the start.
    const std::vector<EdgePoint> all =
        DetectLidarEdges(*frames[f].points, Eigen::Vector3f::Zero(), options);
    for (const EdgePoint& point : all) {
      for (size_t v = 0; v < frames[f].views.size(); ++v) {
        const View& view = frames[f].views[v];
        Eigen::Matrix3d rotation;
        Eigen::Vector3d translation;
        ViewPose(view, cam_from_lidar_start, &rotation, &translation);
        const double margin = view.camera.MeanFocalLength() * std::tan(margin_deg * M_PI / 180.0);
        Eigen::Vector2d pixel;
        if (!ProjectToView(view, rotation, translation, point.point_in_lidar, margin, &pixel)) continue;
        uint8_t part = (f % 2 == 1) ? kOddFrame : 0;
        if (pixel.x() >= 0.5 * view.camera.width) part |= kRight;
        if (pixel.y() >= 0.5 * view.camera.height) part |= kLower;
        frame_points_[f].push_back(point);
        parts_[f].push_back(part);
        view_of_[f].push_back(static_cast<int>(v));
        break;
      }
    }
  }
}

size_t EdgeMetric::points(int kind) const {
  size_t count = 0;
  for (const std::vector<EdgePoint>& points : frame_points_) {
    for (const EdgePoint& point : points) count += point.kind == kind;
  }
  return count;
}

double EdgeMetric::Evaluate(const Rigid3d& cam_from_lidar, int level, uint8_t mask,
                            uint8_t value) const {
  level = std::clamp(level, 0, levels() - 1);
  double score[2] = {0, 0}, weight[2] = {0, 0};
  for (size_t f = 0; f < frame_points_.size(); ++f) {
    const std::vector<View>& views = frames_[f].views;
    std::vector<Eigen::Matrix3d> rotations(views.size());
    std::vector<Eigen::Vector3d> translations(views.size());
    for (size_t v = 0; v < views.size(); ++v) ViewPose(views[v], cam_from_lidar, &rotations[v], &translations[v]);
    const std::vector<EdgePoint>& points = frame_points_[f];
    for (size_t k = 0; k < points.size(); ++k) {
      if ((parts_[f][k] & mask) != value) continue;
      const int v = view_of_[f][k];
      const EdgePoint& point = points[k];
      weight[point.kind] += point.weight;
      Eigen::Vector2d pixel;
      if (!ProjectToView(views[v], rotations[v], translations[v], point.point_in_lidar, 0.0, &pixel)) continue;
      float d = 0;
      if (images_[first_view_[f] + v][level].Sample(pixel.x(), pixel.y(), &d)) score[point.kind] += point.weight * d;
    }
  }
  double sum = 0;
  int kinds = 0;
  for (int kind = 0; kind < 2; ++kind) {
    if (weight[kind] > 0) {
      sum += score[kind] / weight[kind];
      ++kinds;
    }
  }
  return kinds > 0 ? sum / kinds : 0.0;
}

}  // namespace mmba::registration::mi
