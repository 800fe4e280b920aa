#include "mmba/registration/mi/mi_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "mmba/core/logging.h"
#include "mmba/core/progress.h"

namespace mmba::registration::mi {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

Eigen::Matrix3d RotationFromRollPitchYawDeg(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Vector6d BoundVector(const RegistrationOptions& options) {
  Vector6d bound;
  bound << options.bound_translation_m, options.bound_translation_m, options.bound_translation_m,
      options.bound_rotation_deg, options.bound_rotation_deg, options.bound_rotation_deg;
  return bound;
}

std::string Fixed(double v, int digits = 3) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << v;
  return out.str();
}

}  // namespace

const char* ParameterName(int axis) {
  static const char* kNames[6] = {"tx", "ty", "tz", "roll", "pitch", "yaw"};
  return axis >= 0 && axis < 6 ? kNames[axis] : "?";
}

Rigid3d ApplyCorrection(const Rigid3d& cam_from_lidar_start, const Vector6d& correction) {
  const Rigid3d lidar_from_cam = cam_from_lidar_start.Inverse();
  const Eigen::Matrix3d delta =
      RotationFromRollPitchYawDeg(correction[3], correction[4], correction[5]);
  Rigid3d corrected(Eigen::Quaterniond(delta * lidar_from_cam.rotation.toRotationMatrix()),
                    lidar_from_cam.translation + correction.head<3>());
  return corrected.Inverse();
}

Vector6d CorrectionBetween(const Rigid3d& cam_from_lidar_start, const Rigid3d& corrected) {
  const Rigid3d a = cam_from_lidar_start.Inverse();
  const Rigid3d b = corrected.Inverse();
  const Eigen::Matrix3d delta =
      b.rotation.toRotationMatrix() * a.rotation.toRotationMatrix().transpose();
  // ZYX Euler angles: delta = Rz(yaw)·Ry(pitch)·Rx(roll).
  const double pitch = std::asin(std::clamp(-delta(2, 0), -1.0, 1.0));
  const double roll = std::atan2(delta(2, 1), delta(2, 2));
  const double yaw = std::atan2(delta(1, 0), delta(0, 0));
  Vector6d correction;
  correction.head<3>() = b.translation - a.translation;
  correction[3] = roll / kDegToRad;
  correction[4] = pitch / kDegToRad;
  correction[5] = yaw / kDegToRad;
  return correction;
}

