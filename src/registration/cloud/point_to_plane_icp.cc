// The rigid ICP of the cloud registration.

#include "registration/cloud/point_to_plane_icp.h"

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "registration/cloud/cloud_levels.h"

namespace mmba::registration::internal {

namespace {

Eigen::Matrix3d CrossMatrix(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

}  // namespace

Eigen::Matrix4d PointToPlaneIcp(const std::vector<Eigen::Vector3d>& src,
                                const std::vector<Eigen::Vector3d>& tgt,
                                const std::vector<Eigen::Vector3d>& tgt_normals,
                                const PointIndex& tgt_index, Eigen::Matrix4d transform,
                                double start_distance, double end_distance, int iterations,
                                const Eigen::Vector3d* up,
                                const std::vector<Eigen::Vector3d>* src_normals) {
  constexpr double kPlaneEpsilon = 1e-3;
  double distance = std::max(start_distance, end_distance);
  // Each step turns the source about its own centroid c (where it lies under the current
  // transform), not about the origin of the coordinates: a source far from that origin
  // against its size would move by the step's second-order term at that distance (a part
  // registered onto a whole model: the model's centre can be tens of metres away).
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : src) c += p;
  c /= static_cast<double>(std::max<size_t>(1, src.size()));
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> jtj = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> jtr = Eigen::Matrix<double, 6, 1>::Zero();
    int count = 0;
    int index;
    double sq;
    const double d2 = distance * distance;
    const Eigen::Vector3d centre = Apply(transform, c);
    const Eigen::Matrix3d rotation = transform.topLeftCorner<3, 3>();
    for (size_t i = 0; i < src.size(); ++i) {
      const Eigen::Vector3d q = Apply(transform, src[i]);
      if (!tgt_index.NearestWithin(q, d2, &index, &sq)) continue;
      const Eigen::Vector3d& n = tgt_normals[index];
      if (!n.allFinite()) continue;
      if (src_normals != nullptr && (*src_normals)[i].allFinite()) {
        const Eigen::Vector3d ns = rotation * (*src_normals)[i];
        const Eigen::Matrix3d cov = 2.0 * Eigen::Matrix3d::Identity() -
                                    (1.0 - kPlaneEpsilon) * (ns * ns.transpose() + n * n.transpose());
        const Eigen::Matrix3d info = cov.inverse();
        const Eigen::Vector3d e = q - tgt[index];
        // The weight from the residual a point-to-plane fit would see (eᵀ·info·e·2ε is
        // (n·e)² where the normals agree).
        const double r2 = e.dot(info * e) * 2.0 * kPlaneEpsilon;
        const double w = 1.0 / (1.0 + r2 / (0.25 * d2));
        Eigen::Matrix<double, 3, 6> j;
        j.leftCols<3>() = -CrossMatrix(q - centre);
        j.rightCols<3>() = Eigen::Matrix3d::Identity();
        // Scaled by 2ε so that the normal direction weighs as in the point-to-plane sum.
        const Eigen::Matrix3d wi = (w * 2.0 * kPlaneEpsilon) * info;
        jtj += j.transpose() * wi * j;
        jtr += j.transpose() * wi * e;
        ++count;
        continue;
      }
      const double r = (q - tgt[index]).dot(n);
      // Tukey-like down-weighting of the far residuals.
      const double w = 1.0 / (1.0 + (r * r) / (0.25 * d2));
      Eigen::Matrix<double, 6, 1> j;
      j.head<3>() = (q - centre).cross(n);
      j.tail<3>() = n;
      jtj += w * j * j.transpose();
      jtr += w * j * r;
      ++count;
    }
    if (count < 6) break;
    Eigen::Matrix<double, 6, 1> x;
    if (up != nullptr) {
      // Parameters (α about up, t): J_α = (q × n)·up.
      Eigen::Matrix<double, 6, 4> b = Eigen::Matrix<double, 6, 4>::Zero();
      b.block<3, 1>(0, 0) = *up;
      b.block<3, 3>(3, 1) = Eigen::Matrix3d::Identity();
      const Eigen::Matrix4d a = b.transpose() * jtj * b;
      const Eigen::Vector4d y = a.ldlt().solve(-b.transpose() * jtr);
      x = b * y;
    } else {
      x = jtj.ldlt().solve(-jtr);
    }
    if (!x.allFinite()) break;
    Eigen::Matrix4d delta = Eigen::Matrix4d::Identity();
    const Eigen::Vector3d omega = x.head<3>();
    if (omega.norm() > 1e-12) {
      delta.topLeftCorner<3, 3>() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    }
    delta.topRightCorner<3, 1>() = centre + x.tail<3>() - delta.topLeftCorner<3, 3>() * centre;
    transform = delta * transform;
    const bool small = omega.norm() < 1e-6 && x.tail<3>().norm() < 1e-3 * end_distance;
    if (small && distance <= end_distance) break;
    distance = std::max(end_distance, distance * 0.7);
  }
  return transform;
}

}  // namespace mmba::registration::internal
