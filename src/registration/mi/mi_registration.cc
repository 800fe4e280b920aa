#include "mmba/registration/mi/mi_registration.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include <immintrin.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <glog/logging.h>

#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "registration/mi/pinhole_block.h"

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

// Σ JᵀJ of the points' pixel Jacobians: the information the points' pixels hold on the
// correction (RaiseToPixelFloor, WeaklyObservedDirection).
Eigen::Matrix<double, 6, 6> PixelInformation(
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians) {
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  for (const Eigen::Matrix<double, 2, 6>& j : jacobians) information += j.transpose() * j;
  return information;
}

}  // namespace

Eigen::Matrix<double, 6, 6> RaiseToPixelFloor(
    const Eigen::Matrix<double, 6, 6>& covariance,
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians, double mean_variance,
    int* raised) {
  *raised = 0;
  if (jacobians.empty() || !(mean_variance > 0)) return covariance;
  const Eigen::Matrix<double, 6, 6> information =
      PixelInformation(jacobians) / static_cast<double>(jacobians.size());
  Eigen::LLT<Eigen::Matrix<double, 6, 6>> information_llt(information);
  if (information_llt.info() != Eigen::Success) return covariance;
  const Eigen::Matrix<double, 6, 6> floor =
      (mean_variance / 6.0) * information_llt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  Eigen::LLT<Eigen::Matrix<double, 6, 6>> floor_llt(floor);
  if (floor_llt.info() != Eigen::Success) return covariance;
  const Eigen::Matrix<double, 6, 6> l = floor_llt.matrixL();
  const Eigen::Matrix<double, 6, 6> l_inv =
      l.triangularView<Eigen::Lower>().solve(Eigen::Matrix<double, 6, 6>::Identity());
  const Eigen::Matrix<double, 6, 6> whitened = l_inv * covariance * l_inv.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(
      0.5 * (whitened + whitened.transpose()));
  Vector6d values = eigen.eigenvalues();
  for (int i = 0; i < 6; ++i) {
    if (values[i] < 1.0) {
      values[i] = 1.0;
      ++*raised;
    }
  }
  const Eigen::Matrix<double, 6, 6> raised_whitened =
      eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
  const Eigen::Matrix<double, 6, 6> result = l * raised_whitened * l.transpose();
  return 0.5 * (result + result.transpose());
}

Vector6d WeaklyObservedDirection(const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians,
                                 const Vector6d& bound) {
  if (jacobians.empty()) return Vector6d::Zero();
  const Eigen::Matrix<double, 6, 6> scaled =
      bound.asDiagonal() * PixelInformation(jacobians) * bound.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(scaled);
  if (eigen.info() != Eigen::Success) return Vector6d::Zero();
  spdlog::debug("MI weakly observed direction: eigenvalue {:.4g} (largest {:.4g})",
                eigen.eigenvalues()[0], eigen.eigenvalues()[5]);
  const Vector6d u = eigen.eigenvectors().col(0);  // eigenvalues ascending
  const double largest = u.cwiseAbs().maxCoeff();
  if (!(largest > 0)) return Vector6d::Zero();
  return bound.cwiseProduct(u) / largest;
}

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
  if (sample_block_px < 0 || sample_block_px > 256) {
    *error = "sample_block_px " + std::to_string(sample_block_px) + " must be in 0..256 pixels";
    return false;
  }
  if (effective_sample_max_lag < 0 || effective_sample_max_lag > 64) {
    *error = "effective_sample_max_lag " + std::to_string(effective_sample_max_lag) +
             " must be in 0..64 pixels";
    return false;
  }
  if (covariance_level < 0 || covariance_level > 5) {
    *error = "covariance_level " + std::to_string(covariance_level) +
             " must be in 0..5 (levels beyond the pyramid mean its coarsest)";
    return false;
  }
  if (!(max_sigma_px > 0) || !(restart_tolerance_px > 0) || !(max_calibrated_sigma_px > 0)) {
    *error = "max_sigma_px, restart_tolerance_px and max_calibrated_sigma_px must be > 0 (found " +
             std::to_string(max_sigma_px) + ", " + std::to_string(restart_tolerance_px) + ", " +
             std::to_string(max_calibrated_sigma_px) + ")";
    return false;
  }
  if (finest_nelder_mead_level < 0 || finest_nelder_mead_level > 5) {
    *error = "finest_nelder_mead_level " + std::to_string(finest_nelder_mead_level) +
             " must be in 0..5 (levels beyond the pyramid mean its coarsest)";
    return false;
  }
  if (polish_rounds < 0 || polish_rounds > 3) {
    *error = "polish_rounds " + std::to_string(polish_rounds) + " must be in 0..3";
    return false;
  }
  if (restart_level < 0 || restart_level > 5) {
    *error = "restart_level " + std::to_string(restart_level) +
             " must be in 0..5 (levels beyond the pyramid mean its coarsest)";
    return false;
  }
  if (restarts < 0 || restarts > 32 || !(restart_offset_m > 0) || !(restart_offset_deg > 0)) {
    *error = "restarts must be in 0..32 with offsets > 0 (found " + std::to_string(restarts) +
             ", " + std::to_string(restart_offset_m) + " m, " +
             std::to_string(restart_offset_deg) + " deg)";
    return false;
  }
  if (pyramid_paths < 1 || pyramid_paths > 6) {
    *error = "pyramid_paths " + std::to_string(pyramid_paths) + " must be in 1..6";
    return false;
  }
  if (coarse_starts < 0 || coarse_starts > 256 || coarse_candidates < 1 ||
      coarse_candidates > 32 || !(coarse_start_spread > 0 && coarse_start_spread <= 1)) {
    *error = "coarse_starts must be in 0..256, coarse_candidates in 1..32 and "
             "coarse_start_spread in (0, 1] (found " + std::to_string(coarse_starts) + ", " +
             std::to_string(coarse_candidates) + ", " + std::to_string(coarse_start_spread) + ")";
    return false;
  }
  if (threads < 1 || threads > 256) {
    *error = "threads " + std::to_string(threads) + " must be in 1..256";
    return false;
  }
  if (split_level < 0 || split_level > 5 || !(split_tolerance_px > 0)) {
    *error = "split_level must be in 0..5 and split_tolerance_px > 0 (found " +
             std::to_string(split_level) + ", " + std::to_string(split_tolerance_px) + ")";
    return false;
  }
  if (shuffles < 2 || shuffles > 100) {
    *error = "shuffles " + std::to_string(shuffles) + " must be in 2..100";
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------
// FrameSetEvaluator

namespace {

// One render buffer per thread, reused between evaluations.
LidarImage& ThreadBuffer() {
  thread_local LidarImage buffer;
  return buffer;
}

}  // namespace

namespace {

// On the threads of a running ParallelFor (the caller's included): the number of its
// workers still taking items, and how many it started; nullptr outside a loop. An evaluation
// made there splits itself over two threads only when a worker of the loop has run out of
// items (its core is free): e.g. the third of three restarts on two threads, or the longer
// of the two halves. The split does not change the result (fixed partial sums).
thread_local std::atomic<int>* t_loop_busy = nullptr;
thread_local int t_loop_threads = 0;

bool CoreFreeForSplit() {
  return t_loop_busy == nullptr || t_loop_busy->load() < t_loop_threads;
}

// Fewer points are rendered on one thread (a thread costs tens of µs).
constexpr size_t kMinPointsToSplit = 20000;

// body(0) .. body(count − 1) on up to `threads` threads (the caller's included).
void ParallelFor(int count, int threads, const std::function<void(int)>& body) {
  threads = std::max(1, std::min(threads, count));
  if (threads == 1) {
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<int> next{0};
  std::atomic<int> busy{threads};
  auto worker = [&] {
    std::atomic<int>* const outer_busy = t_loop_busy;
    const int outer_threads = t_loop_threads;
    t_loop_busy = &busy;
    t_loop_threads = threads;
    for (int i = next++; i < count; i = next++) body(i);
    --busy;  // no more items for this worker
    t_loop_busy = outer_busy;
    t_loop_threads = outer_threads;
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& thread : pool) thread.join();
}

}  // namespace

namespace {

// Key of a point that falls on no view (after every pixel's).
constexpr uint64_t kNowhere = std::numeric_limits<uint64_t>::max();

// RenderOrder's keys for one pinhole view (perspective cuts, KITTI), a block of points at a
// time: the transform, squared norm and projection in loops without branches as in
// CullPinholeBlocks (the arithmetic of the general path: Eigen's product and squared norm,
// ImgFromCam), then the general path's tests; only keys still kNowhere are set.
__attribute__((target_clones("avx2", "default"))) void PinholeKeys(
    const std::vector<Eigen::Vector3f>& points, const Eigen::Matrix3f& rotation,
    const Eigen::Vector3f& translation, const sensors::Camera& camera, double min_range2,
    double max_range2, uint64_t view_bits, uint64_t* key) {
  constexpr int kBlock = 64;
  alignas(64) float bx[kBlock], by[kBlock], gz[kBlock], bz[kBlock], b2[kBlock];
  alignas(64) double bu[kBlock], bv[kBlock];
  const internal::PinholeBlockProjection projection(rotation, translation,
                                                   camera.params.data());
  const double width = camera.width, height = camera.height;
  constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
  for (size_t block = 0; block < points.size(); block += kBlock) {
    const int n = static_cast<int>(std::min<size_t>(kBlock, points.size() - block));
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3f& q = points[block + j];
      bx[j] = q.x();
      by[j] = q.y();
      gz[j] = q.z();
    }
    projection.Project<1>(bx, by, gz, n, bz, b2, bu, bv);
    for (int j = 0; j < n; ++j) {
      uint64_t& k = key[block + j];
      if (k != kNowhere || !(bz[j] > 0.f)) continue;
      const double range2 = b2[j];
      if (range2 < min_range2 || range2 > max_range2) continue;
      if (!(static_cast<double>(bz[j]) > kEpsilon)) continue;
      const double x = bu[j], y = bv[j];
      if (!(x >= 0 && y >= 0 && x < width && y < height)) continue;
      k = view_bits | (static_cast<uint64_t>(y) << 24) | static_cast<uint64_t>(x);
    }
  }
}

// The positions 0 .. points.size() − 1 in the order of the pixel each point falls on at
// `cam_from_lidar` (the first view it projects into; view, row, column), the points that fall
// on no view last; ties in the points' order (a stable sort: deterministic). Sorted by counting
// the points per pixel (the keys are pixels: the order of a stable sort by key).
std::vector<uint32_t> RenderOrder(const std::vector<Eigen::Vector3f>& points,
                                  const std::vector<View>& views, const Rigid3d& cam_from_lidar,
                                  const RenderOptions& render) {
  std::vector<uint64_t> key(points.size(), kNowhere);
  const double min_range2 = render.min_range_m * render.min_range_m;
  const double max_range2 = render.max_range_m * render.max_range_m;
  for (size_t v = 0; v < views.size(); ++v) {
    const View& view = views[v];
    const auto [rotation, translation] = MakeTransform(view, cam_from_lidar);
    if (view.camera.model_id == sensors::CameraModelId::kPinhole) {
      PinholeKeys(points, rotation, translation, view.camera, min_range2, max_range2,
                  static_cast<uint64_t>(v) << 48, key.data());
      continue;
    }
    const bool spherical = view.camera.IsSpherical();
    const double period = 2.0 * M_PI * view.camera.params[0];
    for (size_t k = 0; k < points.size(); ++k) {
      if (key[k] != kNowhere) continue;
      const Eigen::Vector3f p = rotation * points[k] + translation;
      if (!spherical && !(p.z() > 0.f)) continue;
      const double range2 = p.squaredNorm();
      if (range2 < min_range2 || range2 > max_range2) continue;
      const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p.cast<double>());
      if (!xy) continue;
      double x = (*xy)[0];
      if (spherical) x -= period * std::floor(x / period);
      if (!(x >= 0 && (*xy)[1] >= 0 && x < view.camera.width && (*xy)[1] < view.camera.height)) {
        continue;
      }
      key[k] = (static_cast<uint64_t>(v) << 48) | (static_cast<uint64_t>((*xy)[1]) << 24) |
               static_cast<uint64_t>(x);
    }
  }
  std::vector<uint32_t> order(points.size());
  // A key's pixel (view, row, column) numbered in key order: view-major, then row-major;
  // kNowhere after them all. (Columns and rows below 2^24, as the keys need.)
  std::vector<size_t> first_pixel(views.size() + 1, 0);
  bool countable = views.size() < (size_t{1} << 16);
  for (size_t v = 0; v < views.size(); ++v) {
    const sensors::Camera& camera = views[v].camera;
    countable = countable && camera.width < (1 << 24) && camera.height < (1 << 24);
    first_pixel[v + 1] = first_pixel[v] + static_cast<size_t>(camera.width) * camera.height;
  }
  if (!countable) {
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&key](uint32_t a, uint32_t b) { return key[a] < key[b]; });
    return order;
  }
  const size_t nowhere = first_pixel.back();
  auto pixel = [&](uint64_t k) {
    if (k == kNowhere) return nowhere;
    const size_t v = static_cast<size_t>(k >> 48);
    const size_t row = static_cast<size_t>((k >> 24) & 0xFFFFFF);
    const size_t column = static_cast<size_t>(k & 0xFFFFFF);
    return first_pixel[v] + row * views[v].camera.width + column;
  };
  std::vector<uint32_t> start(nowhere + 2, 0);  // points before each pixel, then its fill
  for (uint64_t k : key) ++start[pixel(k) + 1];
  for (size_t p = 1; p < start.size(); ++p) start[p] += start[p - 1];
  for (size_t k = 0; k < key.size(); ++k) order[start[pixel(key[k])]++] = static_cast<uint32_t>(k);
  return order;
}

}  // namespace