bool RegistrationOptions::Check(std::string* error) const {
  if (!metric.Check(error) || !render.Check(error)) return false;
  if (!(bound_translation_m > 0) || !(bound_rotation_deg > 0) || bound_rotation_deg > 45) {
    *error = "bounds must be > 0 (rotation <= 45 deg); found " +
             std::to_string(bound_translation_m) + " m, " + std::to_string(bound_rotation_deg) +
             " deg";
    return false;
  }
  if (pyramid_levels < 1 || pyramid_levels > 6) {
    *error = "pyramid_levels " + std::to_string(pyramid_levels) + " must be in 1..6";
    return false;
  }
  if (nelder_mead.max_iterations < 1 || !(nelder_mead.parameter_tolerance > 0) ||
      !(nelder_mead.function_tolerance >= 0) || !(nelder_mead.initial_step.minCoeff() > 0)) {
    *error = "Nelder-Mead settings must be positive (iterations, tolerances, simplex size)";
    return false;
  }
  if (!(max_points_per_pixel > 0)) {
    *error = "max_points_per_pixel must be > 0";
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------
// FrameSetEvaluator

FrameSetEvaluator::FrameSetEvaluator(const std::vector<Frame>& frames,
                                     const Rigid3d& cam_from_lidar_start,
                                     const RegistrationOptions& options)
    : frames_(frames), options_(options) {
  const int levels = options.pyramid_levels;
  pyramid_.resize(levels);
  points_.resize(levels);
  for (const Frame& frame : frames_) pyramid_[0].push_back(frame.views);
  for (int level = 1; level < levels; ++level) {
    for (const std::vector<View>& views : pyramid_[level - 1]) {
      std::vector<View> half;
      for (const View& view : views) half.push_back(DownsampleView(view));
      pyramid_[level].push_back(std::move(half));
    }
  }
  // Cull: keep the points that project into some view (expanded by what the rotation
  // bound can move a pixel, plus a margin for the translation) at the start pose.
  const double rot_margin = std::tan(options.bound_rotation_deg * kDegToRad);
  for (size_t f = 0; f < frames_.size(); ++f) {
    const LidarPoints& all = *frames_[f].points;
    std::vector<char> keep(all.size(), 0);
    for (const View& view : frames_[f].views) {
      const Eigen::Matrix3f rotation =
          (view.view_from_cam * cam_from_lidar_start.rotation.toRotationMatrix()).cast<float>();
      const Eigen::Vector3f translation =
          (view.view_from_cam * cam_from_lidar_start.translation).cast<float>();
      const double focal = view.camera.MeanFocalLength();
      const bool spherical = view.camera.IsSpherical();
      for (size_t i = 0; i < all.size(); ++i) {
        if (keep[i]) continue;
        const Eigen::Vector3f p = rotation * all.points_in_lidar[i] + translation;
        const double range = p.norm();
        if (range > options.render.max_range_m + options.bound_translation_m) continue;
        if (spherical || range < 2.0 * options.bound_translation_m + options.render.min_range_m) {
          keep[i] = 1;
          continue;
        }
        if (p.z() <= 0.f) continue;
        const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p.cast<double>());
        if (!xy) continue;
        const double margin = focal * (rot_margin + options.bound_translation_m / range) + 8.0;
        if ((*xy)[0] >= -margin && (*xy)[1] >= -margin &&
            (*xy)[0] <= view.camera.width + margin && (*xy)[1] <= view.camera.height + margin) {
          keep[i] = 1;
        }
      }
    }
    std::vector<size_t> kept;
    for (size_t i = 0; i < all.size(); ++i) {
      if (keep[i]) kept.push_back(i);
    }
    for (int level = 0; level < levels; ++level) {
      double pixels = 0;
      for (const View& view : pyramid_[level][f]) {
        pixels += static_cast<double>(view.camera.width) * view.camera.height;
      }
      const double cap = options.max_points_per_pixel * pixels;
      const double stride = std::max(1.0, kept.size() / cap);
      LidarPoints subset;
      for (double k = 0; k < kept.size(); k += stride) {
        const size_t i = kept[static_cast<size_t>(k)];
        subset.points_in_lidar.push_back(all.points_in_lidar[i]);
        if (all.has_intensity()) subset.intensity01.push_back(all.intensity01[i]);
      }
      points_[level].push_back(std::move(subset));
    }
  }
}

MetricValue FrameSetEvaluator::Evaluate(const Rigid3d& cam_from_lidar, int level,
                                        const MetricOptions& metric) const {
  // Each pyramid level has a quarter of the samples; halving the bins keeps the plug-in
  // estimator's bias, ≈ (bins_x − 1)(bins_y − 1) / (2N) (Miller 1955), the same at every level.
  MetricOptions level_metric = metric;
  level_metric.bins = std::max(8, metric.bins >> level);
  JointHistogram histogram(level_metric);
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer_);
      histogram.Add(buffer_, view.image);
    }
  }
  return histogram.Evaluate();
}

double FrameSetEvaluator::CoveredFraction(const Rigid3d& cam_from_lidar) const {
  double covered = 0, pixels = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[0][f]) {
      RenderLidarImage(points_[0][f], view, cam_from_lidar, options_.render, &buffer_);
      covered += buffer_.covered_pixels;
      pixels += static_cast<double>(buffer_.width) * buffer_.height;
    }
  }
  return pixels > 0 ? covered / pixels : 0.0;
}

size_t FrameSetEvaluator::VisiblePoints(const Rigid3d& cam_from_lidar) const {
  size_t visible = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[0][f]) {
      RenderLidarImage(points_[0][f], view, cam_from_lidar, options_.render, &buffer_);
      visible += CountVisiblePoints(buffer_);
    }
  }
  return visible;
}

// ---------------------------------------------------------------------------------------
// Registration

