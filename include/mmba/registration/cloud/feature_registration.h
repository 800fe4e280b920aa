#pragma once

// Feature-based rigid registration of two point clouds of possibly different origin (LiDAR,
// spherical stereo, multi-view stereo, planar proxy models), after
//   Kim & Hilton, "Evaluation of 3D Feature Descriptors for Multi-modal Data Registration",
//   3DV 2013 (Sec. 3: normals within R_n, 3D Kanade–Tomasi keypoints, descriptors within R_s,
//   SAC-IA, ICP),
// and past the failures it reports (Sec. 5): several hypotheses, each refined by
// point-to-plane ICP and verified by overlap and normal agreement; a robust
// correspondence-set estimator (maximum clique of pairwise-distance-consistent
// correspondences); an optional gravity constraint (1-DoF rotation); coarse-to-fine for
// large clouds; a confidence from the margin between the best and the runner-up hypothesis.
// PCL is used inside the implementation only.

#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/io_cloud/point_cloud.h"

namespace mmba::registration {

/// Local 3D descriptor (Kim & Hilton Sec. 3.2).
enum class Descriptor {
  kFpfh,          ///< Fast Point Feature Histogram, 11 × 3 = 33-D (Rusu et al. 2009)
  kShot,          ///< Signature of Histograms of OrienTations, 32 spatial bins × 11 = 352-D
  kSpinImage,     ///< Spin Image, 8 bins a side (9 × 17) = 153-D (Johnson & Hebert 1999)
  kShapeContext,  ///< 3D Shape Context, 12 × 11 × 15 = 1980-D (Frome et al. 2004)
  kAuto,          ///< FPFH and SHOT both tried; the best verified hypothesis wins
};

/// How estimated normals are turned (their sign: FPFH, spin images and 3D shape context
/// depend on it). A cloud's given sensor positions (source_viewpoints / target_viewpoints)
/// always decide: each normal faces the nearest.
enum class NormalOrientation {
  /// towards the cloud's frame origin (PCL's convention: the scanner of a scan in its own
  /// frame)
  kViewpoint,
  /// consistent over the neighbour graph (Hoppe et al. 1992), each connected part keeping
  /// the sign most of its normals had towards the origin: independent of where the origin
  /// lies, for a cloud moved into another frame (src/registration/cloud/normal_orientation.h)
  kConsistent,
  /// kConsistent, then every normal of the source turned (the source's normals face away
  /// from where the target's do: its origin lies behind its surfaces)
  kConsistentTurned,
  /// kViewpoint; when that fails after the normals with no pose that fits (not when it is
  /// refused as ambiguous or not fixed) and the two clouds do not both have sensor
  /// positions, once more with kConsistentTurned and then with kConsistent. A retry's result
  /// is taken only when it is "ok"; notes say which try registered. RegisterCloudsOverScales
  /// does not retry (it would multiply every failing trial): its trials use kViewpoint.
  kAuto,
};

/// "viewpoint", "consistent", "consistent-turned", "auto". Returns false on an unknown name.
bool ParseNormalOrientation(const std::string& name, NormalOrientation* orientation);

/// "fpfh", "shot", "si", "sc3d", "auto". Returns false on an unknown name.
bool ParseDescriptor(const std::string& name, Descriptor* descriptor);
std::string DescriptorName(Descriptor descriptor);

/// Options of RegisterClouds. Radii default from the measured point spacing s (median
/// nearest-neighbour distance of the coarser of the two clouds after downsampling).
struct CloudRegistrationOptions {
  Descriptor descriptor = Descriptor::kAuto;  ///< see Descriptor
  double normal_radius_m = 0.0;   ///< R_n; 0 = normal_radius_spacing × s
  double support_radius_m = 0.0;  ///< R_s; 0 = support_radius_spacing × s
  double normal_radius_spacing = 4.0;    ///< R_n in spacings when normal_radius_m = 0 (> 0)
  double support_radius_spacing = 12.0;  ///< R_s in spacings when support_radius_m = 0 (> 0)
  double keypoint_threshold = 0.1;  ///< F_t, smallest eigenvalue of the normal covariance (0..1/3)
  double keypoint_grid_spacing = 0.5;  ///< keypoint grid cell in units of R_n (> 0): one per cell
  int min_keypoints = 150;  ///< below this F_t is lowered, then uniform grid points are used (>= 3)
  int max_keypoints = 600;  ///< above this the keypoint grid is coarsened (>= min_keypoints)
  /// Coarse (feature) level: a voxel grid of at least this many times the larger of the two
  /// clouds' point spacings — averaging a few points per voxel steadies the normals of noisy
  /// reconstructions and quarters the descriptor work (>= 1).
  double coarse_voxel_spacing = 2.0;
  int min_points_coarse = 3000;  ///< … unless the smaller cloud would keep fewer points (>= 10)
  int max_points_features = 15000;  ///< coarse level: voxel size grows until the smaller
                                    ///< cloud fits (>= 1000)
  /// The larger cloud (e.g. a whole LiDAR model against one object) may keep up to this
  /// many times as many coarse points, and up to 4 × as many keypoints, so both are matched
  /// at one resolution (>= 1).
  double larger_cloud_factor = 10.0;
  int max_points_icp = 100000;      ///< fine level for ICP (>= 1000); the target is cropped
                                    ///< to each hypothesis' footprint before it is thinned
  bool use_existing_normals = true;  ///< use normals stored in the clouds when present
  /// Remove scattered blunders — a dense matcher's, a scanner's stray returns — from both
  /// clouds before anything else (not in paper_only runs). A point is a blunder when it is
  /// isolated — fewer than isolated_min_neighbours other points in the 3 × 3 × 3 cells of size
  /// isolated_cell_spacing × the cloud's 90th-percentile nearest-neighbour distance around
  /// it — and off the surface of its 8 nearest others (they form no surface: smallest
  /// singular value > 0.25 × the largest; or it lies off their plane by > 0.3 × their spread):
  /// a clean model's sparse far points lie on the surface their neighbours form. Blunders
  /// otherwise take voxels of their own at the coarse level, which the point budget answers
  /// with a coarser voxel, and inflate the measured spacing and with it R_n and R_s. They are
  /// removed only when they are at least isolated_min_fraction of the cloud: clean clouds
  /// have 0–0.65 % such points (bench/RESULTS.md "The verification's thresholds") and are registered as given.
  bool remove_blunders = true;
  double isolated_cell_spacing = 3.0;  ///< see remove_blunders (> 0)
  int isolated_min_neighbours = 4;     ///< see remove_blunders (>= 1)
  double isolated_min_fraction = 0.01;  ///< see remove_blunders (0..1)
  NormalOrientation normal_orientation = NormalOrientation::kAuto;  ///< see NormalOrientation

