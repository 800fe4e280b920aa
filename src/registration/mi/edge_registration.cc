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
  const MetricOptions& metric;  ///< the MI term's metric
  double mi_weight = 0;  ///< per unit of the MI metric's value
  int mi_levels = 1;
  int mi_finest = 0;  ///< RegistrationOptions::edge_mi_level
  int edge_levels = 1;

  bool UsesMi() const { return mi != nullptr && mi_weight > 0; }
  int MiLevel(int level) const { return std::min(std::max(level, mi_finest), mi_levels - 1); }
  // Level l of the search: the edge level l and the MI level min(l, MI levels − 1), MI from
  // the point samples `samples` when given (visibility frozen at their reference).
  double operator()(const Vector6d& x, int level, uint8_t mask = 0, uint8_t value = 0,
                    const FrameSetEvaluator::SampleSet* samples = nullptr) const {
    const Rigid3d pose = ApplyCorrection(start, x);
    double f = edges.Evaluate(pose, level, mask, value);
    if (UsesMi()) f += mi_weight * mi->Evaluate(pose, MiLevel(level), metric, samples).value;
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
    // With MI, its point samples at the pass's start (as Search does): one fixed function of
    // the correction per Nelder–Mead run, rebuilt and the run repeated with half the simplex
    // once when it ended farther than sample_rebuild_px from where they were made.
    const bool sampled = f.UsesMi() && options.point_samples && f.mi->UsesSamples(options.metric);
    for (int pass = 0; pass < 2; ++pass) {
      FrameSetEvaluator::SampleSet samples;
      const int mi_level = f.MiLevel(level);
      if (sampled) samples = f.mi->MakeSampleSet(ApplyCorrection(f.start, result.x), mi_level, options.SamplePerPoint(mi_level));
      const NelderMeadResult r = MaximizeNelderMead(
          [&](const Vector6d& x) { return f(x, level, mask, value, sampled ? &samples : nullptr); }, result.x, nm);
      result.x = r.x;
      result.value = r.value;
      result.iterations += r.iterations;
      result.evaluations += r.evaluations;
      if (!sampled ||
          !(f.mi->SampleSetDisplacementPx(samples, ApplyCorrection(f.start, r.x)) > options.sample_rebuild_px)) {
        break;
      }
      nm.initial_step = (0.5 * nm.initial_step).cwiseMax(2.0 * nm.parameter_tolerance);
    }
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

// RegisterEdges' steps, each a member: the global stage (and the MI term's weight), the
// coarse-to-fine searches from its best points, the restarts, the half-data optima, the
// covariance from their scatter, the decision.
class EdgeRegistration {
 public:
  EdgeRegistration(const std::vector<Frame>& frames, const Rigid3d& start, const RegistrationOptions& options)
      : frames_(frames),
        start_(start),
        options_(options),
        bound_(PerParameter(options.edge_bound_m, options.edge_bound_deg)),
        edges_(frames, start, options.edge, options.edge_bound_deg + 1.0),
        f_{edges_, nullptr, start, options.metric, 0.0, 1, edges_.levels()},
        top_(edges_.levels() - 1),
        threads_(std::max(1, options.threads)) {
    rotation_bound_ = bound_;
    rotation_bound_.head<3>().setZero();
    free_bound_ = options.edge_translation_stage ? bound_ : rotation_bound_;
    result_.cam_from_lidar = start;
    result_.edge_term = true;
    result_.edge_points = static_cast<int>(edges_.points(0));
    result_.edge_intensity_points = static_cast<int>(edges_.points(1));
  }

  RegistrationResult Run() {
    if (edges_.points(0) + edges_.points(1) < static_cast<size_t>(options_.edge_min_points)) {
      result_.reason = "too few LiDAR edge points in the image (" + std::to_string(edges_.points(0)) + " depth, " +
                       std::to_string(edges_.points(1)) + " intensity; at least " +
                       std::to_string(options_.edge_min_points) + ")";
      result_.runtime_seconds = timer_.ElapsedSeconds();
      return result_;
    }
    MakeMiTerm();
    std::vector<Vector6d> candidates = GlobalStage();
    Search(candidates);
    Restarts();
    Halves();
    Covariance();
    Decide();
    result_.evaluations = evaluations_;
    result_.runtime_seconds = timer_.ElapsedSeconds();
    return result_;
  }

 private:
  // The MI term where every cloud has intensity (edge_mi), culled for the edge box.
  void MakeMiTerm() {
    const bool intensity = std::all_of(frames_.begin(), frames_.end(),
                                       [](const Frame& f) { return f.points->has_intensity(); });
    if (!intensity || !options_.edge_mi) return;
    RegistrationOptions mi_options = options_;
    mi_options.bound_translation_m = options_.edge_bound_m;
    mi_options.bound_rotation_deg = options_.edge_bound_deg;
    mi_ = std::make_unique<FrameSetEvaluator>(frames_, start_, mi_options);
    f_.mi = mi_.get();
    f_.mi_levels = mi_->levels();
    f_.mi_finest = options_.edge_mi_level;
  }

  // The edge score over the rotation grid; its best points (and the start). With MI, the MI
  // weight from a grid three times coarser: each term in units of its spread there (MAD-σ),
  // times its peakedness (a term without a peak adds little), times edge_mi_scale.
  std::vector<Vector6d> GlobalStage() {
    const std::vector<Vector6d> grid = RotationGrid(options_.edge_bound_deg, options_.edge_grid_step_deg);
    std::vector<double> values(grid.size());
    ParallelFor(static_cast<int>(grid.size()), threads_,
                [&](int k) { values[k] = edges_.Evaluate(ApplyCorrection(start_, grid[k]), top_); });
    evaluations_ += static_cast<int>(grid.size());
    if (mi_) WeighMi();
    std::vector<Vector6d> candidates = BestOf(grid, values, options_.edge_grid_keep);
    if (std::none_of(candidates.begin(), candidates.end(), [](const Vector6d& x) { return x.isZero(); })) {
      candidates.push_back(Vector6d::Zero());
    }
    return candidates;
  }

  void WeighMi() {
    const std::vector<Vector6d> coarse = RotationGrid(options_.edge_bound_deg, 3 * options_.edge_grid_step_deg);
    std::vector<double> edge_values(coarse.size()), mi_values(coarse.size());
    ParallelFor(static_cast<int>(coarse.size()), threads_, [&](int k) {
      const Rigid3d pose = ApplyCorrection(start_, coarse[k]);
      edge_values[k] = edges_.Evaluate(pose, top_);
      mi_values[k] = mi_->Evaluate(pose, f_.MiLevel(top_)).value;
    });
    evaluations_ += static_cast<int>(coarse.size());
    const double pe = Peakedness(edge_values), pm = Peakedness(mi_values);
    const double se = MadSigma(edge_values), sm = MadSigma(mi_values);
    result_.edge_peakedness = pe;
    result_.mi_peakedness = pm;
    if (se > 0 && sm > 0 && pe > 0 && pm > 0) f_.mi_weight = (pm / pe) * (se / sm) * options_.edge_mi_scale;
    result_.edge_mi_weight = f_.mi_weight;
    spdlog::debug("edges: grid peakedness edges {:.2f}, MI {:.2f}; MI weight {:.4g}", pe, pm, f_.mi_weight);
  }

  // Coarse to fine from each candidate, the rotation first (the translation at the start's: a
  // single frame's translation is the weakly observed part, and free from the first step it
  // trades against the rotation), then all six; the best at the finest level.
  void Search(const std::vector<Vector6d>& candidates) {
    const Vector6d step = PerParameter(options_.edge_simplex_m, options_.edge_simplex_deg);
    std::vector<internal::SearchResult> ends(candidates.size());
    ParallelFor(static_cast<int>(candidates.size()), threads_, [&](int k) {
      const internal::SearchResult rotation = CoarseToFine(f_, candidates[k], top_, step, rotation_bound_, options_);
      ends[k] = rotation;
      if (!options_.edge_translation_stage) return;
      ends[k] = CoarseToFine(f_, rotation.x, 0, 0.5 * step, bound_, options_);
      ends[k].iterations += rotation.iterations;
      ends[k].evaluations += rotation.evaluations;
    });
    size_t best = 0;
    for (size_t k = 0; k < ends.size(); ++k) {
      evaluations_ += ends[k].evaluations;
      result_.iterations += ends[k].iterations;
      if (ends[k].value > ends[best].value) best = k;
    }
    x_ = ends[best].x;
    value_ = ends[best].value;
    spdlog::debug("edges: searched to t ({:.3f}, {:.3f}, {:.3f}) m, r/p/y ({:.2f}, {:.2f}, {:.2f}) deg, {:.4f}",
                  x_[0], x_[1], x_[2], x_[3], x_[4], x_[5], value_);
  }

  // Restarts around the optimum at the finest levels: the best end replaces the optimum;
  // their scatter about it enters the covariance.
  void Restarts() {
    const std::vector<Vector6d> offsets = RestartOffsets(options_);
    std::vector<internal::SearchResult> restarts(offsets.size());
    ParallelFor(static_cast<int>(offsets.size()), threads_, [&](int k) {
      restarts[k] = CoarseToFine(f_, (x_ + offsets[k]).cwiseMin(free_bound_).cwiseMax(-free_bound_),
                                 std::min(1, top_), RestartStep(), free_bound_, options_);
    });
    for (const internal::SearchResult& r : restarts) {
      evaluations_ += r.evaluations;
      if (r.value > value_) {
        value_ = r.value;
        x_ = r.x;
      }
    }
    restart_scatter_.setZero();
    for (const internal::SearchResult& r : restarts) restart_scatter_ += (r.x - x_) * (r.x - x_).transpose();
    if (!restarts.empty()) restart_scatter_ /= static_cast<double>(restarts.size());
    result_.checks.restarts_run = static_cast<int>(restarts.size());
  }

  // Independent parts: the left and right halves of the views' edge points, the upper and
  // lower, and with several frames the odd and even frames, each re-optimised alone from the
  // optimum. Two halves of equal information: Var(x_A − x_B) = 2 · 2Σ, so
  // Σ ≈ E[(x_A − x_B)(x_A − x_B)ᵀ] / 4. The MI term, where present, is not split.
  void Halves() {
    std::vector<uint8_t> masks = {EdgeMetric::kRight, EdgeMetric::kLower};
    if (frames_.size() >= 2) masks.push_back(EdgeMetric::kOddFrame);
    std::vector<internal::SearchResult> halves(2 * masks.size());
    ParallelFor(static_cast<int>(halves.size()), threads_, [&](int k) {
      const uint8_t mask = masks[k / 2];
      halves[k] = CoarseToFine(f_, x_, std::min(1, top_), RestartStep(), free_bound_, options_, mask,
                               k % 2 == 0 ? 0 : mask);
    });
    split_scatter_.setZero();
    for (size_t s = 0; s < masks.size(); ++s) {
      evaluations_ += halves[2 * s].evaluations + halves[2 * s + 1].evaluations;
      const Vector6d d = halves[2 * s].x - halves[2 * s + 1].x;
      split_scatter_ += d * d.transpose() / 4.0;
    }
    split_scatter_ /= static_cast<double>(masks.size());
    result_.checks.split_parts = static_cast<int>(halves.size());
    result_.checks.split_kind =
        frames_.size() >= 2 ? "left/right, upper/lower, odd/even frames" : "left/right, upper/lower";
  }

  // σ² = edge_sigma_scale² · (half-data + restart scatter), raised to a floor of edge_floor_px
  // (at edge_floor_depth_m for the shifts): a pose is never known better than the pixels allow.
  void Covariance() {
    Eigen::Matrix<double, 6, 6> covariance =
        options_.edge_sigma_scale * options_.edge_sigma_scale * (split_scatter_ + restart_scatter_);
    const double focal = frames_[0].views[0].camera.MeanFocalLength();
    const double floor_deg = options_.edge_floor_px / focal * 180.0 / M_PI;
    const double floor_m = options_.edge_floor_px / focal * options_.edge_floor_depth_m;
    for (int i = 0; i < 6; ++i) {
      const double floor = i < 3 ? floor_m : floor_deg;
      covariance(i, i) = std::max(covariance(i, i), floor * floor);
    }
    result_.covariance = covariance;
    result_.covariance_laplace = covariance;
    result_.covariance_valid = true;
    for (int i = 0; i < 3; ++i) {
      result_.sigma_m = std::max(result_.sigma_m, std::sqrt(covariance(i, i)));
      result_.sigma_deg = std::max(result_.sigma_deg, std::sqrt(covariance(i + 3, i + 3)));
    }
  }

  // "ok": off the box's 90 % margin, edges above chance, σ within the limits.
  void Decide() {
    result_.correction = x_;
    result_.cam_from_lidar = ApplyCorrection(start_, x_);
    result_.metric_before.value = f_(Vector6d::Zero(), 0);
    result_.metric_after.value = f_(x_, 0);
    result_.edge_score_before = edges_.Evaluate(start_, 0);
    result_.edge_score_after = edges_.Evaluate(result_.cam_from_lidar, 0);
    const int on = OnBound(x_, bound_);
    result_.checks.on_bound = on >= 0;
    static const char* kNames[6] = {"tx", "ty", "tz", "roll", "pitch", "yaw"};
    const std::string sigmas =
        "largest sigma " + Fixed(result_.sigma_deg, 3) + " deg, " + Fixed(100 * result_.sigma_m, 1) + " cm";
    if (on >= 0) {
      result_.reason = std::string("optimum on the search bound of ") + kNames[on] + " (" + Fixed(x_[on]) + ")";
    } else if (result_.edge_score_after < options_.edge_min_score) {
      result_.reason = "LiDAR edges do not meet image edges: edge score " + Fixed(result_.edge_score_after, 3) +
                       " < " + Fixed(options_.edge_min_score, 2) + " (1 = chance)";
    } else if (result_.sigma_deg > options_.edge_max_sigma_deg || result_.sigma_m > options_.edge_max_sigma_m) {
      result_.reason = "pose not determined to the accuracy asked: " + sigmas + " (limits " +
                       Fixed(options_.edge_max_sigma_deg, 2) + " deg, " +
                       Fixed(100 * options_.edge_max_sigma_m, 1) + " cm; independent parts of the data disagree)";
    } else {
      result_.status = "ok";
      result_.trusted = true;
      result_.confidence_reason = "edges agree: " + sigmas + " from " +
                                  std::to_string(result_.checks.split_parts) + " half-data and " +
                                  std::to_string(result_.checks.restarts_run) + " restart optima; edge score " +
                                  Fixed(result_.edge_score_after, 3);
    }
  }

  Vector6d RestartStep() const { return 2.0 * PerParameter(options_.restart_offset_m, options_.restart_offset_deg); }

  const std::vector<Frame>& frames_;
  const Rigid3d& start_;
  const RegistrationOptions& options_;
  Timer timer_;
  RegistrationResult result_;
  const Vector6d bound_;
  Vector6d rotation_bound_, free_bound_;
  const EdgeMetric edges_;
  std::unique_ptr<FrameSetEvaluator> mi_;
  EdgeObjective f_;
  const int top_;
  const int threads_;
  int evaluations_ = 0;
  Vector6d x_ = Vector6d::Zero();
  double value_ = 0;
  Eigen::Matrix<double, 6, 6> restart_scatter_ = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> split_scatter_ = Eigen::Matrix<double, 6, 6>::Zero();
};

}  // namespace

RegistrationResult RegisterEdges(const std::vector<Frame>& frames, const Rigid3d& start,
                                 const RegistrationOptions& options) {
  return EdgeRegistration(frames, start, options).Run();
}

}  // namespace mmba::registration::mi
