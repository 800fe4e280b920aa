#pragma once

// The JSON of an MI registration result, as `mmba register-mi --output OUT.json` writes it
// (docs/commands/register-mi.md): shared by the command and by `mmba adjust`, which runs the same
// registration per image and writes one such file per image.

#include <string>

#include <nlohmann/json.hpp>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io/pose_json.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {

using io::Matrix4FromJson;
using io::PoseToJson;
/// {tx, ty, tz [m], roll, pitch, yaw [deg]}.
nlohmann::json CorrectionToJson(const Vector6d& correction);
/// {mi_bits, nmi, nid, joint_entropy_bits, samples, lidar_samples}.
nlohmann::json MetricToJson(const MetricValue& metric);

/// The result's fields: status, reason, cam_from_lidar (and its start), correction,
/// covariance (calibrated and Laplace), confidence, acceptance checks, stages, metric
/// before/after (`metric_*` in the convention "larger is better" turned back for NID),
/// iterations, evaluations, runtime_seconds.
nlohmann::json ResultToJson(const RegistrationResult& result, const RegistrationOptions& options,
                            const Rigid3d& start);

}  // namespace mmba::registration::mi
