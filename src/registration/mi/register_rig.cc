#include "mmba/registration/mi/mi_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "registration/mi/mi_internal.h"

namespace mmba::registration::mi {

using internal::Fixed;

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

}  // namespace mmba::registration::mi
