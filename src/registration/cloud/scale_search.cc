// RegisterCloudsOverScales: the rigid registration at trial scales, refined as a similarity.

#include "mmba/registration/cloud/feature_registration.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "mmba/core/error.h"
#include "mmba/core/parallel_for.h"
#include "mmba/core/progress.h"
#include "registration/cloud/cloud_levels.h"

namespace mmba::registration {

using internal::CheckCloud;

namespace {

// Runs job(0) … job(n − 1), two at a time on a machine with two cores or more (each is mostly
// single-threaded); the first exception is rethrown on the caller's thread.
void RunTwoAtATime(size_t n, const std::function<void(size_t)>& job) {
  const int threads = static_cast<int>(std::min<unsigned>(2, std::max(1u, std::thread::hardware_concurrency())));
  ParallelFor(static_cast<int>(n), threads, [&](int k) { job(static_cast<size_t>(k)); });
}

}  // namespace

double ScaleSearchTolerance(const io::PointCloud& target) {
  return std::max(3.0 * EstimatePointSpacing(target), 0.005 * RobustExtent(target.points));
}

namespace {

// A trial's rigid registration and, when it is "ok" (or refined in the second pass), its
// similarity refinement.
struct Outcome {
  CloudRegistrationResult rigid;
  std::optional<SimilarityFit> fit;
};

// The trials of one scale search: the source scaled about its centroid and registered
// rigidly, each "ok" one refined as a similarity.
class ScaleTrials {
 public:
  ScaleTrials(const io::PointCloud& source, const io::PointCloud& target, const CloudRegistrationOptions& options,
              double tau, const std::function<void(size_t, size_t, const ScaleTrial&)>& progress)
      : source_(source), target_(target), options_(options), tau_(tau), progress_(progress) {
    centroid_ = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& x : source.points) centroid_ += x;
    centroid_ /= static_cast<double>(source.size());
    extent_ = RobustExtent(source.points);
  }

  // Runs trials k ∈ [first, scales.size()), two at a time; their results are taken in the
  // order of their scales, so they do not depend on which finished first.
  void Run(const std::vector<double>& scales, size_t first) {
    scales_ = scales;
    outcomes_.resize(scales.size());
    trials_.resize(scales.size());
    RunTwoAtATime(scales.size() - first, [&](size_t i) { TrialJob(first + i); });
  }

  // The similarity target ← source of a trial's rigid pose, refined with the scale free.
  SimilarityFit Refine(double scale, const CloudRegistrationResult& rigid) const {
    Eigen::Matrix4d start = Eigen::Matrix4d::Identity();
    start.topLeftCorner<3, 3>() = scale * rigid.target_from_source.topLeftCorner<3, 3>();
    start.topRightCorner<3, 1>() =
        rigid.target_from_source.topRightCorner<3, 1>() - start.topLeftCorner<3, 3>() * centroid_;
    const double reach = std::max(10.0 * tau_, 0.05 * scale * extent_);
    return RefineSimilarity(source_, target_, start, reach, tau_);
  }

  const std::vector<double>& scales() const { return scales_; }
  const std::vector<Outcome>& outcomes() const { return outcomes_; }
  std::vector<ScaleTrial>& trials() { return trials_; }

 private:
  // One trial: the source at `scale` (about its centroid) registered rigidly; an "ok" one is
  // refined as a similarity (a rigid pose at a scale 5 % off leaves the source's ends 5 % of
  // its half extent off).
  void RunTrial(double scale, Outcome* o, ScaleTrial* trial) const {
    io::PointCloud scaled;
    scaled.points.reserve(source_.size());
    for (const Eigen::Vector3d& x : source_.points) scaled.points.push_back(scale * (x - centroid_));
    CloudRegistrationOptions trial_options = options_;
    for (Eigen::Vector3d& c : trial_options.source_viewpoints) c = scale * (c - centroid_);
    if (trial_options.normal_orientation == NormalOrientation::kAuto) {
      trial_options.normal_orientation = NormalOrientation::kViewpoint;  // no retries
    }
    o->rigid = RegisterClouds(scaled, target_, trial_options);
    trial->scale = scale;
    trial->status = o->rigid.ok() ? "ok" : "failed: " + o->rigid.reason;
    trial->fitness = o->rigid.fitness;
  }

  void TrialJob(size_t k) {
    Outcome& o = outcomes_[k];
    ScaleTrial& trial = trials_[k];
    RunTrial(scales_[k], &o, &trial);
    if (o.rigid.ok()) {
      o.fit = Refine(scales_[k], o.rigid);
      trial.refined = true;
      trial.refined_scale = o.fit->scale;
      trial.refined_fitness = o.fit->fitness;
    }
    const std::lock_guard<std::mutex> lock(progress_mutex_);
    ++finished_;
    if (progress_) progress_(finished_, trials_.size(), trial);
  }

