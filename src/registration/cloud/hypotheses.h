#pragma once

// Pose hypotheses of the cloud registration: SAC-IA (Rusu et al. 2009) and the maximum
// consistent clique of the descriptor matches, kept in a pool of the best distinct ones.

#include <algorithm>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/point_index.h"
#include "mmba/registration/cloud/feature_registration.h"
#include "registration/cloud/descriptor_matching.h"

namespace mmba::registration::internal {

/// A pose hypothesis and its verification (coarse, or fine for a finalist).
struct Hypothesis {
  std::string origin;
  std::string descriptor;
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
  double cost = 0.0;  // SAC-IA cost (lower is better)
  double fitness = 0.0, rmse = 0.0, normal_agreement = 0.0, score = 0.0;
  double conflict = 0.0;  // fine: of the points near a target surface, those not on it
  double violation = 0.0;  // fine: fraction of the source in observed free space
  size_t inliers = 0;
};

/// Transforms differ less than `rotation_deg` and `translation_m` (measured at `centre`).
bool SameTransform(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b,
                   const Eigen::Vector3d& centre, double rotation_deg, double translation_m);

/// Keeps the `capacity` best distinct hypotheses by cost.
class HypothesisPool {
 public:
  HypothesisPool(size_t capacity, Eigen::Vector3d centre, double translation_m)
      : capacity_(capacity), centre_(std::move(centre)), translation_m_(translation_m) {}
  void Offer(const Hypothesis& h) {
    for (Hypothesis& existing : pool_) {
      if (SameTransform(existing.transform, h.transform, centre_, 5.0, translation_m_)) {
        if (h.cost < existing.cost) existing = h;
        Sort();
        return;
      }
    }
    if (pool_.size() < capacity_) {
      pool_.push_back(h);
    } else if (h.cost < pool_.back().cost) {
      pool_.back() = h;
    } else {
      return;
    }
    Sort();
  }
  const std::vector<Hypothesis>& hypotheses() const { return pool_; }
  /// Cost a new hypothesis must beat to enter (infinite while the pool is not full).
  double worst_cost() const {
    return pool_.size() < capacity_ ? std::numeric_limits<double>::infinity() : pool_.back().cost;
  }

 private:
  void Sort() {
    std::stable_sort(pool_.begin(), pool_.end(),
                     [](const Hypothesis& a, const Hypothesis& b) { return a.cost < b.cost; });
  }
  size_t capacity_;
  Eigen::Vector3d centre_;
  double translation_m_;
  std::vector<Hypothesis> pool_;
};

/// Truncated-quadratic alignment cost of `sample` under `t` (mean of min(d², τ²) / τ²).
/// Stops early (returns 1) once the cost must exceed `bound` (a hypothesis that cannot enter
/// the pool is not worth scoring to the end).
double AlignmentCost(const std::vector<Eigen::Vector3d>& sample, const PointIndex& target,
                     const Eigen::Matrix4d& t, double tau,
                     double bound = std::numeric_limits<double>::infinity());

/// SAC-IA (Rusu, Blodow & Beetz, "Fast Point Feature Histograms for 3D Registration", ICRA
/// 2009, Sec. IV-A): draw samples of source keypoints at least `min_distance` apart, pair each
/// with one of its k most similar target keypoints at random, fit a rigid transform and score
/// the whole (sampled) source; here with a truncated quadratic score, a cheap edge-length
/// pre-check of the sample, and the best distinct hypotheses kept rather than one.
void SacIa(const Matching& m, const std::vector<Eigen::Vector3d>& score_sample,
           const PointIndex& target, const CloudRegistrationOptions& options, double spacing,
           double min_distance, double tau, std::mt19937_64* rng, HypothesisPool* pool);

/// Maximum clique of pairwise-consistent correspondences, then a least-squares fit; then the
/// maximum clique of the remaining correspondences, and so on (`count` cliques): a
/// pseudo-symmetric object has one consistent set per symmetric pose, and the largest is not
/// always the true one.
void CliqueHypotheses(const Matching& m, const CloudRegistrationOptions& options,
                      double spacing, int count, std::vector<Hypothesis>* out,
                      std::vector<std::string>* notes);

}  // namespace mmba::registration::internal