namespace {

// Confidence along each axis (a reduced probe): the metric must peak near the optimum,
// rise above the scan's minimum, and show no second comparable peak.
bool CheckConfidence(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                     const Vector6d& x, const RegistrationOptions& options, int level,
                     std::string* reason, int* evaluations) {
  const Vector6d bound = BoundVector(options);
  constexpr int kSide = 5;
  // Judged on MI (bits) so that the relative thresholds mean the same for every metric.
  MetricOptions metric = options.metric;
  metric.kind = MetricKind::kMi;
  for (int axis = 0; axis < 6; ++axis) {
    std::vector<double> values;
    const double step = bound[axis] / kSide;
    for (int k = -kSide; k <= kSide; ++k) {
      Vector6d y = x;
      y[axis] = x[axis] + k * step;
      values.push_back(evaluator.Evaluate(ApplyCorrection(start, y), level, metric).value);
      ++*evaluations;
    }
    const double center = values[kSide];
    const double peak = *std::max_element(values.begin(), values.end());
    const double low = *std::min_element(values.begin(), values.end());
    const double depth = peak - low;
    const double scale = std::max(std::abs(peak), 1e-12);
    if (depth < options.min_relative_peak * scale) {
      *reason = std::string("metric surface flat along ") + ParameterName(axis) +
                " (peak-to-trough " + Fixed(100 * depth / scale, 3) + " % of the metric)";
      return false;
    }
    if (!options.check_multiple_peaks) continue;
    // The optimum must hold the maximum within ±2 samples of the centre.
    const int argmax = static_cast<int>(std::max_element(values.begin(), values.end()) -
                                        values.begin());
    if (std::abs(argmax - kSide) > 1 && peak - center > 0.25 * depth) {
      *reason = std::string("higher MI along ") + ParameterName(axis) + " at offset " +
                Fixed((argmax - kSide) * step, 3) + " from the optimum: multi-peaked or not "
                "converged";
      return false;
    }
    // A second local maximum, away from the centre, nearly as high as the peak.
    for (int k = 1; k + 1 < static_cast<int>(values.size()); ++k) {
      if (std::abs(k - kSide) <= 1) continue;
      if (values[k] >= values[k - 1] && values[k] >= values[k + 1] &&
          values[k] > peak - 0.1 * depth && std::abs(k - argmax) > 1) {
        *reason = std::string("second peak along ") + ParameterName(axis) + " at offset " +
                  Fixed((k - kSide) * step, 3);
        return false;
      }
    }
  }
  return true;
}

// Hessian of MI (nats) w.r.t. the correction (units m, deg): a full quadratic
// f(x + d) ≈ a + gᵀd + ½ dᵀHd fitted by least squares to samples on a ±2h star and random
// points of the box x ± 2h. The rendered metric is piecewise constant at the pixel scale, so
// a regression over many samples is far steadier than finite differences.
Eigen::Matrix<double, 6, 6> MiHessian(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                                      const Vector6d& x, const MetricOptions& metric,
                                      int* evaluations) {
  Vector6d h;
  h << 0.04, 0.04, 0.04, 0.2, 0.2, 0.2;
  std::vector<Vector6d> offsets;  // in units of h
  offsets.push_back(Vector6d::Zero());
  for (int i = 0; i < 6; ++i) {
    for (double s : {-2.0, -1.0, 1.0, 2.0}) {
      Vector6d d = Vector6d::Zero();
      d[i] = s;
      offsets.push_back(d);
    }
  }
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  while (offsets.size() < 56) {
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = uniform(rng);
    offsets.push_back(d);
  }
  constexpr int kTerms = 1 + 6 + 21;
  Eigen::MatrixXd design(offsets.size(), kTerms);
  Eigen::VectorXd values(offsets.size());
  for (size_t k = 0; k < offsets.size(); ++k) {
    const Vector6d& d = offsets[k];  // scaled coordinates
    int col = 0;
    design(k, col++) = 1.0;
    for (int i = 0; i < 6; ++i) design(k, col++) = d[i];
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) design(k, col++) = (i == j ? 0.5 : 1.0) * d[i] * d[j];
    }
    values[k] = evaluator.Evaluate(ApplyCorrection(start, x + d.cwiseProduct(h)), 0, metric).mi *
                M_LN2;
    ++*evaluations;
  }
  const Eigen::VectorXd coef = design.colPivHouseholderQr().solve(values);
  Eigen::Matrix<double, 6, 6> hessian;
  int col = 7;
  for (int i = 0; i < 6; ++i) {
    for (int j = i; j < 6; ++j) {
      // Back from scaled coordinates: ∂²f/∂x_i∂x_j = H_scaled(i, j) / (h_i h_j).
      hessian(i, j) = hessian(j, i) = coef[col++] / (h[i] * h[j]);
    }
  }
  return hessian;
}

}  // namespace

