#pragma once

// Private to the problem module: one log line per solver iteration (progress of long solves).

#include <ceres/iteration_callback.h>

#include "mmba/core/logging.h"

namespace mmba::internal {

class LoggingCallback : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    spdlog::info("iteration {:3d}: cost {:.6e}, change {:.3e}, |step| {:.2e}, radius {:.1e}, ratio {:.2f}{}, {:.2f} s",
                 s.iteration, s.cost, s.cost_change, s.step_norm, s.trust_region_radius, s.relative_decrease,
                 s.step_is_successful ? "" : " (rejected)", s.cumulative_time_in_seconds);
    return ceres::SOLVER_CONTINUE;
  }
};

}  // namespace mmba::internal
