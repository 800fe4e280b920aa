// The static LiDAR around the photo block coloured from the adjusted photos (issue 7's
// "georeferenced point clouds (coloured from images where seen)"). The only other OpenCV
// translation unit of mmba_adjust besides sphere_dense.cc (it reads colour images).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "internal.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

/// The LiDAR points in the box, in the world frame (adjusted scans, else the reference cloud),
/// thinned evenly to at most `cap`.
io::PointCloud LidarInBox(const JointState& s, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, size_t cap) {
  io::PointCloud out;
  const auto read = [&](const std::string& path, const Rigid3d& world_from_file) {
    io::StreamPointCloud(path, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
      for (const Eigen::Vector3d& p : chunk.points) {
        const Eigen::Vector3d w = world_from_file * p;
        if ((w.array() >= lo.array()).all() && (w.array() <= hi.array()).all()) out.points.push_back(w);
      }
    });
  };
  if (!s.scans.empty()) {
    for (size_t k = 0; k < s.scans.size(); ++k) read(s.scans[k].file, s.scan_from_world[k].Inverse());
  } else {
    read(s.project->lidar_static.front().reference_cloud, Rigid3d());
  }
  ThinEvenly(&out.points, cap);
  return out;
}

}  // namespace

json WriteColouredLidar(const JointState& s, const fs::path& stage, json* files) {
  json entry;
  if (!s.photos || s.project->lidar_static.empty()) return entry;
  // The box of the photo block's tie points, 1 m around: the LiDAR the photos can colour.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& [id, p] : s.scene.points()) {
    if (id.value >= kCheckPointIdBase) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (!(lo.array() <= hi.array()).all()) return entry;
  lo.array() -= 1.0;
  hi.array() += 1.0;
  constexpr size_t kMaxPoints = 5000000;
  io::PointCloud cloud = LidarInBox(s, lo, hi, kMaxPoints);
  const size_t n = cloud.size();
  std::vector<Eigen::Vector3f> sum(n, Eigen::Vector3f::Zero());
  std::vector<float> weight(n, 0.0f);
  size_t images = 0;
  std::vector<std::string> unreadable;
  for (const auto& [id, image] : s.photos->model.images) {
    const fs::path path = fs::path(s.photos->config->images) / image.name;
    const cv::Mat bgr = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (bgr.empty()) {
      unreadable.push_back(path.string());
      continue;
    }
    const sensors::Camera& camera = s.scene.Camera(image.camera_id);
    const Rigid3d& cam_from_world = s.scene.Image(id).cam_from_world;
    // Visibility: a coarse z-buffer of the LiDAR itself (cells of ~1/400 of the width), so the
    // far side of a wall is not painted with the wall's colour.
    const int cell = std::max(2, bgr.cols / 400);
    const int gw = (bgr.cols + cell - 1) / cell, gh = (bgr.rows + cell - 1) / cell;
    std::vector<float> depth(static_cast<size_t>(gw) * gh, std::numeric_limits<float>::infinity());
    std::vector<int> pixel(n, -1);
    std::vector<float> range(n, 0.0f);
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d pc = cam_from_world * cloud.points[i];
      if (pc.z() <= 0.1) continue;
      const std::optional<Eigen::Vector2d> uv = camera.ImgFromCam(pc);
      if (!uv) continue;
      const int u = static_cast<int>(std::floor(uv->x())), v = static_cast<int>(std::floor(uv->y()));
      if (u < 0 || v < 0 || u >= bgr.cols || v >= bgr.rows) continue;
      pixel[i] = v * bgr.cols + u;
      range[i] = static_cast<float>(pc.norm());
      float& d = depth[static_cast<size_t>(v / cell) * gw + u / cell];
      d = std::min(d, range[i]);
    }
    for (size_t i = 0; i < n; ++i) {
      if (pixel[i] < 0) continue;
      const int u = pixel[i] % bgr.cols, v = pixel[i] / bgr.cols;
      const float front = depth[static_cast<size_t>(v / cell) * gw + u / cell];
      if (range[i] > front * 1.02f + 0.05f) continue;  // behind the first surface of its cell
      const cv::Vec3b c = bgr.at<cv::Vec3b>(v, u);
      const float w = 1.0f / (range[i] * range[i]);  // nearer views see more detail
      sum[i] += w * Eigen::Vector3f(c[2], c[1], c[0]);
      weight[i] += w;
    }
    ++images;
  }
  size_t coloured = 0;
  cloud.colors.resize(n);
  for (size_t i = 0; i < n; ++i) {
    if (weight[i] > 0) {
      const Eigen::Vector3f c = sum[i] / weight[i];
      cloud.colors[i] = {static_cast<uint8_t>(std::lround(c.x())), static_cast<uint8_t>(std::lround(c.y())),
                         static_cast<uint8_t>(std::lround(c.z()))};
      ++coloured;
    } else {
      cloud.colors[i] = {128, 128, 128};  // not seen by any photo
    }
  }
  io::WritePly(cloud, (stage / "lidar_coloured.ply").string());
  files->push_back({{"name", "lidar_coloured.ply"},
                    {"description", "the static LiDAR around the photo block (adjusted scans, else the reference "
                                    "cloud), coloured from the adjusted photos where seen (grey: not seen)"}});
  entry = {{"file", "lidar_coloured.ply"}, {"points", n}, {"coloured", coloured}, {"images", images},
           {"unreadable_images", unreadable}};
  spdlog::info("adjust: LiDAR coloured from {} photos: {} of {} points seen", images, coloured, n);
  return entry;
}

}  // namespace mmba::adjust::internal
