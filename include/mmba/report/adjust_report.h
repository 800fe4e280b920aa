#pragma once

// report.html of `mmba adjust`: the page a surveyor sends a client.
//
// Input: the report JSON, schema "mmba-adjust-report-1" (lengths in metres, angles in
// degrees, coordinates in the local ENU frame of the project's origin):
//
//   schema          string, "mmba-adjust-report-1"                                  REQUIRED
//   project         string                                                          REQUIRED
//   status          "converged" | "failed" | "no_convergence"                       REQUIRED
//   sigma0          object: apriori, aposteriori, dof, confidence, chi2_lower,      REQUIRED
//                   chi2_upper (bounds of aposteriori/apriori, two-sided χ² test),
//                   passed (bool; computed from the bounds when absent)
//   groups          array (may be empty) of {name (required), unit, observations,   REQUIRED
//                   residuals, rms, mean, max, sigma, loss, outliers,
//                   variance_component, redundancy, whitened[],
//                   whitened_kind ("components" | "norms"), whitened_dof}
//   generated_utc, reason, frame, utm_zone: strings
//   origin {latitude_deg, longitude_deg, height_m}
//   solver {iterations, outer_iterations, initial_cost, final_cost, seconds}
//   control_points [{id, role "control"|"check", surveyed[3], adjusted[3], d[3], sigma[3],
//                    ellipse {a, b, azimuth_deg (of a, from north towards east),
//                    confidence (optional: the ellipse's probability; absent = 1σ)}}]
//   check_summary {count, rmse[3], rmse_3d, expected_rmse_3d}
//   blunders [{group, observation, studentized, whitened, downweighted}]
//   pose_corrections [{image, sensor, d[3], d_position_m, d_rotation_deg}]
//   calibrations [{name, parameters [{name, initial, adjusted, sigma}]}]
//   files [{name, description}],  warnings [string]
//
// Every optional field may be absent; a number may be null (NaN), shown as "—". Whitened
// residuals: "components" are drawn against N(0,1); "norms" (|r|/σ of a k-vector, k =
// whitened_dof, else residuals/observations when that is a whole number, else 1) against
// the χ distribution with k dof. Without whitened_kind, values with a negative one are
// components, all non-negative ones norms.

#include <string>

#include <nlohmann/json.hpp>

namespace mmba::report {

/// The schema string RenderAdjustReportHtml accepts.
inline constexpr const char* kAdjustReportSchema = "mmba-adjust-report-1";

/// Renders the report page from the report JSON (schema above). Self-contained HTML: inline
/// CSS, inline SVG plots (no JavaScript, no network), printable on A4. Missing optional
/// sections are omitted; every string of the JSON is HTML-escaped.
/// Throws std::invalid_argument naming the JSON field (e.g. "groups[2].rms"), the value found
/// and the type expected when a required field is missing or any present field is mistyped.
std::string RenderAdjustReportHtml(const nlohmann::json& report);

}  // namespace mmba::report
