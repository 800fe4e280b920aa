#pragma once

// The JSON of an MI registration result, as `mmba register-mi --output OUT.json` writes it
// (docs/commands/register-mi.md): shared by the command and by `mmba adjust`, which runs the same
// registration per image and writes one such file per image.

#include <string>

#include <nlohmann/json.hpp>

#include "mmba/geometry/rigid3d.h"
#include "mmba/registration/mi/job.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {

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

/// OUT.json of `mmba register-mi` for a prepared job: ResultToJson of `result` (its poses in
/// the clouds' own frame, as RegisterJob gives them), the settings as the request set them and
/// the job resolved them, the clouds and their incidence fits; with a rig the pose named
/// rig_from_lidar and each camera's cam_from_lidar; with several frames each frame's status and
/// screening; with a perturbation (or a start from `request.initial` where the calibration
/// holds a pose) the pixel offsets of the first frame's views against the unperturbed (the
/// calibration's) pose, at the start and at `cam_from_local` (the result about the job's origin).
nlohmann::json JobResultToJson(const JobRequest& request, const Job& job, const RegistrationResult& result,
                               const Rigid3d& cam_from_local);

}  // namespace mmba::registration::mi
