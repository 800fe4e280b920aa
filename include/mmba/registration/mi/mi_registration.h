#pragma once

// Mutual-information registration of LiDAR to panoramas and images (Wang, Ferrie &
// Macfarlane, "Automatic Registration of Mobile LiDAR and Spherical Panoramas", CVPRW 2012):
// the pose of each image's camera relative to the cloud is corrected by maximising a
// similarity of a rendered LiDAR image and the photo over 6 corrections; the result carries
// a 6×6 covariance from the curvature of the metric and a confidence flag.
//
// Correction convention (tx, ty, tz in metres; roll, pitch, yaw in degrees): the camera pose
// in the LiDAR frame is corrected about the camera centre, with axes of the LiDAR frame:
//   lidar_from_cam' = [R_z(yaw)·R_y(pitch)·R_x(roll) · R | c + (tx, ty, tz)]
// where lidar_from_cam = [R | c] is the start. For KITTI (x forward, y left, z up) and for a
// local east-north-up world this is the vehicle's roll/pitch/yaw and a shift of the camera.

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/registration/mi/edges.h"
#include "mmba/registration/mi/lidar_image.h"
#include "mmba/registration/mi/metric.h"
#include "mmba/registration/mi/nelder_mead.h"
#include "mmba/registration/mi/point_samples.h"

