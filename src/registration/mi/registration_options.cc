#include <string>

#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/registration_settings.h"

namespace mmba::registration::mi {
namespace {

using Options = RegistrationOptions;

// A level of the pyramid: 0 = full resolution; levels beyond the pyramid mean its coarsest.
const SettingRange kLevel = SettingRange::Closed(0, 5);

void AddMetricAndRendering(SettingsTable<Options>* t) {
  t->Integer("bins", {&Options::metric, &MetricOptions::bins}, SettingRange::Closed(4, 1024),
             "joint histogram bins per axis (the paper: 256)")
      .Choice("smoothing",
              {[](const Options& o) { return SmoothingName(o.metric.smoothing); },
               [](Options* o, std::string v) { ParseSmoothing(v, &o->metric.smoothing); }},
              {"none", "parzen", "bspline"}, "histogram smoothing")
      .Number("parzen_sigma_bins", {&Options::metric, &MetricOptions::parzen_sigma_bins},
              SettingRange::Open(0, 32), "Parzen window sigma, bins (smoothing parzen)")
      .Choice("region",
              {[](const Options& o) { return RegionName(o.metric.region); },
               [](Options* o, std::string v) { ParseRegion(v, &o->metric.region); }},
              {"whole", "overlap"}, "pixels the metric counts (points: whole unless set)")
      .Number("point_radius_m", {&Options::render, &RenderOptions::point_radius_m}, SettingRange::AtLeast(0),
              "point footprint: radius = this * f / range pixels")
      .Integer("max_point_radius_px", {&Options::render, &RenderOptions::max_point_radius_px},
               SettingRange::Closed(0, 16), "footprint cap, px")
      .Number("min_range_m", {&Options::render, &RenderOptions::min_range_m}, SettingRange::Above(0),
              "points nearer than this are ignored, m")
      .Number("max_range_m", {&Options::render, &RenderOptions::max_range_m}, SettingRange::Above(0),
              "points farther than this are ignored, m (> min_range_m)");
}

void AddSearch(SettingsTable<Options>* t) {
  t->Number("bound_m", &Options::bound_translation_m, SettingRange::Above(0),
            "search box on the translation, +- m around the start")
      .Number("bound_deg", &Options::bound_rotation_deg, SettingRange::LeftOpen(0, 45),
              "search box on the rotation, +- deg around the start")
      .Integer("pyramid_levels", &Options::pyramid_levels, SettingRange::Closed(1, 6),
               "coarse-to-fine levels (1 = full resolution only)")
      .Integer("finest_nelder_mead_level", &Options::finest_nelder_mead_level, kLevel,
               "Nelder-Mead down to this level; finer ones get the gradient refinement only")
      .Number("simplex",
              {[](const Options& o) { return o.nelder_mead.initial_step.minCoeff(); },
               [](Options* o, double v) { o->nelder_mead.initial_step = Vector6d::Constant(v); }},
              SettingRange::Above(0), "initial simplex edge, m and deg (the paper: 1)")
      .Integer("max_iterations", {&Options::nelder_mead, &NelderMeadOptions::max_iterations},
               SettingRange::AtLeast(1), "Nelder-Mead iterations per level (the paper: 200)")
      .Number("parameter_tolerance", {&Options::nelder_mead, &NelderMeadOptions::parameter_tolerance},
              SettingRange::Above(0), "Nelder-Mead stops when the simplex is within this, m and deg")
      .Number("function_tolerance", {&Options::nelder_mead, &NelderMeadOptions::function_tolerance},
              SettingRange::AtLeast(0), "and its values within this (the paper: 0.001)")
      .Integer("pyramid_paths", &Options::pyramid_paths, SettingRange::Closed(1, 6),
               "searches entering at the coarsest level and each of the next N-1 finer ones")
      .Flag("pyramid_paths_adaptive", &Options::pyramid_paths_adaptive,
            "enter at the finest level only when the coarser entries end apart")
      .Integer("coarse_starts", &Options::coarse_starts, SettingRange::Closed(0, 256),
               "extra Nelder-Mead starts at the coarsest level over the bounds (0 = the paper's one)")
      .Number("coarse_spread", &Options::coarse_start_spread, SettingRange::LeftOpen(0, 1),
              "coarse starts within +- this fraction of the bounds")
      .Integer("coarse_candidates", &Options::coarse_candidates, SettingRange::Closed(1, 32),
               "distinct coarse optima carried to full resolution")
      .Flag("gradient_refinement", &Options::gradient_refinement,
            "gradient ascent on the B-spline histogram after Nelder-Mead")
      .Integer("gradient_max_iterations", &Options::gradient_max_iterations, SettingRange::AtLeast(0),
               "gradient ascent iterations")
      .Number("max_points_per_pixel", &Options::max_points_per_pixel, SettingRange::Above(0),
              "points kept per view pixel at full resolution, doubled per coarser level")
      .Integer("threads", &Options::threads, SettingRange::Closed(1, 256),
               "threads for independent metric evaluations");
}

void AddPointSamples(SettingsTable<Options>* t) {
  t->Flag("point_samples", &Options::point_samples,
          "metric from the visible points' projections (false: every pose rendered)")
      .Number("sample_rebuild_px", &Options::sample_rebuild_px, SettingRange::Above(0),
              "point samples re-rendered when the pose moved the image by more, px of the level")
      .Integer("per_point_samples_from_level", &Options::per_point_samples_from_level, SettingRange::AtLeast(0),
               "levels from this one use one sample per point, finer ones one per pixel")
      .Integer("sample_block_px", &Options::sample_block_px, SettingRange::Closed(0, 256),
               "a point sampled at its projection, weighted by its N x N block's pixels (0: its won pixels)")
      .Flag("covariance_per_point_samples", &Options::covariance_per_point_samples,
            "the covariance fit on one sample per point (false: per pixel)")
      .Flag("point_samples_in_checks", &Options::point_samples_in_checks,
            "point samples in the restarts and halves too");
}

void AddAcceptance(SettingsTable<Options>* t) {
  t->Number("min_covered_fraction", &Options::min_covered_fraction, SettingRange::Closed(0, 1),
            "fraction of view pixels covered by LiDAR at the start")
      .Number("max_dark_or_saturated", &Options::max_dark_or_saturated, SettingRange::Closed(0, 1),
              "fraction of photo pixels <= 5 or >= 250")
      .Number("min_photo_stdev", &Options::min_photo_stdev, SettingRange::AtLeast(0), "photo grey levels")
      .Number("min_relative_peak", &Options::min_relative_peak, SettingRange::AtLeast(0),
              "axis scans: the peak above the scan's mean by this fraction of |peak|")
      .Flag("check_multiple_peaks", &Options::check_multiple_peaks, "axis scans: no second peak within it")
      .Flag("weak_direction_scan", &Options::scan_weak_direction,
            "scan also along the weakly observed direction across the search box")
      .Integer("effective_sample_lag", &Options::effective_sample_max_lag, SettingRange::Closed(0, 64),
               "covariance: correlated pixels counted over lags within this many px (0: points independent)")
      .Integer("covariance_level", &Options::covariance_level, kLevel, "pyramid level of the covariance fit")
      .Number("max_sigma_px", &Options::max_sigma_px, SettingRange::Above(0),
              "largest predicted pixel sigma (Laplace covariance)")
      .Number("max_calibrated_sigma_px", &Options::max_calibrated_sigma_px, SettingRange::Above(0),
              "largest pixel sigma of the calibrated covariance")
      .Integer("restarts", &Options::restarts, SettingRange::Closed(0, 32),
               "re-optimisations from around the optimum that must agree")
      .Integer("restart_level", &Options::restart_level, kLevel,
               "pyramid level of the restarts (0: more precise, ~4x cost)")
      .Integer("polish_rounds", &Options::polish_rounds, SettingRange::Closed(0, 3),
               "a restart ending higher beyond the tolerance becomes the optimum, this often")
      .Number("restart_offset_m", &Options::restart_offset_m, SettingRange::Above(0), "restart offsets, m")
      .Number("restart_offset_deg", &Options::restart_offset_deg, SettingRange::Above(0), "restart offsets, deg")
      .Number("restart_tolerance_px", &Options::restart_tolerance_px, SettingRange::Above(0),
              "largest median pixel distance of a restart from the optimum")
      .Integer("shuffles", &Options::shuffles, SettingRange::Closed(2, 100),
               "permutations of the shuffled-pairing baseline")
      .Number("min_mi_gain_bits", &Options::min_mi_gain_bits, SettingRange::Any(),
              "MI above the shuffled baseline by at least this, bits")
      .Number("min_mi_significance", &Options::min_mi_significance, SettingRange::Any(),
              "and by this many sigmas of the shuffled MI")
      .Flag("halves", &Options::split_check, "two independent halves of the data must agree")
      .Integer("split_level", &Options::split_level, kLevel, "pyramid level of the halves' re-optimisation")
      .Number("split_tolerance_px", &Options::split_tolerance_px, SettingRange::Above(0),
              "largest median pixel distance of a half's optimum from the joint one")
      .Flag("calibrate_covariance", &Options::calibrate_covariance,
            "scale the Laplace covariance by the halves' and restarts' scatter")
      .Flag("covariance_pixel_floor", &Options::covariance_pixel_floor,
            "raise the covariance to at least the calibrated pixel sigma in every direction")
      .Flag("whole_image_checks", &Options::whole_image_checks,
            "a panorama registered on cuts must pass the calibrated sigma over the whole panorama")
      .Flag("all_checks", &Options::measure_all_checks,
            "measure every check after one has failed (diagnostics; slower)");
}

void AddEdges(SettingsTable<Options>* t) {
  t->Choice("edges", &Options::edges, {"auto", "on", "off"},
            "geometric term (LiDAR edges against image edges) with MI; auto: LiDAR sweeps and a perspective camera")
      .Flag("edge_mi", &Options::edge_mi, "add MI on intensity to the geometric term, weighted from the data")
      .Number("edge_mi_scale", &Options::edge_mi_scale, SettingRange::AtLeast(0), "times the data's MI weight")
      .Integer("edge_mi_level", &Options::edge_mi_level, SettingRange::Closed(0, 5),
               "finest pyramid level of the MI term (each level 4x fewer pixels to render)")
      .Number("edge_cell_deg", {&Options::edge, &EdgeOptions::cell_deg}, SettingRange::LeftOpen(0, 5),
              "LiDAR scan grid cell (azimuth x elevation), deg")
      .Integer("edge_neighbour_cells", {&Options::edge, &EdgeOptions::neighbour_cells}, SettingRange::Closed(1, 64),
               "ring neighbours searched within this many cells")
      .Number("edge_min_jump_m", {&Options::edge, &EdgeOptions::min_jump_m}, SettingRange::Above(0),
              "depth edge: a neighbour farther by at least this, m")
      .Number("edge_jump_fraction", {&Options::edge, &EdgeOptions::jump_fraction}, SettingRange::AtLeast(0),
              "or by this fraction of the range")
      .Number("edge_intensity_quantile", {&Options::edge, &EdgeOptions::intensity_quantile},
              SettingRange::LeftOpen(0, 1), "intensity edges above this quantile of ring differences (1: none)")
      .Number("edge_alpha", {&Options::edge, &EdgeOptions::alpha}, SettingRange::Closed(0, 1),
              "Levinson & Thrun's alpha: edge image weight in D")
      .Number("edge_gamma", {&Options::edge, &EdgeOptions::gamma}, SettingRange::Open(0, 1),
              "Levinson & Thrun's gamma: decay per pixel of the spread edges")
      .Number("edge_blur_px", {&Options::edge, &EdgeOptions::blur_px}, SettingRange::AtLeast(0),
              "photo blur before its edges at the finest level, px")
      .Number("edge_level_blur_factor", {&Options::edge, &EdgeOptions::level_blur_factor}, SettingRange::AtLeast(1),
              "blur and spread grow by this per coarser level")
      .Integer("edge_levels", {&Options::edge, &EdgeOptions::levels}, SettingRange::Closed(1, 6),
               "coarse-to-fine edge levels")
      .Number("edge_bound_m", &Options::edge_bound_m, SettingRange::Above(0),
              "edge registration's search box, +- m around the start")
      .Number("edge_bound_deg", &Options::edge_bound_deg, SettingRange::LeftOpen(0, 45),
              "edge registration's search box, +- deg around the start")
      .Number("edge_grid_step_deg", &Options::edge_grid_step_deg, SettingRange::Above(0),
              "global stage: rotation grid step over +-edge_bound_deg, deg")
      .Integer("edge_grid_keep", &Options::edge_grid_keep, SettingRange::Closed(1, 64),
               "grid points searched on")
      .Flag("edge_translation_stage", &Options::edge_translation_stage,
            "after the rotation stage, all six parameters (false: the start's translation kept)")
      .Number("edge_simplex_m", &Options::edge_simplex_m, SettingRange::Above(0), "coarsest simplex, m")
      .Number("edge_simplex_deg", &Options::edge_simplex_deg, SettingRange::Above(0), "coarsest simplex, deg")
      .Integer("edge_min_points", &Options::edge_min_points, SettingRange::AtLeast(1),
               "fewer LiDAR edge points in the views: failed")
      .Number("edge_min_score", &Options::edge_min_score, SettingRange::AtLeast(0),
              "edge score at the optimum (1 = chance) at least")
      .Number("edge_max_sigma_deg", &Options::edge_max_sigma_deg, SettingRange::Above(0),
              "ok: largest sigma of the angles, deg")
      .Number("edge_max_sigma_m", &Options::edge_max_sigma_m, SettingRange::Above(0),
              "ok: largest sigma of the shifts, m")
      .Number("edge_sigma_scale", &Options::edge_sigma_scale, SettingRange::Above(0),
              "sigma = this x the scatter of half-data and restart optima")
      .Number("edge_floor_px", &Options::edge_floor_px, SettingRange::AtLeast(0), "sigma floor, px")
      .Number("edge_floor_depth_m", &Options::edge_floor_depth_m, SettingRange::Above(0),
              "depth at which the floor is taken for the shifts, m");
}

}  // namespace

const SettingsTable<RegistrationOptions>& RegistrationSettingsTable() {
  static const SettingsTable<Options> table = [] {
    SettingsTable<Options> t("mmba register-mi --help lists them");
    AddMetricAndRendering(&t);
    AddSearch(&t);
    AddPointSamples(&t);
    AddAcceptance(&t);
    AddEdges(&t);
    return t;
  }();
  return table;
}

bool RegistrationOptions::Check(std::string* error) const {
  if (!metric.Check(error) || !render.Check(error)) return false;
  return RegistrationSettingsTable().Check(*this, error);
}

}  // namespace mmba::registration::mi
