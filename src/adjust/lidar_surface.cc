// The LiDAR surface: the reference cloud around a region of interest and local planes fitted to
// its nearest points (mmba's kd-tree, geometry/point_index.h).
#include <algorithm>
#include <string>

#include <Eigen/Eigenvalues>

#include "mmba/adjust/groups.h"
#include "mmba/geometry/point_index.h"
#include "mmba/io_cloud/point_cloud.h"

namespace mmba::adjust {

struct LidarSurface::Impl {
  std::vector<Eigen::Vector3f> points;               // relative to `offset`, float precision
  std::unique_ptr<PointIndex> tree;                  // over `points` (their float values)
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // float precision: points relative to it
};

LidarSurface::LidarSurface(const std::string& path, const Eigen::Vector3d& roi_min,
                           const Eigen::Vector3d& roi_max, double margin, const Rigid3d& roi_from_file)
    : impl_(std::make_unique<Impl>()) {
  // Streamed: only the points inside the region of interest are held (a binary PLY is read a
  // chunk at a time, whatever its size).
  constexpr size_t kChunkPoints = 1000000;
  const Eigen::Vector3d lo = roi_min.array() - margin, hi = roi_max.array() + margin;
  impl_->offset = roi_from_file.Inverse() * (0.5 * (roi_min + roi_max));
  io::StreamPointCloud(path, kChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t total) {
    num_read_ = total;
    for (const Eigen::Vector3d& p : chunk.points) {
      const Eigen::Vector3d r = roi_from_file * p;
      read_min_ = read_min_.cwiseMin(r);
      read_max_ = read_max_.cwiseMax(r);
      if ((r.array() < lo.array()).any() || (r.array() > hi.array()).any()) continue;
      impl_->points.push_back((p - impl_->offset).cast<float>());
    }
  });
  if (impl_->points.empty()) return;
  // The index holds the same float coordinates (its local origin is zero for points about the
  // offset), so its float distances are those of the points.
  std::vector<Eigen::Vector3d> exact(impl_->points.size());
  for (size_t i = 0; i < exact.size(); ++i) exact[i] = impl_->points[i].cast<double>();
  impl_->tree = std::make_unique<PointIndex>(exact);
}

LidarSurface::~LidarSurface() = default;

size_t LidarSurface::size() const { return impl_->points.size(); }

std::vector<Eigen::Vector3d> LidarSurface::Sample(size_t n) const {
  std::vector<Eigen::Vector3d> sample;
  const size_t size = impl_->points.size();
  if (size == 0 || n == 0) return sample;
  const double step = std::max(1.0, static_cast<double>(size) / n);
  for (double x = 0.5 * step; x < size; x += step) {
    sample.push_back(impl_->points[static_cast<size_t>(x)].cast<double>() + impl_->offset);
  }
  return sample;
}

bool LidarSurface::FitPlane(const Eigen::Vector3d& query, double max_distance, int k,
                            Eigen::Vector3d* normal, Eigen::Vector3d* centroid, double* roughness) const {
  if (impl_->points.size() < static_cast<size_t>(k)) return false;
  // The query as the float the points are (relative to the offset).
  const Eigen::Vector3d q = (query - impl_->offset).cast<float>().cast<double>();
  std::vector<int> index;
  std::vector<float> distance2;
  impl_->tree->KNearest(q, k, &index, &distance2);
  if (index.size() < static_cast<size_t>(k)) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : index) mean += impl_->points[i].cast<double>();
  mean /= k;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int i : index) {
    const Eigen::Vector3d d = impl_->points[i].cast<double>() - mean;
    covariance += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(covariance / k);
  if (!(eig.eigenvalues()(0) <= 0.1 * eig.eigenvalues()(1))) return false;  // not planar
  const Eigen::Vector3d n = eig.eigenvectors().col(0);
  const Eigen::Vector3d offset = query - impl_->offset - mean;
  const double along = n.dot(offset);
  if (std::abs(along) > max_distance) return false;
  // Over the patch, not beyond it: a plane is not extrapolated past its own points (the query
  // within the patch's RMS in-plane radius of its centroid).
  if ((offset - along * n).squaredNorm() > eig.eigenvalues()(1) + eig.eigenvalues()(2)) return false;
  *normal = n;
  *centroid = mean + impl_->offset;
  if (roughness) *roughness = std::sqrt(std::max(0.0, eig.eigenvalues()(0)));
  return true;
}

std::string CoordinateHint(const Eigen::Vector3d& cloud_min, const Eigen::Vector3d& cloud_max,
                           const Eigen::Vector3d& block_min, const Eigen::Vector3d& block_max) {
  if (!(cloud_min.array() <= cloud_max.array()).all()) return "";
  // Intersection over union of the horizontal boxes of the scaled cloud and the block (each
  // side at least 1 m): a cloud in other units has the block's place and size once scaled.
  const auto iou = [&](double scale) {
    double intersection = 1.0, a = 1.0, b = 1.0;
    for (int k = 0; k < 2; ++k) {
      const double c0 = scale * cloud_min[k], c1 = std::max(scale * cloud_max[k], c0 + 1.0);
      const double b0 = block_min[k], b1 = std::max(block_max[k], b0 + 1.0);
      intersection *= std::max(0.0, std::min(c1, b1) - std::max(c0, b0));
      a *= c1 - c0;
      b *= b1 - b0;
    }
    return intersection / (a + b - intersection);
  };
  const double as_given = iou(1.0);
  const struct {
    double scale;
    const char* unit;
  } units[] = {{0.001, "millimetres"}, {0.01, "centimetres"}, {0.3048, "feet (international or US survey)"}};
  for (const auto& u : units) {
    if (iou(u.scale) > 0.1 && iou(u.scale) > 10 * as_given) {
      return std::string("its coordinates look like ") + u.unit +
             " (scaled to metres its extent would match the block's); the project's world is in metres";
    }
  }
  const Eigen::Vector3d centre = 0.5 * (cloud_min + cloud_max);
  if (centre.head<2>().norm() > 1.0e5) {
    return "its coordinates (centre " + std::to_string(centre.x()) + ", " + std::to_string(centre.y()) +
           ") look projected (UTM or a national grid) or geocentric; the project's world is the local ENU tangent plane "
           "at the origin, in metres";
  }
  return "";
}

}  // namespace mmba::adjust