  const io::PointCloud& source_;
  const io::PointCloud& target_;
  const CloudRegistrationOptions& options_;
  double tau_;
  const std::function<void(size_t, size_t, const ScaleTrial&)>& progress_;
  Eigen::Vector3d centroid_;
  double extent_ = 0.0;
  std::vector<double> scales_;
  std::vector<Outcome> outcomes_;
  std::vector<ScaleTrial> trials_;
  std::mutex progress_mutex_;
  size_t finished_ = 0;
};

// Second pass, when no trial scale registered: the checks of a rigid registration refuse a
// pose whose scale is a few per cent off (its ends lie beyond the fine tolerance, so it is
// "not resolved" or "not determined" though it fits). Every failed trial whose pose fits is
// refined as a similarity; the two refined scales that fit best (distinct, within the range
// widened by a step) are each registered again from scratch, with every check. An "ok" there
// is a trial like the others.
void RetryAtRefinedScales(ScaleTrials* trials, double min_scale, double max_scale, double step) {
  const std::vector<double> scales = trials->scales();
  const std::vector<Outcome>& outcomes = trials->outcomes();
  std::vector<std::optional<SimilarityFit>> fits(scales.size());
  RunTwoAtATime(scales.size(), [&](size_t k) {
    if (outcomes[k].rigid.best_pose_fits) fits[k] = trials->Refine(scales[k], outcomes[k].rigid);
  });
  std::vector<SimilarityFit> refined;
  for (const std::optional<SimilarityFit>& fit : fits) {
    if (fit && fit->scale >= min_scale / step && fit->scale <= max_scale * step) refined.push_back(*fit);
  }
  std::stable_sort(refined.begin(), refined.end(),
                   [](const SimilarityFit& a, const SimilarityFit& b) { return a.fitness > b.fitness; });
  std::vector<double> tried = scales;
  for (const SimilarityFit& fit : refined) {
    if (tried.size() == scales.size() + 2) break;
    if (std::none_of(tried.begin(), tried.end(), [&](double t) { return std::abs(fit.scale / t - 1.0) < 1e-3; })) {
      tried.push_back(fit.scale);
    }
  }
  const size_t first_new = scales.size();
  std::vector<ScaleTrial>& all = trials->trials();
  all.resize(tried.size());
  for (size_t k = first_new; k < tried.size(); ++k) all[k].from_refinement = true;
  trials->Run(tried, first_new);
}

}  // namespace

ScaleSearchResult RegisterCloudsOverScales(
    const io::PointCloud& source, const io::PointCloud& target,
    const CloudRegistrationOptions& options, double min_scale, double max_scale, double step,
    double tolerance_m, const std::function<void(size_t, size_t, const ScaleTrial&)>& progress) {
  ScaleSearchResult result;
  Timer timer;
  if (!(min_scale > 0) || !(max_scale >= min_scale) || !(step > 1.0) || !std::isfinite(max_scale)) {
    throw InputError::Message("scale search", "expected 0 < min scale <= max scale and a step > 1");
  }
  const double tau = tolerance_m > 0 ? tolerance_m : ScaleSearchTolerance(target);
  result.tolerance_m = tau;
  auto fail = [&](const std::string& reason) {
    result.status = "failed";
    result.reason = reason;
    result.seconds = timer.ElapsedSeconds();
    return result;
  };
  for (const auto& [cloud, which] : {std::pair{&source, "source"}, std::pair{&target, "target"}}) {
    const std::string problem = CheckCloud(*cloud, which);
    if (!problem.empty()) return fail(problem);
  }
  std::vector<double> first_scales;
  for (double x = min_scale; x <= max_scale * (1 + 1e-9); x *= step) first_scales.push_back(x);
  ScaleTrials trials(source, target, options, tau, progress);
  trials.Run(first_scales, 0);
  if (std::none_of(trials.outcomes().begin(), trials.outcomes().end(),
                   [](const Outcome& o) { return o.rigid.ok(); })) {
    RetryAtRefinedScales(&trials, min_scale, max_scale, step);
  }
  const std::vector<double>& scales = trials.scales();
  struct Candidate {
    double trial_scale;
    SimilarityFit fit;
  };
  std::vector<Candidate> candidates;
  std::string closest;  // the reason of the failed trial that fitted best
  double closest_fitness = -1.0;
  for (size_t k = 0; k < scales.size(); ++k) {
    const Outcome& o = trials.outcomes()[k];
    if (o.fit) {
      candidates.push_back({scales[k], *o.fit});
    } else if (o.rigid.fitness > closest_fitness) {
      closest_fitness = o.rigid.fitness;
      std::ostringstream m;
      m << "; the best-fitting trial, scale " << scales[k] << ", " << o.rigid.reason;
      closest = m.str();
    }
  }
  result.trials = trials.trials();
  if (candidates.empty()) {
    std::ostringstream m;
    m << "registered at none of " << scales.size() << " trial scales " << min_scale << " … " << max_scale << closest;
    return fail(m.str());
  }
  std::stable_sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.fit.fitness > b.fit.fitness; });
  const Candidate& best = candidates.front();
  // Another trial that ends elsewhere (a pseudo-symmetric site, a repeated bay) and fits almost
  // as well: ambiguous.
  for (size_t k = 1; k < candidates.size(); ++k) {
    const double apart = TransformRmsOnCloud(source, best.fit.target_from_source, candidates[k].fit.target_from_source);
    if (apart > 5.0 * tau && candidates[k].fit.fitness > 0.9 * best.fit.fitness) {
      std::ostringstream m;
      m << "ambiguous: the trial scales " << best.trial_scale << " and " << candidates[k].trial_scale
        << " place the source " << apart << " m RMS apart with fitness " << best.fit.fitness << " and "
        << candidates[k].fit.fitness;
      return fail(m.str());
    }
  }
  result.target_from_source = best.fit.target_from_source;
  result.scale = best.fit.scale;
  result.fitness = best.fit.fitness;
  result.inlier_rmse = best.fit.inlier_rmse;
  if (best.fit.fitness < 0.3) {
    std::ostringstream m;
    m << "the best placement puts only " << 100 * best.fit.fitness << " % of the source within " << tau
      << " m of the target (30 % needed)";
    return fail(m.str());
  }
  result.status = "ok";
  result.seconds = timer.ElapsedSeconds();
  return result;
}

}  // namespace mmba::registration