std::string RegistrationResult::BriefReport() const {
  std::ostringstream out;
  out << "MI registration: " << status;
  if (!reason.empty()) out << " (" << reason << ")";
  out << "; correction t = (" << Fixed(correction[0]) << ", " << Fixed(correction[1]) << ", "
      << Fixed(correction[2]) << ") m, r/p/y = (" << Fixed(correction[3]) << ", "
      << Fixed(correction[4]) << ", " << Fixed(correction[5]) << ") deg; metric "
      << Fixed(metric_before.value, 5) << " -> " << Fixed(metric_after.value, 5) << "; "
      << iterations << " iterations, " << Fixed(runtime_seconds, 2) << " s";
  return out.str();
}

RegistrationResult RegisterFrames(const std::vector<Frame>& frames,
                                  const Rigid3d& cam_from_lidar_start,
                                  const RegistrationOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = cam_from_lidar_start;
  auto fail = [&](const std::string& reason) {
    result.status = "failed";
    result.reason = reason;
    result.runtime_seconds = timer.ElapsedSeconds();
    return result;
  };
  std::string error;
  if (!options.Check(&error)) return fail("invalid options: " + error);
  if (frames.empty()) return fail("no frames");
  for (const Frame& frame : frames) {
    if (frame.points == nullptr || frame.points->size() == 0) {
      return fail("frame '" + frame.name + "': empty cloud");
    }
    if (options.render.representation == Representation::kIntensity &&
        !frame.points->has_intensity()) {
      return fail("frame '" + frame.name +
                  "': intensity representation asked for but the cloud has no intensity");
    }
    for (const View& view : frame.views) {
      const ImageContrast contrast = MeasureContrast(view.image);
      if (contrast.fraction_dark + contrast.fraction_saturated > options.max_dark_or_saturated ||
          contrast.stdev < options.min_photo_stdev) {
        return fail("frame '" + frame.name + "' view '" + view.name +
                    "': image without usable contrast (" +
                    Fixed(100 * contrast.fraction_dark, 1) + " % black, " +
                    Fixed(100 * contrast.fraction_saturated, 1) + " % saturated, stdev " +
                    Fixed(contrast.stdev, 1) + " grey levels): overexposed or black");
      }
    }
  }
  FrameSetEvaluator evaluator(frames, cam_from_lidar_start, options);
  const double covered = evaluator.CoveredFraction(cam_from_lidar_start);
  if (covered < options.min_covered_fraction) {
    return fail("image does not overlap the cloud: " + Fixed(100 * covered, 2) +
                " % of the view pixels see LiDAR points at the start pose (minimum " +
                Fixed(100 * options.min_covered_fraction, 2) + " %)");
  }
  result.metric_before = evaluator.Evaluate(cam_from_lidar_start, 0);

  const Vector6d bound = BoundVector(options);
  NelderMeadOptions nm = options.nelder_mead;
  nm.lower = -bound;
  nm.upper = bound;
  Vector6d x = Vector6d::Zero();
  const int levels = evaluator.levels();
  for (int level = levels - 1; level >= 0; --level) {
    const double scale = std::pow(0.5, levels - 1 - level);
    NelderMeadOptions level_nm = nm;
    level_nm.initial_step = nm.initial_step.cwiseMin(bound) * scale;
    level_nm.parameter_tolerance = nm.parameter_tolerance * scale;
    const NelderMeadResult r = MaximizeNelderMead(
        [&](const Vector6d& y) {
          return evaluator.Evaluate(ApplyCorrection(cam_from_lidar_start, y), level).value;
        },
        x, level_nm);
    spdlog::debug("MI level {}: {} iterations, metric {:.6f}, correction [{:.3f} {:.3f} {:.3f} "
                  "{:.3f} {:.3f} {:.3f}]",
                  level, r.iterations, r.value, r.x[0], r.x[1], r.x[2], r.x[3], r.x[4], r.x[5]);
    x = r.x;
    result.iterations += r.iterations;
    result.evaluations += r.evaluations;
  }
  // Gradient refinement on the B-spline histogram (smooth in the pose): steepest ascent in
  // the scaled units with a backtracking step.
  if (options.gradient_refinement) {
    MetricOptions smooth = options.metric;
    smooth.smoothing = Smoothing::kBSpline;
    auto f = [&](const Vector6d& y) {
      ++result.evaluations;
      return evaluator.Evaluate(ApplyCorrection(cam_from_lidar_start, y), 0, smooth).value;
    };
    Vector6d h;
    h << 0.005, 0.005, 0.005, 0.02, 0.02, 0.02;
    double fx = f(x);
    double alpha = 0.05;  // units per unit of normalised gradient
    for (int it = 0; it < options.gradient_max_iterations && alpha > 1e-3; ++it) {
      Vector6d g;
      for (int i = 0; i < 6; ++i) {
        Vector6d a = x, b = x;
        a[i] += h[i];
        b[i] -= h[i];
        g[i] = (f(a) - f(b)) / (2 * h[i]);
      }
      if (!(g.norm() > 0)) break;
      const Vector6d direction = g / g.cwiseAbs().maxCoeff();
      bool improved = false;
      while (alpha > 1e-3) {
        const Vector6d y = (x + alpha * direction).cwiseMax(-bound).cwiseMin(bound);
        const double fy = f(y);
        if (fy > fx) {
          x = y;
          fx = fy;
          improved = true;
          alpha *= 1.5;
          break;
        }
        alpha *= 0.5;
      }
      ++result.iterations;
      if (!improved) break;
    }
  }
  result.correction = x;
  result.cam_from_lidar = ApplyCorrection(cam_from_lidar_start, x);
  result.metric_after = evaluator.Evaluate(result.cam_from_lidar, 0);

  // Uncertainty: Laplace approximation. N·MI (nats) is the log-likelihood ratio of the
  // joint against independent intensities (Roche et al. 2000), so the covariance of the
  // correction is (N_eff · (−∇²MI))⁻¹ with N_eff the distinct LiDAR points seen.
  const double n_eff = static_cast<double>(evaluator.VisiblePoints(result.cam_from_lidar));
  const Eigen::Matrix<double, 6, 6> hessian =
      MiHessian(evaluator, cam_from_lidar_start, x, options.metric, &result.evaluations);
  const Eigen::Matrix<double, 6, 6> information = -n_eff * hessian;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(information);
  const double min_eigen = eigen.eigenvalues().minCoeff();
  {
    std::ostringstream diag;
    diag << "MI Hessian (nats/unit^2) diagonal " << hessian.diagonal().transpose()
         << "; information eigenvalues " << eigen.eigenvalues().transpose() << "; N_eff "
         << n_eff;
    spdlog::debug("{}", diag.str());
  }
  const double max_eigen = eigen.eigenvalues().maxCoeff();
  int weak_directions = 0;
  if (max_eigen > 0) {
    // Directions the curvature does not determine (information below 1e-3 of the strongest,
    // or negative from noise on a near-flat ridge, e.g. forward motion against pitch) get the
    // variance of a uniform distribution over the search box: the only knowledge left.
    Eigen::Matrix<double, 6, 6> box_variance = Eigen::Matrix<double, 6, 6>::Zero();
    for (int i = 0; i < 6; ++i) box_variance(i, i) = bound[i] * bound[i] / 3.0;
    const Eigen::Matrix<double, 6, 6>& v = eigen.eigenvectors();
    for (int k = 0; k < 6; ++k) {
      const Vector6d direction = v.col(k);
      double variance;
      if (eigen.eigenvalues()[k] > 1e-3 * max_eigen) {
        variance = 1.0 / eigen.eigenvalues()[k];
      } else {
        variance = direction.dot(box_variance * direction);
        ++weak_directions;
      }
      result.covariance += variance * direction * direction.transpose();
    }
    result.covariance_valid = true;
  }

  // Confidence and status.
  std::string reason;
  const int check_level = std::min(1, levels - 1);
  bool trusted = true;
  for (int i = 0; i < 6; ++i) {
    if (std::abs(x[i]) >= 0.9 * bound[i]) {
      trusted = false;
      reason = std::string("optimum on the search bound of ") + ParameterName(i) + " (" +
               Fixed(x[i]) + ")";
      break;
    }
  }
  // One weak direction is usual for a single view (forward motion against a rotation); more
  // means the surface is flat in a subspace and the pose is not determined (measured on KITTI:
  // two weak directions accompanied 9 px errors).
  if (trusted && (!result.covariance_valid || weak_directions > 1)) {
    trusted = false;
    reason = "metric surface not peaked at the optimum (" + std::to_string(weak_directions) +
             " of 6 directions without curvature; information eigenvalues " +
             Fixed(min_eigen, 1) + " .. " + Fixed(max_eigen, 1) + ")";
  }
  if (trusted) {
    trusted = CheckConfidence(evaluator, cam_from_lidar_start, x, options, check_level, &reason,
                              &result.evaluations);
  }
  result.trusted = trusted;
  result.confidence_reason =
      trusted ? (weak_directions == 0
                     ? std::string("single clear peak")
                     : "single peak; " + std::to_string(weak_directions) +
                           " weakly determined direction(s) carry the search-box variance")
              : reason;
  result.status = trusted ? "ok" : "failed";
  result.reason = trusted ? "" : reason;
  result.runtime_seconds = timer.ElapsedSeconds();
  return result;
}

