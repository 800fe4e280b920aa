#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/ids.h"
#include "mmba/problem/factor_group.h"

namespace mmba {

/// One image measurement of a 3-D point.
struct ReprojectionObservation {
  ImageId image_id;
  Point3DId point3D_id;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  ///< pixels, COLMAP convention
  double sigma_px = 1.0;                         ///< a-priori σ of each coordinate, > 0
};

/// The reprojection factor group: every observation ties an image pose, the image's
/// intrinsics and a 3-D point (factors/reprojection_error.h). Perspective models use a
/// pixel residual; EQUIRECTANGULAR uses the angle on the sphere, scaled to pixels.
///
/// Observations that cannot be used are counted, never silently dropped: a missing image,
/// camera or point id, or a point the model cannot image at the initial values (behind a
/// perspective camera). See skipped_behind() / skipped_missing().
class ReprojectionGroup : public FactorGroup {
 public:
  explicit ReprojectionGroup(std::vector<ReprojectionObservation> observations,
                             LossOptions loss = {}, std::string name = "reprojection");

  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

  const std::vector<ReprojectionObservation>& observations() const { return observations_; }
  size_t skipped_behind() const { return skipped_behind_; }
  size_t skipped_missing() const { return skipped_missing_; }

 private:
  std::vector<ReprojectionObservation> observations_;
  size_t skipped_behind_ = 0;
  size_t skipped_missing_ = 0;
};

}  // namespace mmba
