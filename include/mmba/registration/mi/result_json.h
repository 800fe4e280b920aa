#pragma once

// The JSON of an MI registration result, as `mmba register-mi --output OUT.json` writes it
// (README, "register-mi"): shared by the command and by `mmba adjust`, which runs the same
// registration per image and writes one such file per image.

#include <string>

#include <nlohmann/json.hpp>

#include "mmba/geometry/rigid3d.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {

/// The 4×4 matrix as 4 rows of 4 numbers.
nlohmann::json PoseToJson(const Rigid3d& pose);
/// A 4×4 matrix as 16 numbers (row-major) or as four rows of four numbers
/// ([[r00, r01, r02, t0], …], as PoseToJson writes it and numpy's tolist()). False, with `problem` saying what
/// was found, when it is neither.
bool Matrix4FromJson(const nlohmann::json& value, double row_major[16], std::string* problem);
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