RegistrationResult RegisterRig(const std::vector<Frame>& frames,
                               const Rigid3d& cam_from_lidar_start, const RigOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = cam_from_lidar_start;
  std::vector<int> candidates;
  for (size_t i = 0; i < frames.size(); ++i) {
    RegistrationResult r = RegisterFrames({frames[i]}, cam_from_lidar_start,
                                          options.registration);
    spdlog::info("frame {}: {}", frames[i].name, r.BriefReport());
    if (r.ok()) {
      candidates.push_back(static_cast<int>(i));
    } else {
      result.rejected_frames.emplace_back(frames[i].name, r.reason);
    }
    result.iterations += r.iterations;
    result.evaluations += r.evaluations;
    result.frame_results.push_back(std::move(r));
  }
  auto fail = [&](const std::string& reason) {
    result.status = "failed";
    result.reason = reason;
    result.runtime_seconds = timer.ElapsedSeconds();
    return result;
  };
  if (static_cast<int>(candidates.size()) < options.min_frames) {
    return fail(std::to_string(candidates.size()) + " of " + std::to_string(frames.size()) +
                " frames registered alone with confidence; at least " +
                std::to_string(options.min_frames) + " needed");
  }
  // Robust agreement: median and MAD of each correction component.
  Vector6d median, mad;
  for (int k = 0; k < 6; ++k) {
    std::vector<double> v;
    for (int i : candidates) v.push_back(result.frame_results[i].correction[k]);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    median[k] = v[v.size() / 2];
    for (double& e : v) e = std::abs(e - median[k]);
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    mad[k] = 1.4826 * v[v.size() / 2];
  }
  std::vector<Frame> kept;
  for (int i : candidates) {
    const Vector6d d = result.frame_results[i].correction - median;
    std::string why;
    for (int k = 0; k < 6 && why.empty(); ++k) {
      const double floor = k < 3 ? options.disagree_floor_m : options.disagree_floor_deg;
      const double limit = std::max(3 * mad[k], floor);
      if (std::abs(d[k]) > limit) {
        why = std::string("disagrees with the other frames: ") + ParameterName(k) + " off the " +
              "median by " + Fixed(d[k]) + " (limit " + Fixed(limit) + ")";
      }
    }
    if (why.empty()) {
      kept.push_back(frames[i]);
      result.used_frames.push_back(frames[i].name);
    } else {
      result.rejected_frames.emplace_back(frames[i].name, why);
    }
  }
  if (static_cast<int>(kept.size()) < options.min_frames) {
    return fail("only " + std::to_string(kept.size()) + " frames agree; at least " +
                std::to_string(options.min_frames) + " needed");
  }
  // Joint registration of the agreeing frames from the median correction.
  const Rigid3d joint_start = ApplyCorrection(cam_from_lidar_start, median);
  RegistrationResult joint = RegisterFrames(kept, joint_start, options.registration);
  result.status = joint.status;
  result.reason = joint.reason;
  result.trusted = joint.trusted;
  result.confidence_reason = joint.confidence_reason;
  result.cam_from_lidar = joint.cam_from_lidar;
  result.correction = CorrectionBetween(cam_from_lidar_start, joint.cam_from_lidar);
  result.covariance = joint.covariance;
  result.covariance_valid = joint.covariance_valid;
  FrameSetEvaluator evaluator(kept, cam_from_lidar_start, options.registration);
  result.metric_before = evaluator.Evaluate(cam_from_lidar_start, 0);
  result.metric_after = joint.metric_after;
  result.iterations += joint.iterations;
  result.evaluations += joint.evaluations;
  result.runtime_seconds = timer.ElapsedSeconds();
  return result;
}

