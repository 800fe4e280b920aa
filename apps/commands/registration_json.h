#pragma once
// JSON of a cloud registration result, shared by register-cloud and register-eval.

#include <cmath>

#include <nlohmann/json.hpp>

#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::app {

inline nlohmann::json MatrixJson(const Eigen::Matrix4d& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

// A number, or null when not finite (JSON has no infinity).
inline nlohmann::ordered_json FiniteOrNull(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

inline nlohmann::ordered_json VectorJson(const Eigen::Vector3d& v) {
  return {FiniteOrNull(v.x()), FiniteOrNull(v.y()), FiniteOrNull(v.z())};
}

// A registration's transform: the matrix when it is ok, null when it failed (a failed file
// holds no transform a reader could take for the answer).
inline nlohmann::ordered_json TransformIfOk(bool ok, const Eigen::Matrix4d& m) {
  return ok ? nlohmann::ordered_json(MatrixJson(m)) : nlohmann::ordered_json(nullptr);
}

// A failed registration's best attempt, for diagnosis only (null when ok or never attempted).
inline nlohmann::ordered_json FailedAttempt(bool ok, bool attempted, const Eigen::Matrix4d& m) {
  return !ok && attempted ? nlohmann::ordered_json(MatrixJson(m)) : nlohmann::ordered_json(nullptr);
}

// A value, or null when `valid` is false.
inline nlohmann::ordered_json ValueIf(bool valid, double v) {
  return valid ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

// Seconds per stage (wall or CPU, by `seconds`) and their "total".
inline nlohmann::ordered_json StageSecondsJson(
    const std::vector<registration::StageTime>& runtime,
    double registration::StageTime::*seconds) {
  nlohmann::ordered_json json = nlohmann::ordered_json::object();
  double total = 0.0;
  for (const auto& stage : runtime) {
    json[stage.stage] = stage.*seconds;
    total += stage.*seconds;
  }
  json["total"] = total;
  return json;
}

inline nlohmann::ordered_json HypothesesJson(const registration::CloudRegistrationResult& result) {
  nlohmann::ordered_json hypotheses = nlohmann::ordered_json::array();
  for (const auto& h : result.hypotheses) {
    hypotheses.push_back({{"origin", h.origin},
                          {"fitness", h.fitness},
                          {"inlier_rmse", h.inlier_rmse},
                          {"normal_agreement", h.normal_agreement},
                          {"score", h.score},
                          {"conflict", h.conflict},
                          {"violation", h.violation},
                          {"intensity_correlation",
                           ValueIf(h.intensity_correlation >= 0, h.intensity_correlation)},
                          {"target_from_source", MatrixJson(h.target_from_source)}});
  }
  return hypotheses;
}

// The 6×6 covariance as rows, null when not finite.
inline nlohmann::ordered_json CovarianceJson(const Eigen::Matrix<double, 6, 6>& covariance) {
  if (!covariance.allFinite()) return nlohmann::ordered_json(nullptr);
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (int r = 0; r < 6; ++r) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (int c = 0; c < 6; ++c) row.push_back(covariance(r, c));
    rows.push_back(row);
  }
  return rows;
}

inline nlohmann::ordered_json RegistrationJson(const registration::CloudRegistrationResult& result) {
  using registration::StageTime;
  return {{"status", result.status},
          {"reason", result.reason},
          {"descriptor", result.descriptor},
          {"target_from_source", TransformIfOk(result.ok(), result.target_from_source)},
          {"failed_attempt_target_from_source",
           FailedAttempt(result.ok(), !result.hypotheses.empty(), result.target_from_source)},
          {"fitness", result.fitness},
          {"inlier_rmse", result.inlier_rmse},
          {"normal_agreement", result.normal_agreement},
          {"confidence", result.confidence},
          // null when no distinct runner-up was left (JSON has no infinity)
          {"significance", FiniteOrNull(result.significance)},
          {"conflict", result.conflict},
          // the free-space test (sensor positions given): fraction of the source in space a
          // sensor observed as empty
          {"visibility_tested", result.visibility_tested},
          {"violation", result.violation},
          // the intensity test (a geometric tie, both clouds with intensity or colour): the
          // chosen pose's |rank correlation| of source and target brightness over its inliers,
          // and the intensity t against the runner-up behind `significance`
          {"intensity_tested", result.intensity_tested},
          {"intensity_correlation", ValueIf(result.intensity_tested, result.intensity_correlation)},
          {"intensity_significance",
           ValueIf(result.intensity_tested, result.intensity_significance)},
          {"fine_inlier_distance_m", result.fine_inlier_distance_m},
          // null when the pose is not resolved up to R_s (or not tested: --paper)
          {"resolution_m", FiniteOrNull(result.resolution_m)},
          {"weak_motion_resolution_m", FiniteOrNull(result.weak_motion_resolution_m)},
          {"fine_spacing_m", result.fine_spacing_m},
          // uncertainty of the fine fit (see feature_registration.h): covariance of
          // (rx, ry, rz [rad], tx, ty, tz [m]), a correction about covariance_centre in the
          // target frame; null when the inliers leave a motion free
          {"covariance", CovarianceJson(result.covariance)},
          {"covariance_centre", VectorJson(result.covariance_centre)},
          {"sigma_translation_m", VectorJson(result.sigma_translation_m)},
          {"sigma_rotation_deg", VectorJson(result.sigma_rotation_deg)},
          {"sigma_rms_m", FiniteOrNull(result.sigma_rms_m)},
          {"gate_sensitivity_m", result.gate_sensitivity_m},
          {"constraint_ratio", result.constraint_ratio},
          {"weakest_motion", result.weakest_motion},
          {"num_keypoints", {{"source", result.num_keypoints_source},
                             {"target", result.num_keypoints_target}}},
          {"num_correspondences", result.num_correspondences},
          {"num_inliers", result.num_inliers},
          {"point_spacing_m", result.point_spacing_m},
          {"blunders_removed", {{"source", result.blunders_removed_source},
                                {"target", result.blunders_removed_target}}},
          {"normal_radius_m", result.normal_radius_m},
          {"support_radius_m", result.support_radius_m},
          {"runtime_seconds", StageSecondsJson(result.runtime, &StageTime::seconds)},
          // process CPU time per stage (all threads)
          {"cpu_seconds", StageSecondsJson(result.runtime, &StageTime::cpu_seconds)},
          {"hypotheses", HypothesesJson(result)},
          {"notes", result.notes}};
}

}  // namespace mmba::app