namespace {

// One pinhole view's cull test (FrameSetEvaluator's constructor): its transform of the
// LiDAR frame in float, its intrinsics, the margins and ranges.
struct PinholeCull {
  Eigen::Matrix3f rotation;
  Eigen::Vector3f translation;
  const sensors::Camera& camera;
  double focal, rot_margin, bound_translation_m, max_range, near_range;
};

// The cull of candidates [begin, end) (indices into `all`, or the points themselves when
// `candidates` is null) against one pinhole view (perspective cuts, KITTI): keep[k] |= the
// test of candidate k. A block of points at a time in loops without branches, which the
// compiler vectorises: the transform, squared norm and projection with the arithmetic of the
// general path (Eigen's 3×3 product r₀x + (r₁y + r₂z) per row, the squared norm
// x² + (y² + z²), ImgFromCam f·(x/z + 0) + c), then the general path's test written as one
// expression of comparisons — kept iff not beyond the range, and nearer than the near range
// or in front of the camera and inside the view's margin (test
// StreetTest.PinholeCullEqualsTheGenericModel). No FMA in either clone: the same roundings.
__attribute__((target_clones("avx2", "default"))) void CullPinholeBlocks(
    const PinholeCull& cull, const LidarPoints& all, const std::vector<uint32_t>* candidates,
    size_t begin, size_t end, char* keep) {
  constexpr int kBlock = 64;
  alignas(64) float bx[kBlock], by[kBlock], gz[kBlock], bz[kBlock], b2[kBlock];
  alignas(64) float br[kBlock];
  alignas(64) double bu[kBlock], bv[kBlock];
  alignas(64) char flag[kBlock];
  const internal::PinholeBlockProjection projection(cull.rotation, cull.translation,
                                                   cull.camera.params.data());
  const double width = cull.camera.width, height = cull.camera.height;
  const double focal = cull.focal, rot_margin = cull.rot_margin;
  const double bound_m = cull.bound_translation_m;
  const double max_range = cull.max_range, near_range = cull.near_range;
  constexpr double kEpsilon = std::numeric_limits<double>::epsilon();
  const Eigen::Vector3f* points = all.points_in_lidar.data();
  const uint32_t* index = candidates != nullptr ? candidates->data() : nullptr;
  for (size_t block = begin; block < end; block += kBlock) {
    const int n = static_cast<int>(std::min<size_t>(kBlock, end - block));
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3f& q = points[index != nullptr ? index[block + j] : block + j];
      bx[j] = q.x();
      by[j] = q.y();
      gz[j] = q.z();
    }
    projection.Project<1>(bx, by, gz, n, bz, b2, bu, bv);
    // p.norm(): the float root (SSE's, correctly rounded as std::sqrt; without errno, so the
    // loop below has no branch), four at a time over the block (the tail set to 0).
    for (int j = n; j < kBlock; ++j) b2[j] = 0.f;
    for (int j = 0; j < n; j += 4) _mm_store_ps(br + j, _mm_sqrt_ps(_mm_load_ps(b2 + j)));
    for (int j = 0; j < n; ++j) {
      const double range = br[j];
      const double margin = focal * (rot_margin + bound_m / range) + 8.0;
      const bool inside = (bu[j] >= -margin) & (bv[j] >= -margin) & (bu[j] <= width + margin) &
                          (bv[j] <= height + margin);
      const bool front = !(bz[j] <= 0.f) & (static_cast<double>(bz[j]) > kEpsilon);
      flag[j] = (!(range > max_range)) & ((range < near_range) | (front & inside));
    }
    for (int j = 0; j < n; ++j) keep[block + j] |= flag[j];
  }
}

}  // namespace

FrameSetEvaluator::FrameSetEvaluator(const std::vector<Frame>& frames,
                                     const Rigid3d& cam_from_lidar_start,
                                     const RegistrationOptions& options,
                                     const FrameSetEvaluator* parent)
    : frames_(frames), options_(options), start_(cam_from_lidar_start) {
  for (const Frame& frame : frames_) {
    CHECK(frame.points == nullptr || frame.points->classes <= options.metric.lidar_classes)
        << frame.name << ": points carry " << frame.points->classes
        << " surface classes but the metric is conditioned on " << options.metric.lidar_classes;
  }
  const int levels = options.pyramid_levels;
  pyramid_.resize(levels);
  points_.resize(levels);
  kept_.resize(frames_.size());
  for (const Frame& frame : frames_) pyramid_[0].push_back(frame.views);
  for (int level = 1; level < levels; ++level) {
    for (const std::vector<View>& views : pyramid_[level - 1]) {
      std::vector<View> half;
      for (const View& view : views) half.push_back(DownsampleView(view));
      pyramid_[level].push_back(std::move(half));
    }
  }
  if (parent != nullptr) {
    CHECK(parent->start_.rotation.coeffs() == start_.rotation.coeffs() &&
          parent->start_.translation == start_.translation &&
          parent->options_.bound_translation_m == options.bound_translation_m &&
          parent->options_.bound_rotation_deg == options.bound_rotation_deg &&
          parent->options_.render.max_range_m == options.render.max_range_m &&
          parent->options_.render.min_range_m == options.render.min_range_m)
        << "a part's evaluator needs its parent's start pose, bounds and ranges";
  }
  // Cull: keep the points that project into some view (expanded by what the rotation
  // bound can move a pixel, plus a margin for the translation) at the start pose.
  const double rot_margin = std::tan(options.bound_rotation_deg * kDegToRad);
  for (size_t f = 0; f < frames_.size(); ++f) {
    const LidarPoints& all = *frames_[f].points;
    // The points to test: all, or those the parent kept for the frame these views were
    // taken from (its views contain these: what one of them keeps, the parent kept).
    const std::vector<uint32_t>* candidates = nullptr;
    if (parent != nullptr) {
      int match = -1, matches = 0;
      for (size_t g = 0; g < parent->frames_.size(); ++g) {
        if (parent->frames_[g].points == frames_[f].points &&
            parent->frames_[g].name == frames_[f].name) {
          match = static_cast<int>(g);
          ++matches;
        }
      }
      if (matches == 1 && !parent->kept_[match].empty()) candidates = &parent->kept_[match];
    }
    const size_t tested = candidates != nullptr ? candidates->size() : all.size();
    std::vector<char> keep(tested, 0);
    // Candidates [begin, end) against every view (keep[k]: candidate k is kept).
    auto cull = [&](size_t begin, size_t end) {
      for (const View& view : frames_[f].views) {
        const auto [rotation, translation] = MakeTransform(view, cam_from_lidar_start);
        const double focal = view.camera.MeanFocalLength();
        const bool spherical = view.camera.IsSpherical();
        const double max_range = options.render.max_range_m + options.bound_translation_m;
        const double near_range = 2.0 * options.bound_translation_m + options.render.min_range_m;
        if (view.camera.model_id == sensors::CameraModelId::kPinhole) {
          const PinholeCull test{rotation, translation, view.camera, focal, rot_margin,
                                 options.bound_translation_m, max_range, near_range};
          CullPinholeBlocks(test, all, candidates, begin, end, keep.data());
          continue;
        }
        for (size_t k = begin; k < end; ++k) {
          if (keep[k]) continue;
          const size_t i = candidates != nullptr ? (*candidates)[k] : k;
          const Eigen::Vector3f p = rotation * all.points_in_lidar[i] + translation;
          const double range = p.norm();
          if (range > max_range) continue;
          if (spherical || range < near_range) {
            keep[k] = 1;
            continue;
          }
          if (p.z() <= 0.f) continue;
          const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p.cast<double>());
          if (!xy) continue;
          const double margin = focal * (rot_margin + options.bound_translation_m / range) + 8.0;
          if ((*xy)[0] >= -margin && (*xy)[1] >= -margin &&
              (*xy)[0] <= view.camera.width + margin && (*xy)[1] <= view.camera.height + margin) {
            keep[k] = 1;
          }
        }
      }
    };
    // Two threads over the two halves of the points (each point's test is independent).
    if (options.threads >= 2 && CoreFreeForSplit() && tested >= 2 * kMinPointsToSplit) {
      std::thread other(cull, tested / 2, tested);
      cull(0, tested / 2);
      other.join();
    } else {
      cull(0, tested);
    }
    // The kept indices in order, without a branch per point (each written, then counted
    // when kept; one slot more for the last write).
    const size_t kept_count = tested - std::count(keep.begin(), keep.end(), 0);
    std::vector<size_t> kept(kept_count + 1);
    for (size_t k = 0, j = 0; k < tested; ++k) {
      kept[j] = candidates != nullptr ? (*candidates)[k] : k;
      j += keep[k] != 0;
    }
    kept.resize(kept_count);
    // What the parts' evaluators (the halves) test instead of the whole cloud.
    if (parent == nullptr && all.size() < (size_t{1} << 32)) {
      kept_[f].assign(kept.begin(), kept.end());
    }
    // The levels' subsets on the threads (each independent of the others).
    std::vector<LidarPoints> subsets(levels);
    ParallelFor(levels, CoreFreeForSplit() ? options.threads : 1, [&](int level) {
      double pixels = 0;
      for (const View& view : pyramid_[level][f]) {
        pixels += static_cast<double>(view.camera.width) * view.camera.height;
      }
      // Coarser levels keep more points per (larger) pixel: a dense coarse image keeps the
      // basin of convergence wide (measured: 0.75 at every level lost a 0.3 m / 2° start).
      const double cap = options.max_points_per_pixel * std::pow(2.0, level) * pixels;
      const double stride = std::max(1.0, kept.size() / cap);
      std::vector<size_t> chosen;
      for (double k = 0; k < kept.size(); k += stride) chosen.push_back(kept[static_cast<size_t>(k)]);
      // Their points and intensities in the subsample's order (read through the cloud once).
      std::vector<Eigen::Vector3f> chosen_points(chosen.size());
      std::vector<float> chosen_intensity(all.has_intensity() ? chosen.size() : 0);
      for (size_t k = 0; k < chosen.size(); ++k) chosen_points[k] = all.points_in_lidar[chosen[k]];
      for (size_t k = 0; k < chosen_intensity.size(); ++k) {
        chosen_intensity[k] = all.intensity01[chosen[k]];
      }
      // Render order: the points sorted by the pixel they fall on at the start pose (view,
      // row, column), so that a render writes the z-buffer almost sequentially instead of
      // scattering over the whole image in the cloud's order (measured: the z-buffer's cache
      // misses were the largest single cost of an evaluation). Each point keeps its position
      // in the even subsample as its rank (LidarPoints::tie_rank): equally near points
      // compete in that order, and what depends on a point order (SampleVisiblePoints) is
      // as it was — the same images and results as unsorted, bit for bit.
      const std::vector<uint32_t> order = RenderOrder(chosen_points, pyramid_[level][f],
                                                      cam_from_lidar_start, options.render);
      LidarPoints subset;
      subset.points_in_lidar.resize(chosen.size());
      subset.intensity01.resize(chosen_intensity.size());
      subset.tie_rank = order;
      subset.index_of_rank.resize(order.size());
      for (size_t j = 0; j < order.size(); ++j) {
        const uint32_t k = order[j];
        subset.points_in_lidar[j] = chosen_points[k];
        if (!chosen_intensity.empty()) subset.intensity01[j] = chosen_intensity[k];
        subset.index_of_rank[k] = static_cast<uint32_t>(j);
      }
      subsets[level] = std::move(subset);
    });
    for (int level = 0; level < levels; ++level) points_[level].push_back(std::move(subsets[level]));
  }
}

MetricValue FrameSetEvaluator::Evaluate(const Rigid3d& cam_from_lidar, int level,
                                        const MetricOptions& metric) const {
  LidarImage& buffer = ThreadBuffer();
  // Each pyramid level has a quarter of the samples; halving the bins keeps the plug-in
  // estimator's bias, ≈ (bins_x − 1)(bins_y − 1) / (2N) (Miller 1955), the same at every level.
  MetricOptions level_metric = metric;
  level_metric.bins = std::max(8, metric.bins >> level);
  JointHistogram histogram(level_metric);
  for (size_t f = 0; f < frames_.size(); ++f) {
    // The footprints drawn by two threads when a core is free (the same image).
    const bool two_threads = options_.threads >= 2 && CoreFreeForSplit() &&
                             points_[level][f].size() >= kMinPointsToSplit;
    for (const View& view : pyramid_[level][f]) {
      // The B-spline histogram (the default) reads each pixel's winner from the z-buffer:
      // the same sums as rendering the full image first, without its per-pixel arrays.
      const bool zbuffer_only = level_metric.smoothing == Smoothing::kBSpline;
      Timer render;
      if (zbuffer_only) {
        RenderLidarZBuffer(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                           two_threads);
      } else {
        RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                         two_threads);
      }
      render_ns_ += static_cast<int64_t>(1e9 * render.ElapsedSeconds());
      Timer fill;
      if (zbuffer_only) {
        histogram.AddZBuffer(buffer, points_[level][f], options_.render, view.image);
      } else {
        histogram.Add(buffer, view.image);
      }
      histogram_ns_ += static_cast<int64_t>(1e9 * fill.ElapsedSeconds());
    }
  }
  Timer fill;
  const MetricValue value = histogram.Evaluate();
  histogram_ns_ += static_cast<int64_t>(1e9 * fill.ElapsedSeconds());
  return value;
}

bool FrameSetEvaluator::SplitRender(const LidarPoints& points) const {
  return options_.threads >= 2 && CoreFreeForSplit() && points.size() >= kMinPointsToSplit;
}

bool FrameSetEvaluator::UsesSamples(const MetricOptions& metric) const {
  if (!options_.point_samples || metric.smoothing != Smoothing::kBSpline) return false;
  if (metric.region == Region::kOverlap) return true;
  // Whole image: the sample sets carry the background of the options' metric only.
  return options_.metric.region == Region::kWholeImage && metric.bins == options_.metric.bins;
}

FrameSetEvaluator::SampleSet FrameSetEvaluator::MakeSampleSet(const Rigid3d& cam_from_lidar,
                                                              int level, bool per_point) const {
  Timer timer;
  LidarImage& buffer = ThreadBuffer();
  SampleSet set;
  set.level = level;
  set.reference = cam_from_lidar;
  PerPointPlacement placement;
  placement.block_px = options_.sample_block_px;
  for (size_t f = 0; f < frames_.size(); ++f) {
    const bool two_threads = options_.threads >= 2 && CoreFreeForSplit() &&
                             points_[level][f].size() >= kMinPointsToSplit;
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       two_threads);
      set.views.push_back(
          MakeViewSamples(points_[level][f], buffer, options_.render, per_point, placement));
      set.samples += set.views.back().samples();
      if (options_.metric.region == Region::kWholeImage) {
        // The reference's background pixels and its samples' photo values, one histogram:
        // what the background is at any pose once the samples' values are taken out of it.
        MetricOptions level_metric = options_.metric;
        level_metric.bins = std::max(8, options_.metric.bins >> level);
        level_metric.smoothing = Smoothing::kBSpline;
        JointHistogram rendered(level_metric), sampled(level_metric);
        rendered.Add(buffer, view.image);
        AccumulateViewSamples(set.views.back(), view, cam_from_lidar, options_.render, 0,
                              set.views.back().points(), &sampled);
        std::vector<double> background = rendered.PaddedEmptyPhoto();
        const std::vector<double> covered = sampled.PaddedCoveredPhoto();
        for (size_t q = 0; q < background.size(); ++q) background[q] += covered[q];
        set.background.push_back(std::move(background));
        set.view_pixels.push_back(static_cast<double>(view.camera.width) * view.camera.height);
      }
    }
  }
  ++sample_sets_;
  render_ns_ += static_cast<int64_t>(1e9 * timer.ElapsedSeconds());
  return set;
}

