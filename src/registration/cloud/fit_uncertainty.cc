// The pose covariance of the cloud registration (cluster-robust sandwich over blocks).

#include "registration/cloud/fit_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

namespace mmba::registration::internal {

Eigen::Matrix4d MotionAbout(const Vector6d& xi, const Eigen::Vector3d& c) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const Eigen::Vector3d omega = xi.head<3>();
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  if (omega.norm() > 0) r = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = c - r * c + xi.tail<3>();
  return m;
}

Matrix6d DisplacementMetric(const std::vector<Eigen::Vector3d>& q, const Eigen::Vector3d& c) {
  Matrix6d m = Matrix6d::Zero();
  for (const Eigen::Vector3d& p : q) {
    Eigen::Matrix<double, 3, 6> a;
    const Eigen::Vector3d d = p - c;
    a.leftCols<3>() << 0, d.z(), -d.y(), -d.z(), 0, d.x(), d.y(), -d.x(), 0;  // −[d]×
    a.rightCols<3>().setIdentity();
    m += a.transpose() * a;
  }
  return m / static_cast<double>(std::max<size_t>(1, q.size()));
}

FitUncertainty EstimateFitUncertainty(const std::vector<Eigen::Vector3d>& src,
                                      const TargetCrop& crop, const Eigen::Matrix4d& t,
                                      const std::vector<double>& residuals,
                                      const std::vector<bool>& agree, double reach, double tau,
                                      double block) {
  FitUncertainty out;
  std::vector<Eigen::Vector3d> q(src.size());
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < src.size(); ++i) {
    q[i] = Apply(t, src[i]);
    c += q[i];
  }
  if (src.empty()) return out;
  c /= static_cast<double>(src.size());
  out.centre = c;
  Matrix6d h = Matrix6d::Zero();
  std::unordered_map<VoxelKey, Vector6d, VoxelKeyHash> gradients;
  double sum_sq = 0.0;
  size_t m = 0;
  int index;
  double sq;
  for (size_t i = 0; i < src.size(); ++i) {
    const double r = residuals[i];
    if (!std::isfinite(r) || !(std::abs(r) < tau) || !agree[i]) continue;
    if (!crop.index->NearestWithin(q[i], reach * reach, &index, &sq)) continue;
    const Eigen::Vector3d& n = crop.level.normals[index];
    if (!n.allFinite()) continue;
    Vector6d j;
    j.head<3>() = (q[i] - c).cross(n);
    j.tail<3>() = n;
    h += j * j.transpose();
    const VoxelKey key{static_cast<int64_t>(std::floor(src[i].x() / block)),
                       static_cast<int64_t>(std::floor(src[i].y() / block)),
                       static_cast<int64_t>(std::floor(src[i].z() / block))};
    auto it = gradients.try_emplace(key, Vector6d::Zero()).first;
    it->second += j * r;
    sum_sq += r * r;
    ++m;
  }
  out.blocks = static_cast<int>(gradients.size());
  if (m < 12) return out;
  out.metric = DisplacementMetric(q, c);
  const Eigen::LLT<Matrix6d> llt(out.metric);
  if (llt.info() != Eigen::Success) return out;  // a degenerate (linear) source
  const Matrix6d l = llt.matrixL();
  const Matrix6d l_inv = l.inverse();
  const Matrix6d h_eta = l_inv * h * l_inv.transpose();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig_h(h_eta);
  const double lambda_max = eig_h.eigenvalues()(5);
  const double lambda_min = eig_h.eigenvalues()(0);
  out.constraint_ratio = lambda_max > 0 ? std::max(0.0, lambda_min) / lambda_max : 0.0;
  for (int k = 0; k < 2; ++k) {
    out.weak_directions.push_back(l_inv.transpose() * eig_h.eigenvectors().col(k));
  }
  out.weakest = out.weak_directions.front();
  if (!(out.constraint_ratio > 1e-9)) return out;  // a motion is free: infinite covariance
  const Matrix6d h_inv = eig_h.eigenvectors() * eig_h.eigenvalues().cwiseInverse().asDiagonal() *
                         eig_h.eigenvectors().transpose();
  Matrix6d cov_eta;
  const double b = static_cast<double>(out.blocks);
  if (out.blocks >= 12) {
    Matrix6d meat = Matrix6d::Zero();
    for (const auto& [key, g] : gradients) {
      const Vector6d g_eta = l_inv * g;
      meat += g_eta * g_eta.transpose();
    }
    cov_eta = h_inv * meat * h_inv * (b / (b - 1.0));
  } else {
    const double s2 = sum_sq / static_cast<double>(m - 6);
    cov_eta = s2 * (static_cast<double>(m) / b) * h_inv;
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig_c(cov_eta);
  out.sigma_rms = std::sqrt(std::max(0.0, eig_c.eigenvalues()(5)));
  out.weakest = l_inv.transpose() * eig_c.eigenvectors().col(5);
  out.covariance = l_inv.transpose() * cov_eta * l_inv;
  return out;
}

std::string DescribeMotion(const Vector6d& xi, double scale) {
  std::ostringstream s;
  s << std::setprecision(3) << std::fixed;
  const Eigen::Vector3d omega = scale * xi.head<3>(), shift = scale * xi.tail<3>();
  auto direction = [&s](const Eigen::Vector3d& v) {
    const Eigen::Vector3d u = v.normalized();
    s << "(" << u.x() << ", " << u.y() << ", " << u.z() << ")";
  };
  const bool turn = omega.norm() > 1e-9, move = shift.norm() > 1e-9;
  if (turn) {
    s << "a turn of " << omega.norm() * 180.0 / M_PI << " deg about ";
    direction(omega);
  }
  if (turn && move) s << " and ";
  if (move) {
    s << "a shift of " << shift.norm() << " m along ";
    direction(shift);
  }
  if (!turn && !move) s << "no motion";
  return s.str();
}

void RegisteredMoments(const std::vector<Eigen::Vector3d>& src, const Eigen::Matrix4d& t,
                       Eigen::Vector3d* c, Eigen::Matrix3d* cov) {
  *c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : src) *c += Apply(t, p);
  *c /= static_cast<double>(std::max<size_t>(1, src.size()));
  *cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : src) {
    const Eigen::Vector3d d = Apply(t, p) - *c;
    *cov += d * d.transpose();
  }
  *cov /= static_cast<double>(std::max<size_t>(1, src.size()));
}

}  // namespace mmba::registration::internal
