#pragma once

#include <memory>

#include <ceres/manifold.h>

namespace mmba {

/// Manifold of a pose stored as 7 doubles [qx, qy, qz, qw, tx, ty, tz] (Eigen quaternion
/// coefficient order, then translation): SO(3) × R³ with a 6-dof tangent space
/// (rotation increment in the quaternion's body frame, then translation).
/// Ceres 2.1 Manifold API (ProductManifold of EigenQuaternionManifold and R³).
std::unique_ptr<ceres::Manifold> CreatePoseManifold();

/// Manifold of a unit quaternion stored in Eigen order [qx, qy, qz, qw].
std::unique_ptr<ceres::Manifold> CreateQuaternionManifold();

/// Manifold of a 3-vector of fixed norm (its tangent space is 2-dof): used to fix the
/// distance of a second camera from the first when fixing the gauge of a free network.
std::unique_ptr<ceres::Manifold> CreateFixedNormManifold();

}  // namespace mmba
