// Hypothesis generation of the cloud registration: SAC-IA and maximum cliques.

#include "registration/cloud/hypotheses.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "mmba/registration/cloud/robust_estimators.h"
#include "registration/cloud/cloud_levels.h"

namespace mmba::registration::internal {

bool SameTransform(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b,
                   const Eigen::Vector3d& centre, double rotation_deg, double translation_m) {
  const Eigen::Matrix3d r = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  return RotationAngleDeg(r) < rotation_deg &&
         (Apply(a, centre) - Apply(b, centre)).norm() < translation_m;
}

double AlignmentCost(const std::vector<Eigen::Vector3d>& sample, const PointIndex& target,
                     const Eigen::Matrix4d& t, double tau,
                     double bound) {
  double cost = 0.0;
  int index;
  double sq;
  const double tau2 = tau * tau;
  const double n = static_cast<double>(std::max<size_t>(1, sample.size()));
  const double limit = bound * tau2 * n;
  // The sample is in random order: after the first kPreview points the mean cost already
  // tells a hopeless hypothesis (preemptive scoring, as Nistér's preemptive RANSAC, 2005).
  constexpr size_t kPreview = 64;
  for (size_t i = 0; i < sample.size(); ++i) {
    if (!target.NearestWithin(Apply(t, sample[i]), tau2, &index, &sq)) sq = tau2;
    cost += std::min(sq, tau2);
    if (cost > limit) return 1.0;
    if (i + 1 == kPreview && sample.size() > 2 * kPreview &&
        cost / (tau2 * kPreview) > std::min(1.0, 1.5 * bound + 0.1)) {
      return 1.0;
    }
  }
  return cost / (tau2 * n);
}

void SacIa(const Matching& m, const std::vector<Eigen::Vector3d>& score_sample,
           const PointIndex& target, const CloudRegistrationOptions& options, double spacing,
           double min_distance, double tau, std::mt19937_64* rng, HypothesisPool* pool) {
  const int n = static_cast<int>(m.src_kp.size());
  if (n < 3 || m.tgt_kp.size() < 3) return;
  const int sample_size = options.gravity_aligned ? 2 : 3;
  const double tolerance = options.consistency_spacing * spacing;
  std::uniform_int_distribution<int> pick(0, n - 1);
  const Eigen::Vector3d* up = options.gravity_aligned ? &options.up : nullptr;
  // `sac_ia_iterations` samples that pass the edge-length pre-check are scored; with many
  // wrong matches (repetitive structure) most draws fail it, so up to
  // sac_ia_draws_per_iteration × as many are drawn.
  int scored = 0;
  const int64_t max_draws =
      static_cast<int64_t>(options.sac_ia_iterations) * options.sac_ia_draws_per_iteration;
  // Adaptive stop (Fischler & Bolles 1981, Eq. for k; Hartley & Zisserman Sec. 4.7.1): with ε
  // the probability that a draw for one source keypoint picks a correct target, a sample is
  // all-correct with probability ε^m, and N = log(1 − p) / log(1 − ε^m) draws find one with
  // probability p. ε is measured under the best pose so far: the fraction of the (keypoint,
  // candidate) pairs it maps within the consistency tolerance; it is scaled by
  // sac_ia_alternative_ratio so that a competing pose with that share of the matches is
  // sampled with probability p as well. Re-estimated whenever the best pose changes.
  int64_t needed_draws = max_draws;
  // The paper's pipeline (paper_only) draws its fixed number of samples.
  const bool adaptive = options.sac_ia_confidence < 1.0 && !options.paper_only;
  Eigen::Matrix4d best_transform = Eigen::Matrix4d::Zero();
  auto update_stop = [&]() {
    if (!adaptive || pool->hypotheses().empty()) return;
    const Hypothesis& best = pool->hypotheses().front();
    if (best.transform == best_transform) return;
    best_transform = best.transform;
    double eps = 0.0;
    for (int i = 0; i < n; ++i) {
      const std::vector<int>& candidates = m.src_to_tgt[i];
      if (candidates.empty()) continue;
      const Eigen::Vector3d q = Apply(best.transform, m.src_kp[i]);
      int right = 0;
      for (int j : candidates) right += j >= 0 && (m.tgt_kp[j] - q).norm() < tolerance;
      eps += static_cast<double>(right) / static_cast<double>(candidates.size());
    }
    eps = options.sac_ia_alternative_ratio * eps / n;
    const double all_right = std::pow(eps, sample_size);
    if (all_right <= 0.0) return;
    if (all_right >= 1.0) {
      needed_draws = 1;
      return;
    }
    const double draws = std::log(1.0 - options.sac_ia_confidence) / std::log1p(-all_right);
    needed_draws = static_cast<int64_t>(std::min(static_cast<double>(max_draws), std::ceil(draws)));
  };
  for (int64_t draw = 0;
       draw < max_draws && scored < options.sac_ia_iterations && draw < needed_draws; ++draw) {
    int sample[3];
    bool ok = true;
    for (int s = 0; s < sample_size && ok; ++s) {
      bool found = false;
      for (int attempt = 0; attempt < 50 && !found; ++attempt) {
        const int c = pick(*rng);
        found = true;
        for (int r = 0; r < s; ++r) {
          if (c == sample[r] || (m.src_kp[c] - m.src_kp[sample[r]]).norm() < min_distance) {
            found = false;
          }
        }
        if (found) sample[s] = c;
      }
      ok = found;
    }
    if (!ok) continue;
    std::vector<Eigen::Vector3d> src, dst;
    for (int s = 0; s < sample_size; ++s) {
      const std::vector<int>& candidates = m.src_to_tgt[sample[s]];
      if (candidates.empty()) {
        ok = false;
        break;
      }
      std::uniform_int_distribution<int> choose(0, static_cast<int>(candidates.size()) - 1);
      const int j = candidates[choose(*rng)];
      if (j < 0) {
        ok = false;
        break;
      }
      src.push_back(m.src_kp[sample[s]]);
      dst.push_back(m.tgt_kp[j]);
    }
    if (!ok) continue;
    for (int a = 0; a < sample_size && ok; ++a) {
      for (int b = a + 1; b < sample_size; ++b) {
        if (std::abs((src[a] - src[b]).norm() - (dst[a] - dst[b]).norm()) > tolerance) ok = false;
      }
    }
    if (!ok) continue;
    Hypothesis h;
    h.transform = EstimateRigid(src, dst, up);
    ++scored;
    h.cost = AlignmentCost(score_sample, target, h.transform, tau, pool->worst_cost());
    h.origin = "sac-ia " + m.descriptor;
    h.descriptor = m.descriptor;
    pool->Offer(h);
    update_stop();
  }
}

void CliqueHypotheses(const Matching& m, const CloudRegistrationOptions& options,
                      double spacing, int count, std::vector<Hypothesis>* out,
                      std::vector<std::string>* notes) {
  std::vector<std::pair<int, int>> pairs = m.best_pairs;
  for (int k = 0; k < count && pairs.size() >= 3; ++k) {
    std::vector<Eigen::Vector3d> src, dst;
    for (const auto& [i, j] : pairs) {
      src.push_back(m.src_kp[i]);
      dst.push_back(m.tgt_kp[j]);
    }
    CliqueOptions clique_options;
    clique_options.tolerance_m = options.consistency_spacing * spacing;
    bool exact = true;
    const std::vector<int> clique = MaxConsistentClique(src, dst, clique_options, &exact);
    if (!exact) notes->push_back("max-clique " + m.descriptor + ": search budget reached");
    if (clique.size() < (options.gravity_aligned ? 3u : 4u)) return;
    std::vector<Eigen::Vector3d> cs, cd;
    for (int i : clique) {
      cs.push_back(src[i]);
      cd.push_back(dst[i]);
    }
    Hypothesis h;
    h.transform = EstimateRigid(cs, cd, options.gravity_aligned ? &options.up : nullptr);
    h.origin = "max-clique " + m.descriptor + " #" + std::to_string(k) + " (" +
               std::to_string(clique.size()) + " of " + std::to_string(src.size()) + ")";
    h.descriptor = m.descriptor;
    out->push_back(h);
    std::vector<bool> used(pairs.size(), false);
    for (int i : clique) used[static_cast<size_t>(i)] = true;
    std::vector<std::pair<int, int>> rest;
    for (size_t i = 0; i < pairs.size(); ++i) {
      if (!used[i]) rest.push_back(pairs[i]);
    }
    pairs.swap(rest);
  }
}

}  // namespace mmba::registration::internal