namespace mmba::registration::mi {

/// Applies a correction (tx, ty, tz [m], roll, pitch, yaw [deg]) to a start pose.
Rigid3d ApplyCorrection(const Rigid3d& cam_from_lidar_start, const Vector6d& correction);
/// The correction that takes `start` to `corrected` (inverse of ApplyCorrection).
Vector6d CorrectionBetween(const Rigid3d& cam_from_lidar_start, const Rigid3d& corrected);

/// One image and its cloud: the views cut from the image and the prepared points.
struct Frame {
  std::string name;
  std::vector<View> views;
  const LidarPoints* points = nullptr;  ///< not owned
};

struct RegistrationOptions {
  MetricOptions metric;
  RenderOptions render;
  NelderMeadOptions nelder_mead;  ///< paper defaults; bounds set from the fields below
  double bound_translation_m = 0.5;  ///< search box ± around the start (trust region)
  double bound_rotation_deg = 3.0;
  int pyramid_levels = 3;            ///< 1 = full resolution only
  /// Nelder–Mead runs from the coarsest level down to this one; finer levels get only the
  /// gradient refinement (0 = Nelder–Mead at full resolution too).
  int finest_nelder_mead_level = 0;
  /// Coarse-to-fine paths (without coarse starts): 1 = the single search from the start
  /// that enters at the coarsest level; k > 1 adds the searches from the start that enter at
  /// each of the next k − 1 finer levels (down to the finest Nelder–Mead level), and the one
  /// with the highest metric at the finest Nelder–Mead level (rendered, the same level and
  /// metric for all) goes on to the gradient refinement. A coarse level assumes that its
  /// maximum lies in the basin of the full-resolution one; where a downsampled image has its
  /// own maximum elsewhere (measured on KITTI: level 2 led the yaw +1° start to a pose 10.5 px
  /// off whose full-resolution NMI was below the calibration's), the finer level decides.
  /// Default 3 (every level of the default pyramid, adaptively, below): with point samples,
  /// on 160 simulated panorama registrations, 60 ok (59 right) against 47 (46) with one path
  /// (bench/RESULTS.md "Pyramid paths as the default").
  int pyramid_paths = 3;
  /// With pyramid_paths ≥ 3: the coarser entries are searched down to the level above the
  /// finest Nelder–Mead level; if they end there within restart_tolerance_px of each other
  /// (median over the visible points), the coarsest entry's path alone goes on (the single
  /// coarse-to-fine search, exactly); otherwise each goes on and the finest entry (the
  /// dearest: the full simplex at the finest level) is searched too, i.e. only when a coarse
  /// level may have led a search astray. Measured: 60 ok of the 160 simulated panorama
  /// registrations (61 with every entry searched), and the synthetic street's view +9 % wall
  /// at 8 M points against the single path (bench/RESULTS.md "Pyramid paths as the default").
  bool pyramid_paths_adaptive = true;
  /// Coarse global stage: extra Nelder–Mead starts at the coarsest level, spread over
  /// ±coarse_start_spread·bound (Halton points in opposite pairs; 0 = the paper's single
  /// local search from the start). The `coarse_candidates` best distinct coarse optima are
  /// carried down the pyramid and the best at the finest Nelder–Mead level wins.
  int coarse_starts = 0;
  double coarse_start_spread = 0.6;  ///< fraction of the bound, (0, 1]
  int coarse_candidates = 3;
  bool gradient_refinement = true;   ///< after Nelder–Mead, on the B-spline histogram
  int gradient_max_iterations = 5;
  /// Points kept per view pixel at full resolution, doubled per coarser level (an even
  /// subsample; the z-buffer keeps the nearest). Measured on the synthetic street: 1.5 at
  /// every level → 0.75·2^level is ~15 % faster and as accurate; 0.75 at every level lost a
  /// 0.3 m / 2° start (sparse coarse images); 0.3 made the level-1 restarts too noisy.
  double max_points_per_pixel = 0.75;
  /// Point-sample evaluation (point_samples.h; sample-based MI, Viola & Wells 1997), ON by
  /// default: where the histogram is the B-spline one, the searches render the z-buffer
  /// once at a reference pose and then move only the visible points' samples, re-rendering
  /// when the pose has moved the image by more than `sample_rebuild_px` pixels of the level
  /// (largest displacement of 16 probe points per view). Over the whole image (the
  /// points-only representation's region) the pixels without LiDAR are the complement of
  /// the samples: the reference's background and samples make one photo histogram, and what
  /// the moved samples' photo values no longer take the background takes (JointHistogram::
  /// AddBackgroundComplement: frozen samples move the coverage with the points). false =
  /// every evaluation rendered. Measured (bench/RESULTS.md, "Point samples as the
  /// default"): on the 80 simulated panorama registrations
  /// 23 ok of which 22 < 1 px and one 1.02 px off (rendered: 6 ok, all < 1 px), at about
  /// half the CPU.
  bool point_samples = true;
  double sample_rebuild_px = 1.0;
  /// With point samples, pyramid levels >= this one use one sample per visible point
  /// weighted by its footprint pixels; finer levels one sample per covered pixel (the
  /// rendered histogram's samples, exactly at the reference pose). 0 = per point at every
  /// level; a value beyond the pyramid = per pixel everywhere. The covariance fit has its
  /// own switch below.
  int per_point_samples_from_level = 0;
  bool SamplePerPoint(int level) const { return level >= per_point_samples_from_level; }
  /// Where a per-point sample is taken and what it weighs (point_samples.h,
  /// PerPointPlacement): > 0 = at the point's own projection, weighted by the covered pixels
  /// of its sample_block_px × sample_block_px block shared among the block's samples, and
  /// only points in front at their own pixel (the footprint decides visibility only);
  /// 0 = at the pixel it won nearest its projection, weighted by its won pixels (the
  /// rendered histogram's weights). Measured on 200 simulated panorama registrations, 8
  /// against 0: the ok results' median error 0.12 against 0.36 px (spheres), 69 against 72
  /// ok (bench/RESULTS.md, "The footprint decides visibility only").
  int sample_block_px = 8;
  /// With point samples, the covariance fit's samples (at its level, the visibility of the
  /// optimum): one weighted sample per visible point (true; ~2.6 times fewer samples at full
  /// resolution) or one per covered pixel (false; the rendered histogram's samples).
  bool covariance_per_point_samples = true;
  /// Point samples also in the restarts and the independent halves (false: those
  /// re-optimisations render every evaluation).
  bool point_samples_in_checks = true;
  /// Failure checks.
  double min_covered_fraction = 0.02;  ///< of view pixels covered by LiDAR at the start
  double max_dark_or_saturated = 0.85; ///< fraction of photo pixels ≤5 or ≥250
  double min_photo_stdev = 3.0;        ///< grey levels
  /// Confidence: the peak must rise above the metric's mean along each axis scan by this
  /// fraction of |peak|, and no other local maximum may come within it.
  double min_relative_peak = 0.002;
  bool check_multiple_peaks = true;
  /// The scans also cross the search box along its weakly observed direction: the
  /// combination of the corrections that moves the visible points least relative to the
  /// bounds (e.g. a camera lowered and tilted back), where a distant higher maximum hides
  /// from the one-parameter scans. Tested for a higher MI and for flatness, not for a second
  /// lower peak (the metric is bumpy along it; bench/RESULTS.md "The weakly observed direction").
  bool scan_weak_direction = true;
  /// Threads for independent evaluations (covariance fit, restarts, scans, gradient).
  int threads = 2;
  /// Laplace covariance: the number of independent samples is the covered pixels over
  /// Bartlett's inflation factor for correlated pixels, lags within ±this many pixels
  /// (0 = the distinct LiDAR points seen, as if every point were independent: measured
  /// 3–13× over-confident, bench/RESULTS.md "Acceptance and covariance honesty").
  int effective_sample_max_lag = 8;
  /// Pyramid level of the quadratic fit that gives the covariance (0 = full resolution; at
  /// level 1, a quarter of the cost, the fit was too noisy on the synthetic street: a
  /// spurious negative curvature made a 0.3 px result look undetermined).
  int covariance_level = 0;
  /// Acceptance: status "ok" needs every check below to pass (see AcceptanceChecks).
  /// Predicted 1-σ displacement of the visible LiDAR points in the image, px: median over
  /// the points of sqrt(trace(J Σ Jᵀ)), J = ∂pixel/∂correction, Σ = the covariance. Pixels
  /// of the frame's image (View::image_pixels_per_pixel: a 940×452 cut of a 1024-wide
  /// panorama has 2.9 cut pixels per panorama pixel).
  double max_sigma_px = 0.5;
  /// The same σ from the calibrated covariance (the one reported and used as a prior:
  /// AcceptanceChecks::sigma_px_calibrated) must not exceed this: a result whose own error
  /// estimate is above the paper's accuracy (< 1 px) is not "ok". Measured (bench/RESULTS.md,
  /// "MI inside the adjustment"): a photo registered "ok" 0.21 m / 0.25° from its adjusted
  /// pose had 1.35 px here (0.20 px Laplace); the 7 right "ok" of the simulated panoramas had
  /// 0.38–1.11 px; the two above 1 px ended 0.88 px from the truth and are refused.
  double max_calibrated_sigma_px = 1.0;
  /// Restarts: Nelder–Mead at `restart_level` (simplex 2·offset, the main run's finest
  /// tolerance) from this many points around the optimum (offset ±restart_offset in each
  /// parameter, deterministic signs, in opposite pairs); each must end within
  /// restart_tolerance_px (median pixel distance of the visible points, in pixels of the
  /// frame's image as for max_sigma_px) of the optimum. Level 1 costs a quarter of level 0.
  int restarts = 3;
  int restart_level = 1;
  /// Polish: before the acceptance, the restarts above are run from the search's optimum; one
  /// that ends beyond restart_tolerance_px where the full-resolution metric is higher (the
  /// optimum was not the maximum: the level-0 Nelder–Mead can stop on a ridge) is refined at
  /// level 0 and becomes the optimum, at most this many times (0: off). The last round's
  /// restarts are the acceptance's own (not run twice).
  int polish_rounds = 2;
  double restart_offset_m = 0.05;
  double restart_offset_deg = 0.5;
  double restart_tolerance_px = 1.0;
  /// Shuffled-pairing baseline: MI at the optimum against MI with the photo values permuted
  /// over the same samples (`shuffles` permutations). Needs gain ≥ min_mi_gain_bits and
  /// (gain / σ of the shuffled MI) ≥ min_mi_significance.
  int shuffles = 8;
  double min_mi_gain_bits = 0.02;
  double min_mi_significance = 10.0;
  /// Independent halves (SplitIntoHalves: alternate frames, alternate views, or the left and
  /// right halves of a single view): each half is re-optimised alone by Nelder–Mead at
  /// `split_level` from the optimum (simplex 2·restart offset, the restarts' tolerance); each
  /// half's optimum must put that half's own visible points within split_tolerance_px
  /// (median, pixels of the frame's image) of where the joint optimum puts them. The restarts
  /// test the shape of one metric surface; this tests whether independent parts of the data
  /// agree on the pose — a systematic error that affects the parts differently (a stitched
  /// panorama's parallax, a lens model error, a moving object, one frame's georeferencing)
  /// moves their optima apart.
  bool split_check = true;
  int split_level = 0;
  double split_tolerance_px = 1.0;
  /// Calibrate the covariance by the halves and the restarts (AcceptanceChecks::
  /// variance_factor): `covariance` = factor · the Laplace one (kept as covariance_laplace),
  /// then raised to the pixel-isotropic floor (covariance_pixel_floor).
  bool calibrate_covariance = true;
  /// With calibrate_covariance: the reported covariance is raised, direction by direction,
  /// to at least the pixel-isotropic one (v/6)·M⁻¹, M = mean JᵀJ of the visible points'
  /// pixel Jacobians and v the calibrated covariance's mean squared pixel σ — so that no
  /// combination of the six corrections is claimed better than the pixel accuracy allows.
  /// The calibrated Laplace covariance alone was over-confident in 6-D on the simulated
  /// photos: Mahalanobis² of the actual error median 17–111 against 5.35 for a right
  /// covariance, 1.8–4.8 with the floor; on the panoramas 3.0 (p90 33), 0.5 (p90 5.5) with
  /// it, i.e. on the safe side (bench/RESULTS.md, "MI priors on photos"). The acceptance
  /// checks and every status are unchanged by it.
  bool covariance_pixel_floor = true;
  /// Views cut from the frame's own image (a panorama's perspective cuts or cube faces,
  /// View::image_camera): the calibrated σ must also be ≤ max_calibrated_sigma_px over the
  /// whole image (AcceptanceChecks::image_sigma_px_calibrated) — the pose is the image's,
  /// not the cuts'.
  bool whole_image_checks = true;
  /// false (the default): the acceptance stops at the first check that fails — the status is
  /// "failed" whatever the others would measure, so the later (costlier) checks are not run:
  /// below start / on the bound (before the covariance), the Laplace σ (right after the
  /// covariance), the shuffled baseline, the restarts (in index order: those after the first
  /// one that ends too far are not reported, nor started if it is known by then), the halves
  /// (likewise), the calibrated σ, the axis scans. A check not run keeps its "not measured"
  /// value in AcceptanceChecks (−1, NaN, 0 restarts; no covariance when it was skipped) and
  /// AcceptanceChecks::stopped_after names the check that decided. Status,
  /// pose and the values of an "ok" result are the same either way; true measures every
  /// check of a failed registration too (diagnostics; slower).
  bool measure_all_checks = false;

