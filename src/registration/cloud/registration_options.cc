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

namespace {

// Sets *error to "option 'field' = value violates rule"; returns false.
bool Violation(std::string* error, const std::string& field, double value,
               const std::string& rule) {
  std::ostringstream s;
  s << "option '" << field << "' = " << value << " violates " << rule;
  *error = s.str();
  return false;
}

// Normals, descriptors, keypoints, subsampling and the isolated-point filter.
bool CheckFeatureOptions(const CloudRegistrationOptions& o, std::string* error) {
  if (!(o.normal_radius_m >= 0)) return Violation(error, "normal_radius_m", o.normal_radius_m, ">= 0");
  if (!(o.support_radius_m >= 0)) return Violation(error, "support_radius_m", o.support_radius_m, ">= 0");
  if (o.normal_radius_m > 0 && o.support_radius_m > 0 && o.support_radius_m < o.normal_radius_m) {
    return Violation(error, "support_radius_m", o.support_radius_m, ">= normal_radius_m");
  }
  if (!(o.normal_radius_spacing > 0)) return Violation(error, "normal_radius_spacing", o.normal_radius_spacing, "> 0");
  if (!(o.support_radius_spacing > 0)) return Violation(error, "support_radius_spacing", o.support_radius_spacing, "> 0");
  if (!(o.keypoint_threshold >= 0 && o.keypoint_threshold <= 1.0 / 3.0)) {
    return Violation(error, "keypoint_threshold", o.keypoint_threshold, "0 <= F_t <= 1/3");
  }
  if (!(o.keypoint_grid_spacing > 0)) return Violation(error, "keypoint_grid_spacing", o.keypoint_grid_spacing, "> 0");
  if (o.min_keypoints < 3) return Violation(error, "min_keypoints", o.min_keypoints, ">= 3");
  if (o.max_keypoints < o.min_keypoints) return Violation(error, "max_keypoints", o.max_keypoints, ">= min_keypoints");
  if (o.max_points_features < 1000) return Violation(error, "max_points_features", o.max_points_features, ">= 1000");
  if (o.max_points_icp < 1000) return Violation(error, "max_points_icp", o.max_points_icp, ">= 1000");
  if (!(o.coarse_voxel_spacing >= 1)) return Violation(error, "coarse_voxel_spacing", o.coarse_voxel_spacing, ">= 1");
  if (o.min_points_coarse < 10) return Violation(error, "min_points_coarse", o.min_points_coarse, ">= 10");
  if (!(o.larger_cloud_factor >= 1)) return Violation(error, "larger_cloud_factor", o.larger_cloud_factor, ">= 1");
  if (!(o.isolated_cell_spacing > 0)) return Violation(error, "isolated_cell_spacing", o.isolated_cell_spacing, "> 0");
  if (o.isolated_min_neighbours < 1) return Violation(error, "isolated_min_neighbours", o.isolated_min_neighbours, ">= 1");
  if (!(o.isolated_min_fraction >= 0 && o.isolated_min_fraction <= 1)) {
    return Violation(error, "isolated_min_fraction", o.isolated_min_fraction, "0 <= x <= 1");
  }
  return true;
}

// The coarse alignment: SAC-IA, hypotheses, search window, correspondences, up.
bool CheckCoarseOptions(const CloudRegistrationOptions& o, std::string* error) {
  if (!(o.inlier_sigma > 0)) return Violation(error, "inlier_sigma", o.inlier_sigma, "> 0");
  if (o.sac_ia_iterations < 1) return Violation(error, "sac_ia_iterations", o.sac_ia_iterations, ">= 1");
  if (o.sac_ia_draws_per_iteration < 1) {
    return Violation(error, "sac_ia_draws_per_iteration", o.sac_ia_draws_per_iteration, ">= 1");
  }
  if (o.num_cliques < 1) return Violation(error, "num_cliques", o.num_cliques, ">= 1");
  if (o.sac_ia_randomness < 1) return Violation(error, "sac_ia_randomness", o.sac_ia_randomness, ">= 1");
  if (!(o.sac_ia_confidence > 0 && o.sac_ia_confidence <= 1)) {
    return Violation(error, "sac_ia_confidence", o.sac_ia_confidence, "0 < x <= 1");
  }
  if (!(o.sac_ia_alternative_ratio > 0 && o.sac_ia_alternative_ratio <= 1)) {
    return Violation(error, "sac_ia_alternative_ratio", o.sac_ia_alternative_ratio, "0 < x <= 1");
  }
  if (o.num_hypotheses < 1) return Violation(error, "num_hypotheses", o.num_hypotheses, ">= 1");
  if (!(o.search_window_m >= 0.0)) return Violation(error, "search_window_m", o.search_window_m, ">= 0");
  if (o.search_window_m > 0.0 && !(o.search_window_deg > 0.0 && o.search_window_deg <= 180.0)) {
    return Violation(error, "search_window_deg", o.search_window_deg, "(0, 180] with a search window");
  }
  if (!(o.consistency_spacing > 0)) return Violation(error, "consistency_spacing", o.consistency_spacing, "> 0");
  if (o.max_correspondences < 3) return Violation(error, "max_correspondences", o.max_correspondences, ">= 3");
  if (!(std::abs(o.up.norm() - 1.0) < 1e-6)) return Violation(error, "up (norm)", o.up.norm(), "a unit vector");
  return true;
}

// ICP, the acceptance tests, symmetry and resolution.
bool CheckFineOptions(const CloudRegistrationOptions& o, std::string* error) {
  if (o.icp_iterations < 1) return Violation(error, "icp_iterations", o.icp_iterations, ">= 1");
  if (!(o.icp_distance_spacing > 0)) return Violation(error, "icp_distance_spacing", o.icp_distance_spacing, "> 0");
  if (!(o.icp_plane_distance_spacing > 0)) {
    return Violation(error, "icp_plane_distance_spacing", o.icp_plane_distance_spacing, "> 0");
  }
  if (!(o.icp_noise_sigmas >= 0)) return Violation(error, "icp_noise_sigmas", o.icp_noise_sigmas, ">= 0");
  if (!(o.inlier_distance_spacing > 0)) {
    return Violation(error, "inlier_distance_spacing", o.inlier_distance_spacing, "> 0");
  }
  if (!(o.min_fitness > 0 && o.min_fitness <= 1)) return Violation(error, "min_fitness", o.min_fitness, "0 < x <= 1");
  if (!(o.min_normal_agreement >= 0 && o.min_normal_agreement <= 1)) {
    return Violation(error, "min_normal_agreement", o.min_normal_agreement, "0 <= x <= 1");
  }
  if (!(o.min_significance >= 0)) return Violation(error, "min_significance", o.min_significance, ">= 0");
  if (o.num_period_shifts < 0) return Violation(error, "num_period_shifts", o.num_period_shifts, ">= 0");
  if (!(o.symmetry_cone_deg >= 0 && o.symmetry_cone_deg <= 90)) {
    return Violation(error, "symmetry_cone_deg", o.symmetry_cone_deg, "0 <= x <= 90");
  }
  if (!(o.symmetry_cone_step_deg > 0)) {
    return Violation(error, "symmetry_cone_step_deg", o.symmetry_cone_step_deg, "> 0");
  }
  if (!(o.resolution_t > 0)) return Violation(error, "resolution_t", o.resolution_t, "> 0");
  if (!(o.max_resolution_spacing > 0)) {
    return Violation(error, "max_resolution_spacing", o.max_resolution_spacing, "> 0");
  }
  if (!(o.max_weak_motion_resolution_spacing > 0)) {
    return Violation(error, "max_weak_motion_resolution_spacing", o.max_weak_motion_resolution_spacing, "> 0");
  }
  if (!(o.min_coarse_agreement >= 0 && o.min_coarse_agreement <= 1)) {
    return Violation(error, "min_coarse_agreement", o.min_coarse_agreement, "0 <= x <= 1");
  }
  if (!(o.max_ambiguity >= 0 && o.max_ambiguity <= 1)) {
    return Violation(error, "max_ambiguity", o.max_ambiguity, "0 <= x <= 1");
  }
  if (!(o.max_violation_ratio >= 0)) return Violation(error, "max_violation_ratio", o.max_violation_ratio, ">= 0");
  if (!(o.min_fitness_visible > 0 && o.min_fitness_visible <= 1)) {
    return Violation(error, "min_fitness_visible", o.min_fitness_visible, "0 < x <= 1");
  }
  return true;
}

// The given sensor positions: finite coordinates.
bool CheckViewpoints(const CloudRegistrationOptions& o, std::string* error) {
  for (const auto* v : {&o.source_viewpoints, &o.target_viewpoints}) {
    for (size_t i = 0; i < v->size(); ++i) {
      if (!(*v)[i].allFinite()) {
        return Violation(error,
                         std::string(v == &o.source_viewpoints ? "source" : "target") +
                             "_viewpoints[" + std::to_string(i) + "] (a coordinate)",
                         (*v)[i].sum(), "finite");
      }
    }
  }
  return true;
}

}  // namespace

bool CloudRegistrationOptions::Check(std::string* error) const {
  return CheckFeatureOptions(*this, error) && CheckCoarseOptions(*this, error) &&
         CheckFineOptions(*this, error) && CheckViewpoints(*this, error);
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
