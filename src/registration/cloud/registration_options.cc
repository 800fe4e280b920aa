// The options and the result of the cloud registration: names, Check(), reports
// (include/mmba/registration/cloud/feature_registration.h).

#include "mmba/registration/cloud/feature_registration.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace mmba::registration {

bool ParseDescriptor(const std::string& name, Descriptor* descriptor) {
  if (name == "fpfh") *descriptor = Descriptor::kFpfh;
  else if (name == "shot") *descriptor = Descriptor::kShot;
  else if (name == "si" || name == "spin") *descriptor = Descriptor::kSpinImage;
  else if (name == "sc3d" || name == "3dsc") *descriptor = Descriptor::kShapeContext;
  else if (name == "auto") *descriptor = Descriptor::kAuto;
  else return false;
  return true;
}

bool ParseNormalOrientation(const std::string& name, NormalOrientation* orientation) {
  if (name == "viewpoint") *orientation = NormalOrientation::kViewpoint;
  else if (name == "consistent") *orientation = NormalOrientation::kConsistent;
  else if (name == "consistent-turned") *orientation = NormalOrientation::kConsistentTurned;
  else if (name == "auto") *orientation = NormalOrientation::kAuto;
  else return false;
  return true;
}

std::string DescriptorName(Descriptor descriptor) {
  switch (descriptor) {
    case Descriptor::kFpfh: return "fpfh";
    case Descriptor::kShot: return "shot";
    case Descriptor::kSpinImage: return "si";
    case Descriptor::kShapeContext: return "sc3d";
    case Descriptor::kAuto: return "auto";
  }
  return "?";
}