  /// The geometric term (edges.h; Levinson & Thrun 2013) and its registration (RegisterEdges):
  /// "on", "off", or "auto" — on where the clouds are LiDAR sweeps in their own frame seen by a
  /// perspective camera (PrepareJob decides: not a panorama, not a rig, not a map-grid cloud,
  /// no scanner sidecar or trajectory). With intensity, MI on it is added, weighted from the
  /// data (edge_mi). Off by default: on the three real frames of bench/RESULTS.md "Real
  /// vehicles: the geometric term" it does not yet recover the calibration from one frame.
  std::string edges = "off";
  EdgeOptions edge;
  bool edge_mi = true;             ///< add the MI term where the clouds carry intensity
  double edge_mi_scale = 1.0;      ///< × the data's weight of the MI term
  /// The finest pyramid level at which the MI term is evaluated (0: full resolution; clamped
  /// to pyramid_levels − 1): its cost is the rendered image's pixels, 4× less per level.
  int edge_mi_level = 0;
  /// The edge registration's search box (instead of bound_m, bound_deg): a start up to 3° per
  /// angle and 0.2 m off lies inside it, off its 90 % margin.
  double edge_bound_m = 0.3;
  double edge_bound_deg = 4.5;
  double edge_grid_step_deg = 0.5;  ///< global stage: rotation grid step over ±edge_bound_deg
  int edge_grid_keep = 4;          ///< grid points searched on, best first
  double edge_simplex_m = 0.1;     ///< simplex at the coarsest edge level, m
  /// After the rotation stage, all six parameters at the finest level (false: the translation
  /// stays the start's).
  bool edge_translation_stage = true;
  double edge_simplex_deg = 1.0;   ///< and deg
  int edge_min_points = 100;       ///< fewer LiDAR edge points in the views: failed
  /// The edge score at the optimum (1 = the image's mean edge value, chance) must reach this:
  /// the calibrations of the three real frames score 1.11–1.56 (bench/RESULTS.md "Real
  /// vehicles: the geometric term"), a black image 0.
  double edge_min_score = 1.05;
  /// "ok" needs the largest σ of the angles and of the shifts within these.
  double edge_max_sigma_deg = 0.2;
  double edge_max_sigma_m = 0.05;
  /// σ = edge_sigma_scale · the scatter of the half-data and restart optima.
  double edge_sigma_scale = 1.0;
  /// σ floor: this many pixels, at edge_floor_depth_m for the shifts.
  double edge_floor_px = 0.5;
  double edge_floor_depth_m = 10.0;
  bool Check(std::string* error) const;
};

/// Per-axis scan of the metric around a pose: the paper's probe (Figs. 3, 11).
struct ProbeSample {
  int axis = 0;            ///< 0..5 = tx, ty, tz, roll, pitch, yaw
  double offset = 0;       ///< units (m or deg)
  MetricValue metric;
};

/// Time and metric evaluations of one stage of a registration (profiling, bench/RESULTS.md).
struct StageStat {
  std::string name;
  int evaluations = 0;
  double seconds = 0;      ///< wall time
  double cpu_seconds = 0;  ///< CPU time of the process (all its threads) during the stage
};

/// The acceptance tests of one registration, all measured (also when an earlier one failed).
struct AcceptanceChecks {
  bool on_bound = false;            ///< optimum at ≥ 90 % of the search bound in some parameter
  bool below_start = false;         ///< optimum's full-resolution search metric below the start's
  double sigma_px = -1;             ///< predicted pixel σ (median over visible points)
  int weak_directions = 0;          ///< no positive curvature / less than the box: box σ
  // NaN: not measured (the registration failed or the checks stopped before; JSON null).
  double effective_samples = std::numeric_limits<double>::quiet_NaN();  ///< N_eff of the Laplace covariance
  double sample_inflation = 1;      ///< covered pixels / N_eff (correlated pixels)
  int restarts_run = 0;
  double restart_spread_px = -1;    ///< largest median pixel distance restart ↔ optimum
  double restart_rms_px = -1;       ///< RMS pixel distance restart ↔ optimum, all points
  /// best restart metric − optimum metric (> 0: higher)
  double restart_best_gain = std::numeric_limits<double>::quiet_NaN();
  double mi_bits = std::numeric_limits<double>::quiet_NaN();           ///< MI at the optimum (pixel-centre samples)
  double mi_shuffled_bits = std::numeric_limits<double>::quiet_NaN();  ///< mean MI of the shuffled pairings
  double mi_shuffled_sd_bits = std::numeric_limits<double>::quiet_NaN();  ///< their standard deviation
  double mi_significance = std::numeric_limits<double>::quiet_NaN();   ///< (mi − shuffled mean) / shuffled sd
  bool scans_passed = false;        ///< per-axis scans: single peak, not flat
  std::string scans_reason;
  /// The check after which the acceptance stopped, the ones after it not measured
  /// (RegistrationOptions::measure_all_checks false and a check failed); empty when every
  /// check was measured.
  std::string stopped_after;
  /// Independent halves: number of halves re-optimised (0 = check off or not applicable),
  /// the median pixel distance of each half's own points between its optimum and the
  /// joint one (largest of the two), and how each half was formed.
  int split_parts = 0;
  double split_spread_px = -1;
  std::string split_kind;
  /// Calibration of the Laplace covariance Σ_L (`covariance` = variance_factor · Σ_L). The
  /// error of the optimum has a statistical part and an optimisation part (the rendered
  /// metric is piecewise constant at the pixel scale, so the optimum reached scatters);
  /// independent, so their variances add, each measured in pixels against Σ_L's prediction:
  /// * halves (a half-sample estimate, as the jackknife: Efron & Stein 1981; Shao & Tu
  ///   1995, Ch. 5.2): each half's estimate x_h differs from the joint x by
  ///   Var(x_h − x) = Σ_h − Σ ≈ Σ for two halves of equal information (Σ_h ≈ 2Σ), so
  ///     variance_factor_halves = Σ_h Σ_p ‖pixel_p(x_h) − pixel_p(x)‖² / Σ_h Σ_p tr(J_p Σ_L J_pᵀ)
  ///   over each half's own visible points p (J_p = ∂pixel/∂correction; in pixels, so the
  ///   directions one half alone cannot see, and wanders along, do not count);
  /// * restarts: variance_factor_restarts = mean_{k,p} ‖pixel_p(x_k) − pixel_p(x)‖² /
  ///   mean_p tr(J_p Σ_L J_pᵀ) over the restarts k and the visible points p.
  /// variance_factor = max(1, halves + restarts) — the halves' part stands for the whole
  /// statistical error (it replaces Σ_L's own 1), the restarts' part adds the optimiser's.
  /// A part not measured (halves or restarts off) is NaN and counts 0; with neither, the
  /// covariance stays Σ_L and variance_factor is 1.
  double variance_factor = 1;
  double variance_factor_halves = std::numeric_limits<double>::quiet_NaN();
  double variance_factor_restarts = std::numeric_limits<double>::quiet_NaN();
  /// sigma_px of the calibrated covariance (sigma_px is the Laplace one, which the
  /// acceptance checks: the conditioning of the maximum).
  double sigma_px_calibrated = -1;
  /// The same measured over the WHOLE image of frames whose views were cut from it
  /// (View::image_camera: a panorama registered on perspective cuts or cube faces) — the
  /// pose is the image's, and an error the cuts barely see (a turn about their axis offset by
  /// a shift) moves the rest of the image: on up to 2000 of the cloud's points that project
  /// anywhere into the image at the optimum (within range), in the image's pixels, the
  /// Laplace σ, the restarts' largest median distance, the halves' (each half's optimum
  /// against the joint one), the variance factor from the halves' and restarts' scatter as
  /// above, and the calibrated σ. −1 when no view is a cut (the views are the image).
  double image_sigma_px = -1;
  double image_restart_spread_px = -1;
  double image_split_spread_px = -1;
  double image_variance_factor = -1;
  double image_sigma_px_calibrated = -1;
  /// The factor of the reported covariance (RegistrationResult::covariance = covariance_factor
  /// · covariance_laplace, before the pixel-isotropic floor): variance_factor, or, for views
  /// cut from the frame's image, max(variance_factor, image_variance_factor). One scale factor of Σ_L estimated on a set
  /// of points weighs the directions those points see; Σ_L's shape is not exact, and the
  /// directions the cuts see little of move the rest of the panorama most, so the views'
  /// points alone gave a covariance over-confident for the whole panorama, whose
  /// pose it is and where `mmba adjust` uses it (bench/RESULTS.md, "Point samples as the
  /// default"). The larger factor keeps the covariance honest over both sets of points. The
  /// acceptance checks use each set's own factor (sigma_px_calibrated,
  /// image_sigma_px_calibrated).
  double covariance_factor = 1;
  /// Directions (0..6) in which RegistrationOptions::covariance_pixel_floor raised the
  /// reported covariance above covariance_factor · covariance_laplace.
  int covariance_floor_directions = 0;
};

struct RegistrationResult {
  std::string status = "failed";  ///< "ok" or "failed"
  std::string reason;
  Rigid3d cam_from_lidar;          ///< the corrected pose (the start when failed early)
  Vector6d correction = Vector6d::Zero();
  /// m², deg²: the Laplace covariance times checks.covariance_factor (calibrated), raised to
  /// the pixel-isotropic floor (RegistrationOptions::covariance_pixel_floor).
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  /// The Laplace covariance (N_eff · −∇²MI)⁻¹ before the calibration.
  Eigen::Matrix<double, 6, 6> covariance_laplace = Eigen::Matrix<double, 6, 6>::Zero();
  bool covariance_valid = false;
  bool trusted = false;            ///< confidence flag: single clear peak
  std::string confidence_reason;
  AcceptanceChecks checks;
  MetricValue metric_before;
  MetricValue metric_after;
  /// The metric optimised (RegistrationOptions::metric.kind). MetricValue::value is "larger =
  /// better", so it holds −NID for NID; BriefReport and ResultToJson give NID itself.
  MetricKind metric_kind = MetricKind::kNmi;
  int iterations = 0;              ///< Nelder–Mead + gradient iterations, all levels
  int evaluations = 0;
  double runtime_seconds = 0;
  std::vector<StageStat> stages;   ///< in order of execution
  /// Multi-frame only: frames used and frames rejected, with reasons.
  std::vector<std::string> used_frames;
  std::vector<std::pair<std::string, std::string>> rejected_frames;
  std::vector<RegistrationResult> frame_results;  ///< per frame (multi-frame only)

