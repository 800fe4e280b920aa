#pragma once

// Helpers shared by the units of the MI registration (private to src/registration/mi): the
// search box, number formatting, the one parallel loop, pixel geometry, the covariance's
// regressions and the acceptance's axis scans.

#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/parallel_for.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi::internal {

constexpr double kDegToRad = M_PI / 180.0;

/// (shift_m ×3, angle_deg ×3): one value for the shifts tx, ty, tz and one for the angles.
Vector6d PerParameter(double shift_m, double angle_deg);
/// The search box: (bound_translation_m ×3, bound_rotation_deg ×3).
Vector6d BoundVector(const RegistrationOptions& options);
/// `v` in fixed notation with `digits` decimals.
std::string Fixed(double v, int digits = 3);

// ---- Threads.
/// One render buffer per thread, reused between evaluations.
LidarImage& ThreadBuffer();
/// core/parallel_for.h: an evaluation made inside a ParallelFor splits itself over two
/// threads only when CoreFreeForSplit(); the split does not change the result (fixed partial
/// sums).
using mmba::CoreFreeForSplit;
using mmba::ParallelFor;
/// Fewer points are rendered on one thread (a thread costs tens of µs).
constexpr size_t kMinPointsToSplit = 20000;

// ---- Pixel geometry.
/// Pixel difference a − b in `view`; across the ±180° seam of a panorama the shorter way.
Eigen::Vector2d PixelDifference(const View& view, const Eigen::Vector2d& a,
                                const Eigen::Vector2d& b);
/// The median (upper median of an even count); +inf when empty.
double Median(std::vector<double> values);
double MeanOf(const std::vector<double>& values);
/// The median of the square roots of `squares`.
double MedianSqrtOf(std::vector<double> squares);

/// Per point of `sample` (those that project at x ± the steps): ∂pixel/∂correction at x, in
/// pixels of the frame's image per m and per degree (central differences).
std::vector<Eigen::Matrix<double, 2, 6>> PixelJacobians(
    const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x,
    const std::vector<FrameSetEvaluator::VisiblePoint>& sample);
/// Per Jacobian J of PixelJacobians: the predicted pixel variance trace(J Σ Jᵀ), in pixels²
/// of the frame's image.
std::vector<double> PredictedPixelVariances(
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians,
    const Eigen::Matrix<double, 6, 6>& covariance);
/// Per point of `sample`: the squared pixel distance between poses a and b, in pixels² of
/// the frame's image.
std::vector<double> PixelDisplacements2(const FrameSetEvaluator& evaluator,
                                        const std::vector<FrameSetEvaluator::VisiblePoint>& sample,
                                        const Rigid3d& a, const Rigid3d& b);

// ---- Points of a frame's own image (the panorama its views were cut from).
struct ImagePoint {
  const sensors::Camera* camera;
  Eigen::Vector3d point_in_lidar;
};
/// Up to `max_points` of the frames' cloud points, within range, that project into their own
/// image at `cam_from_lidar` (frames whose views are cuts, View::image_camera; none
/// otherwise), an even subsample in cloud order.
std::vector<ImagePoint> SampleImagePoints(const std::vector<Frame>& frames,
                                          const Rigid3d& cam_from_lidar,
                                          const RenderOptions& render, size_t max_points);
/// Per image point: squared pixel distance between poses a and b.
std::vector<double> ImageDisplacements2(const std::vector<ImagePoint>& sample, const Rigid3d& a,
                                        const Rigid3d& b);
/// Per image point: trace(J Σ Jᵀ) at correction x (J by central differences), pixels².
std::vector<double> ImagePredictedVariances(const std::vector<ImagePoint>& sample,
                                            const Rigid3d& start, const Vector6d& x,
                                            const Eigen::Matrix<double, 6, 6>& covariance);

// ---- Curvature of the metric (the Laplace covariance).
/// Hessian of MI (nats) w.r.t. the correction (units m, deg): a full quadratic
/// f(x + d) ≈ a + gᵀd + ½ dᵀHd fitted by least squares to samples on a ±2h star and random
/// points of the box x ± 2h. The rendered metric is piecewise constant at the pixel scale, so
/// a regression over many samples is far steadier than finite differences.
Eigen::Matrix<double, 6, 6> MiHessian(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                                      const Vector6d& x, const MetricOptions& metric, int level,
                                      const FrameSetEvaluator::SampleSet* samples, int threads,
                                      int* evaluations);
/// Second derivative of MI (nats per unit²) along a unit direction of the correction: a
/// parabola a + b·t + ½·c·t² fitted by least squares to 13 samples t ∈ [−0.3, 0.3].
double CurvatureAlong(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x,
                      const Vector6d& direction, const MetricOptions& metric, int level,
                      const FrameSetEvaluator::SampleSet* samples, int threads,
                      int* evaluations);

// ---- Acceptance: the axis scans.
/// Confidence along each axis (a reduced probe), and along `weak` (WeaklyObservedDirection;
/// skipped when zero): the metric must peak near the optimum, rise above the scan's minimum,
/// and (the axes) show no second comparable peak. False with `reason` when it does not.
bool CheckConfidence(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                     const Vector6d& x, const Vector6d& weak, const RegistrationOptions& options,
                     int level, std::string* reason, int* evaluations);

}  // namespace mmba::registration::mi::internal