bool CloudRegistrationOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& field, double value, const std::string& rule) {
    std::ostringstream s;
    s << "option '" << field << "' = " << value << " violates " << rule;
    *error = s.str();
    return false;
  };
  if (!(normal_radius_m >= 0)) return fail("normal_radius_m", normal_radius_m, ">= 0");
  if (!(support_radius_m >= 0)) return fail("support_radius_m", support_radius_m, ">= 0");
  if (normal_radius_m > 0 && support_radius_m > 0 && support_radius_m < normal_radius_m) {
    return fail("support_radius_m", support_radius_m, ">= normal_radius_m");
  }
  if (!(normal_radius_spacing > 0)) return fail("normal_radius_spacing", normal_radius_spacing, "> 0");
  if (!(support_radius_spacing > 0)) return fail("support_radius_spacing", support_radius_spacing, "> 0");
  if (!(keypoint_threshold >= 0 && keypoint_threshold <= 1.0 / 3.0)) {
    return fail("keypoint_threshold", keypoint_threshold, "0 <= F_t <= 1/3");
  }
  if (!(keypoint_grid_spacing > 0)) return fail("keypoint_grid_spacing", keypoint_grid_spacing, "> 0");
  if (min_keypoints < 3) return fail("min_keypoints", min_keypoints, ">= 3");
  if (max_keypoints < min_keypoints) return fail("max_keypoints", max_keypoints, ">= min_keypoints");
  if (max_points_features < 1000) return fail("max_points_features", max_points_features, ">= 1000");
  if (max_points_icp < 1000) return fail("max_points_icp", max_points_icp, ">= 1000");
  if (!(coarse_voxel_spacing >= 1)) return fail("coarse_voxel_spacing", coarse_voxel_spacing, ">= 1");
  if (min_points_coarse < 10) return fail("min_points_coarse", min_points_coarse, ">= 10");
  if (!(larger_cloud_factor >= 1)) return fail("larger_cloud_factor", larger_cloud_factor, ">= 1");
  if (!(isolated_cell_spacing > 0)) return fail("isolated_cell_spacing", isolated_cell_spacing, "> 0");
  if (isolated_min_neighbours < 1) return fail("isolated_min_neighbours", isolated_min_neighbours, ">= 1");
  if (!(isolated_min_fraction >= 0 && isolated_min_fraction <= 1)) {
    return fail("isolated_min_fraction", isolated_min_fraction, "0 <= x <= 1");
  }
  if (!(inlier_sigma > 0)) return fail("inlier_sigma", inlier_sigma, "> 0");
  if (sac_ia_iterations < 1) return fail("sac_ia_iterations", sac_ia_iterations, ">= 1");
  if (sac_ia_draws_per_iteration < 1) {
    return fail("sac_ia_draws_per_iteration", sac_ia_draws_per_iteration, ">= 1");
  }
  if (num_cliques < 1) return fail("num_cliques", num_cliques, ">= 1");
  if (sac_ia_randomness < 1) return fail("sac_ia_randomness", sac_ia_randomness, ">= 1");
  if (!(sac_ia_confidence > 0 && sac_ia_confidence <= 1)) {
    return fail("sac_ia_confidence", sac_ia_confidence, "0 < x <= 1");
  }
  if (!(sac_ia_alternative_ratio > 0 && sac_ia_alternative_ratio <= 1)) {
    return fail("sac_ia_alternative_ratio", sac_ia_alternative_ratio, "0 < x <= 1");
  }
  if (num_hypotheses < 1) return fail("num_hypotheses", num_hypotheses, ">= 1");
  if (!(search_window_m >= 0.0)) return fail("search_window_m", search_window_m, ">= 0");
  if (search_window_m > 0.0 && !(search_window_deg > 0.0 && search_window_deg <= 180.0)) {
    return fail("search_window_deg", search_window_deg, "(0, 180] with a search window");
  }
  if (!(consistency_spacing > 0)) return fail("consistency_spacing", consistency_spacing, "> 0");
  if (max_correspondences < 3) return fail("max_correspondences", max_correspondences, ">= 3");
  if (!(std::abs(up.norm() - 1.0) < 1e-6)) return fail("up (norm)", up.norm(), "a unit vector");
  if (icp_iterations < 1) return fail("icp_iterations", icp_iterations, ">= 1");
  if (!(icp_distance_spacing > 0)) return fail("icp_distance_spacing", icp_distance_spacing, "> 0");
  if (!(icp_plane_distance_spacing > 0)) {
    return fail("icp_plane_distance_spacing", icp_plane_distance_spacing, "> 0");
  }
  if (!(icp_noise_sigmas >= 0)) return fail("icp_noise_sigmas", icp_noise_sigmas, ">= 0");
  if (!(inlier_distance_spacing > 0)) {
    return fail("inlier_distance_spacing", inlier_distance_spacing, "> 0");
  }
  if (!(min_fitness > 0 && min_fitness <= 1)) return fail("min_fitness", min_fitness, "0 < x <= 1");
  if (!(min_normal_agreement >= 0 && min_normal_agreement <= 1)) {
    return fail("min_normal_agreement", min_normal_agreement, "0 <= x <= 1");
  }
  if (!(min_significance >= 0)) return fail("min_significance", min_significance, ">= 0");
  if (num_period_shifts < 0) return fail("num_period_shifts", num_period_shifts, ">= 0");
  if (!(symmetry_cone_deg >= 0 && symmetry_cone_deg <= 90)) {
    return fail("symmetry_cone_deg", symmetry_cone_deg, "0 <= x <= 90");
  }
  if (!(symmetry_cone_step_deg > 0)) {
    return fail("symmetry_cone_step_deg", symmetry_cone_step_deg, "> 0");
  }
  if (!(resolution_t > 0)) return fail("resolution_t", resolution_t, "> 0");
  if (!(max_resolution_spacing > 0)) {
    return fail("max_resolution_spacing", max_resolution_spacing, "> 0");
  }
  if (!(max_weak_motion_resolution_spacing > 0)) {
    return fail("max_weak_motion_resolution_spacing", max_weak_motion_resolution_spacing, "> 0");
  }
  if (!(min_coarse_agreement >= 0 && min_coarse_agreement <= 1)) {
    return fail("min_coarse_agreement", min_coarse_agreement, "0 <= x <= 1");
  }
  if (!(max_ambiguity >= 0 && max_ambiguity <= 1)) {
    return fail("max_ambiguity", max_ambiguity, "0 <= x <= 1");
  }
  if (!(max_violation_ratio >= 0)) return fail("max_violation_ratio", max_violation_ratio, ">= 0");
  if (!(min_fitness_visible > 0 && min_fitness_visible <= 1)) {
    return fail("min_fitness_visible", min_fitness_visible, "0 < x <= 1");
  }
  for (const auto* v : {&source_viewpoints, &target_viewpoints}) {
    for (size_t i = 0; i < v->size(); ++i) {
      if (!(*v)[i].allFinite()) {
        return fail(std::string(v == &source_viewpoints ? "source" : "target") +
                        "_viewpoints[" + std::to_string(i) + "] (a coordinate)",
                    (*v)[i].sum(), "finite");
      }
    }
  }
  return true;
}

double CloudRegistrationResult::total_seconds() const {
  double t = 0.0;
  for (const StageTime& s : runtime) t += s.seconds;
  return t;
}

std::string CloudRegistrationResult::BriefReport() const {
  std::ostringstream s;
  s << std::setprecision(4) << "registration " << status;
  if (!reason.empty()) s << " (" << reason << ")";
  s << ": descriptor " << descriptor << ", fitness " << fitness << ", inlier RMSE "
    << inlier_rmse << " m, normal agreement " << normal_agreement << ", confidence "
    << confidence;
  // How sure the pose is, in the result's own words (the JSON has the full covariance).
  if (std::isfinite(resolution_m) && resolution_m > 0.0) {
    s << ", resolved to " << resolution_m << " m";
  }
  if (std::isfinite(sigma_rms_m) && sigma_rms_m > 0.0) s << " (sigma " << sigma_rms_m << " m RMS)";
  s << ", keypoints " << num_keypoints_source << "/" << num_keypoints_target
    << ", correspondences " << num_correspondences << ", " << total_seconds() << " s";
  return s.str();
}

}  // namespace mmba::registration