  /// RegisterEdges: the geometric term's figures.
  bool edge_term = false;
  int edge_points = 0;            ///< LiDAR depth-edge points in the views
  int edge_intensity_points = 0;  ///< intensity-edge points
  double edge_peakedness = 0;     ///< of each term over the rotation grid, MAD-σ
  double mi_peakedness = 0;
  double edge_mi_weight = 0;      ///< MI term's weight (0: edges alone)
  double edge_score_before = 0;   ///< edge score at the start and the result (1 = chance)
  double edge_score_after = 0;
  double sigma_deg = 0;           ///< the covariance's largest σ of the angles, deg
  double sigma_m = 0;             ///< and of the shifts, m

  bool ok() const { return status == "ok"; }
  std::string BriefReport() const;
  /// A 64-bit FNV-1a digest of everything the registration decided, bit for bit: status,
  /// reason, pose, correction, both covariances, the metrics before/after, the numbers of the
  /// acceptance checks, iterations and evaluations (not the times, not the stage names), and
  /// those of the frame results. Equal digests = reproduced results (for tests and benches).
  uint64_t Digest() const;
};

/// Evaluates the metric of a set of frames (sharing one pose) at a pose, at pyramid level
/// `level` (0 = full resolution). At construction the points are culled to those that can
/// reach a view from anywhere inside the search bounds around `cam_from_lidar_start`, and
/// each level keeps at most `max_points_per_pixel`·2^level points per view pixel (a deterministic
/// even subsample), so that an evaluation costs O(pixels), not O(cloud).
/// Thread-safe: each thread renders into its own buffer.
class FrameSetEvaluator {
 public:
  /// `parent` (optional): an evaluator with the same start pose, bounds and ranges whose
  /// frames contain these frames' views (the halves of SplitIntoHalves: a subset of the
  /// views, or a view's columns); the cull then tests only the points `parent` kept for the
  /// frame of the same name and cloud — the same points as testing the whole cloud, since
  /// a point that reaches one of these views reached the parent's (a frame without a unique
  /// match is culled from its whole cloud). The cull runs on two threads when a core is free.
  FrameSetEvaluator(const std::vector<Frame>& frames, const Rigid3d& cam_from_lidar_start,
                    const RegistrationOptions& options,
                    const FrameSetEvaluator* parent = nullptr);
  int levels() const { return static_cast<int>(pyramid_.size()); }
  MetricValue Evaluate(const Rigid3d& cam_from_lidar, int level,
                       const MetricOptions& metric) const;
  MetricValue Evaluate(const Rigid3d& cam_from_lidar, int level) const {
    return Evaluate(cam_from_lidar, level, options_.metric);
  }
  /// Visibility frozen at a reference pose for one pyramid level: each view rendered once
  /// there, its covered pixels turned into samples of their winning points (point_samples.h).
  struct SampleSet {
    int level = -1;
    Rigid3d reference;
    std::vector<ViewSamples> views;  ///< frame-major, each frame's views in order
    size_t samples = 0;
    /// Whole-image metric (options.metric.region): per view, the padded photo histogram of
    /// its background and its samples at the reference (JointHistogram::
    /// AddBackgroundComplement), for options.metric's bins at this level; empty otherwise.
    std::vector<std::vector<double>> background;
    std::vector<double> view_pixels;
  };
  /// True when `metric` can be evaluated from samples (options.point_samples, B-spline
  /// histogram; the overlap region, or the whole image when it is the options' region with
  /// the options' bins: the background as the complement of the samples).
  bool UsesSamples(const MetricOptions& metric) const;
  /// `per_point`: one weighted sample per visible point (options.SamplePerPoint), or one
  /// per covered pixel.
  SampleSet MakeSampleSet(const Rigid3d& cam_from_lidar, int level, bool per_point) const;
  /// Largest displacement of the set's probe points between its reference and a pose, in
  /// pixels of the set's level.
  double SampleSetDisplacementPx(const SampleSet& set, const Rigid3d& cam_from_lidar) const;
  /// The metric from the samples of `set` when `set` is not null, of this level and
  /// UsesSamples(metric); rendered otherwise. With samples, the work is split over two
  /// threads unless called from a parallel loop whose other workers are all still busy.
  MetricValue Evaluate(const Rigid3d& cam_from_lidar, int level, const MetricOptions& metric,
                       const SampleSet* set) const;
  /// MI (bits) of the pixel-centre samples at a pose, and of `shuffles` random permutations
  /// of the photo values over the same samples (the no-information baseline).
  void EvaluateShuffled(const Rigid3d& cam_from_lidar, int level, int shuffles,
                        double* mi_bits, std::vector<double>* shuffled_mi_bits) const;
  /// A sample (at most `max_points`) of the LiDAR points visible at a pose (full resolution).
  struct VisiblePoint {
    int frame = 0;
    int view = 0;
    Eigen::Vector3d point_in_lidar;
  };
  std::vector<VisiblePoint> SampleVisiblePoints(const Rigid3d& cam_from_lidar,
                                                size_t max_points) const;
  /// Full-resolution pixel of a visible point under a pose; false when it does not project.
  bool Project(const VisiblePoint& point, const Rigid3d& cam_from_lidar,
               Eigen::Vector2d* pixel) const;
  /// Median pixel distance of the sample between two poses (seam-aware for panoramas), in
  /// pixels of the frame's image (View::image_pixels_per_pixel).
  double MedianPixelDistance(const std::vector<VisiblePoint>& sample, const Rigid3d& a,
                             const Rigid3d& b) const;
  /// Effective number of independent samples at a pose and level: the covered pixels
  /// divided by Bartlett's variance-inflation factor Σ_lag ρ_L(lag)·ρ_P(lag) of two
  /// autocorrelated fields (Bartlett 1935; Bretherton et al. 1999, Eq. (31)), ρ_L and ρ_P
  /// the autocorrelations of the LiDAR image and the photo over the covered pixels, lags
  /// within ±max_lag pixels. `inflation` (optional) receives the factor (≥ 1).
  double EffectiveSamples(const Rigid3d& cam_from_lidar, int level, int max_lag,
                          double* inflation = nullptr) const;
  /// Fraction of view pixels covered by LiDAR at a pose (full resolution).
  double CoveredFraction(const Rigid3d& cam_from_lidar) const;
  size_t VisiblePoints(const Rigid3d& cam_from_lidar, int level = 0) const;
  const std::vector<Frame>& frames() const { return frames_; }
  /// Time spent rendering and filling histograms since construction (profiling).
  double render_seconds() const { return 1e-9 * render_ns_.load(); }
  double histogram_seconds() const { return 1e-9 * histogram_ns_.load(); }
  double sample_seconds() const { return 1e-9 * sample_ns_.load(); }
  int sample_sets_built() const { return sample_sets_.load(); }
  int sample_evaluations() const { return sample_evaluations_.load(); }