double FrameSetEvaluator::SampleSetDisplacementPx(const SampleSet& set,
                                                  const Rigid3d& cam_from_lidar) const {
  double largest = 0;
  size_t v = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[set.level][f]) {
      largest = std::max(largest, ProbeDisplacementPx(set.views[v++], view, cam_from_lidar));
    }
  }
  return largest;
}

MetricValue FrameSetEvaluator::Evaluate(const Rigid3d& cam_from_lidar, int level,
                                        const MetricOptions& metric, const SampleSet* set) const {
  if (set == nullptr || set->level != level || !UsesSamples(metric)) {
    return Evaluate(cam_from_lidar, level, metric);
  }
  Timer timer;
  MetricOptions level_metric = metric;
  level_metric.bins = std::max(8, metric.bins >> level);
  // Two partial histograms over the two halves of each view's points, merged: the same sums
  // whether they were filled on one thread or two.
  std::array<JointHistogram, 2> parts = {JointHistogram(level_metric),
                                         JointHistogram(level_metric)};
  auto fill = [&](int h) {
    size_t v = 0;
    for (size_t f = 0; f < frames_.size(); ++f) {
      for (const View& view : pyramid_[level][f]) {
        const ViewSamples& samples = set->views[v++];
        const size_t half = samples.points() / 2;
        AccumulateViewSamples(samples, view, cam_from_lidar, options_.render,
                              h == 0 ? 0 : half, h == 0 ? half : samples.points(), &parts[h]);
      }
    }
  };
  // Splitting pays above several thousand samples (a thread costs ~20 µs here, an
  // evaluation of 15 000 samples ~0.4 ms: the coarsest level of a 940×452 view).
  if (options_.threads >= 2 && CoreFreeForSplit() && set->samples >= 8000) {
    std::thread other(fill, 1);
    fill(0);
    other.join();
  } else {
    fill(0);
    fill(1);
  }
  parts[0].Merge(parts[1]);
  if (level_metric.region == Region::kWholeImage) {
    CHECK_EQ(set->background.size(), set->views.size()) << "a sample set without background";
    for (size_t v = 0; v < set->background.size(); ++v) {
      parts[0].AddBackgroundComplement(set->background[v].data(), set->view_pixels[v]);
    }
  }
  const MetricValue value = parts[0].Evaluate();
  ++sample_evaluations_;
  sample_ns_ += static_cast<int64_t>(1e9 * timer.ElapsedSeconds());
  return value;
}

double FrameSetEvaluator::CoveredFraction(const Rigid3d& cam_from_lidar) const {
  LidarImage& buffer = ThreadBuffer();
  double covered = 0, pixels = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[0][f]) {
      RenderLidarImage(points_[0][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[0][f]));
      covered += buffer.covered_pixels;
      pixels += static_cast<double>(buffer.width) * buffer.height;
    }
  }
  return pixels > 0 ? covered / pixels : 0.0;
}

double FrameSetEvaluator::EffectiveSamples(const Rigid3d& cam_from_lidar, int level,
                                           int max_lag, double* inflation) const {
  LidarImage& buffer = ThreadBuffer();
  double covered_pixels = 0, weighted = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[level][f]));
      const int w = buffer.width, h = buffer.height;
      const size_t pixels = buffer.value.size();
      auto covered = [&](size_t k) { return buffer.point_index[k] >= 0; };
      // The intensity without its surface class (class + fraction with several classes).
      const bool classed = options_.metric.lidar_classes > 1;
      auto value = [&](size_t k) {
        const float v = buffer.value[k];
        return classed ? v - std::floor(v) : v;
      };
      // The pose is found from where the two images change: the score of a registration is a
      // sum of gradient-weighted terms, so the correlation that matters is that of the
      // gradient fields (central differences where both neighbours are covered).
      std::vector<float> lx(pixels, 0.f), ly(pixels, 0.f), px(pixels, 0.f), py(pixels, 0.f);
      std::vector<char> on(pixels, 0);
      double n = 0, ll = 0, pp = 0;
      for (int y = 1; y + 1 < h; ++y) {
        for (int x = 1; x + 1 < w; ++x) {
          const size_t k = static_cast<size_t>(y) * w + x;
          if (!covered(k) || !covered(k - 1) || !covered(k + 1) || !covered(k - w) ||
              !covered(k + w)) {
            continue;
          }
          on[k] = 1;
          lx[k] = value(k + 1) - value(k - 1);
          ly[k] = value(k + w) - value(k - w);
          px[k] = view.image.pixels[k + 1] - view.image.pixels[k - 1];
          py[k] = view.image.pixels[k + w] - view.image.pixels[k - w];
          n += 1;
          ll += lx[k] * lx[k] + ly[k] * ly[k];
          pp += px[k] * px[k] + py[k] * py[k];
        }
      }
      if (n < 16 || !(ll > 0) || !(pp > 0)) continue;
      // Σ over lags of ρ_L·ρ_P (Bartlett); ρ(−lag) = ρ(lag), so the half plane dy > 0 or
      // (dy = 0, dx > 0) counts twice and lag 0 (ρ = 1) once.
      // Each lag's term on its own (the lags shared out over the threads), then summed in
      // lag order: the same sum on any number of threads.
      std::vector<std::pair<int, int>> lags;
      for (int dy = 0; dy <= max_lag; ++dy) {
        for (int dx = -max_lag; dx <= max_lag; ++dx) {
          if (dy == 0 && dx <= 0) continue;
          lags.emplace_back(dy, dx);
        }
      }
      // The columns of each row's pixels that are on, in order: a lag visits only those
      // (the same pairs, added in the same order, as a scan of every pixel).
      std::vector<int> on_columns;
      std::vector<size_t> row_begin(h + 1, 0);
      for (int y = 0; y < h; ++y) {
        row_begin[y] = on_columns.size();
        for (int x = 0; x < w; ++x) {
          if (on[static_cast<size_t>(y) * w + x]) on_columns.push_back(x);
        }
      }
      row_begin[h] = on_columns.size();
      std::vector<double> terms(lags.size(), 0.0);
      ParallelFor(static_cast<int>(lags.size()), CoreFreeForSplit() ? options_.threads : 1,
                  [&](int l) {
        const auto [dy, dx] = lags[l];
        // Without a branch per pixel: a partner that is not on has zero gradients, so its
        // term is ±0 and leaves the sums as they are (they start at +0 and never become −0),
        // and it counts 0 pairs; the columns whose partner is outside the row are cut off by
        // a search in the row's sorted on-columns. The same sums as adding the on pairs only.
        double pairs = 0, cl = 0, cp = 0;
        const int x0 = std::max(0, -dx), x1 = std::min(w, w - dx);
        for (int y = 0; y + dy < h; ++y) {
          const size_t row = static_cast<size_t>(y) * w, row2 = static_cast<size_t>(y + dy) * w;
          const int* first = on_columns.data() + row_begin[y];
          const int* last = on_columns.data() + row_begin[y + 1];
          const int* begin = std::lower_bound(first, last, x0);
          const int* end = std::lower_bound(begin, last, x1);
          for (const int* column = begin; column < end; ++column) {
            const int x = *column;
            const size_t a = row + x, b = row2 + x + dx;
            pairs += static_cast<double>(on[b]);
            cl += lx[a] * lx[b] + ly[a] * ly[b];
            cp += px[a] * px[b] + py[a] * py[b];
          }
        }
        if (pairs < 16) return;
        terms[l] = 2.0 * (cl / pairs) / (ll / n) * (cp / pairs) / (pp / n);
      });
      double factor = 1.0;
      for (double term : terms) factor += term;  // + 0 for a lag with too few pairs
      factor = std::max(1.0, factor);
      covered_pixels += static_cast<double>(buffer.covered_pixels);
      weighted += static_cast<double>(buffer.covered_pixels) / factor;
    }
  }
  if (inflation != nullptr) *inflation = weighted > 0 ? covered_pixels / weighted : 1.0;
  return weighted;
}

size_t FrameSetEvaluator::VisiblePoints(const Rigid3d& cam_from_lidar, int level) const {
  LidarImage& buffer = ThreadBuffer();
  size_t visible = 0;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[level][f]));
      visible += CountVisiblePoints(buffer);
    }
  }
  return visible;
}

void FrameSetEvaluator::EvaluateShuffled(const Rigid3d& cam_from_lidar, int level, int shuffles,
                                         double* mi_bits,
                                         std::vector<double>* shuffled_mi_bits) const {
  LidarImage& buffer = ThreadBuffer();
  MetricOptions metric = options_.metric;
  metric.kind = MetricKind::kMi;
  metric.bins = std::max(8, metric.bins >> level);
  const bool whole = metric.region == Region::kWholeImage;
  std::vector<float> lidar, photo;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (const View& view : pyramid_[level][f]) {
      RenderLidarImage(points_[level][f], view, cam_from_lidar, options_.render, &buffer,
                       SplitRender(points_[level][f]));
      for (size_t k = 0; k < buffer.value.size(); ++k) {
        const bool covered = buffer.point_index[k] >= 0;
        if (!covered && !whole) continue;
        lidar.push_back(covered ? buffer.value[k] : -1.f);
        photo.push_back(view.image.pixels[k]);
      }
    }
  }
  // The permutations one after the other (each shuffles the previous one), then the
  // histograms of the pairing and of each permutation on the threads: the same values.
  std::vector<std::vector<float>> photos(shuffles + 1);
  photos[0] = std::move(photo);
  std::mt19937 rng(20120616);
  for (int s = 1; s <= shuffles; ++s) {
    photos[s] = photos[s - 1];
    std::shuffle(photos[s].begin(), photos[s].end(), rng);
  }
  std::vector<double> mi(shuffles + 1);
  ParallelFor(shuffles + 1, CoreFreeForSplit() ? options_.threads : 1, [&](int s) {
    JointHistogram histogram(metric);
    histogram.AddPairs(lidar, photos[s]);
    mi[s] = histogram.Evaluate().mi;
  });
  *mi_bits = mi[0];
  shuffled_mi_bits->assign(mi.begin() + 1, mi.end());
}

std::vector<FrameSetEvaluator::VisiblePoint> FrameSetEvaluator::SampleVisiblePoints(
    const Rigid3d& cam_from_lidar, size_t max_points) const {
  LidarImage& buffer = ThreadBuffer();
  std::vector<VisiblePoint> all;
  for (size_t f = 0; f < frames_.size(); ++f) {
    for (size_t v = 0; v < pyramid_[0][f].size(); ++v) {
      RenderLidarImage(points_[0][f], pyramid_[0][f][v], cam_from_lidar, options_.render,
                       &buffer, SplitRender(points_[0][f]));
      // The winners in the order of the even subsample (not the render order), as the
      // points were before they were sorted for rendering.
      const std::vector<uint32_t>& order = points_[0][f].tie_rank;
      std::vector<std::pair<uint32_t, int>> winners;  // (position in the subsample, index)
      for (int index : buffer.point_index) {
        if (index >= 0) winners.emplace_back(order[index], index);
      }
      std::sort(winners.begin(), winners.end());
      winners.erase(std::unique(winners.begin(), winners.end()), winners.end());
      for (const auto& [position, index] : winners) {
        all.push_back({static_cast<int>(f), static_cast<int>(v),
                       points_[0][f].points_in_lidar[index].cast<double>()});
      }
    }
  }
  if (all.size() <= max_points) return all;
  std::vector<VisiblePoint> sample;
  const double stride = static_cast<double>(all.size()) / max_points;
  for (double k = 0; k < all.size() && sample.size() < max_points; k += stride) {
    sample.push_back(all[static_cast<size_t>(k)]);
  }
  return sample;
}

bool FrameSetEvaluator::Project(const VisiblePoint& point, const Rigid3d& cam_from_lidar,
                                Eigen::Vector2d* pixel) const {
  const View& view = pyramid_[0][point.frame][point.view];
  const Eigen::Vector3d p =
      view.view_from_cam * (cam_from_lidar * point.point_in_lidar) + view.view_from_cam_t;
  if (!view.camera.IsSpherical() && p.z() <= 0) return false;
  const std::optional<Eigen::Vector2d> xy = view.camera.ImgFromCam(p);
  if (!xy) return false;
  *pixel = *xy;
  return true;
}

