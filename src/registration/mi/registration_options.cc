#include "mmba/registration/mi/mi_registration.h"

#include <string>

namespace mmba::registration::mi {

bool RegistrationOptions::Check(std::string* error) const {
  if (!metric.Check(error) || !render.Check(error)) return false;
  if (!(bound_translation_m > 0) || !(bound_rotation_deg > 0) || bound_rotation_deg > 45) {
    *error = "bounds must be > 0 (rotation <= 45 deg); found " +
             std::to_string(bound_translation_m) + " m, " + std::to_string(bound_rotation_deg) +
             " deg";
    return false;
  }
  if (pyramid_levels < 1 || pyramid_levels > 6) {
    *error = "pyramid_levels " + std::to_string(pyramid_levels) + " must be in 1..6";
    return false;
  }
  if (nelder_mead.max_iterations < 1 || !(nelder_mead.parameter_tolerance > 0) ||
      !(nelder_mead.function_tolerance >= 0) || !(nelder_mead.initial_step.minCoeff() > 0)) {
    *error = "Nelder-Mead settings must be positive (iterations, tolerances, simplex size)";
    return false;
  }
  if (!(max_points_per_pixel > 0)) {
    *error = "max_points_per_pixel must be > 0";
    return false;
  }
  if (sample_block_px < 0 || sample_block_px > 256) {
    *error = "sample_block_px " + std::to_string(sample_block_px) + " must be in 0..256 pixels";
    return false;
  }
  if (effective_sample_max_lag < 0 || effective_sample_max_lag > 64) {
    *error = "effective_sample_max_lag " + std::to_string(effective_sample_max_lag) +
             " must be in 0..64 pixels";
    return false;
  }
  if (covariance_level < 0 || covariance_level > 5) {
    *error = "covariance_level " + std::to_string(covariance_level) +
             " must be in 0..5 (levels beyond the pyramid mean its coarsest)";
    return false;
  }
  if (!(max_sigma_px > 0) || !(restart_tolerance_px > 0) || !(max_calibrated_sigma_px > 0)) {
    *error = "max_sigma_px, restart_tolerance_px and max_calibrated_sigma_px must be > 0 (found " +
             std::to_string(max_sigma_px) + ", " + std::to_string(restart_tolerance_px) + ", " +
             std::to_string(max_calibrated_sigma_px) + ")";
    return false;
  }
  if (finest_nelder_mead_level < 0 || finest_nelder_mead_level > 5) {
    *error = "finest_nelder_mead_level " + std::to_string(finest_nelder_mead_level) +
             " must be in 0..5 (levels beyond the pyramid mean its coarsest)";
    return false;
  }
  if (polish_rounds < 0 || polish_rounds > 3) {
    *error = "polish_rounds " + std::to_string(polish_rounds) + " must be in 0..3";
    return false;
  }
  if (restart_level < 0 || restart_level > 5) {
    *error = "restart_level " + std::to_string(restart_level) +
             " must be in 0..5 (levels beyond the pyramid mean its coarsest)";
    return false;
  }
  if (restarts < 0 || restarts > 32 || !(restart_offset_m > 0) || !(restart_offset_deg > 0)) {
    *error = "restarts must be in 0..32 with offsets > 0 (found " + std::to_string(restarts) +
             ", " + std::to_string(restart_offset_m) + " m, " +
             std::to_string(restart_offset_deg) + " deg)";
    return false;
  }
  if (pyramid_paths < 1 || pyramid_paths > 6) {
    *error = "pyramid_paths " + std::to_string(pyramid_paths) + " must be in 1..6";
    return false;
  }
  if (coarse_starts < 0 || coarse_starts > 256 || coarse_candidates < 1 ||
      coarse_candidates > 32 || !(coarse_start_spread > 0 && coarse_start_spread <= 1)) {
    *error = "coarse_starts must be in 0..256, coarse_candidates in 1..32 and "
             "coarse_start_spread in (0, 1] (found " + std::to_string(coarse_starts) + ", " +
             std::to_string(coarse_candidates) + ", " + std::to_string(coarse_start_spread) + ")";
    return false;
  }
  if (threads < 1 || threads > 256) {
    *error = "threads " + std::to_string(threads) + " must be in 1..256";
    return false;
  }
  if (split_level < 0 || split_level > 5 || !(split_tolerance_px > 0)) {
    *error = "split_level must be in 0..5 and split_tolerance_px > 0 (found " +
             std::to_string(split_level) + ", " + std::to_string(split_tolerance_px) + ")";
    return false;
  }
  if (shuffles < 2 || shuffles > 100) {
    *error = "shuffles " + std::to_string(shuffles) + " must be in 2..100";
    return false;
  }
  return true;
}

}  // namespace mmba::registration::mi
