#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace mmba {

/// Progress of a long loop, reported through the logger at most every `interval_s`
/// seconds (and at the end): "stage: 1200/5000 (24%), 3.1 s".
class Progress {
 public:
  Progress(std::string stage, size_t total, double interval_s = 1.0);
  /// Advances by `n` items; logs if the interval has elapsed.
  void Step(size_t n = 1);
  /// Logs the final line.
  void Done();

 private:
  std::string stage_;
  size_t total_;
  size_t done_ = 0;
  double interval_s_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_;
};

/// Wall-clock stopwatch.
class Timer {
 public:
  Timer() : start_(std::chrono::steady_clock::now()) {}
  double ElapsedSeconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  void Restart() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace mmba