  // Hypotheses.
  int sac_ia_iterations = 4000;     ///< SAC-IA samples scored (Rusu et al. 2009) (>= 1)
  /// SAC-IA draws at most this many samples per scored one (most fail the edge-length
  /// pre-check when few matches are right) (>= 1).
  int sac_ia_draws_per_iteration = 50;
  int sac_ia_randomness = 3;        ///< SAC-IA: pick among this many nearest features (>= 1)
  /// SAC-IA stops early once a sample of correct matches for any pose supported by at least
  /// sac_ia_alternative_ratio × the matches of the best pose so far has been drawn with this
  /// probability (the RANSAC bound, Fischler & Bolles 1981); 1 = always draw
  /// sac_ia_iterations samples (0 < x <= 1).
  double sac_ia_confidence = 0.999;
  /// See sac_ia_confidence: competing poses (a pseudo-symmetric turn) with this fraction of
  /// the best pose's correct matches are still sampled (0 < x <= 1).
  double sac_ia_alternative_ratio = 0.5;
  int num_hypotheses = 12;          ///< hypotheses kept for ICP and verification (>= 1)
  bool use_max_clique = true;       ///< add the maximum-consistent-clique hypotheses
  int num_cliques = 3;              ///< cliques per descriptor: the largest, then the largest
                                    ///< of the remaining correspondences, … (>= 1)
  bool paper_only = false;          ///< SAC-IA best + ICP only, no verification (the paper);
                                    ///< status is then "unverified", never "ok"
  double consistency_spacing = 3.0;  ///< clique: pairwise-length tolerance in spacings (> 0)
  int max_correspondences = 600;    ///< correspondences fed to the clique search (>= 3)

  // Gravity.
  /// Both clouds levelled (to a few degrees): hypotheses rotate about `up` only; the final
  /// fine ICP is free (6 DoF) to absorb the residual tilt.
  bool gravity_aligned = false;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  ///< unit "up" in both frames

