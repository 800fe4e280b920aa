#pragma once

// The BAL / Bundler camera ("Snavely camera", Ceres examples/snavely_reprojection_error.h):
// 9 parameters [ω (angle-axis, 3), t (3), f, k1, k2], projection
//   P = R(ω)·X + t,  p = −P.xy / P.z,  r² = ‖p‖²,  x = f·(1 + k1 r² + k2 r⁴)·p,
// observations with the image centre at the origin and y up.

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>
#include <ceres/sized_cost_function.h>

namespace mmba::factors {

/// Automatic-differentiation version (identical to Ceres' example); the reference the
/// analytic version is tested and benchmarked against.
struct SnavelyReprojectionErrorAutoDiff {
  SnavelyReprojectionErrorAutoDiff(double observed_x, double observed_y)
      : observed_x(observed_x), observed_y(observed_y) {}

  template <typename T>
  bool operator()(const T* camera, const T* point, T* residuals) const {
    T p[3];
    ceres::AngleAxisRotatePoint(camera, point, p);
    p[0] += camera[3];
    p[1] += camera[4];
    p[2] += camera[5];
    const T xp = -p[0] / p[2];
    const T yp = -p[1] / p[2];
    const T r2 = xp * xp + yp * yp;
    const T distortion = T(1.0) + r2 * (camera[7] + camera[8] * r2);
    residuals[0] = camera[6] * distortion * xp - observed_x;
    residuals[1] = camera[6] * distortion * yp - observed_y;
    return true;
  }

  static ceres::CostFunction* Create(double observed_x, double observed_y) {
    return new ceres::AutoDiffCostFunction<SnavelyReprojectionErrorAutoDiff, 2, 9, 3>(
        new SnavelyReprojectionErrorAutoDiff(observed_x, observed_y));
  }

  double observed_x;
  double observed_y;
};

/// Same residual with an analytic Jacobian: ∂(R(ω)X)/∂ω = −[R X]× J_l(ω) with the left
/// Jacobian of SO(3), J_l(ω) = I + (1−cos θ)/θ² [ω]× + (θ−sin θ)/θ³ [ω]×²
/// (Barfoot, State Estimation for Robotics, 2017, Eq. (7.86)); the rest is the chain rule
/// through the perspective division and the radial distortion.
class SnavelyReprojectionError : public ceres::SizedCostFunction<2, 9, 3> {
 public:
  SnavelyReprojectionError(double observed_x, double observed_y)
      : observed_x_(observed_x), observed_y_(observed_y) {}

  static ceres::CostFunction* Create(double observed_x, double observed_y) {
    return new SnavelyReprojectionError(observed_x, observed_y);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double observed_x_;
  double observed_y_;
};

}  // namespace mmba::factors
