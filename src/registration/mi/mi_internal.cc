#include "registration/mi/mi_internal.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <thread>

namespace mmba::registration::mi {

namespace internal {

Vector6d BoundVector(const RegistrationOptions& options) {
  Vector6d bound;
  bound << options.bound_translation_m, options.bound_translation_m, options.bound_translation_m,
      options.bound_rotation_deg, options.bound_rotation_deg, options.bound_rotation_deg;
  return bound;
}

std::string Fixed(double v, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << v;
  return out.str();
}

// One render buffer per thread, reused between evaluations.
LidarImage& ThreadBuffer() {
  thread_local LidarImage buffer;
  return buffer;
}

}  // namespace internal

namespace {

// On the threads of a running ParallelFor (the caller's included): the number of its
// workers still taking items, and how many it started; nullptr outside a loop. An evaluation
// made there splits itself over two threads only when a worker of the loop has run out of
// items (its core is free): e.g. the third of three restarts on two threads, or the longer
// of the two halves. The split does not change the result (fixed partial sums).
thread_local std::atomic<int>* t_loop_busy = nullptr;
thread_local int t_loop_threads = 0;

}  // namespace

namespace internal {

bool CoreFreeForSplit() {
  return t_loop_busy == nullptr || t_loop_busy->load() < t_loop_threads;
}

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

double MeanOf(const std::vector<double>& values) {
  return values.empty() ? 0.0
                        : std::accumulate(values.begin(), values.end(), 0.0) / values.size();
}

double MedianSqrtOf(std::vector<double> squares) {
  for (double& v : squares) v = std::sqrt(v);
  return Median(std::move(squares));
}

}  // namespace internal

}  // namespace mmba::registration::mi
