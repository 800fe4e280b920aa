// Surface normals that widen their neighbourhood where it is a line (declared in
// pcl_backend.h; no PCL here).

#include "registration/cloud/pcl_backend.h"

#include <atomic>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "mmba/core/parallel_for.h"

namespace mmba::registration::internal {

size_t SurfaceNormals(const std::vector<Eigen::Vector3d>& points, const PointIndex& index,
                      double radius, double max_radius, const Eigen::Vector3d& viewpoint,
                      std::vector<Eigen::Vector3d>* normals, double min_ratio) {
  normals->assign(points.size(), Eigen::Vector3d::Constant(std::nan("")));
  // Points [begin, end): each normal depends on its own neighbourhood only, so the two
  // halves run in parallel with the same result as in sequence.
  auto estimate = [&](size_t begin, size_t end, size_t* widened) {
    std::vector<int> idx;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    // Covariance eigen-decomposition of the neighbours of points[i] within r; false with
    // fewer than 3 neighbours.
    auto pca = [&](size_t i, double r) {
      index.Radius(points[i], r, &idx);
      if (idx.size() < 3) return false;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int j : idx) mean += points[static_cast<size_t>(j)] - points[i];
      mean /= static_cast<double>(idx.size());
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (int j : idx) {
        const Eigen::Vector3d d = points[static_cast<size_t>(j)] - points[i] - mean;
        cov += d * d.transpose();
      }
      eig.computeDirect(cov / static_cast<double>(idx.size()));
      return eig.info() == Eigen::Success;
    };
    auto surface = [&] {
      const Eigen::Vector3d& l = eig.eigenvalues();  // ascending
      return l(2) > 0 && l(1) >= min_ratio * l(2);
    };
    // The eigenvector of the smallest eigenvalue, towards the viewpoint.
    auto normal = [&](size_t i) {
      Eigen::Vector3d n = eig.eigenvectors().col(0);
      return n.dot(viewpoint - points[i]) < 0 ? Eigen::Vector3d(-n) : n;
    };
    for (size_t i = begin; i < end; ++i) {
      if (!pca(i, radius)) continue;  // too sparse: NaN
      if (surface()) {
        (*normals)[i] = normal(i);
        continue;
      }
      for (double r = 2.0 * radius; r <= max_radius * 1.0001; r *= 2.0) {
        if (pca(i, r) && surface()) {
          (*normals)[i] = normal(i);
          break;
        }
      }
      ++*widened;
    }
  };
  std::atomic<size_t> widened{0};
  ParallelChunks(points.size(), 2, [&](size_t begin, size_t end) {
    size_t chunk_widened = 0;
    estimate(begin, end, &chunk_widened);
    widened += chunk_widened;
  });
  return widened;
}

}  // namespace mmba::registration::internal
