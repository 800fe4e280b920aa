#include "mmba/registration/cloud/registration_settings.h"

namespace mmba::registration {

using Options = CloudRegistrationOptions;

// The tunable settings of CloudRegistrationOptions, ranges as its comments state them. The
// radii in metres, the descriptor, gravity, the search window and the normal orientation
// have options of their own.
const SettingsTable<CloudRegistrationOptions>& CloudRegistrationSettingsTable() {
  static const SettingsTable<Options> table = SettingsTable<Options>("mmba register-cloud --help lists them")
      .Number("normal_radius_spacing", &Options::normal_radius_spacing, SettingRange::Above(0),
            "R_n in point spacings when --normal-radius is not given")
      .Number("support_radius_spacing", &Options::support_radius_spacing, SettingRange::Above(0),
            "R_s in point spacings when --support-radius is not given")
      .Number("keypoint_threshold", &Options::keypoint_threshold, SettingRange::Closed(0, 1.0 / 3.0).Described("0..1/3"),
            "F_t: smallest eigenvalue of the normals' covariance for a 3D Kanade-Tomasi keypoint (paper 0.1)")
      .Number("keypoint_grid_spacing", &Options::keypoint_grid_spacing, SettingRange::Above(0),
            "keypoint grid cell in units of R_n: the strongest keypoint per cell")
      .Integer("min_keypoints", &Options::min_keypoints, SettingRange::AtLeast(3),
            "below this F_t is lowered, then uniform grid points are used")
      .Integer("max_keypoints", &Options::max_keypoints, SettingRange::AtLeast(3),
            "above this the keypoint grid is coarsened (>= min_keypoints)")
      .Number("coarse_voxel_spacing", &Options::coarse_voxel_spacing, SettingRange::AtLeast(1),
            "feature level: voxel of at least this many point spacings")
      .Integer("min_points_coarse", &Options::min_points_coarse, SettingRange::AtLeast(10),
            "feature level keeps at least this many points of the smaller cloud")
      .Integer("max_points_features", &Options::max_points_features, SettingRange::AtLeast(1000),
            "feature level: the voxel grows until the smaller cloud has at most this many points")
      .Number("larger_cloud_factor", &Options::larger_cloud_factor, SettingRange::AtLeast(1),
            "the larger cloud may keep this many times as many feature-level points")
      .Integer("max_points_icp", &Options::max_points_icp, SettingRange::AtLeast(1000),
            "fine level points for ICP")
      .Flag("use_existing_normals", &Options::use_existing_normals,
            "use normals stored in the clouds")
      .Flag("remove_blunders", &Options::remove_blunders,
            "remove scattered isolated points first")
      .Number("isolated_cell_spacing", &Options::isolated_cell_spacing, SettingRange::Above(0),
            "blunders: cell size in 90th-percentile neighbour distances")
      .Integer("isolated_min_neighbours", &Options::isolated_min_neighbours, SettingRange::AtLeast(1),
            "blunders: fewer neighbours than this in the 27 cells = isolated")
      .Number("isolated_min_fraction", &Options::isolated_min_fraction, SettingRange::Closed(0, 1),
            "blunders: removed only when at least this fraction of the cloud")
      .Integer("sac_ia_iterations", &Options::sac_ia_iterations, SettingRange::AtLeast(1),
            "SAC-IA samples scored")
      .Integer("sac_ia_draws_per_iteration", &Options::sac_ia_draws_per_iteration, SettingRange::AtLeast(1),
            "SAC-IA draws at most this many samples per scored one")
      .Integer("sac_ia_randomness", &Options::sac_ia_randomness, SettingRange::AtLeast(1),
            "SAC-IA picks among this many nearest features")
      .Number("sac_ia_confidence", &Options::sac_ia_confidence, SettingRange::LeftOpen(0, 1),
            "SAC-IA stops once a correct sample was drawn with this probability (1 = never early)")
      .Number("sac_ia_alternative_ratio", &Options::sac_ia_alternative_ratio, SettingRange::LeftOpen(0, 1),
            "SAC-IA keeps sampling for poses with this fraction of the best pose's matches")
      .Integer("num_hypotheses", &Options::num_hypotheses, SettingRange::AtLeast(1),
            "hypotheses kept for ICP and verification")
      .Flag("use_max_clique", &Options::use_max_clique,
            "add the maximum-consistent-clique hypotheses")
      .Integer("num_cliques", &Options::num_cliques, SettingRange::AtLeast(1),
            "cliques per descriptor")
      .Number("consistency_spacing", &Options::consistency_spacing, SettingRange::Above(0),
            "clique: pairwise-length tolerance in point spacings")
      .Integer("max_correspondences", &Options::max_correspondences, SettingRange::AtLeast(3),
            "correspondences fed to the clique search")
      .Integer("icp_iterations", &Options::icp_iterations, SettingRange::AtLeast(1),
            "ICP iterations per level")
      .Number("icp_distance_spacing", &Options::icp_distance_spacing, SettingRange::Above(0),
            "ICP final correspondence distance in point spacings")
      .Number("icp_noise_sigmas", &Options::icp_noise_sigmas, SettingRange::AtLeast(0),
            "fine ICP again with this many robust residual scales when larger (0 = off)")
      .Flag("icp_plane_to_plane", &Options::icp_plane_to_plane,
            "fine ICP: plane-to-plane residuals from both clouds' normals (Generalized-ICP)")
      .Number("icp_plane_distance_spacing", &Options::icp_plane_distance_spacing, SettingRange::Above(0),
            "plane-to-plane fine ICP: final correspondence distance in point spacings")
      .Number("inlier_distance_spacing", &Options::inlier_distance_spacing, SettingRange::Above(0),
            "inlier: distance to the target below this many point spacings")
      .Number("inlier_sigma", &Options::inlier_sigma, SettingRange::Above(0),
            "fine verification: inlier below this many robust residual scales")
      .Number("min_fitness", &Options::min_fitness, SettingRange::LeftOpen(0, 1),
            "fraction of the source that must be inliers")
      .Number("min_normal_agreement", &Options::min_normal_agreement, SettingRange::LeftOpen(0, 1),
            "fraction of inliers whose normals agree within 30 deg")
      .Number("max_ambiguity", &Options::max_ambiguity, SettingRange::Closed(0, 1),
            "ambiguity test: finalists above this fraction of the best are compared (0 = all, 1 = off)")
      .Number("min_coarse_agreement", &Options::min_coarse_agreement, SettingRange::Closed(0, 1),
            "the chosen pose's coarse score at least this fraction of the best coarse finalist's (0 = off)")
      .Number("min_significance", &Options::min_significance, SettingRange::AtLeast(0),
            "the best must beat each competitor by this many standard errors")
      .Integer("num_period_shifts", &Options::num_period_shifts, SettingRange::AtLeast(0),
            "repeated structures: displacement modes added to the ambiguity test (0 = off)")
      .Flag("symmetry_turns", &Options::symmetry_turns,
            "turned poses (90/180/270 deg) added to the ambiguity test")
      .Flag("local_search", &Options::local_search,
            "move an unresolved best along its slides")
      .Number("symmetry_cone_deg", &Options::symmetry_cone_deg, SettingRange::Closed(0, 180),
            "non-levelled turns: axes within this angle of each principal axis too")
      .Number("symmetry_cone_step_deg", &Options::symmetry_cone_step_deg, SettingRange::LeftOpen(0, 180),
            "non-levelled turns: ring step, degrees")
      .Flag("intensity_test", &Options::intensity_test,
            "brightness rank correlation may settle a geometric tie")
      .Number("resolution_t", &Options::resolution_t, SettingRange::Above(0),
            "a displacement is told apart when it scores worse by this many standard errors")
      .Number("max_resolution_spacing", &Options::max_resolution_spacing, SettingRange::Above(0),
            "ok needs the pose resolved within this many fine point spacings")
      .Flag("probe_weak_motions", &Options::probe_weak_motions,
            "resolution test also along the fit's two least-constrained motions")
      .Number("max_weak_motion_resolution_spacing", &Options::max_weak_motion_resolution_spacing, SettingRange::Above(0),
            "ok needs the weak motions told apart within this many fine point spacings")
      .Flag("check_fit_uncertainty", &Options::check_fit_uncertainty,
            "ok also needs the fit's covariance within the resolution bound");
  return table;
}

std::vector<RegistrationSetting> RegistrationSettings() { return CloudRegistrationSettingsTable().List(); }

bool SetRegistrationSetting(const std::string& name, const std::string& value, CloudRegistrationOptions* options,
                            std::string* problem) {
  const SettingsTable<Options>& table = CloudRegistrationSettingsTable();
  if (table.Set(name, value, options, problem)) return true;
  if (table.Has(name)) *problem = name + ": " + *problem;
  return false;
}

bool ApplyRegistrationSettings(const std::vector<std::string>& settings, CloudRegistrationOptions* options,
                               std::string* problem) {
  return CloudRegistrationSettingsTable().Apply(settings, options, problem);
}

}  // namespace mmba::registration