 private:
  std::vector<Frame> frames_;
  RegistrationOptions options_;
  /// Whether a render of `points` draws its footprints on two threads (a core is free and
  /// the points are many enough to pay for a thread): the same image either way.
  bool SplitRender(const LidarPoints& points) const;
  std::vector<std::vector<std::vector<View>>> pyramid_;  ///< level → frame → views
  std::vector<std::vector<LidarPoints>> points_;           ///< level → frame → culled points
  Rigid3d start_;
  /// Per frame, the indices of the cloud's points the cull kept, in cloud order (empty for
  /// an evaluator made with a parent: only parents pass theirs on).
  std::vector<std::vector<uint32_t>> kept_;
  mutable std::atomic<int64_t> render_ns_{0};
  mutable std::atomic<int64_t> histogram_ns_{0};
  mutable std::atomic<int64_t> sample_ns_{0};
  mutable std::atomic<int> sample_sets_{0};
  mutable std::atomic<int> sample_evaluations_{0};
};

/// Two independent halves of a frame set (for the split check): with two or more frames that
/// have views, the frames alternately (a rig calibration's frames: one half must agree with
/// the other); with one frame of two or more views, the views alternately (a frame's two
/// perspective cuts: one each; a cube's four faces: two opposite faces each); with a single
/// view, its left and right halves (CropView). `kind` (optional) receives "frames", "views"
/// or "left/right halves". Both empty when there is nothing to halve (no view, or a single
/// view narrower than 16 pixels).
std::array<std::vector<Frame>, 2> SplitIntoHalves(const std::vector<Frame>& frames,
                                                  std::string* kind = nullptr);
/// Columns [col0, col1) of a view: the image cropped and the principal point shifted (any
/// model, including the equirectangular one, whose columns outside are then not drawn).
View CropView(const View& view, int col0, int col1);

/// Registers frames sharing one pose by the geometric term (edges.h) and, with intensity, MI:
/// a grid over the rotation at the coarsest edge level, coarse-to-fine Nelder–Mead from its
/// best points, restarts, and the covariance from the scatter of the optima of independent
/// halves of the data (left/right, upper/lower, odd/even frames) and of the restarts.
RegistrationResult RegisterEdges(const std::vector<Frame>& frames, const Rigid3d& cam_from_lidar_start,
                                 const RegistrationOptions& options);

/// Registers one frame (or several frames sharing one pose, treated as one image set).
RegistrationResult RegisterFrames(const std::vector<Frame>& frames,
                                  const Rigid3d& cam_from_lidar_start,
                                  const RegistrationOptions& options);

/// Rig calibration: one cam_from_lidar shared by many frames. Each frame is registered alone
/// first (with `frame_restarts` restarts); frames that carry no information alone (optimum on
/// the search bound or below the start, MI not above the shuffled baseline, a flat or
/// multi-peaked axis scan; a frame's own pixel σ is not asked for: weak frames are what the
/// joint registration is for) or whose correction disagrees with the median of the others by
/// more than 3 robust σ (MAD) are rejected; the kept frames are registered jointly (sum of their metrics, all acceptance
/// checks), and the covariance comes from the summed curvature.
struct RigOptions {
  RegistrationOptions registration;
  double disagree_floor_m = 0.05;    ///< a frame disagrees only beyond max(3σ_MAD, floor)
  double disagree_floor_deg = 0.3;
  int min_frames = 2;
  /// Restarts of each frame's own registration (a screening: the agreement between frames
  /// plays their part there); the joint registration uses `registration.restarts`.
  int frame_restarts = 0;
};
RegistrationResult RegisterRig(const std::vector<Frame>& frames,
                               const Rigid3d& cam_from_lidar_start, const RigOptions& options);

/// The probe: each parameter perturbed from −range to +range in `step` units around `pose`
/// (others fixed), at pyramid `level` (0 = full resolution). Paper: ±2 units, 0.1 step.
std::vector<ProbeSample> Probe(const FrameSetEvaluator& evaluator, const Rigid3d& pose,
                               double range = 2.0, double step = 0.1, int level = 0);
/// Writes probe.csv (axis, offset, mi, nmi, nid, joint_entropy, samples) and one PNG plot
/// per axis (probe_<axis>.png: MI, NMI, joint entropy, each normalised to its own range)
/// atomically into `dir`.
void WriteProbe(const std::vector<ProbeSample>& samples, const std::string& dir);

/// Pixel offsets between the projections of the LiDAR points seen by `view` under a
/// reference pose and under an estimate: how far the result moves the LiDAR points' projections
/// from where the calibration's own pose puts them. Points within [min, max] range.
struct PixelOffsetStats {
  size_t points = 0;
  double median_px = 0;
  double mean_px = 0;
  double p90_px = 0;
  double max_px = 0;
  std::vector<double> offsets_px;  ///< one per point (for histograms)
};
PixelOffsetStats PixelOffsets(const LidarPoints& points, const View& view,
                              const Rigid3d& cam_from_lidar_reference,
                              const Rigid3d& cam_from_lidar_estimate,
                              const RenderOptions& render);

/// The weakly observed direction of the search box (the scan of
/// RegistrationOptions::scan_weak_direction): the combination of the six corrections that
/// moves the visible points least relative to the bounds — the eigenvector of the smallest
/// eigenvalue of B·M·B, M = Σ JᵀJ over `jacobians` (∂pixel/∂correction, pixels per m and
/// per degree, as in RaiseToPixelFloor), B = diag(`bound`). Returned as a correction (m,
/// deg) whose largest component relative to its bound is ±1 bound (the sign is arbitrary).
/// Along it the image changes least, so the metric can have a second maximum far off along
/// it while the pixels barely differ — a camera lowered and tilted back with its far scene
/// in place (bench/RESULTS.md, "The weakly observed direction") — which the one-parameter
/// axis scans do not cross. Zero without Jacobians.
Vector6d WeaklyObservedDirection(const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians,
                                 const Vector6d& bound);

/// The pixel-isotropic floor of the reported covariance (RegistrationOptions::
/// covariance_pixel_floor), for `jacobians` ∂pixel/∂correction of the visible points (pixels
/// per m and per degree). Σ_P = (v / 6) · M⁻¹ with M = mean JᵀJ over the points: the
/// covariance of a pose error that moves the points by the same mean squared pixel distance v
/// in every direction the points see, i.e. the shape of a least-squares fit of the points'
/// pixel positions (Hartley & Zisserman, "Multiple View Geometry", 2nd ed., Sec. 5.2.3,
/// Σ = (JᵀΣ_x⁻¹J)⁻¹ with isotropic Σ_x), scaled so that trace(M Σ_P) = v. Returns `covariance`
/// raised to at least Σ_P in every direction, and left as it is where it already is: with
/// Σ_P = L Lᵀ and L⁻¹ covariance L⁻ᵀ = V diag(a) Vᵀ, L V diag(max(a, 1)) Vᵀ Lᵀ (at least
/// both matrices). `raised`: the directions lifted (a < 1). Unchanged when M is not positive
/// definite or v ≤ 0.
Eigen::Matrix<double, 6, 6> RaiseToPixelFloor(
    const Eigen::Matrix<double, 6, 6>& covariance,
    const std::vector<Eigen::Matrix<double, 2, 6>>& jacobians, double mean_variance,
    int* raised);

/// Names of the six parameters: tx, ty, tz, roll, pitch, yaw.
const char* ParameterName(int axis);

}  // namespace mmba::registration::mi