  // Search window: the source is already near its place (an approximate pose applied, e.g. a
  // station's setup). When search_window_m > 0 the identity is a hypothesis too, and only
  // poses that move the source's centre by at most search_window_m and turn it by at most
  // search_window_deg are kept — the ambiguity test then weighs only poses inside the window
  // (a repeated facade bay farther away than the setup's error is no alternative).
  double search_window_m = 0.0;     ///< 0 = no window (>= 0)
  double search_window_deg = 10.0;  ///< (0, 180] when the window is on

  // ICP (point-to-plane, Chen & Medioni 1991).
  bool icp = true;                  ///< refine each hypothesis with ICP
  int icp_iterations = 40;          ///< per level (>= 1)
  double icp_distance_spacing = 1.0;  ///< final correspondence distance in spacings (> 0)
  /// Fine ICP on a noisy cloud: when this × the robust residual scale exceeds the final
  /// correspondence distance, ICP runs again with that distance (0 = off; >= 0).
  double icp_noise_sigmas = 2.5;
  /// Fine ICP with the plane-to-plane residual (Generalized-ICP, Segal et al. 2009): both
  /// clouds' normals weigh each pair, ending at icp_plane_distance_spacing, and
  /// point-to-plane's answer enters the stated σ; false (the default) = point-to-plane with
  /// the target's normals, ending at icp_distance_spacing. Opt-in, for a simplified model (a
  /// plane proxy, a CAD/BIM model) against a scan: on eight simulated scenes it brought the
  /// plane proxy to the LiDAR from 1.9–17 cm to 1.1–4.9 cm; but between two scans of the same
  /// surface it is less accurate (real pairs: 1.7× the error, median), and a model with a
  /// 4 cm step left out (the relief test) ends 8 mm off instead of 3.
  bool icp_plane_to_plane = false;
  /// The plane-to-plane fine ICP's final correspondence distance in spacings (> 0). A
  /// simplified model (a plane proxy) lies off the scanned detail by more than a spacing:
  /// within one spacing only the pairs where model and detail happen to meet are kept.
  double icp_plane_distance_spacing = 2.0;

