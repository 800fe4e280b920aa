// The only translation unit of mmba_adjust that includes PCL (its k-d tree).
#include <Eigen/Eigenvalues>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "mmba/adjust/groups.h"
#include "mmba/io/point_cloud.h"

namespace mmba::adjust {

struct LidarSurface::Impl {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
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
      if ((r.array() < lo.array()).any() || (r.array() > hi.array()).any()) continue;
      const Eigen::Vector3f q = (p - impl_->offset).cast<float>();
      impl_->cloud->push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
    }
  });
  if (!impl_->cloud->empty()) impl_->tree.setInputCloud(impl_->cloud);
}

LidarSurface::~LidarSurface() = default;

size_t LidarSurface::size() const { return impl_->cloud->size(); }

std::vector<Eigen::Vector3d> LidarSurface::Sample(size_t n) const {
  std::vector<Eigen::Vector3d> sample;
  const size_t size = impl_->cloud->size();
  if (size == 0 || n == 0) return sample;
  const double step = std::max(1.0, static_cast<double>(size) / n);
  for (double x = 0.5 * step; x < size; x += step) {
    sample.push_back(impl_->cloud->points[static_cast<size_t>(x)].getVector3fMap().cast<double>() + impl_->offset);
  }
  return sample;
}

bool LidarSurface::FitPlane(const Eigen::Vector3d& query, double max_distance, int k,
                            Eigen::Vector3d* normal, Eigen::Vector3d* centroid, double* roughness) const {
  if (impl_->cloud->size() < static_cast<size_t>(k)) return false;
  const Eigen::Vector3f q = (query - impl_->offset).cast<float>();
  std::vector<int> index(k);
  std::vector<float> distance2(k);
  if (impl_->tree.nearestKSearch(pcl::PointXYZ(q.x(), q.y(), q.z()), k, index, distance2) < k) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : index) mean += impl_->cloud->points[i].getVector3fMap().cast<double>();
  mean /= k;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int i : index) {
    const Eigen::Vector3d d = impl_->cloud->points[i].getVector3fMap().cast<double>() - mean;
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

}  // namespace mmba::adjust