namespace {

// Pixel difference a − b; across the ±180° seam of a panorama the shorter way round.
Eigen::Vector2d PixelDifference(const View& view, const Eigen::Vector2d& a,
                                const Eigen::Vector2d& b) {
  Eigen::Vector2d d = a - b;
  if (view.camera.IsSpherical()) {
    const double period = 2 * M_PI * view.camera.params[0];
    d.x() -= period * std::round(d.x() / period);
  }
  return d;
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace

double FrameSetEvaluator::MedianPixelDistance(const std::vector<VisiblePoint>& sample,
                                              const Rigid3d& a, const Rigid3d& b) const {
  std::vector<double> distances;
  for (const VisiblePoint& point : sample) {
    Eigen::Vector2d pa, pb;
    if (!Project(point, a, &pa) || !Project(point, b, &pb)) continue;
    const View& view = pyramid_[0][point.frame][point.view];
    distances.push_back(view.image_pixels_per_pixel * PixelDifference(view, pa, pb).norm());
  }
  return Median(distances);
}

View CropView(const View& view, int col0, int col1) {
  CHECK(0 <= col0 && col0 < col1 && col1 <= view.image.width) << "crop columns out of range";
  View crop;
  crop.name = view.name + "[" + std::to_string(col0) + ":" + std::to_string(col1) + "]";
  crop.view_from_cam = view.view_from_cam;
  crop.view_from_cam_t = view.view_from_cam_t;
  crop.image_pixels_per_pixel = view.image_pixels_per_pixel;
  crop.image_camera = view.image_camera;
  crop.image = GrayImage(col1 - col0, view.image.height);
  for (int r = 0; r < view.image.height; ++r) {
    for (int c = col0; c < col1; ++c) crop.image.at(c - col0, r) = view.image.at(c, r);
  }
  crop.camera = view.camera;
  crop.camera.width = col1 - col0;
  const std::vector<int> principal = sensors::CameraModelPrincipalIdxs(view.camera.model_id);
  CHECK(!principal.empty()) << "camera model without a principal point";
  crop.camera.params[principal[0]] -= col0;
  return crop;
}

std::array<std::vector<Frame>, 2> SplitIntoHalves(const std::vector<Frame>& frames,
                                                  std::string* kind) {
  std::array<std::vector<Frame>, 2> halves;
  size_t total = 0, with_views = 0;
  for (const Frame& frame : frames) {
    total += frame.views.size();
    with_views += frame.views.empty() ? 0 : 1;
  }
  if (with_views >= 2) {
    // Several frames sharing one pose (the rig calibration): whole frames alternately. What
    // differs between frames — their scene, the LiDAR's georeferencing over each frame's
    // time window — is what must agree; halves that each hold part of every frame share it.
    size_t index = 0;
    for (const Frame& frame : frames) {
      if (!frame.views.empty()) halves[index++ % 2].push_back(frame);
    }
    if (kind != nullptr) *kind = "frames";
  } else if (total >= 2) {
    size_t index = 0;
    for (const Frame& frame : frames) {
      std::array<Frame, 2> parts;
      for (int h = 0; h < 2; ++h) {
        parts[h].name = frame.name;
        parts[h].points = frame.points;
      }
      for (const View& view : frame.views) parts[index++ % 2].views.push_back(view);
      for (int h = 0; h < 2; ++h) {
        if (!parts[h].views.empty()) halves[h].push_back(std::move(parts[h]));
      }
    }
    if (kind != nullptr) *kind = "views";
  } else if (total == 1) {
    for (const Frame& frame : frames) {
      if (frame.views.empty()) continue;
      const View& view = frame.views.front();
      if (view.image.width < 16) break;  // too narrow to halve: the check is not applicable
      const int middle = view.image.width / 2;
      for (int h = 0; h < 2; ++h) {
        Frame part;
        part.name = frame.name;
        part.points = frame.points;
        part.views.push_back(h == 0 ? CropView(view, 0, middle)
                                    : CropView(view, middle, view.image.width));
        halves[h].push_back(std::move(part));
      }
    }
    if (kind != nullptr) *kind = "left/right halves";
  }
  return halves;
}

// ---------------------------------------------------------------------------------------
// Registration

namespace {

std::string DescribeCorrection(const Vector6d& d) {
  return "tx " + Fixed(d[0], 2) + ", ty " + Fixed(d[1], 2) + ", tz " + Fixed(d[2], 2) +
         " m; roll " + Fixed(d[3], 2) + ", pitch " + Fixed(d[4], 2) + ", yaw " + Fixed(d[5], 2) +
         " deg";
}

// Confidence along each axis (a reduced probe), and along `weak` (WeaklyObservedDirection;
// skipped when zero): the metric must peak near the optimum, rise above the scan's minimum,
// and (the axes) show no second comparable peak.
bool CheckConfidence(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                     const Vector6d& x, const Vector6d& weak, const RegistrationOptions& options,
                     int level, std::string* reason, int* evaluations) {
  const Vector6d bound = BoundVector(options);
  constexpr int kSide = 5;
  // Judged on MI (bits) so that the relative thresholds mean the same for every metric.
  MetricOptions metric = options.metric;
  metric.kind = MetricKind::kMi;
  // Each scan: x + s·direction, s in [−1, 1] (the axes: ±their bound). The weak direction
  // is not tested for a second, lower peak: along it the image changes least by construction,
  // so the metric is flat and bumpy there, and a lower bump does not contradict the optimum
  // (measured: that test refused 5 right photo registrations of the cathedral, 0.19–0.83 px;
  // bench/RESULTS.md "The weakly observed direction"); a higher value does.
  struct Scan {
    Vector6d direction;
    std::string name;
    bool axis;
  };
  std::vector<Scan> scans;
  for (int axis = 0; axis < 6; ++axis) {
    Vector6d d = Vector6d::Zero();
    d[axis] = bound[axis];
    scans.push_back({d, ParameterName(axis), true});
  }
  if (weak.squaredNorm() > 0) {
    scans.push_back({weak, "the weakly observed direction (" + DescribeCorrection(weak) + ")",
                     false});
  }
  for (const Scan& scan : scans) {
    std::vector<double> values(2 * kSide + 1);
    ParallelFor(2 * kSide + 1, options.threads, [&](int k) {
      const Vector6d y = x + (static_cast<double>(k - kSide) / kSide) * scan.direction;
      values[k] = evaluator.Evaluate(ApplyCorrection(start, y), level, metric).value;
    });
    *evaluations += 2 * kSide + 1;
    // Offsets in m or deg along an axis, as the fraction of the scan's half-length otherwise.
    auto offset = [&](int k) {
      const double s = static_cast<double>(k - kSide) / kSide;
      return scan.axis ? Fixed(s * scan.direction.cwiseAbs().maxCoeff(), 3)
                       : Fixed(s, 2) + " of it";
    };
    const double center = values[kSide];
    const double peak = *std::max_element(values.begin(), values.end());
    const double low = *std::min_element(values.begin(), values.end());
    const double depth = peak - low;
    const double scale = std::max(std::abs(peak), 1e-12);
    if (depth < options.min_relative_peak * scale) {
      *reason = "metric surface flat along " + scan.name + " (peak-to-trough " +
                Fixed(100 * depth / scale, 3) + " % of the metric)";
      return false;
    }
    if (!options.check_multiple_peaks) continue;
    // The optimum must hold the maximum within ±1 sample of the centre.
    const int argmax = static_cast<int>(std::max_element(values.begin(), values.end()) -
                                        values.begin());
    if (std::abs(argmax - kSide) > 1 && peak - center > 0.25 * depth) {
      *reason = "higher MI along " + scan.name + " at offset " + offset(argmax) +
                " from the optimum: multi-peaked or not converged";
      return false;
    }
    // A second local maximum, away from the centre, nearly as high as the peak (the axes).
    if (!scan.axis) continue;
    for (int k = 1; k + 1 < static_cast<int>(values.size()); ++k) {
      if (std::abs(k - kSide) <= 1) continue;
      if (values[k] >= values[k - 1] && values[k] >= values[k + 1] &&
          values[k] > peak - 0.1 * depth && std::abs(k - argmax) > 1) {
        *reason = "second peak along " + scan.name + " at offset " + offset(k);
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
                                      const Vector6d& x, const MetricOptions& metric, int level,
                                      const FrameSetEvaluator::SampleSet* samples, int threads,
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
  }
  ParallelFor(static_cast<int>(offsets.size()), threads, [&](int k) {
    values[k] = evaluator.Evaluate(ApplyCorrection(start, x + offsets[k].cwiseProduct(h)), level,
                                   metric, samples)
                    .mi *
                M_LN2;
  });
  *evaluations += static_cast<int>(offsets.size());
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

// Coarse-to-fine search from x0: Nelder–Mead at levels top_level .. bottom_level with the
// simplex `top_step` at the top level, halved at each finer one, and the tolerances of the
// main run at each level (`finest_tolerance` > 0 replaces the one of bottom_level); then
// (optionally) gradient ascent on the B-spline histogram at level 0. With point samples, the
// visibility of the first Nelder–Mead run is decided at `visibility_at` (default: x0).
struct SearchResult {
  Vector6d x = Vector6d::Zero();
  double value = 0;
  int iterations = 0;
  int evaluations = 0;
};

SearchResult Search(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    int top_level, int bottom_level, const Vector6d& top_step,
                    double finest_tolerance, bool gradient,
                    const RegistrationOptions& options, class StageClock* clock,
                    const std::string& stage_prefix, const Vector6d* visibility_at = nullptr);

// CPU time of the process, all threads (the comparable figure on a shared machine).
double ProcessCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

// Records the time and evaluations of consecutive stages into a result.
class StageClock {
 public:
  explicit StageClock(RegistrationResult* result)
      : result_(result), cpu_start_(ProcessCpuSeconds()) {}
  /// Closes a stage that made `evaluations` metric evaluations (added to the result).
  void Mark(const std::string& name, int evaluations) {
    StageStat stat;
    stat.name = name;
    stat.seconds = timer_.ElapsedSeconds();
    const double cpu = ProcessCpuSeconds();
    stat.cpu_seconds = cpu - cpu_start_;
    stat.evaluations = evaluations;
    result_->evaluations += evaluations;
    result_->stages.push_back(stat);
    spdlog::debug("MI stage {}: {} evaluations, {:.3f} s (cpu {:.3f} s)", name, stat.evaluations,
                  stat.seconds, stat.cpu_seconds);
    timer_.Restart();
    cpu_start_ = cpu;
  }

 private:
  RegistrationResult* result_;
  Timer timer_;
  double cpu_start_;
};

SearchResult Search(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    int top_level, int bottom_level, const Vector6d& top_step,
                    double finest_tolerance, bool gradient,
                    const RegistrationOptions& options, StageClock* clock,
                    const std::string& stage_prefix, const Vector6d* visibility_at) {
  SearchResult search;
  const Vector6d bound = BoundVector(options);
  const int levels = evaluator.levels();
  Vector6d x = x0;
  for (int level = top_level; level >= bottom_level; --level) {
    NelderMeadOptions nm = options.nelder_mead;
    nm.lower = -bound;
    nm.upper = bound;
    nm.initial_step = top_step * std::pow(0.5, top_level - level);
    // Tolerance: the paper's at the coarsest level, halved per finer level.
    nm.parameter_tolerance =
        options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1 - level);
    if (level == bottom_level && finest_tolerance > 0) nm.parameter_tolerance = finest_tolerance;
    // Point samples with the visibility frozen at the pass's start: within one Nelder–Mead
    // run the metric is one fixed function of the correction. When the run ends more than
    // options.sample_rebuild_px (pixels of the level) from where the visibility was
    // decided, it is decided again there and the run repeated from that point with half the
    // simplex (at most kPasses runs per level).
    constexpr int kPasses = 3;
    const bool sampled = options.point_samples && evaluator.UsesSamples(options.metric);
    NelderMeadResult r;
    int level_iterations = 0, level_evaluations = 0;
    for (int pass = 0; pass < kPasses; ++pass) {
      FrameSetEvaluator::SampleSet samples;
      if (sampled) {
        // The first pass at the top level may take its visibility elsewhere (the restarts:
        // at the optimum they are expected to return to).
        const Vector6d& at =
            pass == 0 && level == top_level && visibility_at != nullptr ? *visibility_at : x;
        samples = evaluator.MakeSampleSet(ApplyCorrection(start, at), level,
                                          options.SamplePerPoint(level));
      }
      r = MaximizeNelderMead(
          [&](const Vector6d& y) {
            return evaluator
                .Evaluate(ApplyCorrection(start, y), level, options.metric,
                          sampled ? &samples : nullptr)
                .value;
          },
          x, nm);
      level_iterations += r.iterations;
      level_evaluations += r.evaluations;
      x = r.x;
      if (!sampled ||
          !(evaluator.SampleSetDisplacementPx(samples, ApplyCorrection(start, r.x)) >
            options.sample_rebuild_px)) {
        break;
      }
      nm.initial_step = (0.5 * nm.initial_step).cwiseMax(2.0 * nm.parameter_tolerance);
    }
    r.iterations = level_iterations;
    r.evaluations = level_evaluations;
    spdlog::debug("MI {}level {}: {} iterations, metric {:.6f}, correction [{:.3f} {:.3f} {:.3f} "
                  "{:.3f} {:.3f} {:.3f}]",
                  stage_prefix, level, r.iterations, r.value, r.x[0], r.x[1], r.x[2], r.x[3],
                  r.x[4], r.x[5]);
    search.value = r.value;
    search.iterations += r.iterations;
    search.evaluations += r.evaluations;
    if (clock != nullptr) clock->Mark(stage_prefix + "nelder-mead level " + std::to_string(level),
                                      r.evaluations);
  }
  // Gradient refinement on the B-spline histogram (smooth in the pose): steepest ascent in
  // the scaled units with a backtracking step.
  if (gradient) {
    MetricOptions smooth = options.metric;
    smooth.smoothing = Smoothing::kBSpline;
    int evaluations = 0;
    // Each iteration's samples have the visibility of its own start x.
    const bool sampled = options.point_samples && evaluator.UsesSamples(smooth);
    FrameSetEvaluator::SampleSet samples;
    auto f = [&](const Vector6d& y) {
      ++evaluations;
      return evaluator
          .Evaluate(ApplyCorrection(start, y), 0, smooth, sampled ? &samples : nullptr)
          .value;
    };
    Vector6d h;
    h << 0.005, 0.005, 0.005, 0.02, 0.02, 0.02;
    double fx = 0;
    double alpha = 0.05;  // units per unit of normalised gradient
    for (int it = 0; it < options.gradient_max_iterations && alpha > 1e-3; ++it) {
      if (sampled || it == 0) {
        if (sampled) {
          samples = evaluator.MakeSampleSet(ApplyCorrection(start, x), 0,
                                            options.SamplePerPoint(0));
        }
        fx = f(x);
      }
      Eigen::Matrix<double, 12, 1> sides;
      ParallelFor(12, options.threads, [&](int k) {
        Vector6d y = x;
        y[k / 2] += (k % 2 == 0 ? 1.0 : -1.0) * h[k / 2];
        sides[k] = evaluator
                       .Evaluate(ApplyCorrection(start, y), 0, smooth,
                                 sampled ? &samples : nullptr)
                       .value;
      });
      evaluations += 12;
      Vector6d g;
      for (int i = 0; i < 6; ++i) g[i] = (sides[2 * i] - sides[2 * i + 1]) / (2 * h[i]);
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
      ++search.iterations;
      if (!improved) break;
    }
    search.evaluations += evaluations;
    if (clock != nullptr) clock->Mark(stage_prefix + "gradient refinement", evaluations);
  }
  search.x = x;
  return search;
}

// Points spread over the box ±spread·bound for the coarse global stage: a Halton sequence
// (bases 2, 3, 5, 7, 11, 13; Halton 1960) mapped to [−1, 1]⁶, each point followed by its
// opposite so that the set is symmetric about the start. Deterministic.
std::vector<Vector6d> SpreadStarts(int count, const Vector6d& bound, double spread) {
  static const int kBases[6] = {2, 3, 5, 7, 11, 13};
  std::vector<Vector6d> starts;
  for (int k = 1; static_cast<int>(starts.size()) < count; ++k) {
    Vector6d u;
    for (int i = 0; i < 6; ++i) {
      double f = 1.0, r = 0.0;
      for (int n = k; n > 0; n /= kBases[i]) {
        f /= kBases[i];
        r += f * (n % kBases[i]);
      }
      u[i] = 2.0 * r - 1.0;
    }
    const Vector6d x = spread * u.cwiseProduct(bound);
    starts.push_back(x);
    if (static_cast<int>(starts.size()) < count) starts.push_back(-x);
  }
  return starts;
}

// The search of the main run. Without coarse starts: one coarse-to-fine Nelder–Mead from the
// start. With them (a multi-start global stage at the coarsest level, as the paper's
// single local search leaves a repeating façade or a paved ground on a secondary maximum):
// Nelder–Mead at the coarsest level from the start and from `coarse_starts` points spread over
// the box; the `coarse_candidates` best distinct coarse optima are each carried down to the
// finest Nelder–Mead level, and the one with the highest metric there wins (the coarse level
// may rank the basins wrongly: measured on the simulated panoramas, bench/RESULTS.md); then the
// gradient refinement of the winner.
SearchResult MainSearch(const FrameSetEvaluator& evaluator, const Rigid3d& start,
                        const RegistrationOptions& options, StageClock* clock) {
  const Vector6d bound = BoundVector(options);
  const int levels = evaluator.levels();
  const int top = levels - 1;
  const int bottom = std::min(options.finest_nelder_mead_level, top);
  const Vector6d top_step = options.nelder_mead.initial_step.cwiseMin(bound);
  if (options.coarse_starts <= 0) {
    // Paths entering the pyramid at top, top − 1, ..., each with the full simplex (the
    // start's uncertainty does not depend on the level), ranked at `bottom`.
    const int paths = std::min(options.pyramid_paths, top - bottom + 1);
    if (paths <= 1) {
      return Search(evaluator, start, Vector6d::Zero(), top, bottom, top_step, -1.0,
                    options.gradient_refinement, options, clock, "");
    }
    std::vector<SearchResult> path(paths);
    std::vector<double> ranked(paths);
    auto run_path = [&](int k) {
      path[k] = Search(evaluator, start, Vector6d::Zero(), top - k, bottom, top_step, -1.0,
                       false, options, nullptr, "path " + std::to_string(k) + " ");
      ranked[k] = evaluator.Evaluate(ApplyCorrection(start, path[k].x), bottom).value;
    };
    int run = paths;      // paths ranked at `bottom`
    int entries = paths;  // entry levels searched
    int unranked_evaluations = 0, unranked_iterations = 0;
    if (options.pyramid_paths_adaptive && paths >= 3) {
      // The coarser entries first, each down to the level above the finest only; if they end
      // there within the restart tolerance of each other, the coarsest entry's path alone goes
      // on to the finest level (the single coarse-to-fine search, exactly). Otherwise a coarse
      // level may have led one astray: each goes on, and the finest entry (the dearest: the
      // full simplex at the finest level) is searched too.
      const int coarse_paths = paths - 1;
      const int above = bottom + 1;
      std::vector<SearchResult> upper(coarse_paths);
      ParallelFor(coarse_paths, options.threads, [&](int k) {
        upper[k] = Search(evaluator, start, Vector6d::Zero(), top - k, above, top_step, -1.0,
                          false, options, nullptr, "path " + std::to_string(k) + " ");
      });
      const Rigid3d first = ApplyCorrection(start, upper[0].x);
      const std::vector<FrameSetEvaluator::VisiblePoint> sample =
          evaluator.SampleVisiblePoints(first, 500);
      double spread = 0;
      for (int k = 1; k < coarse_paths; ++k) {
        spread = std::max(spread, evaluator.MedianPixelDistance(
                                      sample, first, ApplyCorrection(start, upper[k].x)));
      }
      spdlog::debug("MI paths: the coarser entries end {:.2f} px apart at level {}", spread,
                    above);
      const bool agree = spread <= options.restart_tolerance_px;
      run = agree ? 1 : paths;
      entries = agree ? coarse_paths : paths;
      for (int k = run; k < coarse_paths; ++k) {
        unranked_evaluations += upper[k].evaluations;
        unranked_iterations += upper[k].iterations;
      }
      ParallelFor(run, options.threads, [&](int i) {
        const int k = run - 1 - i;  // the finest entry first
        if (k == coarse_paths) {
          run_path(k);
          return;
        }
        // On from `above` to `bottom`: the same steps as one search from the entry level.
        const SearchResult down =
            Search(evaluator, start, upper[k].x, bottom, bottom,
                   top_step * std::pow(0.5, top - k - bottom), -1.0, false, options, nullptr,
                   "path " + std::to_string(k) + " ");
        path[k] = upper[k];
        path[k].x = down.x;
        path[k].value = down.value;
        path[k].iterations += down.iterations;
        path[k].evaluations += down.evaluations;
        ranked[k] = evaluator.Evaluate(ApplyCorrection(start, path[k].x), bottom).value;
      });
    } else {
      // The finest entry has the most work (the full simplex at the finest level): it starts
      // first, so that the coarser entries share the other thread (the same results in any
      // order: the paths are independent).
      ParallelFor(paths, options.threads, [&](int i) { run_path(paths - 1 - i); });
    }
    SearchResult result;
    int evaluations = unranked_evaluations, best = 0;
    result.iterations = unranked_iterations;
    for (int k = 0; k < run; ++k) {
      evaluations += path[k].evaluations + 1;
      result.iterations += path[k].iterations;
      spdlog::debug("MI path from level {}: metric {:.6f} at level {}, correction [{:.3f} {:.3f} "
                    "{:.3f} {:.3f} {:.3f} {:.3f}]",
                    top - k, ranked[k], bottom, path[k].x[0], path[k].x[1], path[k].x[2],
                    path[k].x[3], path[k].x[4], path[k].x[5]);
      if (ranked[k] > ranked[best]) best = k;
    }
    if (clock != nullptr) {
      clock->Mark("pyramid paths levels " + std::to_string(top) + ".." +
                      std::to_string(top - entries + 1) + " (best from level " +
                      std::to_string(top - best) + ")",
                  evaluations);
    }
    result.x = path[best].x;
    result.value = ranked[best];
    if (options.gradient_refinement) {
      const SearchResult g = Search(evaluator, start, result.x, -1, 0, top_step, -1.0, true,
                                    options, clock, "");
      result.x = g.x;
      result.iterations += g.iterations;
      result.evaluations += g.evaluations;
    }
    result.evaluations += evaluations;
    return result;
  }
  std::vector<Vector6d> starts = {Vector6d::Zero()};
  for (const Vector6d& x : SpreadStarts(options.coarse_starts, bound, options.coarse_start_spread)) {
    starts.push_back(x);
  }
  std::vector<SearchResult> coarse(starts.size());
  ParallelFor(static_cast<int>(starts.size()), options.threads, [&](int k) {
    coarse[k] = Search(evaluator, start, starts[k], top, top, top_step, -1.0, false, options,
                       nullptr, "coarse start " + std::to_string(k) + " ");
  });
  SearchResult result;
  int evaluations = 0;
  for (const SearchResult& r : coarse) {
    evaluations += r.evaluations;
    result.iterations += r.iterations;
  }
  if (clock != nullptr) {
    clock->Mark("coarse starts level " + std::to_string(top) + " (" +
                    std::to_string(starts.size()) + ")",
                evaluations);
  }
  // The start's own coarse optimum (the paper's search), then the best distinct other coarse
  // optima (distinct: apart by more than the coarse tolerance in some parameter). The
  // start's is always kept: the coarse level may rank a wrong basin above the true one
  // (measured: gate S1_upper, bench/RESULTS.md), the finest level ranks them.
  std::vector<int> order(coarse.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin() + 1, order.end(),
                   [&](int a, int b) { return coarse[a].value > coarse[b].value; });
  std::vector<Vector6d> candidates;
  for (int k : order) {
    if (static_cast<int>(candidates.size()) >= options.coarse_candidates) break;
    bool distinct = true;
    for (const Vector6d& c : candidates) {
      distinct = distinct && (coarse[k].x - c).cwiseAbs().maxCoeff() >
                                 options.nelder_mead.parameter_tolerance;
    }
    if (distinct) candidates.push_back(coarse[k].x);
  }
  std::vector<SearchResult> fine(candidates.size());
  if (top > bottom) {
    ParallelFor(static_cast<int>(candidates.size()), options.threads, [&](int k) {
      fine[k] = Search(evaluator, start, candidates[k], top - 1, bottom, 0.5 * top_step, -1.0,
                       false, options, nullptr, "candidate " + std::to_string(k) + " ");
    });
  } else {
    for (size_t k = 0; k < candidates.size(); ++k) {
      fine[k].x = candidates[k];
      fine[k].value = evaluator.Evaluate(ApplyCorrection(start, candidates[k]), bottom).value;
    }
  }
  evaluations = 0;
  int best = 0;
  for (size_t k = 0; k < fine.size(); ++k) {
    evaluations += fine[k].evaluations;
    result.iterations += fine[k].iterations;
    spdlog::debug("MI candidate {}: coarse [{:.3f} {:.3f} {:.3f} {:.3f} {:.3f} {:.3f}] -> metric "
                  "{:.6f} at level {}",
                  k, candidates[k][0], candidates[k][1], candidates[k][2], candidates[k][3],
                  candidates[k][4], candidates[k][5], fine[k].value, bottom);
    if (fine[k].value > fine[best].value) best = static_cast<int>(k);
  }
  if (clock != nullptr) {
    clock->Mark("candidates levels " + std::to_string(top - 1) + ".." + std::to_string(bottom) +
                    " (" + std::to_string(candidates.size()) + ")",
                evaluations);
  }
  result.x = fine[best].x;
  result.value = fine[best].value;
  if (options.gradient_refinement) {
    // No Nelder–Mead level (top < bottom): the gradient refinement alone.
    const SearchResult g = Search(evaluator, start, result.x, -1, 0, top_step, -1.0, true,
                                  options, clock, "");
    result.x = g.x;
    result.iterations += g.iterations;
  }
  return result;
}

// Per point of `sample` (those that project at x ± the steps): ∂pixel/∂correction at x, in
// pixels of the frame's image per m and per degree (central differences).
std::vector<Eigen::Matrix<double, 2, 6>> PixelJacobians(
    const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x,
    const std::vector<FrameSetEvaluator::VisiblePoint>& sample) {
  Vector6d h;
  h << 1e-3, 1e-3, 1e-3, 1e-2, 1e-2, 1e-2;
  std::vector<Eigen::Matrix<double, 2, 6>> jacobians;
  for (const FrameSetEvaluator::VisiblePoint& point : sample) {
    const View& view = evaluator.frames()[point.frame].views[point.view];
    Eigen::Matrix<double, 2, 6> jacobian;
    bool ok = true;
    for (int k = 0; k < 6 && ok; ++k) {
      Vector6d a = x, b = x;
      a[k] += h[k];
      b[k] -= h[k];
      Eigen::Vector2d pa, pb;
      ok = evaluator.Project(point, ApplyCorrection(start, a), &pa) &&
           evaluator.Project(point, ApplyCorrection(start, b), &pb);
      if (ok) jacobian.col(k) = PixelDifference(view, pa, pb) / (2 * h[k]);
    }
    if (ok) jacobians.push_back(view.image_pixels_per_pixel * jacobian);
  }
  return jacobians;
}

// Per Jacobian J of PixelJacobians: the predicted pixel variance trace(J Σ Jᵀ), in pixels² of
// the frame's image.
std::vector<double> PredictedPixelVariances(
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians,
    const Eigen::Matrix<double, 6, 6>& covariance) {
  std::vector<double> variances;
  for (const Eigen::Matrix<double, 2, 6>& jacobian : jacobians) {
    variances.push_back((jacobian * covariance * jacobian.transpose()).trace());
  }
  return variances;
}

// Per point of `sample`: the squared pixel distance between poses a and b, in pixels² of the
// frame's image.
std::vector<double> PixelDisplacements2(const FrameSetEvaluator& evaluator,
                                        const std::vector<FrameSetEvaluator::VisiblePoint>& sample,
                                        const Rigid3d& a, const Rigid3d& b) {
  std::vector<double> d2;
  for (const FrameSetEvaluator::VisiblePoint& point : sample) {
    Eigen::Vector2d pa, pb;
    if (!evaluator.Project(point, a, &pa) || !evaluator.Project(point, b, &pb)) continue;
    const View& view = evaluator.frames()[point.frame].views[point.view];
    d2.push_back(std::pow(view.image_pixels_per_pixel, 2) *
                 PixelDifference(view, pa, pb).squaredNorm());
  }
  return d2;
}

// A point of a frame's own image (the panorama its views were cut from).
struct ImagePoint {
  const sensors::Camera* camera;
  Eigen::Vector3d point_in_lidar;
};

// Up to `max_points` of the frames' cloud points, within range, that project into their own
// image at `cam_from_lidar` (frames whose views are cuts, View::image_camera; none otherwise),
// an even subsample in cloud order.
std::vector<ImagePoint> SampleImagePoints(const std::vector<Frame>& frames,
                                          const Rigid3d& cam_from_lidar,
                                          const RenderOptions& render, size_t max_points) {
  std::vector<ImagePoint> all;
  for (const Frame& frame : frames) {
    if (frame.views.empty() || !frame.views.front().image_camera) continue;
    const sensors::Camera* camera = &*frame.views.front().image_camera;
    const LidarPoints& points = *frame.points;
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = points.points_in_lidar[i].cast<double>();
      const Eigen::Vector3d c = cam_from_lidar * p;
      const double range = c.norm();
      if (range < render.min_range_m || range > render.max_range_m) continue;
      if (!camera->IsSpherical() && c.z() <= 0) continue;
      const std::optional<Eigen::Vector2d> xy = camera->ImgFromCam(c);
      if (!xy || (*xy)[0] < 0 || (*xy)[1] < 0 || (*xy)[0] >= camera->width ||
          (*xy)[1] >= camera->height) {
        continue;
      }
      all.push_back({camera, p});
    }
  }
  if (all.size() <= max_points) return all;
  std::vector<ImagePoint> sample;
  const double stride = static_cast<double>(all.size()) / max_points;
  for (double k = 0; k < all.size() && sample.size() < max_points; k += stride) {
    sample.push_back(all[static_cast<size_t>(k)]);
  }
  return sample;
}

// Pixel of an image point at a pose; false when it does not project.
bool ProjectImagePoint(const ImagePoint& point, const Rigid3d& cam_from_lidar,
                       Eigen::Vector2d* xy) {
  const Eigen::Vector3d c = cam_from_lidar * point.point_in_lidar;
  if (!point.camera->IsSpherical() && c.z() <= 0) return false;
  const std::optional<Eigen::Vector2d> projected = point.camera->ImgFromCam(c);
  if (!projected) return false;
  *xy = *projected;
  return true;
}

// a − b in the image's pixels; across a panorama's ±180° seam the shorter way round.
Eigen::Vector2d ImagePixelDifference(const sensors::Camera& camera, const Eigen::Vector2d& a,
                                     const Eigen::Vector2d& b) {
  Eigen::Vector2d d = a - b;
  if (camera.IsSpherical()) {
    const double period = 2 * M_PI * camera.params[0];
    d.x() -= period * std::round(d.x() / period);
  }
  return d;
}

// Per image point: squared pixel distance between poses a and b.
std::vector<double> ImageDisplacements2(const std::vector<ImagePoint>& sample, const Rigid3d& a,
                                        const Rigid3d& b) {
  std::vector<double> d2;
  for (const ImagePoint& point : sample) {
    Eigen::Vector2d pa, pb;
    if (!ProjectImagePoint(point, a, &pa) || !ProjectImagePoint(point, b, &pb)) continue;
    d2.push_back(ImagePixelDifference(*point.camera, pa, pb).squaredNorm());
  }
  return d2;
}

// Per image point: trace(J Σ Jᵀ) at correction x (J by central differences), pixels².
std::vector<double> ImagePredictedVariances(const std::vector<ImagePoint>& sample,
                                            const Rigid3d& start, const Vector6d& x,
                                            const Eigen::Matrix<double, 6, 6>& covariance) {
  Vector6d h;
  h << 1e-3, 1e-3, 1e-3, 1e-2, 1e-2, 1e-2;
  std::array<Rigid3d, 12> poses;
  for (int k = 0; k < 12; ++k) {
    Vector6d y = x;
    y[k / 2] += (k % 2 == 0 ? 1.0 : -1.0) * h[k / 2];
    poses[k] = ApplyCorrection(start, y);
  }
  std::vector<double> variances;
  for (const ImagePoint& point : sample) {
    Eigen::Matrix<double, 2, 6> jacobian;
    bool ok = true;
    for (int k = 0; k < 6 && ok; ++k) {
      Eigen::Vector2d pa, pb;
      ok = ProjectImagePoint(point, poses[2 * k], &pa) &&
           ProjectImagePoint(point, poses[2 * k + 1], &pb);
      if (ok) jacobian.col(k) = ImagePixelDifference(*point.camera, pa, pb) / (2 * h[k]);
    }
    if (ok) variances.push_back((jacobian * covariance * jacobian.transpose()).trace());
  }
  return variances;
}

double MeanOf(const std::vector<double>& values) {
  return values.empty() ? 0.0
                        : std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

double MedianSqrtOf(std::vector<double> squares) {
  for (double& v : squares) v = std::sqrt(v);
  return Median(std::move(squares));
}

// Second derivative of MI (nats per unit²) along a unit direction of the correction: a
// parabola a + b·t + ½·c·t² fitted by least squares to 13 samples t ∈ [−0.3, 0.3].
double CurvatureAlong(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x,
                      const Vector6d& direction, const MetricOptions& metric, int level,
                      const FrameSetEvaluator::SampleSet* samples, int threads,
                      int* evaluations) {
  constexpr int kSide = 6;
  constexpr double kStep = 0.05;
  Eigen::Matrix<double, 2 * kSide + 1, 3> design;
  Eigen::Matrix<double, 2 * kSide + 1, 1> values;
  for (int k = -kSide; k <= kSide; ++k) {
    const double t = k * kStep;
    design.row(k + kSide) << 1.0, t, 0.5 * t * t;
  }
  ParallelFor(2 * kSide + 1, threads, [&](int k) {
    const double t = (k - kSide) * kStep;
    values[k] =
        evaluator.Evaluate(ApplyCorrection(start, x + t * direction), level, metric, samples)
            .mi *
        M_LN2;
  });
  *evaluations += 2 * kSide + 1;
  return design.colPivHouseholderQr().solve(values)[2];
}

}  // namespace

namespace {

// FNV-1a over raw bytes (Fowler, Noll & Vo).
class Fnv1a {
 public:
  void Bytes(const void* data, size_t size) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) hash_ = (hash_ ^ p[i]) * 1099511628211ull;
  }
  void Double(double v) { Bytes(&v, sizeof(v)); }
  void Int(int64_t v) { Bytes(&v, sizeof(v)); }
  void String(const std::string& s) {
    Int(static_cast<int64_t>(s.size()));
    Bytes(s.data(), s.size());
  }
  template <typename Derived>
  void Matrix(const Eigen::MatrixBase<Derived>& m) {
    for (int r = 0; r < m.rows(); ++r) {
      for (int c = 0; c < m.cols(); ++c) Double(m(r, c));
    }
  }
  void Metric(const MetricValue& m) {
    for (double v : {m.mi, m.nmi, m.nid, m.joint_entropy, m.samples, m.lidar_samples, m.value}) {
      Double(v);
    }
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 14695981039346656037ull;
};

}  // namespace

uint64_t RegistrationResult::Digest() const {
  Fnv1a h;
  h.String(status);
  h.String(reason);
  h.Matrix(cam_from_lidar.ToMatrix4());
  h.Matrix(correction);
  h.Matrix(covariance);
  h.Matrix(covariance_laplace);
  h.Int(covariance_valid);
  h.Int(trusted);
  h.String(confidence_reason);
  const AcceptanceChecks& c = checks;
  h.Int(c.on_bound);
  h.Int(c.below_start);
  h.Int(c.weak_directions);
  h.Int(c.restarts_run);
  h.Int(c.scans_passed);
  h.Int(c.split_parts);
  for (double v : {c.sigma_px, c.effective_samples, c.sample_inflation, c.restart_spread_px,
                   c.restart_rms_px, c.restart_best_gain, c.mi_bits, c.mi_shuffled_bits,
                   c.mi_shuffled_sd_bits, c.mi_significance, c.split_spread_px,
                   c.variance_factor, c.variance_factor_halves, c.variance_factor_restarts,
                   c.sigma_px_calibrated, c.image_sigma_px, c.image_restart_spread_px,
                   c.image_split_spread_px, c.image_variance_factor,
                   c.image_sigma_px_calibrated, c.covariance_factor}) {
    h.Double(v);
  }
  h.Int(c.covariance_floor_directions);
  h.String(c.scans_reason);
  h.String(c.split_kind);
  h.Metric(metric_before);
  h.Metric(metric_after);
  h.Int(iterations);
  h.Int(evaluations);
  for (const StageStat& stage : stages) h.Int(stage.evaluations);
  for (const std::string& name : used_frames) h.String(name);
  for (const auto& [name, why] : rejected_frames) {
    h.String(name);
    h.String(why);
  }
  for (const RegistrationResult& frame : frame_results) h.Int(static_cast<int64_t>(frame.Digest()));
  return h.value();
}

std::string RegistrationResult::BriefReport() const {
  std::ostringstream out;
  out << "MI registration: " << status;
  if (!reason.empty()) out << " (" << reason << ")";
  out << "; correction t = (" << Fixed(correction[0]) << ", " << Fixed(correction[1]) << ", "
      << Fixed(correction[2]) << ") m, r/p/y = (" << Fixed(correction[3]) << ", "
      << Fixed(correction[4]) << ", " << Fixed(correction[5]) << ") deg; ";
  // The values OUT.json holds (metric_before/after).
  out << MetricName(metric_kind) << " " << Fixed(ReportedMetric(metric_kind, metric_before.value), 5) << " -> "
      << Fixed(ReportedMetric(metric_kind, metric_after.value), 5)
      << (metric_kind == MetricKind::kNid ? " (minimised)" : " (maximised)") << "; "
      << iterations << " iterations, " << Fixed(runtime_seconds, 2) << " s";
  return out.str();
}

namespace {

// The status and reason of a registration from its failed checks (none: "ok").
RegistrationResult Finish(RegistrationResult& result, const std::vector<std::string>& failures,
                          const Timer& timer, const FrameSetEvaluator& evaluator);

}  // namespace

// The restarts' offset per parameter: restart_offset_m on the shifts, restart_offset_deg on
// the angles.
Vector6d RestartStep(const RegistrationOptions& options) {
  Vector6d offset;
  offset << options.restart_offset_m, options.restart_offset_m, options.restart_offset_m,
      options.restart_offset_deg, options.restart_offset_deg, options.restart_offset_deg;
  return offset;
}

// The restarts' start points around an optimum (offset ±restart_offset per parameter,
// deterministic signs, in opposite pairs), as check (3) uses them.
std::vector<Vector6d> RestartOffsets(const RegistrationOptions& options) {
  const Vector6d offset = RestartStep(options);
  std::mt19937 rng(6);
  std::vector<Vector6d> starts;
  for (int k = 0; k < options.restarts; ++k) {
    Vector6d signs;
    for (int i = 0; i < 6; ++i) signs[i] = (rng() & 1u) ? 1.0 : -1.0;
    if (k % 2 == 1) signs = -starts.back().cwiseQuotient(offset).cwiseSign();  // opposite pair
    starts.push_back(signs.cwiseProduct(offset));
  }
  return starts;
}

// The restarts' options: the search's, with point samples only if the checks use them.
RegistrationOptions RestartOptions(const RegistrationOptions& options) {
  RegistrationOptions restart_options = options;
  restart_options.point_samples = options.point_samples && options.point_samples_in_checks;
  return restart_options;
}

// The first parameter of x within 10 % of its search bound (the acceptance's "optimum on the
// search bound"), or -1.
int OnBound(const Vector6d& x, const Vector6d& bound) {
  for (int i = 0; i < 6; ++i) {
    if (std::abs(x[i]) >= 0.9 * bound[i]) return i;
  }
  return -1;
}

struct PolishResult {
  Vector6d x = Vector6d::Zero();
  std::vector<SearchResult> ends;  // the last round's restarts, run from `x` (check (3)'s own)
  std::vector<double> values;      // their full-resolution metric
};

// RegistrationOptions::polish_rounds: the restarts of check (3) run from the optimum x; the one
// ending highest in the full-resolution metric, if above x and beyond the restart tolerance, is
// refined at level 0 (and by the gradient when the main search was) and replaces x when it is
// still higher and not on the search bound. Not run from an optimum on the bound: the
// acceptance refuses it whatever the polish does, and the climb only runs on along the bound
// (measured: a cathedral rig panorama from 0.3 m / 2°, 12.65 → 17.20 px, 1.8 → 5.8 s CPU, failed
// both ways). `iterations` counts the refinements only (the restarts are the acceptance's work,
// which was not counted before either).
PolishResult Polish(const FrameSetEvaluator& evaluator, const Rigid3d& start, const Vector6d& x0,
                    const RegistrationOptions& options, StageClock* clock, int* iterations) {
  PolishResult out;
  out.x = x0;
  Vector6d& x = out.x;
  const Vector6d bound = BoundVector(options);
  if (options.polish_rounds <= 0 || options.restarts <= 0 || OnBound(x0, bound) >= 0) return out;
  const RegistrationOptions restart_options = RestartOptions(options);
  const int levels = evaluator.levels();
  const int restart_level = std::min(options.restart_level, levels - 1);
  const double tolerance = options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
  const Vector6d offset = RestartStep(options);
  const std::vector<Vector6d> starts = RestartOffsets(options);
  int evaluations = 0;
  for (int round = 0; round < options.polish_rounds; ++round) {
    const double current = evaluator.Evaluate(ApplyCorrection(start, x), 0).value;
    std::vector<SearchResult> ends(starts.size());
    std::vector<double> values(starts.size());
    ParallelFor(static_cast<int>(starts.size()), options.threads, [&](int k) {
      const Vector6d from = (x + starts[k]).cwiseMax(-bound).cwiseMin(bound);
      ends[k] = Search(evaluator, start, from, restart_level, restart_level, 2.0 * offset,
                       tolerance, false, restart_options, nullptr,
                       "restart " + std::to_string(k) + " ", &x);
      values[k] = evaluator.Evaluate(ApplyCorrection(start, ends[k].x), 0).value;
    });
    out.ends = ends;
    out.values = values;
    // Only a restart that the check would count as disagreeing (beyond its tolerance) moves
    // the optimum: one nearer is the same maximum, to within the tolerance.
    const Rigid3d pose = ApplyCorrection(start, x);
    const std::vector<FrameSetEvaluator::VisiblePoint> sample =
        evaluator.SampleVisiblePoints(pose, 2000);
    int best = -1;
    for (size_t k = 0; k < ends.size(); ++k) {
      evaluations += ends[k].evaluations + 1;
      if (!(values[k] > current) || (best >= 0 && values[k] <= values[best])) continue;
      const double distance =
          evaluator.MedianPixelDistance(sample, pose, ApplyCorrection(start, ends[k].x));
      if (distance > options.restart_tolerance_px) best = static_cast<int>(k);
    }
    evaluations += 1;
    if (best < 0) break;
    const SearchResult refined = Search(evaluator, start, ends[best].x, 0, 0, 2.0 * offset,
                                        tolerance, options.gradient_refinement, options, nullptr,
                                        "polish ");
    evaluations += refined.evaluations + 1;
    *iterations += refined.iterations;
    const double value = evaluator.Evaluate(ApplyCorrection(start, refined.x), 0).value;
    spdlog::debug("MI polish round {}: a restart ends {:+.6f} above the optimum; refined {:+.6f}",
                  round, values[best] - current, value - current);
    if (!(value > current) || OnBound(refined.x, bound) >= 0) break;
    x = refined.x;
    out.ends.clear();  // run about the previous optimum
    out.values.clear();
  }
  if (clock != nullptr) clock->Mark("polish", evaluations);
  return out;
}

RegistrationResult RegisterFrames(const std::vector<Frame>& frames,
                                  const Rigid3d& cam_from_lidar_start,
                                  const RegistrationOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = cam_from_lidar_start;
  result.metric_kind = options.metric.kind;
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
  StageClock clock(&result);
  FrameSetEvaluator evaluator(frames, cam_from_lidar_start, options);
  clock.Mark("prepare", 0);
  const double covered = evaluator.CoveredFraction(cam_from_lidar_start);
  if (covered < options.min_covered_fraction) {
    return fail("image does not overlap the cloud: " + Fixed(100 * covered, 2) +
                " % of the view pixels see LiDAR points at the start pose (minimum " +
                Fixed(100 * options.min_covered_fraction, 2) + " %)");
  }
  result.metric_before = evaluator.Evaluate(cam_from_lidar_start, 0);
  clock.Mark("start checks", 2);

  // ---- Optimisation: Nelder–Mead coarse to fine (paper defaults at the coarsest level),
  // then gradient ascent on the smooth histogram.
  const Vector6d bound = BoundVector(options);
  const int levels = evaluator.levels();
  const SearchResult main_search = MainSearch(evaluator, cam_from_lidar_start, options, &clock);
  result.iterations += main_search.iterations;
  const PolishResult polish =
      Polish(evaluator, cam_from_lidar_start, main_search.x, options, &clock, &result.iterations);
  Vector6d x = polish.x;
  result.correction = x;
  result.cam_from_lidar = ApplyCorrection(cam_from_lidar_start, x);
  result.metric_after = evaluator.Evaluate(result.cam_from_lidar, 0);
  AcceptanceChecks& checks = result.checks;
  // ---- Acceptance. Status "ok" needs every check to pass; by default the checks stop at
  // the first failure (options.measure_all_checks): `decided` says the status is "failed"
  // and the rest is not measured (the status, pose and an ok result's values are the same).
  std::vector<std::string> failures;
  const bool fail_fast = !options.measure_all_checks;
  auto decided = [&](const char* stage) {
    if (!fail_fast || failures.empty()) return false;
    if (checks.stopped_after.empty()) {
      checks.stopped_after = stage;
      spdlog::debug("MI acceptance: failed at {}, the later checks not measured", stage);
    }
    return true;
  };
  // The optimum must not be below the start in the full-resolution metric: a search that left
  // the start's maximum at a coarse level and ended on a lower one at full resolution has not
  // found the maximum it reports (measured: a simulated photo registered from its true pose
  // ended 10 cm / 0.19° away, NMI 1.03070 → 1.03009, and every other check passed).
  // Compared in the metric the search maximises: with point samples each pose's own samples
  // (its visibility, options.sample_block_px's placement), which differ from the rendered
  // histogram of metric_before/after by the footprint the samples leave out.
  double search_before = result.metric_before.value, search_after = result.metric_after.value;
  if (options.point_samples && evaluator.UsesSamples(options.metric)) {
    for (const auto& [pose, value] :
         {std::pair<const Rigid3d*, double*>{&cam_from_lidar_start, &search_before},
          std::pair<const Rigid3d*, double*>{&result.cam_from_lidar, &search_after}}) {
      const FrameSetEvaluator::SampleSet own =
          evaluator.MakeSampleSet(*pose, 0, options.SamplePerPoint(0));
      *value = evaluator.Evaluate(*pose, 0, options.metric, &own).value;
    }
  }
  checks.below_start = search_after < search_before;
  if (checks.below_start) {
    failures.push_back("the search ended below the start: metric " + Fixed(search_before, 5) +
                       " at the start, " + Fixed(search_after, 5) + " at the optimum found");
  }
  if (const int i = OnBound(x, bound); i >= 0) {
    checks.on_bound = true;
    failures.push_back(std::string("optimum on the search bound of ") + ParameterName(i) + " (" +
                       Fixed(x[i]) + ")");
  }
  if (decided("the search's end")) return Finish(result, failures, timer, evaluator);

  // ---- Uncertainty: Laplace approximation. N·MI (nats) is the log-likelihood ratio of the
  // joint against independent intensities (Roche et al. 2000), so the covariance of the
  // correction is (N_eff · (−∇²MI))⁻¹ with N_eff the distinct LiDAR points seen at the level
  // of the fit.
  const int covariance_level = std::min(options.covariance_level, levels - 1);
  // Correlated pixels are not independent samples: N_eff from Bartlett's inflation factor,
  // never more than the distinct points seen.
  const double visible_points =
      static_cast<double>(evaluator.VisiblePoints(result.cam_from_lidar, covariance_level));
  double n_eff = visible_points;
  if (options.effective_sample_max_lag > 0) {
    n_eff = std::min(n_eff, evaluator.EffectiveSamples(result.cam_from_lidar, covariance_level,
                                                       options.effective_sample_max_lag,
                                                       &checks.sample_inflation));
  }
  checks.effective_samples = n_eff;
  int hessian_evaluations = 0;
  // The fit's samples: the visibility at the optimum (the fit spans ±0.08 m / ±0.4°); one
  // weighted sample per visible point (options.covariance_per_point_samples: the searches'
  // samples, the same histogram weights) or one per covered pixel (the rendered histogram's).
  FrameSetEvaluator::SampleSet covariance_samples;
  if (evaluator.UsesSamples(options.metric)) {
    covariance_samples = evaluator.MakeSampleSet(result.cam_from_lidar, covariance_level,
                                                 options.covariance_per_point_samples);
  }
  const Eigen::Matrix<double, 6, 6> hessian =
      MiHessian(evaluator, cam_from_lidar_start, x, options.metric, covariance_level,
                &covariance_samples, options.threads, &hessian_evaluations);
  const Eigen::Matrix<double, 6, 6> information = -n_eff * hessian;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(information);
  const double min_eigen = eigen.eigenvalues().minCoeff();
  const double max_eigen = eigen.eigenvalues().maxCoeff();
  if (max_eigen > 0) {
    // Directions the curvature does not determine (no positive curvature, or less
    // information than the search box itself holds) get the variance of a uniform
    // distribution over the box: the only knowledge left. If they move pixels, the σ check
    // below fails.
    Eigen::Matrix<double, 6, 6> box_variance = Eigen::Matrix<double, 6, 6>::Zero();
    for (int i = 0; i < 6; ++i) box_variance(i, i) = bound[i] * bound[i] / 3.0;
    const Eigen::Matrix<double, 6, 6>& v = eigen.eigenvectors();
    for (int k = 0; k < 6; ++k) {
      const Vector6d direction = v.col(k);
      const double box = direction.dot(box_variance * direction);
      double lambda = eigen.eigenvalues()[k];
      if (!(lambda > 0 && 1.0 / lambda < box)) {
        // The 28-term fit is noisiest in its weakest direction: measure the curvature along
        // that one direction alone, a parabola fitted to 13 samples over ±0.3 units.
        lambda = -n_eff * CurvatureAlong(evaluator, cam_from_lidar_start, x, direction,
                                         options.metric, covariance_level,
                                         &covariance_samples, options.threads,
                                         &hessian_evaluations);
      }
      double variance;
      if (lambda > 0 && 1.0 / lambda < box) {
        variance = 1.0 / lambda;
      } else {
        variance = box;
        ++checks.weak_directions;
      }
      result.covariance += variance * direction * direction.transpose();
    }
    result.covariance_valid = true;
  }
  {
    std::ostringstream diag;
    diag << "MI Hessian (nats/unit^2) diagonal " << hessian.diagonal().transpose()
         << "; information eigenvalues " << eigen.eigenvalues().transpose() << "; N_eff "
         << n_eff << " at level " << covariance_level << "; weakest direction "
         << eigen.eigenvectors().col(0).transpose();
    spdlog::debug("{}", diag.str());
  }
  clock.Mark("covariance", hessian_evaluations + 1);

  // (1) Predicted pixel σ: is the maximum well conditioned at the accuracy asked for? (The
  // check itself is made after the split below, on the calibrated covariance.)
  const std::vector<FrameSetEvaluator::VisiblePoint> sample =
      evaluator.SampleVisiblePoints(result.cam_from_lidar, 2000);
  result.covariance_laplace = result.covariance;
  double predicted_ms = 0;  // mean over the sample of trace(J Σ_L Jᵀ), px²
  // The sample's pixel Jacobians at the optimum (also the covariance's pixel floor, below).
  std::vector<Eigen::Matrix<double, 2, 6>> sample_jacobians;
  if (!result.covariance_valid) {
    failures.push_back("no maximum: the metric's curvature is not negative in any direction "
                       "(information eigenvalues " + Fixed(min_eigen, 1) + " .. " +
                       Fixed(max_eigen, 1) + ")");
  } else {
    sample_jacobians = PixelJacobians(evaluator, cam_from_lidar_start, x, sample);
    std::vector<double> sigmas = PredictedPixelVariances(sample_jacobians, result.covariance);
    for (double v : sigmas) predicted_ms += v / sigmas.size();
    for (double& v : sigmas) v = std::sqrt(v);
    checks.sigma_px = Median(sigmas);
  }
  // The σ check (conditioning: does the curvature determine the pose to the accuracy
  // asked?) on the Laplace covariance; made here when the checks stop at the first failure,
  // after the halves when every check is measured (the order of the reasons as before).
  const bool sigma_failed = result.covariance_valid && !(checks.sigma_px <= options.max_sigma_px);
  const std::string sigma_failure =
      "pose not determined to the accuracy asked: predicted pixel sigma " +
      Fixed(checks.sigma_px, 2) + " px > " + Fixed(options.max_sigma_px, 2) + " px (" +
      std::to_string(checks.weak_directions) + " of 6 directions without curvature)";
  if (fail_fast && sigma_failed) failures.push_back(sigma_failure);
  if (decided("the covariance")) return Finish(result, failures, timer, evaluator);
  // The same over the whole image when the views are cuts of it.
  const std::vector<ImagePoint> image_sample =
      SampleImagePoints(frames, result.cam_from_lidar, options.render, 2000);
  double image_predicted_ms = 0;  // mean over the image sample of trace(J Σ_L Jᵀ), px²
  double image_factor_halves = std::numeric_limits<double>::quiet_NaN();
  double image_factor_restarts = std::numeric_limits<double>::quiet_NaN();
  if (!image_sample.empty() && result.covariance_valid) {
    const std::vector<double> variances =
        ImagePredictedVariances(image_sample, cam_from_lidar_start, x, result.covariance);
    image_predicted_ms = MeanOf(variances);
    checks.image_sigma_px = MedianSqrtOf(variances);
  }
  // (2) Significance of the MI against the shuffled-pairing baseline (same samples, photo
  // values permuted: what MI a pose without any relation to the photo would show).
  {
    std::vector<double> shuffled;
    evaluator.EvaluateShuffled(result.cam_from_lidar, 0, options.shuffles, &checks.mi_bits,
                               &shuffled);
    double mean = 0, var = 0;
    for (double v : shuffled) mean += v;
    mean /= shuffled.size();
    for (double v : shuffled) var += (v - mean) * (v - mean);
    checks.mi_shuffled_bits = mean;
    checks.mi_shuffled_sd_bits = std::sqrt(var / (shuffled.size() - 1));
    const double gain = checks.mi_bits - mean;
    checks.mi_significance = gain / std::max(checks.mi_shuffled_sd_bits, 1e-9);
    if (!(gain >= options.min_mi_gain_bits) ||
        !(checks.mi_significance >= options.min_mi_significance)) {
      failures.push_back("MI not significant: " + Fixed(checks.mi_bits, 4) + " bits vs " +
                         Fixed(mean, 4) + " +- " + Fixed(checks.mi_shuffled_sd_bits, 4) +
                         " bits with shuffled pairings");
    }
    clock.Mark("shuffled baseline", 1);
  }
  if (decided("the shuffled baseline")) return Finish(result, failures, timer, evaluator);
  // (3) Restarts: the fine levels re-optimised from points around the optimum must come back
  // to it (a clear maximum draws them back; a plateau or a ridge leaves them elsewhere).
  {
    const Vector6d offset = RestartStep(options);
    const int restart_level = std::min(options.restart_level, levels - 1);
    // The restarts stop where the main run stopped: at its finest tolerance.
    const double tolerance =
        options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
    int evaluations = 0;
    checks.restart_spread_px = 0;
    checks.restart_best_gain = -std::numeric_limits<double>::infinity();
    const std::vector<Vector6d> starts = RestartOffsets(options);
    double restart_displacement2 = 0;
    size_t restart_displacement_count = 0;
    std::vector<SearchResult> restarts(options.restarts);
    std::vector<double> restart_values(options.restarts);
    const RegistrationOptions restart_options = RestartOptions(options);
    std::vector<double> restart_distances(options.restarts, 0.0);
    // Stopping at the first failure: a restart is not started once one before it (in index
    // order) is known to have ended too far; only the restarts up to the first that did are
    // reported, so the result does not depend on which thread finished first.
    std::atomic<int> first_far{options.restarts};
    std::vector<char> restart_run(options.restarts, 0);
    // The polish's last round ran these very restarts from this optimum (the same starts,
    // level, tolerance and options): their ends are taken, not searched again.
    const bool polished = polish.ends.size() == static_cast<size_t>(options.restarts);
    auto run_restart = [&](int k) {
      if (fail_fast && first_far.load() < k) return;
      if (polished) {
        restarts[k] = polish.ends[k];
        restart_values[k] = polish.values[k];
      } else {
        const Vector6d x0 = (x + starts[k]).cwiseMax(-bound).cwiseMin(bound);
        restarts[k] = Search(evaluator, cam_from_lidar_start, x0, restart_level, restart_level,
                             2.0 * offset, tolerance, false, restart_options, nullptr,
                             "restart " + std::to_string(k) + " ", &x);
        restart_values[k] =
            evaluator.Evaluate(ApplyCorrection(cam_from_lidar_start, restarts[k].x), 0).value;
      }
      restart_distances[k] = evaluator.MedianPixelDistance(
          sample, result.cam_from_lidar, ApplyCorrection(cam_from_lidar_start, restarts[k].x));
      restart_run[k] = 1;
      if (!(restart_distances[k] <= options.restart_tolerance_px)) {
        int seen = first_far.load();
        while (k < seen && !first_far.compare_exchange_weak(seen, k)) {
        }
      }
    };
    if (polished) {
      for (int k = 0; k < options.restarts; ++k) run_restart(k);
    } else {
      ParallelFor(options.restarts, options.threads, run_restart);
    }
    // The restarts reported: all, or (stopping at the first failure) those up to the first
    // that ended too far — each of which ran.
    int reported = options.restarts;
    if (fail_fast && first_far.load() < options.restarts) reported = first_far.load() + 1;
    for (int k = 0; k < reported; ++k) {
      // (Only the reported restarts' evaluations are counted: a later one that happened to
      // run on the other thread would make the count depend on the timing.)
      if (!polished) evaluations += restarts[k].evaluations + 1;  // else the polish's
      CHECK(restart_run[k]) << "restart " << k << " reported but not run";
      const Rigid3d pose = ApplyCorrection(cam_from_lidar_start, restarts[k].x);
      const double distance = restart_distances[k];
      const double gain = restart_values[k] - result.metric_after.value;
      checks.restart_spread_px = std::max(checks.restart_spread_px, distance);
      for (double d2 : PixelDisplacements2(evaluator, sample, result.cam_from_lidar, pose)) {
        restart_displacement2 += d2;
        ++restart_displacement_count;
      }
      checks.restart_best_gain = std::max(checks.restart_best_gain, gain);
      ++checks.restarts_run;
      spdlog::debug("MI restart {}: {:.2f} px from the optimum, metric {:+.6f}", k, distance,
                    gain);
    }
    if (!image_sample.empty() && options.restarts > 0) {
      double sum2 = 0;
      size_t count = 0;
      checks.image_restart_spread_px = 0;
      for (int k = 0; k < reported; ++k) {
        const std::vector<double> d2 = ImageDisplacements2(
            image_sample, result.cam_from_lidar,
            ApplyCorrection(cam_from_lidar_start, restarts[k].x));
        checks.image_restart_spread_px =
            std::max(checks.image_restart_spread_px, MedianSqrtOf(d2));
        sum2 += std::accumulate(d2.begin(), d2.end(), 0.0);
        count += d2.size();
      }
      if (count > 0 && image_predicted_ms > 0) {
        image_factor_restarts = sum2 / count / image_predicted_ms;
      }
    }
    if (restart_displacement_count > 0) {
      checks.restart_rms_px = std::sqrt(restart_displacement2 / restart_displacement_count);
      if (predicted_ms > 0) {
        checks.variance_factor_restarts =
            checks.restart_rms_px * checks.restart_rms_px / predicted_ms;
      }
    }
    if (checks.restarts_run > 0 && !(checks.restart_spread_px <= options.restart_tolerance_px)) {
      failures.push_back("restarts disagree: re-optimised from +-(" +
                         Fixed(options.restart_offset_m, 2) + " m, " +
                         Fixed(options.restart_offset_deg, 2) + " deg) around the optimum, one "
                         "ended " + Fixed(checks.restart_spread_px, 2) + " px away (tolerance " +
                         Fixed(options.restart_tolerance_px, 2) + " px)");
    }
    clock.Mark("restarts", evaluations);
  }
  if (decided("the restarts")) return Finish(result, failures, timer, evaluator);
  // (4) Independent halves: does each part of the data put its own points where the joint
  // optimum puts them? And how far apart are they, against the Laplace covariance?
  std::string split_kind;
  const std::array<std::vector<Frame>, 2> halves = SplitIntoHalves(frames, &split_kind);
  if (options.split_check && !halves[0].empty() && !halves[1].empty()) {
    const Vector6d offset = RestartStep(options);
    const double tolerance =
        options.nelder_mead.parameter_tolerance * std::pow(0.5, levels - 1);
    RegistrationOptions half_options = options;
    half_options.point_samples = options.point_samples && options.point_samples_in_checks;
    half_options.pyramid_levels = std::min(options.pyramid_levels, options.split_level + 1);
    const int split_level = std::min(options.split_level, levels - 1);
    std::array<double, 2> distance{}, displacement2{}, predicted2{};
    std::array<int, 2> half_evaluations{};
    std::array<size_t, 2> own_points{};
    std::array<Vector6d, 2> half_x;
    // One half per thread; a half's evaluations split over two threads once the other half
    // is done (CoreFreeForSplit).
    // Stopping at the first failure: the second half is not started once the first is
    // known to disagree, and is not reported when the first disagrees (as the restarts).
    std::atomic<bool> first_far{false};
    std::array<char, 2> half_run{0, 0};
    ParallelFor(2, options.threads, [&](int h) {
      if (fail_fast && h == 1 && first_far.load()) return;
      const FrameSetEvaluator half(halves[h], cam_from_lidar_start, half_options, &evaluator);
      const SearchResult r = Search(half, cam_from_lidar_start, x, split_level, split_level,
                                    2.0 * offset, tolerance, false, half_options, nullptr,
                                    "half " + std::to_string(h) + " ");
      half_x[h] = r.x;
      half_evaluations[h] = r.evaluations;
      const std::vector<FrameSetEvaluator::VisiblePoint> own =
          half.SampleVisiblePoints(result.cam_from_lidar, 2000);
      own_points[h] = own.size();
      const Rigid3d pose = ApplyCorrection(cam_from_lidar_start, r.x);
      distance[h] = half.MedianPixelDistance(own, result.cam_from_lidar, pose);
      for (double d2 : PixelDisplacements2(half, own, result.cam_from_lidar, pose)) {
        displacement2[h] += d2;
      }
      if (result.covariance_valid) {
        const std::vector<Eigen::Matrix<double, 2, 6>> own_jacobians =
            PixelJacobians(half, cam_from_lidar_start, x, own);
        for (double v : PredictedPixelVariances(own_jacobians, result.covariance_laplace)) {
          predicted2[h] += v;
        }
      }
      half_run[h] = 1;
      if (h == 0 && !(distance[0] <= options.split_tolerance_px)) first_far = true;
    });
    const int halves_reported = fail_fast && first_far.load() ? 1 : 2;
    if (halves_reported == 1) {  // the second half, if it ran, is not reported
      distance[1] = 0;
      displacement2[1] = 0;
      predicted2[1] = 0;
    }
    if (!image_sample.empty()) {
      double mean2 = 0;
      checks.image_split_spread_px = 0;
      for (int h = 0; h < halves_reported; ++h) {
        const std::vector<double> d2 =
            ImageDisplacements2(image_sample, result.cam_from_lidar,
                                ApplyCorrection(cam_from_lidar_start, half_x[h]));
        checks.image_split_spread_px = std::max(checks.image_split_spread_px, MedianSqrtOf(d2));
        mean2 += 0.5 * MeanOf(d2);
      }
      if (image_predicted_ms > 0) image_factor_halves = mean2 / image_predicted_ms;
    }
    checks.split_parts = halves_reported;
    checks.split_kind = split_kind;
    checks.split_spread_px = std::max(distance[0], distance[1]);
    if (result.covariance_valid && predicted2[0] + predicted2[1] > 0) {
      checks.variance_factor_halves =
          (displacement2[0] + displacement2[1]) / (predicted2[0] + predicted2[1]);
    }
    for (int h = 0; h < halves_reported; ++h) {
      spdlog::debug("MI half {} ({}): {:.2f} px from the optimum, correction [{:.3f} {:.3f} "
                    "{:.3f} {:.3f} {:.3f} {:.3f}], pixel rms {:.3f} px vs predicted {:.3f} px",
                    h, split_kind, distance[h], half_x[h][0], half_x[h][1], half_x[h][2],
                    half_x[h][3], half_x[h][4], half_x[h][5],
                    std::sqrt(displacement2[h] / std::max<size_t>(1, own_points[h])),
                    std::sqrt(predicted2[h] / std::max<size_t>(1, own_points[h])));
    }
    if (!(checks.split_spread_px <= options.split_tolerance_px)) {
      failures.push_back("independent halves disagree (" + split_kind + "): one re-optimised "
                         "alone puts its own points " + Fixed(checks.split_spread_px, 2) +
                         " px from the joint optimum (tolerance " +
                         Fixed(options.split_tolerance_px, 2) + " px)");
    }
    clock.Mark("independent halves",
               half_evaluations[0] + (halves_reported == 2 ? half_evaluations[1] : 0));
  }
  if (decided("the independent halves")) return Finish(result, failures, timer, evaluator);
  // The σ check (measuring every check: here, as before); then the calibrated covariance
  // that is reported.
  if (result.covariance_valid) {
    if (!fail_fast && sigma_failed) failures.push_back(sigma_failure);
    checks.sigma_px_calibrated = checks.sigma_px;
    // The parts measured (the halves or the restarts may be switched off) add up.
    const bool halves_measured = std::isfinite(checks.variance_factor_halves);
    const bool restarts_measured = std::isfinite(checks.variance_factor_restarts);
    if (options.calibrate_covariance && (halves_measured || restarts_measured)) {
      checks.variance_factor =
          std::max(1.0, (halves_measured ? checks.variance_factor_halves : 0.0) +
                            (restarts_measured ? checks.variance_factor_restarts : 0.0));
      checks.covariance_factor = checks.variance_factor;
      result.covariance = checks.covariance_factor * result.covariance_laplace;
      checks.sigma_px_calibrated = checks.sigma_px * std::sqrt(checks.variance_factor);
      if (!(checks.sigma_px_calibrated <= options.max_calibrated_sigma_px)) {
        failures.push_back("the pose's own error estimate is too large: calibrated pixel sigma " +
                           Fixed(checks.sigma_px_calibrated, 2) + " px > " +
                           Fixed(options.max_calibrated_sigma_px, 2) + " px (the halves and the "
                           "restarts scatter " + Fixed(std::sqrt(checks.variance_factor), 1) +
                           "x more than the curvature predicts)");
      }
    }
  }
  // The calibrated σ over the whole image (the views' cuts of it).
  if (image_predicted_ms > 0) {
    double factor = 0;
    if (std::isfinite(image_factor_halves)) factor += image_factor_halves;
    if (std::isfinite(image_factor_restarts)) factor += image_factor_restarts;
    checks.image_variance_factor = options.calibrate_covariance ? std::max(1.0, factor) : 1.0;
    checks.image_sigma_px_calibrated =
        checks.image_sigma_px * std::sqrt(checks.image_variance_factor);
    // The reported covariance is the pose's, i.e. the whole image's: calibrated so that it
    // is not over-confident over the views' points nor over the whole image (one factor of
    // Σ_L estimated on each set; AcceptanceChecks::covariance_factor).
    if (options.calibrate_covariance && result.covariance_valid &&
        checks.image_variance_factor > checks.covariance_factor) {
      checks.covariance_factor = checks.image_variance_factor;
      result.covariance = checks.covariance_factor * result.covariance_laplace;
    }
    if (options.whole_image_checks &&
        !(checks.image_sigma_px_calibrated <= options.max_calibrated_sigma_px)) {
      failures.push_back("over the whole image the pose's own error estimate is too large: "
                         "calibrated pixel sigma " + Fixed(checks.image_sigma_px_calibrated, 3) +
                         " px > " + Fixed(options.max_calibrated_sigma_px, 2) + " px (restarts " +
                         Fixed(checks.image_restart_spread_px, 2) + " px, halves " +
                         Fixed(checks.image_split_spread_px, 2) + " px apart there)");
    }
  }
  // The reported covariance raised to the pixel-isotropic floor: at least as uncertain in
  // every direction as a pose error that moves the points by the calibrated mean squared
  // pixel distance. The Laplace shape alone is too narrow along the directions the MI
  // surface is sharpest in (bench/RESULTS.md, "MI priors on photos"). No status changes.
  if (options.calibrate_covariance && options.covariance_pixel_floor &&
      result.covariance_valid && predicted_ms > 0) {
    result.covariance = RaiseToPixelFloor(
        result.covariance, sample_jacobians,
        checks.covariance_factor * predicted_ms, &checks.covariance_floor_directions);
  }
  if (decided("the calibrated covariance")) return Finish(result, failures, timer, evaluator);
  // (5) Per-axis scans: flat or multi-peaked surfaces.
  {
    int evaluations = 0;
    const Vector6d weak = options.scan_weak_direction
                              ? WeaklyObservedDirection(sample_jacobians, bound)
                              : Vector6d::Zero();
    checks.scans_passed = CheckConfidence(evaluator, cam_from_lidar_start, x, weak, options,
                                          std::min(1, levels - 1), &checks.scans_reason,
                                          &evaluations);
    if (!checks.scans_passed) failures.push_back(checks.scans_reason);
    clock.Mark("axis scans", evaluations);
  }
  return Finish(result, failures, timer, evaluator);
}

namespace {

RegistrationResult Finish(RegistrationResult& result, const std::vector<std::string>& failures,
                          const Timer& timer, const FrameSetEvaluator& evaluator) {
  const AcceptanceChecks& checks = result.checks;
  result.trusted = failures.empty();
  if (result.trusted) {
    result.confidence_reason =
        "single clear peak: predicted sigma " + Fixed(checks.sigma_px, 2) + " px, " +
        std::to_string(checks.restarts_run) + " restarts within " +
        Fixed(checks.restart_spread_px, 2) + " px, MI " + Fixed(checks.mi_bits, 4) +
        " bits vs shuffled " + Fixed(checks.mi_shuffled_bits, 4) + " bits";
  } else {
    std::string joined;
    for (const std::string& f : failures) joined += (joined.empty() ? "" : "; ") + f;
    result.confidence_reason = joined;
  }
  result.status = result.trusted ? "ok" : "failed";
  result.reason = result.trusted ? "" : result.confidence_reason;
  result.runtime_seconds = timer.ElapsedSeconds();
  spdlog::debug("MI evaluator: render {:.3f} s, histogram {:.3f} s; {} sample sets, {} "
                "evaluations from samples {:.3f} s",
                evaluator.render_seconds(), evaluator.histogram_seconds(),
                evaluator.sample_sets_built(), evaluator.sample_evaluations(),
                evaluator.sample_seconds());
  return result;
}

}  // namespace

RegistrationResult RegisterRig(const std::vector<Frame>& frames,
                               const Rigid3d& cam_from_lidar_start, const RigOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = cam_from_lidar_start;
  result.metric_kind = options.registration.metric.kind;
  std::vector<int> candidates;
  // Screening: each frame alone must carry information about the pose — an optimum inside
  // the search bound and above the start, MI above the shuffled baseline, a metric surface
  // neither flat nor multi-peaked along an axis — but need not determine the pose to the
  // accuracy asked: that is what the frames together are for (a single scan's MI calibration
  // is noisy; Pandey et al., "Automatic extrinsic calibration of vision and lidar by
  // maximizing mutual information", JFR 2015, use many). The frames' agreement then plays the
  // part of the restarts and halves, and the joint registration must pass every check.
  RegistrationOptions frame_options = options.registration;
  frame_options.restarts = options.frame_restarts;
  frame_options.split_check = false;
  frame_options.max_sigma_px = std::numeric_limits<double>::max();
  frame_options.max_calibrated_sigma_px = std::numeric_limits<double>::max();
  for (size_t i = 0; i < frames.size(); ++i) {
    RegistrationResult r = RegisterFrames({frames[i]}, cam_from_lidar_start, frame_options);
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
                " frames carry information alone (a clear optimum inside the bound, MI above "
                "the shuffled baseline); at least " + std::to_string(options.min_frames) + " needed");
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
        const char* unit = k < 3 ? " m" : " deg";
        why = std::string("disagrees with the other frames: ") + ParameterName(k) + " off the " +
              "median by " + Fixed(d[k]) + unit + " (limit " + Fixed(limit) + unit + ")";
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
  result.covariance_laplace = joint.covariance_laplace;
  result.covariance_valid = joint.covariance_valid;
  // The joint registration's acceptance checks and stages are the result's: they decided it.
  result.checks = joint.checks;
  for (const StageStat& stage : joint.stages) result.stages.push_back(stage);
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
    const Eigen::Vector3d a = view_r * (cam_from_lidar_reference * p) + view.view_from_cam_t;
    const double range = a.norm();
    if (range < render.min_range_m || range > render.max_range_m) continue;
    if (!view.camera.IsSpherical() && a.z() <= 0) continue;
    const std::optional<Eigen::Vector2d> xa = view.camera.ImgFromCam(a);
    if (!xa || (*xa)[0] < 0 || (*xa)[1] < 0 || (*xa)[0] >= view.camera.width ||
        (*xa)[1] >= view.camera.height) {
      continue;
    }
    const Eigen::Vector3d b = view_r * (cam_from_lidar_estimate * p) + view.view_from_cam_t;
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
