#include "mmba/geometry/pose_manifold.h"

#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>

namespace mmba {

std::unique_ptr<ceres::Manifold> CreatePoseManifold() {
  using PoseManifold =
      ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
  return std::make_unique<PoseManifold>(ceres::EigenQuaternionManifold(),
                                        ceres::EuclideanManifold<3>());
}

std::unique_ptr<ceres::Manifold> CreateQuaternionManifold() {
  return std::make_unique<ceres::EigenQuaternionManifold>();
}

std::unique_ptr<ceres::Manifold> CreateFixedNormManifold() {
  return std::make_unique<ceres::SphereManifold<3>>();
}

}  // namespace mmba
