// Registration by the geometric term (Levinson & Thrun, RSS 2013) with MI on intensity where
// the data hold it: a global stage over the rotation at the coarsest edge level, coarse-to-fine
// Nelder–Mead, restarts, and a covariance from the scatter of independent parts of the data.

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>

#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/registration/mi/edges.h"
#include "mmba/registration/mi/mi_registration.h"
#include "mmba/registration/mi/nelder_mead.h"
#include "registration/mi/mi_internal.h"
#include "registration/mi/search.h"

namespace mmba::registration::mi {

namespace {

using internal::Fixed;
using internal::OnBound;
using internal::PerParameter;
using internal::RestartOffsets;

// The objective: the edge score plus, where the intensity is compared, the MI term weighted
// from the data (EdgeObjective::Weigh).
struct EdgeObjective {
  const EdgeMetric& edges;
  const FrameSetEvaluator* mi = nullptr;  ///< null: the geometric term alone
  const Rigid3d& start;
  double mi_weight = 0;  ///< per unit of the MI metric's value
  int mi_levels = 1;
  int edge_levels = 1;

  // Level l of the search: the edge level l and the MI level min(l, MI levels − 1).
  double operator()(const Vector6d& x, int level, uint8_t mask = 0, uint8_t value = 0) const {
    const Rigid3d pose = ApplyCorrection(start, x);
    double f = edges.Evaluate(pose, level, mask, value);
    if (mi != nullptr && mi_weight > 0) {
      f += mi_weight * mi->Evaluate(pose, std::min(level, mi_levels - 1)).value;
    }
    return f;
  }
};

// The global stage's points: a grid over roll, pitch and yaw (±bound, `step_deg`) at the
// translation of the start.
std::vector<Vector6d> RotationGrid(double bound_deg, double step_deg) {
  const int half = static_cast<int>(std::floor(bound_deg / step_deg + 1e-9));
  std::vector<Vector6d> grid;
  for (int a = -half; a <= half; ++a) {
    for (int b = -half; b <= half; ++b) {
      for (int c = -half; c <= half; ++c) {
        Vector6d x = Vector6d::Zero();
        x.tail<3>() << a * step_deg, b * step_deg, c * step_deg;
        grid.push_back(x);
      }
    }
  }
  return grid;
}

// The `keep` points of `grid` with the largest `values`, best first.
std::vector<Vector6d> BestOf(const std::vector<Vector6d>& grid, const std::vector<double>& values, int keep) {
  std::vector<size_t> order(grid.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return values[a] > values[b]; });
  std::vector<Vector6d> best;
  for (size_t k = 0; k < order.size() && static_cast<int>(best.size()) < keep; ++k) best.push_back(grid[order[k]]);
  return best;
}

// Nelder–Mead from x0 at levels top .. 0, the simplex `step` at the top, halved per level.
internal::SearchResult CoarseToFine(const EdgeObjective& f, const Vector6d& x0, int top,
                                    const Vector6d& step, const Vector6d& bound,
                                    const RegistrationOptions& options, uint8_t mask = 0,
                                    uint8_t value = 0) {
  internal::SearchResult result;
  result.x = x0;
  for (int level = top; level >= 0; --level) {
    NelderMeadOptions nm;
    nm.initial_step = step * std::pow(0.5, top - level);
    nm.parameter_tolerance = 0.002;
    nm.function_tolerance = 1e-5;
    nm.max_iterations = options.nelder_mead.max_iterations;
    nm.lower = -bound;
    nm.upper = bound;
    const NelderMeadResult r =
        MaximizeNelderMead([&](const Vector6d& x) { return f(x, level, mask, value); }, result.x, nm);
    result.x = r.x;
    result.value = r.value;
    result.iterations += r.iterations;
    result.evaluations += r.evaluations;
  }
  return result;
}

double MedianOf(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// The robust σ of values (1.4826 · their median absolute deviation).
double MadSigma(const std::vector<double>& values) {
  const double median = MedianOf(values);
  std::vector<double> deviations;
  for (double v : values) deviations.push_back(std::abs(v - median));
  return 1.4826 * MedianOf(deviations);
}

// A term's peak over the grid: (best − median) in units of its MAD-σ.
double Peakedness(const std::vector<double>& values) {
  if (values.size() < 3) return 0;
  const double sigma = MadSigma(values);
  return sigma > 0 ? (*std::max_element(values.begin(), values.end()) - MedianOf(values)) / sigma : 0;
}

}  // namespace

RegistrationResult RegisterEdges(const std::vector<Frame>& frames, const Rigid3d& start,
                                 const RegistrationOptions& options) {
  Timer timer;
  RegistrationResult result;
  result.cam_from_lidar = start;
  result.edge_term = true;
  const Vector6d bound = PerParameter(options.edge_bound_m, options.edge_bound_deg);
  const EdgeOptions& eo = options.edge;
  const EdgeMetric edges(frames, start, eo, options.edge_bound_deg + 1.0);
  result.edge_points = static_cast<int>(edges.points(0));
  result.edge_intensity_points = static_cast<int>(edges.points(1));
  if (edges.points(0) + edges.points(1) < static_cast<size_t>(options.edge_min_points)) {
    result.reason = "too few LiDAR edge points in the image (" + std::to_string(edges.points(0)) + " depth, " +
                    std::to_string(edges.points(1)) + " intensity; at least " +
                    std::to_string(options.edge_min_points) + ")";
    result.runtime_seconds = timer.ElapsedSeconds();
    return result;
  }
  const bool intensity = std::all_of(frames.begin(), frames.end(),
                                     [](const Frame& f) { return f.points->has_intensity(); });
  std::unique_ptr<FrameSetEvaluator> mi;
  RegistrationOptions mi_options = options;  // culled for the edge registration's box
  mi_options.bound_translation_m = options.edge_bound_m;
  mi_options.bound_rotation_deg = options.edge_bound_deg;
  if (intensity && options.edge_mi) mi = std::make_unique<FrameSetEvaluator>(frames, start, mi_options);
  EdgeObjective f{edges, mi.get(), start, 0.0, mi ? mi->levels() : 1, edges.levels()};
  const int top = edges.levels() - 1;
  int evaluations = 0;
  // The global stage: the edge score over the rotation grid. With MI, its weight from a
  // grid three times coarser: each term in units of its spread there (MAD-σ), times its
  // peakedness (a term without a peak adds little), times edge_mi_scale.
  const int threads = std::max(1, options.threads);
  const std::vector<Vector6d> grid = RotationGrid(options.edge_bound_deg, options.edge_grid_step_deg);
  std::vector<double> grid_values(grid.size());
  ParallelFor(static_cast<int>(grid.size()), threads,
              [&](int k) { grid_values[k] = edges.Evaluate(ApplyCorrection(start, grid[k]), top); });
  evaluations += static_cast<int>(grid.size());
  if (mi) {
    const std::vector<Vector6d> coarse = RotationGrid(options.edge_bound_deg, 3 * options.edge_grid_step_deg);
    std::vector<double> edge_values(coarse.size()), mi_values(coarse.size());
    ParallelFor(static_cast<int>(coarse.size()), threads, [&](int k) {
      const Rigid3d pose = ApplyCorrection(start, coarse[k]);
      edge_values[k] = edges.Evaluate(pose, top);
      mi_values[k] = mi->Evaluate(pose, std::min(top, mi->levels() - 1)).value;
    });
    evaluations += static_cast<int>(coarse.size());
    const double pe = Peakedness(edge_values), pm = Peakedness(mi_values);
    const double se = MadSigma(edge_values), sm = MadSigma(mi_values);
    result.edge_peakedness = pe;
    result.mi_peakedness = pm;
    if (se > 0 && sm > 0 && pe > 0 && pm > 0) f.mi_weight = (pm / pe) * (se / sm) * options.edge_mi_scale;
    result.edge_mi_weight = f.mi_weight;
    spdlog::debug("edges: grid peakedness edges {:.2f}, MI {:.2f}; MI weight {:.4g}", pe, pm, f.mi_weight);
  }
  std::vector<Vector6d> candidates = BestOf(grid, grid_values, options.edge_grid_keep);
  if (std::none_of(candidates.begin(), candidates.end(), [](const Vector6d& x) { return x.isZero(); })) {
    candidates.push_back(Vector6d::Zero());
  }
  // Coarse to fine from each candidate, the rotation first (the translation at the start's:
  // a single frame's translation is the weakly observed part, and free from the first step
  // it trades against the rotation), then all six; the best at the finest level.
  const Vector6d step = PerParameter(options.edge_simplex_m, options.edge_simplex_deg);
  Vector6d rotation_bound = bound;
  rotation_bound.head<3>().setZero();
  std::vector<internal::SearchResult> ends(candidates.size());
  ParallelFor(static_cast<int>(candidates.size()), threads, [&](int k) {
    const internal::SearchResult rotation = CoarseToFine(f, candidates[k], top, step, rotation_bound, options);
    ends[k] = rotation;
    if (!options.edge_translation_stage) return;
    ends[k] = CoarseToFine(f, rotation.x, 0, 0.5 * step, bound, options);
    ends[k].iterations += rotation.iterations;
    ends[k].evaluations += rotation.evaluations;
  });
  size_t best = 0;
  for (size_t k = 0; k < ends.size(); ++k) {
    evaluations += ends[k].evaluations;
    result.iterations += ends[k].iterations;
    if (ends[k].value > ends[best].value) best = k;
  }
  Vector6d x = ends[best].x;
  const Vector6d free_bound = options.edge_translation_stage ? bound : rotation_bound;
  spdlog::debug("edges: grid best r/p/y ({:.2f}, {:.2f}, {:.2f}) deg (score {:.4f}, at the start {:.4f}); "
                "searched to t ({:.3f}, {:.3f}, {:.3f}) m, r/p/y ({:.2f}, {:.2f}, {:.2f}) deg, {:.4f}",
                candidates[0][3], candidates[0][4], candidates[0][5],
                edges.Evaluate(ApplyCorrection(start, candidates[0]), top), edges.Evaluate(start, top), x[0], x[1],
                x[2], x[3], x[4], x[5], ends[best].value);
  // Restarts around the optimum at the finest levels: the best replaces the optimum.
  const std::vector<Vector6d> offsets = RestartOffsets(options);
  std::vector<internal::SearchResult> restarts(offsets.size());
  const Vector6d restart_step = 2.0 * PerParameter(options.restart_offset_m, options.restart_offset_deg);
  ParallelFor(static_cast<int>(offsets.size()), threads, [&](int k) {
    restarts[k] = CoarseToFine(f, (x + offsets[k]).cwiseMin(free_bound).cwiseMax(-free_bound), std::min(1, top),
                               restart_step, free_bound, options);
  });
  double best_value = ends[best].value;
  for (const internal::SearchResult& r : restarts) {
    evaluations += r.evaluations;
    if (r.value > best_value) {
      best_value = r.value;
      x = r.x;
    }
  }
  Eigen::Matrix<double, 6, 6> restart_scatter = Eigen::Matrix<double, 6, 6>::Zero();
  for (const internal::SearchResult& r : restarts) restart_scatter += (r.x - x) * (r.x - x).transpose();
  if (!restarts.empty()) restart_scatter /= static_cast<double>(restarts.size());
  // Independent parts: the left and right halves of the views, the upper and lower, and with
  // several frames the odd and even frames, each re-optimised alone from the optimum. Two
  // halves of equal information: Var(x_A − x_B) = 2 · 2Σ, so Σ ≈ E[(x_A − x_B)(x_A − x_B)ᵀ] / 4.
  std::vector<uint8_t> masks = {EdgeMetric::kRight, EdgeMetric::kLower};
  if (frames.size() >= 2) masks.push_back(EdgeMetric::kOddFrame);
  std::vector<internal::SearchResult> halves(2 * masks.size());
  ParallelFor(static_cast<int>(halves.size()), threads, [&](int k) {
    const uint8_t mask = masks[k / 2];
    halves[k] = CoarseToFine(f, x, std::min(1, top), restart_step, free_bound, options, mask,
                             k % 2 == 0 ? 0 : mask);
  });
  Eigen::Matrix<double, 6, 6> split_scatter = Eigen::Matrix<double, 6, 6>::Zero();
  for (size_t s = 0; s < masks.size(); ++s) {
    evaluations += halves[2 * s].evaluations + halves[2 * s + 1].evaluations;
    const Vector6d d = halves[2 * s].x - halves[2 * s + 1].x;
    split_scatter += d * d.transpose() / 4.0;
  }
  split_scatter /= static_cast<double>(masks.size());
  Eigen::Matrix<double, 6, 6> covariance = options.edge_sigma_scale * options.edge_sigma_scale *
                                           (split_scatter + restart_scatter);
  // A floor of `edge_floor_px` at the median depth of the edge points (a pose is never known
  // better than the image's pixels allow).
  const double focal = frames[0].views[0].camera.MeanFocalLength();
  const double floor_deg = options.edge_floor_px / focal * 180.0 / M_PI;
  const double floor_m = options.edge_floor_px / focal * options.edge_floor_depth_m;
  for (int i = 0; i < 6; ++i) {
    const double floor = i < 3 ? floor_m : floor_deg;
    covariance(i, i) = std::max(covariance(i, i), floor * floor);
  }
  result.correction = x;
  result.cam_from_lidar = ApplyCorrection(start, x);
  result.covariance = covariance;
  result.covariance_laplace = covariance;
  result.covariance_valid = true;
  result.evaluations = evaluations;
  result.metric_before.value = f(Vector6d::Zero(), 0);
  result.metric_after.value = f(x, 0);
  result.edge_score_before = edges.Evaluate(start, 0);
  result.edge_score_after = edges.Evaluate(result.cam_from_lidar, 0);
  AcceptanceChecks& checks = result.checks;
  checks.restarts_run = static_cast<int>(restarts.size());
  checks.split_parts = static_cast<int>(halves.size());
  checks.split_kind = frames.size() >= 2 ? "left/right, upper/lower, odd/even frames" : "left/right, upper/lower";
  const int on = OnBound(x, bound);
  checks.on_bound = on >= 0;
  double sigma_deg = 0, sigma_m = 0;
  for (int i = 0; i < 3; ++i) {
    sigma_m = std::max(sigma_m, std::sqrt(covariance(i, i)));
    sigma_deg = std::max(sigma_deg, std::sqrt(covariance(i + 3, i + 3)));
  }
  result.sigma_deg = sigma_deg;
  result.sigma_m = sigma_m;
  static const char* kNames[6] = {"tx", "ty", "tz", "roll", "pitch", "yaw"};
  const std::string sigmas = "largest sigma " + Fixed(sigma_deg, 3) + " deg, " + Fixed(100 * sigma_m, 1) + " cm";
  if (on >= 0) {
    result.reason = std::string("optimum on the search bound of ") + kNames[on] + " (" + Fixed(x[on]) + ")";
  } else if (result.edge_score_after < options.edge_min_score) {
    result.reason = "LiDAR edges do not meet image edges: edge score " + Fixed(result.edge_score_after, 3) +
                    " < " + Fixed(options.edge_min_score, 2) + " (1 = chance)";
  } else if (sigma_deg > options.edge_max_sigma_deg || sigma_m > options.edge_max_sigma_m) {
    result.reason = "pose not determined to the accuracy asked: " + sigmas + " (limits " +
                    Fixed(options.edge_max_sigma_deg, 2) + " deg, " + Fixed(100 * options.edge_max_sigma_m, 1) +
                    " cm; independent parts of the data disagree)";
  } else {
    result.status = "ok";
    result.trusted = true;
    result.confidence_reason = "edges agree: " + sigmas + " from " + std::to_string(halves.size()) +
                               " half-data and " + std::to_string(restarts.size()) + " restart optima; edge score " +
                               Fixed(result.edge_score_after, 3);
  }
  result.runtime_seconds = timer.ElapsedSeconds();
  return result;
}

}  // namespace mmba::registration::mi
