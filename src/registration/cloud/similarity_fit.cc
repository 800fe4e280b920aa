// RefineSimilarity: 7-DoF point-to-plane ICP of a cloud in a scale of its own.

#include "mmba/registration/cloud/feature_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "mmba/geometry/point_index.h"
#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/pcl_backend.h"

namespace mmba::registration {

using internal::Apply;
using internal::DropInvalidNormals;
using internal::Level;
using internal::MedianSpacing;
using internal::VoxelDownsample;
using internal::VoxelForBudget;

SimilarityFit RefineSimilarity(const io::PointCloud& source, const io::PointCloud& target,
                               const Eigen::Matrix4d& start, double start_distance,
                               double end_distance, int iterations, size_t max_target_points) {
  SimilarityFit fit;
  fit.target_from_source = start;
  fit.scale = start.topLeftCorner<3, 3>().col(0).norm();
  if (source.empty() || target.empty() || !(end_distance > 0)) return fit;
  // The target near the moved source, thinned, with normals within 4 of its spacings.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Eigen::Vector3d& p : source.points) {
    const Eigen::Vector3d q = Apply(start, p);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  const double margin = std::max(start_distance, end_distance);
  lo.array() -= margin;
  hi.array() += margin;
  io::PointCloud crop;
  for (const Eigen::Vector3d& x : target.points) {
    if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) crop.points.push_back(x);
  }
  if (crop.size() < 10) return fit;
  Level tgt = VoxelDownsample(crop.points, {}, VoxelForBudget(crop, 0.0, max_target_points));
  const double spacing = MedianSpacing(tgt.points, 20000);
  tgt.normals = internal::EstimateNormals(tgt.points, 4.0 * spacing, Eigen::Vector3d::Zero());
  DropInvalidNormals(&tgt);
  if (tgt.points.size() < 10) return fit;
  const internal::PointIndex index(tgt.points);
  Eigen::Matrix4d transform = start;
  double distance = margin;
  int idx;
  double sq;
  for (int it = 0; it < iterations; ++it) {
    fit.iterations = it + 1;
    std::vector<Eigen::Vector3d> moved;
    moved.reserve(source.size());
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : source.points) {
      moved.push_back(Apply(transform, p));
      centre += moved.back();
    }
    centre /= static_cast<double>(moved.size());
    // Parameters (ω, t, σ): q' = c + e^σ Exp(ω)(q − c) + t; at zero the residual
    // n·(q' − x) changes by ω·((q − c) × n) + n·t + σ n·(q − c).
    Eigen::Matrix<double, 7, 7> jtj = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> jtr = Eigen::Matrix<double, 7, 1>::Zero();
    const double d2 = distance * distance;
    int count = 0;
    for (const Eigen::Vector3d& q : moved) {
      if (!index.NearestWithin(q, d2, &idx, &sq)) continue;
      const Eigen::Vector3d& n = tgt.normals[static_cast<size_t>(idx)];
      const Eigen::Vector3d a = q - centre;
      const double r = (q - tgt.points[static_cast<size_t>(idx)]).dot(n);
      const double w = 1.0 / (1.0 + (r * r) / (0.25 * d2));
      Eigen::Matrix<double, 7, 1> j;
      j << a.cross(n), n, n.dot(a);
      jtj += w * j * j.transpose();
      jtr += w * j * r;
      ++count;
    }
    if (count < 7) break;
    const Eigen::Matrix<double, 7, 1> x = jtj.ldlt().solve(-jtr);
    if (!x.allFinite()) break;
    const Eigen::Vector3d omega = x.head<3>();
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    if (omega.norm() > 1e-12) rotation = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    Eigen::Matrix4d delta = Eigen::Matrix4d::Identity();
    delta.topLeftCorner<3, 3>() = std::exp(x(6)) * rotation;
    delta.topRightCorner<3, 1>() = centre + x.segment<3>(3) - delta.topLeftCorner<3, 3>() * centre;
    transform = delta * transform;
    const bool small = omega.norm() < 1e-6 && std::abs(x(6)) < 1e-6 && x.segment<3>(3).norm() < 1e-3 * end_distance;
    if (small && distance <= end_distance) break;
    distance = std::max(end_distance, distance * 0.8);
  }
  fit.target_from_source = transform;
  fit.scale = transform.topLeftCorner<3, 3>().col(0).norm();
  size_t inliers = 0;
  double sum = 0.0;
  for (const Eigen::Vector3d& p : source.points) {
    if (!index.NearestWithin(Apply(transform, p), end_distance * end_distance, &idx, &sq)) continue;
    ++inliers;
    sum += sq;
  }
  fit.fitness = static_cast<double>(inliers) / static_cast<double>(source.size());
  fit.inlier_rmse = inliers > 0 ? std::sqrt(sum / static_cast<double>(inliers)) : 0.0;
  return fit;
}

}  // namespace mmba::registration
