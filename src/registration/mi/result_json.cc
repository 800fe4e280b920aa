#include "mmba/registration/mi/result_json.h"

#include <algorithm>
#include <cmath>

#include "mmba/io/pose_json.h"

namespace mmba::registration::mi {

using json = nlohmann::json;

json CorrectionToJson(const Vector6d& c) {
  return {{"tx", c[0]}, {"ty", c[1]}, {"tz", c[2]}, {"roll", c[3]}, {"pitch", c[4]}, {"yaw", c[5]}};
}

json MetricToJson(const MetricValue& m) {
  return {{"mi_bits", m.mi},
          {"nmi", m.nmi},
          {"nid", m.nid},
          {"joint_entropy_bits", m.joint_entropy},
          {"samples", m.samples},
          {"lidar_samples", m.lidar_samples}};
}

namespace {

json MatrixJson(const Eigen::Matrix<double, 6, 6>& m) {
  json rows = json::array();
  for (int r = 0; r < 6; ++r) {
    json row = json::array();
    for (int c = 0; c < 6; ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

json ResultToJson(const RegistrationResult& result, const RegistrationOptions& options, const Rigid3d& start) {
  json out;
  out["status"] = result.status;
  out["reason"] = result.reason;
  // A failed registration gives no pose: null, as register-cloud's target_from_source. Where
  // its search ended is kept apart, for diagnosis only (null when no search ran).
  out["cam_from_lidar"] = result.ok() ? io::PoseToJson(result.cam_from_lidar) : json(nullptr);
  out["failed_attempt_cam_from_lidar"] =
      !result.ok() && result.evaluations > 0 ? io::PoseToJson(result.cam_from_lidar) : json(nullptr);
  out["cam_from_lidar_start"] = io::PoseToJson(start);
  // Likewise the correction and its covariance: a failed file holds no pose, in any form.
  out["correction"] = result.ok() ? CorrectionToJson(result.correction) : json(nullptr);
  out["failed_attempt_correction"] =
      !result.ok() && result.evaluations > 0 ? CorrectionToJson(result.correction) : json(nullptr);
  out["correction_convention"] =
      "lidar_from_cam' = [Rz(yaw) Ry(pitch) Rx(roll) R | c + t] about the camera centre, "
      "axes of the LiDAR frame; metres and degrees";
  // null when not determined (a registration that failed before the covariance, or one
  // without curvature): an all-zero matrix would read as a perfectly known pose.
  // A failed registration's covariance would describe a pose the file does not give: null too.
  const bool covariance_written = result.ok() && result.covariance_valid;
  out["covariance"] = covariance_written ? MatrixJson(result.covariance) : json(nullptr);
  const bool laplace_computed = result.covariance_laplace.allFinite() && !result.covariance_laplace.isZero(0);
  out["covariance_laplace"] = result.ok() && laplace_computed ? MatrixJson(result.covariance_laplace) : json(nullptr);
  out["covariance_units"] = "m^2, deg^2 in the order tx ty tz roll pitch yaw";
  out["covariance_valid"] = covariance_written;
  out["trusted"] = result.trusted;
  out["confidence_reason"] = result.confidence_reason;
  const AcceptanceChecks& checks = result.checks;
  // A check that did not run (the registration failed before it, or the acceptance stopped
  // at an earlier failure) is null: 0 restarts or 0 weak directions would read as measured.
  auto ran = [&result](const std::string& stage) {
    return std::any_of(result.stages.begin(), result.stages.end(),
                       [&stage](const StageStat& s) { return s.name == stage; });
  };
  auto count_if_ran = [&ran](const std::string& stage, int count) {
    return ran(stage) ? json(count) : json(nullptr);
  };
  // Pixel distances, σ and the image's variance factor are -1 until measured.
  auto pixels = [](double px) { return px >= 0 && std::isfinite(px) ? json(px) : json(nullptr); };
  out["checks"] = {{"on_bound", checks.on_bound},
                   {"below_start", checks.below_start},
                   {"sigma_px", pixels(checks.sigma_px)},
                   {"max_sigma_px", options.max_sigma_px},
                   {"max_calibrated_sigma_px", options.max_calibrated_sigma_px},
                   {"weak_directions", count_if_ran("covariance", checks.weak_directions)},
                   {"effective_samples", checks.effective_samples},
                   {"sample_inflation", checks.sample_inflation},
                   {"restarts", count_if_ran("restarts", checks.restarts_run)},
                   {"restart_spread_px", pixels(checks.restart_spread_px)},
                   {"restart_tolerance_px", options.restart_tolerance_px},
                   {"restart_best_gain", checks.restart_best_gain},
                   {"mi_bits", checks.mi_bits},
                   {"mi_shuffled_bits", checks.mi_shuffled_bits},
                   {"mi_shuffled_sd_bits", checks.mi_shuffled_sd_bits},
                   {"mi_significance", checks.mi_significance},
                   {"restart_rms_px", pixels(checks.restart_rms_px)},
                   {"halves", checks.split_parts},
                   {"halves_kind", checks.split_kind},
                   {"halves_spread_px", pixels(checks.split_spread_px)},
                   {"halves_tolerance_px", options.split_tolerance_px},
                   {"variance_factor", checks.variance_factor},
                   {"variance_factor_halves", checks.variance_factor_halves},
                   {"variance_factor_restarts", checks.variance_factor_restarts},
                   {"sigma_px_calibrated", pixels(checks.sigma_px_calibrated)},
                   {"image_sigma_px", pixels(checks.image_sigma_px)},
                   {"image_restart_spread_px", pixels(checks.image_restart_spread_px)},
                   {"image_halves_spread_px", pixels(checks.image_split_spread_px)},
                   {"image_variance_factor", pixels(checks.image_variance_factor)},
                   {"image_sigma_px_calibrated", pixels(checks.image_sigma_px_calibrated)},
                   {"covariance_factor", checks.covariance_factor},
                   {"covariance_floor_directions", checks.covariance_floor_directions},
                   // null: not measured (the checks stopped before the scans)
                   {"axis_scans_passed", checks.scans_passed || !checks.scans_reason.empty()
                                             ? json(checks.scans_passed)
                                             : json(nullptr)},
                   {"axis_scans_reason", checks.scans_reason},
                   {"stopped_after", checks.stopped_after}};
  json stages = json::array();
  for (const StageStat& stage : result.stages) {
    stages.push_back({{"stage", stage.name},
                      {"evaluations", stage.evaluations},
                      {"seconds", stage.seconds},
                      {"cpu_seconds", stage.cpu_seconds}});
  }
  out["stages"] = stages;
  out["metric_before"] = ReportedMetric(options.metric.kind, result.metric_before.value);
  out["metric_after"] = ReportedMetric(options.metric.kind, result.metric_after.value);
  out["metrics_before"] = MetricToJson(result.metric_before);
  out["metrics_after"] = MetricToJson(result.metric_after);
  out["iterations"] = result.iterations;
  out["evaluations"] = result.evaluations;
  out["runtime_seconds"] = result.runtime_seconds;
  if (result.edge_term) {
    out["edges"] = {{"depth_points", result.edge_points},
                    {"intensity_points", result.edge_intensity_points},
                    {"score_before", result.edge_score_before},
                    {"score_after", result.edge_score_after},
                    {"grid_peakedness_edges", result.edge_peakedness},
                    {"grid_peakedness_mi", result.mi_peakedness},
                    {"mi_weight", result.edge_mi_weight},
                    {"sigma_deg", result.sigma_deg},
                    {"sigma_m", result.sigma_m}};
  }
  return out;
}

}  // namespace mmba::registration::mi
