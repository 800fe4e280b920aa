#include "mmba/core/progress.h"

#include <utility>

#include "mmba/core/logging.h"

namespace mmba {

Progress::Progress(std::string stage, size_t total, double interval_s)
    : stage_(std::move(stage)),
      total_(total),
      interval_s_(interval_s),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void Progress::Step(size_t n) {
  done_ += n;
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_).count() >= interval_s_) {
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    spdlog::info("{}: {}/{} ({:.0f}%), {:.1f} s", stage_, done_, total_,
                 total_ ? 100.0 * done_ / total_ : 100.0, elapsed);
  }
}

void Progress::Done() {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  spdlog::info("{}: {}/{} done, {:.2f} s", stage_, done_, total_, elapsed);
}

}  // namespace mmba