std::vector<ProbeSample> Probe(const FrameSetEvaluator& evaluator, const Rigid3d& pose,
                               double range, double step, int level) {
  std::vector<ProbeSample> samples;
  const int n = static_cast<int>(std::lround(range / step));
  for (int axis = 0; axis < 6; ++axis) {
    for (int k = -n; k <= n; ++k) {
      Vector6d y = Vector6d::Zero();
      y[axis] = k * step;
      ProbeSample sample;
      sample.axis = axis;
      sample.offset = k * step;
      sample.metric = evaluator.Evaluate(ApplyCorrection(pose, y), level);
      samples.push_back(sample);
    }
  }
  return samples;
}

PixelOffsetStats PixelOffsets(const LidarPoints& points, const View& view,
                              const Rigid3d& cam_from_lidar_reference,
                              const Rigid3d& cam_from_lidar_estimate,
                              const RenderOptions& render) {
  PixelOffsetStats stats;
  const Eigen::Matrix3d view_r = view.view_from_cam;
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = points.points_in_lidar[i].cast<double>();
    const Eigen::Vector3d a = view_r * (cam_from_lidar_reference * p);
    const double range = a.norm();
    if (range < render.min_range_m || range > render.max_range_m) continue;
    if (!view.camera.IsSpherical() && a.z() <= 0) continue;
    const std::optional<Eigen::Vector2d> xa = view.camera.ImgFromCam(a);
    if (!xa || (*xa)[0] < 0 || (*xa)[1] < 0 || (*xa)[0] >= view.camera.width ||
        (*xa)[1] >= view.camera.height) {
      continue;
    }
    const Eigen::Vector3d b = view_r * (cam_from_lidar_estimate * p);
    if (!view.camera.IsSpherical() && b.z() <= 0) continue;
    const std::optional<Eigen::Vector2d> xb = view.camera.ImgFromCam(b);
    if (!xb) continue;
    double d = (*xa - *xb).norm();
    if (view.camera.IsSpherical()) {
      // Across the ±180° seam the shorter way round counts.
      const double period = 2 * M_PI * view.camera.params[0];
      const double dx = std::abs((*xa)[0] - (*xb)[0]);
      d = std::hypot(std::min(dx, period - dx), (*xa)[1] - (*xb)[1]);
    }
    stats.offsets_px.push_back(d);
  }
  stats.points = stats.offsets_px.size();
  if (stats.points == 0) return stats;
  std::vector<double> sorted = stats.offsets_px;
  std::sort(sorted.begin(), sorted.end());
  stats.median_px = sorted[sorted.size() / 2];
  stats.p90_px = sorted[std::min(sorted.size() - 1, sorted.size() * 9 / 10)];
  stats.max_px = sorted.back();
  stats.mean_px = std::accumulate(sorted.begin(), sorted.end(), 0.0) / sorted.size();
  return stats;
}

}  // namespace mmba::registration::mi