  // Verification and the verdict.
  double inlier_distance_spacing = 2.0;  ///< inlier: distance to target < this × s (> 0)
  /// Fine verification: inlier when the point-to-plane residual is below this × σ̂, σ̂ the
  /// robust (MAD) residual scale of the best hypothesis, but at least the coarse-free floor
  /// 0.5 × fine spacing (> 0).
  double inlier_sigma = 3.0;
  /// fraction of source points that must be inliers (0..1]; 0.2 let a cathedral stereo part
  /// shifted 30 m along the repeated bays onto the plane proxy pass (fitness 0.27)
  double min_fitness = 0.3;
  /// fraction of inliers with |n_s·n_t| > cos 30° (0..1]; 0.5 let a 177°-turned part of the
  /// gate onto the noisy spherical-stereo cloud pass (0.53), axis-aligned scenes agree by
  /// chance on about a third
  double min_normal_agreement = 0.6;
  /// Ambiguity test: every distinct finalist scoring above this fraction of the best is
  /// compared with it (0 = every one; 1 = none: the test is off) (0..1).
  double max_ambiguity = 0.0;
  /// Scale agreement: the chosen pose, when it comes from a coarse hypothesis, must have
  /// scored at the coarse level at least this fraction of the best coarse hypothesis that
  /// survived as a distinct finalist; else the two levels contradict each other and the
  /// result is refused ("scales disagree"). On the full-preset simulated gate the fine level
  /// preferred the 180° twin (coarse score 0.50) over a pose near the truth (0.91): a wrong
  /// "ok" 5.6 m off (bench/RESULTS.md "The verification's thresholds"). 0 = off (0..1).
  double min_coarse_agreement = 0.8;
  /// ... and "ok" needs the best to beat each of them by at least this many standard errors of
  /// the mean per-point score difference (cluster-robust over blocks of R_s; a paired t
  /// statistic, src/registration/cloud/score_significance.h), the same bar as
  /// resolution_t for small displacements (>= 0). Every distinct rival is tested, not only
  /// those near the best's score: a stereo part shifted by one bay of the simulated cathedral
  /// onto the proxy scores 0.72 × the best with t 2.2.
  double min_significance = 3.0;
  /// Repeated structures: the best pose moved by this many of the strongest displacement
  /// modes of the descriptor matches (beyond R_s) is refined and added to the ambiguity test
  /// (0 = off) (>= 0).
  int num_period_shifts = 4;
  /// Pseudo-symmetric objects: the best pose turned about the registered source's centroid —
  /// by 90°, 180° and 270° about up when levelled, else by 180° about each principal axis of
  /// the source (upside down, turned round) — is refined and added to the ambiguity test.
  bool symmetry_turns = true;
  /// A best pose off the score's maximum: when some displacement of the best finalist along
  /// or about a principal axis of the source is not told apart at the resolution bound (the
  /// pose slides there), the pose is moved along each such direction by the bound, twice and
  /// four times it… up to R_s, each move screened by a short ICP from that distance; the best
  /// move, refined by the fine ICP, joins the finalists when it scores above the best (the
  /// verdict then concerns it), and the search repeats from it (up to 4 rounds). A resolved
  /// best — every "ok" — is left as it is.
  bool local_search = true;
  /// Non-levelled symmetric turns: each principal axis is also tried with the axes within
  /// this angle of it, in rings this step apart (degrees; cone >= 0, 0 = the principal axes
  /// only; step > 0).
  double symmetry_cone_deg = 6.0;
  double symmetry_cone_step_deg = 6.0;
  /// Intensity test: when the ambiguity test leaves a tie and both clouds carry a brightness
  /// (intensity, else colour), the rank correlation of source and target brightness over each
  /// finalist's inliers joins the geometric t (src/registration/cloud/intensity_test.h): it
  /// may settle the tie in favour of the geometric best, never unsettle a pose the geometry
  /// resolved, never pick another pose.
  bool intensity_test = true;
  /// Pose resolution test: a displacement of the chosen pose counts as told apart when it
  /// scores worse by at least this many standard errors (paired block t) (> 0).
  double resolution_t = 3.0;
  /// "ok" needs the pose resolved (every displacement of this RMS size over the source scores
  /// significantly worse) to within this × the fine point spacing (> 0). The same bound holds
  /// for the fit's uncertainty: "ok" also needs resolution_t × sigma_rms_m (the standard
  /// deviation of the least-determined motion, from the covariance of the fine
  /// point-to-plane fit) within it.
  double max_resolution_spacing = 4.0;
  /// The resolution test also displaces the pose along the two least-constrained motions of
  /// the fine fit (the weakest eigenvectors of its point-to-plane Gauss–Newton matrix), not
  /// only along the source's principal axes; "ok" needs them told apart within
  /// max_weak_motion_resolution_spacing fine spacings
  /// (CloudRegistrationResult::weak_motion_resolution_m).
  bool probe_weak_motions = true;
  /// "ok" needs the fit's least-constrained motions told apart within this × the fine point
  /// spacing (> 0; default the axes' bound). A larger value accepts poses whose weak motion
  /// (a slide along a facade, say) the data fix only coarsely; the pose is then known only to
  /// weak_motion_resolution_m, which the result states.
  double max_weak_motion_resolution_spacing = 4.0;
  /// "ok" also needs resolution_t × sigma_rms_m (the fit's covariance) within the resolution
  /// bound; false: the covariance is only reported.
  bool check_fit_uncertainty = true;

  // Visibility (free space). Sensor positions of each cloud in its own frame: scanner
  // stations, camera centres, stereo stations (empty = unknown; a modelled cloud such as a
  // plane proxy has none). When either is given, a source point that a pose puts in space a
  // target sensor saw through (or a target point in space a source sensor saw through) counts
  // −1 in the fine score and the ambiguity test, and the overlap floor min_fitness is
  // replaced by the visibility verdict below.
  std::vector<Eigen::Vector3d> source_viewpoints, target_viewpoints;
  /// "ok" needs the fraction of the source in observed free space to be at most this × the
  /// inlier fraction: the data must support the pose at least twice as much as they refute
  /// it; a competing finalist above it is no alternative in the ambiguity test (>= 0).
  /// (0.1 refused right cathedral poses: windows the LiDAR sees through, interiors behind
  /// them, and the plane proxy spanning recesses put 6–11 % of the multi-view cloud in free
  /// space at the true pose, 0.11–0.19 × its inliers.)
  double max_violation_ratio = 0.5;
  /// overlap floor when visibility is tested (0..1]
  double min_fitness_visible = 0.1;
  uint64_t seed = 42;             ///< random seed (results are deterministic)

