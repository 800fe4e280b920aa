#pragma once

// The skew-symmetric (cross-product) matrix of a 3-vector.

#include <Eigen/Core>

namespace mmba {

/// [v]×, the matrix with Skew(v) * w == v.cross(w) for every 3-vector w:
///   |  0   −v_z   v_y |
///   |  v_z   0   −v_x |
///   | −v_y  v_x    0  |
/// Any 3-vector expression (Eigen::Vector3d, a Map, a vector of ceres::Jet).
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, 3, 3> Skew(const Eigen::MatrixBase<Derived>& v) {
  EIGEN_STATIC_ASSERT_VECTOR_SPECIFIC_SIZE(Derived, 3);
  using T = typename Derived::Scalar;
  Eigen::Matrix<T, 3, 3> m;
  m << T(0), -v(2), v(1),
       v(2), T(0), -v(0),
       -v(1), v(0), T(0);
  return m;
}

}  // namespace mmba
