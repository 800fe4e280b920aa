#include "mmba/factors/snavely_reprojection_error.h"

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mmba/geometry/skew.h"

namespace mmba::factors {

bool SnavelyReprojectionError::Evaluate(double const* const* parameters, double* residuals,
                                        double** jacobians) const {
  const double* camera = parameters[0];
  const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
  const Eigen::Map<const Eigen::Vector3d> omega(camera);
  const double theta2 = omega.squaredNorm();

  // Rotation matrix from the angle-axis vector (Rodrigues), with the Taylor form near 0 as
  // ceres::AngleAxisToRotationMatrix does.
  Eigen::Matrix3d rotation;
  Eigen::Matrix3d left_jacobian;
  const Eigen::Matrix3d skew = Skew(omega);
  if (theta2 > std::numeric_limits<double>::epsilon()) {
    const double theta = std::sqrt(theta2);
    const double s = std::sin(theta);
    const double c = std::cos(theta);
    rotation = Eigen::Matrix3d::Identity() + (s / theta) * skew + ((1 - c) / theta2) * skew * skew;
    left_jacobian = Eigen::Matrix3d::Identity() + ((1 - c) / theta2) * skew +
                    ((theta - s) / (theta2 * theta)) * skew * skew;
  } else {
    rotation = Eigen::Matrix3d::Identity() + skew;
    left_jacobian = Eigen::Matrix3d::Identity() + 0.5 * skew;
  }
  const Eigen::Vector3d rotated = rotation * point;
  const Eigen::Vector3d p = rotated + Eigen::Map<const Eigen::Vector3d>(camera + 3);
  const double inv_z = 1.0 / p.z();
  const double xp = -p.x() * inv_z;
  const double yp = -p.y() * inv_z;
  const double f = camera[6];
  const double k1 = camera[7];
  const double k2 = camera[8];
  const double r2 = xp * xp + yp * yp;
  const double distortion = 1.0 + r2 * (k1 + k2 * r2);
  residuals[0] = f * distortion * xp - observed_x_;
  residuals[1] = f * distortion * yp - observed_y_;
  if (jacobians == nullptr) return true;

  // d(residual)/d(xp, yp)
  const double dd_dr2 = k1 + 2.0 * k2 * r2;
  Eigen::Matrix2d dres_dnorm;
  dres_dnorm << f * (distortion + 2.0 * xp * xp * dd_dr2), f * 2.0 * xp * yp * dd_dr2,
      f * 2.0 * xp * yp * dd_dr2, f * (distortion + 2.0 * yp * yp * dd_dr2);
  // d(xp, yp)/dP
  Eigen::Matrix<double, 2, 3> dnorm_dp;
  dnorm_dp << -inv_z, 0.0, p.x() * inv_z * inv_z, 0.0, -inv_z, p.y() * inv_z * inv_z;
  const Eigen::Matrix<double, 2, 3> dres_dp = dres_dnorm * dnorm_dp;

  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 9, Eigen::RowMajor>> j(jacobians[0]);
    j.leftCols<3>() = dres_dp * (-Skew(rotated) * left_jacobian);
    j.middleCols<3>(3) = dres_dp;
    j(0, 6) = distortion * xp;
    j(1, 6) = distortion * yp;
    j(0, 7) = f * r2 * xp;
    j(1, 7) = f * r2 * yp;
    j(0, 8) = f * r2 * r2 * xp;
    j(1, 8) = f * r2 * r2 * yp;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
    j = dres_dp * rotation;
  }
  return true;
}

}  // namespace mmba::factors