  /// False with a message naming the field, the value and the constraint when invalid.
  bool Check(std::string* error) const;
};

/// One stage's wall-clock time and the process CPU time it used (all threads).
struct StageTime {
  std::string stage;
  double seconds = 0.0;
  double cpu_seconds = 0.0;
};

/// A hypothesis after refinement and verification.
struct RegistrationHypothesis {
  std::string origin;          ///< "sac-ia fpfh #0", "max-clique shot", "gravity-yaw" …
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double fitness = 0.0;        ///< inlier fraction of the source
  double inlier_rmse = 0.0;    ///< metres
  double normal_agreement = 0.0;
  double conflict = 0.0;       ///< fine only: of the source points with a target surface
                               ///< within reach, the fraction off it or with another normal
  double violation = 0.0;      ///< fine only: fraction of the source in observed free space
  double score = 0.0;          ///< coarse: fitness × normal_agreement; fine: Σ(1 − r²/τ²) over
                               ///< the inliers with agreeing normals / source points
  /// fine, intensity test run: |rank correlation| of source and target brightness over the
  /// inliers; −1 when not measured
  double intensity_correlation = -1.0;
};

/// Result of RegisterClouds.
struct CloudRegistrationResult {
  std::string status = "failed";  ///< "ok", "failed", or "unverified" (paper_only runs)
  std::string reason;             ///< why it failed (empty when ok)
  std::string descriptor;         ///< descriptor of the chosen hypothesis
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double fitness = 0.0;           ///< inlier ratio of the (fine) source
  double inlier_rmse = 0.0;       ///< metres
  double normal_agreement = 0.0;
  double conflict = 0.0;          ///< see RegistrationHypothesis::conflict
  /// The best pose passed the overlap, visibility and normal checks: a failure after them
  /// (ambiguous, not resolved, not determined) found a pose that fits but is not sure of it.
  bool best_pose_fits = false;
  bool visibility_tested = false;  ///< sensor positions were given (free-space test done)
  double violation = 0.0;         ///< see RegistrationHypothesis::violation
  double significance = 0.0;      ///< best vs the least distinguishable distinct finalist, in
                                  ///< standard errors (inf: no distinct finalist)
  double confidence = 0.0;        ///< 0..1: 1 − runner-up score / best score, times fitness checks
  /// The intensity test ran (a geometric tie, both clouds with a brightness); `significance`
  /// then includes it.
  bool intensity_tested = false;
  double intensity_correlation = -1.0;   ///< chosen pose's |rank correlation| (−1: not tested)
  double intensity_significance = 0.0;   ///< intensity t against the significance's runner-up
  size_t num_keypoints_source = 0, num_keypoints_target = 0;
  size_t num_correspondences = 0;  ///< descriptor matches
  size_t num_inliers = 0;          ///< fine source points within the inlier distance
  double point_spacing_m = 0.0;    ///< s
  /// Scattered blunders removed before the registration (see remove_blunders); the fitness
  /// and the checks are over the remaining points.
  size_t blunders_removed_source = 0, blunders_removed_target = 0;
  double fine_inlier_distance_m = 0.0;  ///< τ of the fine verification (inlier residual)
  /// Smallest RMS displacement of the source (any direction: translation or rotation) the
  /// fine verification tells from the chosen pose; +inf when not resolved up to R_s. The
  /// larger of the resolution along and about the source's principal axes ("ok" needs it
  /// within max_resolution_spacing fine spacings) and weak_motion_resolution_m.
  double resolution_m = std::numeric_limits<double>::infinity();
  /// The same along the fit's two least-constrained motions (probe_weak_motions); "ok" needs
  /// it within max_weak_motion_resolution_spacing fine spacings; reported up to R_s (+inf:
  /// not told apart at any displacement up to R_s). 0 when not probed.
  double weak_motion_resolution_m = 0.0;
  double fine_spacing_m = 0.0;          ///< point spacing of the fine verification
  /// Uncertainty of the chosen pose from the fine point-to-plane fit of its inliers:
  /// covariance of the correction ξ = (ω, t) — ω a rotation vector (rad), t a translation
  /// (m), both in the target frame — that maps a registered point q to
  /// c + Exp(ω)(q − c) + t, c = covariance_centre (the registered source's centroid).
  /// Cluster-robust ("sandwich") estimate H⁻¹ (Σ_b g_b g_bᵀ) H⁻¹ over blocks of R_s (H the
  /// Gauss–Newton matrix of the point-to-plane residuals, g_b a block's gradient): residuals
  /// correlated within a block (a reconstruction's smooth noise) count once per block, not
  /// once per point. Plus the systematic part of gate_sensitivity_m (below). Infinite (and
  /// pose_determined false) when the inliers leave a motion free (a plane: in-plane shifts,
  /// the turn about its normal).
  Eigen::Matrix<double, 6, 6> covariance =
      Eigen::Matrix<double, 6, 6>::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d covariance_centre = Eigen::Vector3d::Zero();
  /// Standard deviations of t (per target axis) and of ω (about each target axis, degrees).
  Eigen::Vector3d sigma_translation_m =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d sigma_rotation_deg =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  /// Standard deviation of the RMS displacement of the source along its least-determined
  /// motion (the largest eigenvalue of the covariance in the RMS-displacement metric), m.
  double sigma_rms_m = std::numeric_limits<double>::infinity();
  /// How far the pose moves when its last fine ICP ends at half and at twice its final
  /// correspondence distance (RMS over the source of the two moves, m): the error of a model
  /// that departs from the target on one side (a plane proxy of a detailed façade) pulled
  /// towards whatever falls inside the distance, which the residuals' covariance cannot see.
  /// Included in covariance and sigma_rms_m as a systematic part, ½ Σ ξ_k ξ_kᵀ over the two
  /// moves. 0 without ICP.
  double gate_sensitivity_m = 0.0;
  /// That motion, in words ("mostly a turn about (0, 0, 1)", "mostly a shift along …").
  std::string weakest_motion;
  /// Condition of the fit: the smallest over the largest eigenvalue of H in the RMS metric
  /// (1: every motion of the source is constrained alike; 0: some motion is free).
  double constraint_ratio = 0.0;
  double normal_radius_m = 0.0, support_radius_m = 0.0;
  std::vector<StageTime> runtime;  ///< seconds per stage, in order
  std::vector<RegistrationHypothesis> hypotheses;  ///< best first
  std::vector<std::string> notes;  ///< fallbacks taken (lowered F_t, grid keypoints, …)

