// The context of one run of the cloud registration (registration_context.h).

#include "registration/cloud/registration_context.h"

#include <cmath>

#include "mmba/core/logging.h"

namespace mmba::registration::internal {

RegistrationContext::RegistrationContext(const io::PointCloud& source_in,
                                         const io::PointCloud& target_in,
                                         const CloudRegistrationOptions& options,
                                         const Eigen::Vector3d& source_viewpoint,
                                         const Eigen::Vector3d& target_viewpoint)
    : source_in(source_in),
      target_in(target_in),
      options(options),
      source_viewpoint(source_viewpoint),
      target_viewpoint(target_viewpoint),
      stage_cpu(std::clock()),
      source(&source_in),
      target(&target_in) {}

void RegistrationContext::EndStage(const std::string& name) {
  const std::clock_t now = std::clock();
  result.runtime.push_back({name, stage_timer.ElapsedSeconds(),
                            static_cast<double>(now - stage_cpu) / CLOCKS_PER_SEC});
  if (total_timer.ElapsedSeconds() > 10.0) {
    spdlog::info("registration: {} done ({:.1f} s, {:.1f} s in all)", name,
                 stage_timer.ElapsedSeconds(), total_timer.ElapsedSeconds());
  }
  stage_timer.Restart();
  stage_cpu = now;
}

bool RegistrationContext::Fail(const std::string& reason) {
  result.status = "failed";
  result.reason = reason;
  return false;
}

// A known approximate pose (search window): only poses that move the source's centre by at
// most search_window_m and turn it by at most search_window_deg.
bool RegistrationContext::Inside(const Eigen::Matrix4d& t) const {
  if (!(options.search_window_m > 0.0)) return true;
  const Eigen::Vector3d moved = t.topLeftCorner<3, 3>() * centre + t.topRightCorner<3, 1>() - centre;
  const double angle = Eigen::AngleAxisd(Eigen::Matrix3d(t.topLeftCorner<3, 3>())).angle() * 180.0 / M_PI;
  return moved.norm() <= options.search_window_m && angle <= options.search_window_deg;
}

bool RegistrationContext::Contradicted(const Hypothesis& h) const {
  return visibility && h.violation > options.max_violation_ratio * h.fitness;
}

}  // namespace mmba::registration::internal