  bool ok() const { return status == "ok"; }
  double total_seconds() const;
  std::string BriefReport() const;
};

/// Registers `source` onto `target`: returns target_from_source. Never throws on a failed
/// registration (status "failed" with a reason); throws InputError only for invalid
/// options (Check()).
CloudRegistrationResult RegisterClouds(const io::PointCloud& source,
                                       const io::PointCloud& target,
                                       const CloudRegistrationOptions& options);

/// The visibility test of the verification on whole clouds: the fraction of `source` points
/// that `target_from_source` puts in space observed as empty — nearer to a target sensor than
/// the first target surface along its ray, or charged with a target point nearer to a source
/// sensor than the first source surface — by more than `margin` and with no point of the
/// other cloud within `margin`. Viewpoints are in each cloud's own frame (either may be empty).
double FreeSpaceViolation(const io::PointCloud& source, const io::PointCloud& target,
                          const std::vector<Eigen::Vector3d>& source_viewpoints,
                          const std::vector<Eigen::Vector3d>& target_viewpoints,
                          const Eigen::Matrix4d& target_from_source, double margin);

/// Result of RefineSimilarity.
struct SimilarityFit {
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();  ///< [sR | t]
  double scale = 1.0;        ///< s
  double fitness = 0.0;      ///< fraction of the source within `end_distance` of the target
  double inlier_rmse = 0.0;  ///< metres, over those
  int iterations = 0;
};

/// Similarity (7 DoF: rotation, translation and scale) of `source` onto `target` refined by
/// point-to-plane ICP (Chen & Medioni 1991, linearised as Low 2004 Eq. 6–8, with the log of
/// the scale as a seventh parameter, taken about the moved source's centroid) from `start`
/// ([sR | t]); correspondences within `start_distance` shrinking to `end_distance` (metres).
/// For a cloud in a scale of its own (a photogrammetric block without control) once a rigid
/// registration at a trial scale has put it near its place. The target is cropped to the
/// moved source's box grown by `start_distance` and thinned to `max_target_points`.
SimilarityFit RefineSimilarity(const io::PointCloud& source, const io::PointCloud& target,
                               const Eigen::Matrix4d& start, double start_distance,
                               double end_distance, int iterations = 60,
                               size_t max_target_points = 300000);

/// One trial scale of RegisterCloudsOverScales.
struct ScaleTrial {
  double scale = 1.0;            ///< applied to the centred source
  std::string status;            ///< "ok" or "failed: <reason>" of the rigid registration
  double fitness = 0.0;          ///< the rigid registration's
  bool refined = false;          ///< an "ok" trial, refined as a similarity
  /// A second-pass trial: when no trial scale registered, the scale refined from a failed trial
  /// whose pose fits (CloudRegistrationResult::best_pose_fits), registered again from scratch.
  bool from_refinement = false;
  double refined_scale = 0.0;    ///< target units per source unit after the refinement
  double refined_fitness = 0.0;  ///< fraction of the source within the tolerance after it
};

/// Result of RegisterCloudsOverScales.
struct ScaleSearchResult {
  std::string status = "failed";  ///< "ok" or "failed"
  std::string reason;
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();  ///< [sR | t]
  double scale = 1.0;
  double fitness = 0.0;      ///< fraction of the source within tolerance_m of the target
  double inlier_rmse = 0.0;  ///< metres (target units), over those
  double tolerance_m = 0.0;
  double seconds = 0.0;
  std::vector<ScaleTrial> trials;
  bool ok() const { return status == "ok"; }
};

/// Registration of a cloud in a scale of its own (a photogrammetric block without control, an
/// SfM cloud) onto a metric target. Kim & Hilton's pipeline is rigid, and a rigid registration
/// of such a cloud holds to about ±3–5 % of scale (bench/RESULTS.md "The verification's thresholds"), so the centred source is
/// registered by RegisterClouds (`options`; source_viewpoints scaled with it) at trial scales
/// min_scale · step^k up to max_scale; each "ok" trial is refined by RefineSimilarity and
/// scored by the fraction of the source within `tolerance_m` (0: ScaleSearchTolerance). The
/// best moves the source — unless another trial ends more than 5 tolerances away (RMS over the
/// source) with at least 0.9 × its fraction (ambiguous), or fewer than 30 % of the source lie
/// within the tolerance. Failed with the best-fitting failed trial's reason when none is
/// "ok". Two trials run at a time when the machine has two cores or more; the result does not
/// depend on their order. `progress`, when given, is called after each trial (from the thread
/// that ran it, one call at a time, in the order the trials finish).
ScaleSearchResult RegisterCloudsOverScales(
    const io::PointCloud& source, const io::PointCloud& target,
    const CloudRegistrationOptions& options, double min_scale, double max_scale,
    double step = 1.05, double tolerance_m = 0.0,
    const std::function<void(size_t done, size_t total, const ScaleTrial&)>& progress = nullptr);

/// The agreement tolerance of RegisterCloudsOverScales: max(3 × the target's point spacing,
/// 0.5 % of its RobustExtent) — an unadjusted photogrammetric point is decimetres off on a site
/// of tens of metres.
double ScaleSearchTolerance(const io::PointCloud& target);

/// Diagonal of the box between the 5th and 95th percentiles per axis: the extent of a cloud
/// without its stray points (0 for an empty cloud).
double RobustExtent(const std::vector<Eigen::Vector3d>& points);

/// Median nearest-neighbour distance over up to `max_samples` points (metres); 0 when the
/// cloud has fewer than 2 points.
double EstimatePointSpacing(const io::PointCloud& cloud, size_t max_samples = 20000);

/// Per-point distance of `cloud` (after target_from_source) to the nearest point of
/// `target`, in metres.
std::vector<double> DistancesToTarget(const io::PointCloud& source,
                                      const io::PointCloud& target,
                                      const Eigen::Matrix4d& target_from_source);

/// Colours the transformed source by distance to the target, blue (0) → red (>= max_m),
/// the error maps of Kim & Hilton Fig. 6. The result is in the target frame.
io::PointCloud MakeErrorMap(const io::PointCloud& source, const io::PointCloud& target,
                            const Eigen::Matrix4d& target_from_source, double max_m);

/// RMS of ‖A·p − B·p‖ over the points p of `cloud`: the error of an estimated transform A
/// against a ground truth B (Kim & Hilton Sec. 4, RMS error to the ground truth).
double TransformRmsOnCloud(const io::PointCloud& cloud, const Eigen::Matrix4d& a,
                           const Eigen::Matrix4d& b);

}  // namespace mmba::registration
