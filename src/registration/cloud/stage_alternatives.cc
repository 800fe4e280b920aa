// Stage of the cloud registration: poses the hypotheses may lack — period shifts of the best
// (repeated structures), its symmetric turns, and a local search off the score's maximum.

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "mmba/core/logging.h"
#include "registration/cloud/fit_uncertainty.h"
#include "registration/cloud/pcl_backend.h"
#include "registration/cloud/point_to_plane_icp.h"

namespace mmba::registration::internal {

namespace {

// Rounds of the local search (CloudRegistrationOptions::local_search): each starts from the
// move of the round before that scored above the best.
constexpr int kLocalSearchRounds = 4;
// ICP iterations and source points of each move's screening in the local search.
constexpr int kLocalSearchIterations = 10;
constexpr size_t kLocalSearchScreenPoints = 2000;

}  // namespace

std::vector<std::pair<int, Eigen::Vector3d>> DisplacementModes(RegistrationContext& ctx, const Eigen::Matrix4d& t, double min_norm, size_t max_modes) {
  std::vector<Matching>& matchings = ctx.matchings;
  double& normal_radius = ctx.normal_radius;
  const double cell = 2.0 * normal_radius;
  std::unordered_map<VoxelKey, std::pair<Eigen::Vector3d, int>, VoxelKeyHash> votes;
  for (const Matching& m : matchings) {
    for (size_t i = 0; i < m.src_to_tgt.size(); ++i) {
      const Eigen::Vector3d q = Apply(t, m.src_kp[i]);
      for (int j : m.src_to_tgt[i]) {
        if (j < 0) continue;
        const Eigen::Vector3d d = m.tgt_kp[j] - q;
        const VoxelKey key{static_cast<int64_t>(std::floor(d.x() / cell)),
                           static_cast<int64_t>(std::floor(d.y() / cell)),
                           static_cast<int64_t>(std::floor(d.z() / cell))};
        auto it = votes.try_emplace(key, Eigen::Vector3d::Zero(), 0).first;
        it->second.first += d;
        ++it->second.second;
      }
    }
  }
  // A displacement near a cell boundary splits its votes: each cell is scored with its 26
  // neighbours (sum and mean over the 3×3×3 block), and only blocks whose centre cell has
  // the most votes of its neighbourhood are kept (non-maximum suppression).
  std::vector<std::pair<int, Eigen::Vector3d>> modes;  // (votes, mean displacement)
  for (const auto& [key, v] : votes) {
    int total = 0;
    bool peak = true;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = votes.find(VoxelKey{key.x + dx, key.y + dy, key.z + dz});
          if (it == votes.end()) continue;
          total += it->second.second;
          sum += it->second.first;
          const bool other = dx != 0 || dy != 0 || dz != 0;
          if (other && (it->second.second > v.second ||
                        (it->second.second == v.second &&
                         std::make_tuple(it->first.x, it->first.y, it->first.z) <
                             std::make_tuple(key.x, key.y, key.z)))) {
            peak = false;
          }
        }
      }
    }
    const Eigen::Vector3d mean = sum / total;
    if (peak && total >= 3 && mean.norm() > min_norm) modes.emplace_back(total, mean);
  }
  std::sort(modes.begin(), modes.end(), [](const auto& a, const auto& b) {
    return a.first > b.first ||
           (a.first == b.first && std::make_tuple(a.second.x(), a.second.y(), a.second.z()) <
                                      std::make_tuple(b.second.x(), b.second.y(), b.second.z()));
  });
  if (modes.size() > max_modes) modes.resize(max_modes);
  return modes;
}

bool AddFinalist(RegistrationContext& ctx, Finalist f, double start, bool replace_worse) {
  Eigen::Vector3d& centre = ctx.centre;
  std::vector<Finalist>& finalists = ctx.finalists;
  double& fine_spacing = ctx.fine_spacing;
  double& fine_tau = ctx.fine_tau;
  if (!RefineFinalist(ctx, &f, start) || !ctx.Inside(f.h.transform)) return false;
  f.violates = Violations(ctx, f);
  ScoreFine(f.residuals, f.agree, fine_tau, f.violates, &f.h);
  for (Finalist& g : finalists) {
    if (SameTransform(f.h.transform, g.h.transform, centre, 10.0,
                      std::max(10.0 * fine_tau, 2.0 * fine_spacing))) {
      if (!replace_worse || !(f.h.score > g.h.score)) return false;
      g = std::move(f);
      return true;
    }
  }
  finalists.push_back(std::move(f));
  return true;
}

namespace {

// The move off the best finalist `f0` along its open directions that screens best: the
// moves are screened on f0's crop (no new crops) with a sample of the fine source
// (kLocalSearchScreenPoints): a short ICP from δ (kLocalSearchIterations), scored against
// f0's score on the same sample (free space left out). δ doubles from `bound` to the support
// radius. Empty when no move screens above f0.
std::optional<Finalist> BestScreenedMove(RegistrationContext& ctx, const Finalist& f0,
                                         const std::vector<Vector6d>& open, double bound,
                                         double reach) {
  const std::vector<Eigen::Vector3d>& fine_src = ctx.fine_src;
  const std::vector<Eigen::Vector3d>& fine_src_n = ctx.fine_src_n;
  const double fine_tau = ctx.fine_tau;
  const double support_radius = ctx.support_radius;
  const CloudRegistrationOptions& options = ctx.options;
  Eigen::Vector3d c;
  Eigen::Matrix3d cov;
  RegisteredMoments(fine_src, f0.h.transform, &c, &cov);
  std::optional<Finalist> top;
  const TargetCrop& crop0 = *f0.crop;
  const std::vector<size_t> screen_idx =
      StrideSample(fine_src.size(), kLocalSearchScreenPoints);
  const std::vector<Eigen::Vector3d> screen_src = Pick(fine_src, screen_idx);
  const std::vector<Eigen::Vector3d> screen_n = Pick(fine_src_n, screen_idx);
  auto screen_score = [&](const Eigen::Matrix4d& t) {
    std::vector<double> residuals;
    std::vector<bool> agree;
    FineResiduals(screen_src, screen_n, crop0, t, reach, &residuals, &agree);
    Hypothesis h;
    ScoreFine(residuals, agree, fine_tau, {}, &h);
    return h.score;
  };
  double top_screen = open.empty() ? 0.0 : screen_score(f0.h.transform);
  for (double delta = bound; delta <= support_radius * 1.0001 && !open.empty(); delta *= 2.0) {
    for (const Vector6d& xi : open) {
      const Eigen::Matrix4d moved = PointToPlaneIcp(
          screen_src, crop0.level.points, crop0.level.normals, *crop0.index,
          MotionAbout(delta * xi, c) * f0.h.transform, delta,
          options.icp_distance_spacing * f0.spacing,
          std::min(options.icp_iterations, kLocalSearchIterations), nullptr);
      if (!ctx.Inside(moved)) continue;
      const double score = screen_score(moved);
      if (score <= top_screen) continue;
      top_screen = score;
      top.emplace();
      top->h = f0.h;
      top->h.transform = moved;
    }
  }
  return top;
}

// A move that scored above the best replaces a finalist it converged to (scoring below it),
// else joins them; the finalists are sorted again.
void AdoptMove(RegistrationContext& ctx, Finalist top) {
  std::vector<Finalist>& finalists = ctx.finalists;
  const double tolerance = std::max(10.0 * ctx.fine_tau, 2.0 * ctx.fine_spacing);
  auto same = std::find_if(finalists.begin(), finalists.end(), [&](const Finalist& g) {
    return SameTransform(top.h.transform, g.h.transform, ctx.centre, 10.0, tolerance);
  });
  if (same == finalists.end()) {
    finalists.push_back(std::move(top));
  } else if (top.h.score > same->h.score) {
    *same = std::move(top);
  }
  SortFinalists(ctx);
}

// One round of the local search from the best finalist: tests its resolution (kept as
// ctx.best_tested), screens moves along its open directions and refines the best one.
// Returns whether a move beat the best (the search goes on from it).
bool LocalSearchRound(RegistrationContext& ctx, int round) {
  const CloudRegistrationOptions& options = ctx.options;
  const Finalist& f0 = ctx.finalists.front();
  const double bound = options.max_resolution_spacing * f0.spacing;
  const double reach = std::min(ctx.normal_radius, options.normal_radius_spacing * f0.spacing);
  BoundTest test;
  PoseResolution(ctx.fine_src, ctx.fine_src_n, *f0.crop, f0.h.transform, f0.residuals, f0.agree,
                 reach, ctx.fine_tau, ctx.support_radius, bound, ctx.support_radius,
                 options.resolution_t, true, {}, &test);
  ctx.best_tested = {f0.h.transform, f0.crop.get(), f0.spacing, std::move(test)};
  const std::vector<Vector6d>& open = ctx.best_tested.test.directions;
  std::optional<Finalist> top = BestScreenedMove(ctx, f0, open, bound, reach);
  if (top) {
    if (RefineFinalist(ctx, &*top, bound) && ctx.Inside(top->h.transform)) {
      top->violates = Violations(ctx, *top);
      ScoreFine(top->residuals, top->agree, ctx.fine_tau, top->violates, &top->h);
    } else {
      top.reset();
    }
  }
  spdlog::debug("registration: local search round {}: {} open directions, best move scores "
                "{:.4g} (best {:.4g})",
                round + 1, open.size(), top ? top->h.score : 0.0, f0.h.score);
  if (!top || !(top->h.score > f0.h.score)) return false;
  if (round == 0) top->h.origin = f0.h.origin + ", local search";
  top->coarse_score = f0.coarse_score;  // a refinement of the best
  AdoptMove(ctx, std::move(*top));
  return true;
}

}  // namespace

void LocalSearch(RegistrationContext& ctx) {
  const CloudRegistrationOptions& options = ctx.options;
  for (int round = 0; !options.paper_only && options.local_search && !ctx.finalists.empty() &&
                      round < kLocalSearchRounds;
       ++round) {
    if (!LocalSearchRound(ctx, round)) break;
  }
}

void SearchAlternatives(RegistrationContext& ctx) {
  std::vector<Finalist>& finalists = ctx.finalists;
  const CloudRegistrationOptions& options = ctx.options;
  double& spacing = ctx.spacing;
  double& support_radius = ctx.support_radius;
  Eigen::Vector3d& target_centroid = ctx.target_centroid;
  Level& tgt_coarse = ctx.tgt_coarse;
  // Shifted copies of the best pose (a repeated structure: bays, windows, columns). The
  // hypotheses need not contain the pose one period away, and then the ambiguity test has
  // nothing to compare with. Under the best pose T every descriptor match (source keypoint
  // s, candidate target keypoint t) votes for the displacement t − T·s (a Hough vote over
  // translations, Ballard 1981): the right matches vote near 0, the matches to the same
  // feature in a repeated unit vote for the period. The up-to-`num_period_shifts` strongest
  // displacement cells beyond R_s (smaller shifts are the resolution test's) with at least 3
  // votes give T moved by their mean displacement, refined by the fine ICP and scored like
  // the other finalists; a distinct one then enters the ambiguity test.
  if (!options.paper_only && options.num_period_shifts > 0 && !finalists.empty()) {
    const std::vector<std::pair<int, Eigen::Vector3d>> modes =
        DisplacementModes(ctx, finalists.front().h.transform, support_radius,
                           static_cast<size_t>(options.num_period_shifts));
    const size_t before_shifts = finalists.size();
    for (const auto& [count, shift] : modes) {
      Finalist f;
      f.h = finalists.front().h;
      f.h.transform.topRightCorner<3, 1>() += shift;
      std::ostringstream origin;
      origin << std::setprecision(3) << "period shift (" << shift.x() << ", " << shift.y() << ", "
             << shift.z() << ") m, " << count << " votes";
      f.h.origin = origin.str();
      AddFinalist(ctx, std::move(f), options.icp_distance_spacing * spacing);
    }
    if (finalists.size() > before_shifts) {
      SortFinalists(ctx);
    }
  }
  target_centroid = Eigen::Vector3d::Zero();  // for the turns about it
  for (const Eigen::Vector3d& p : tgt_coarse.points) target_centroid += p;
  target_centroid /= static_cast<double>(std::max<size_t>(1, tgt_coarse.points.size()));
  SymmetricTurns(ctx);
  const Eigen::Matrix4d best_before_local_search =
      finalists.empty() ? Eigen::Matrix4d::Zero() : Eigen::Matrix4d(finalists.front().h.transform);
  LocalSearch(ctx);
  // A best pose the local search moved is turned again: the turns above turned the pose it
  // started from, and a turn of a pose some decimetres off lands as far off the twin, beyond
  // the fine ICP's reach (the symmetric gate's part at −0.6 rad: the truth found by the local
  // search, the twin never, "ok"; test EverySymmetricTurnOfTheGatesPartIsRefused).
  if (!finalists.empty() && finalists.front().h.transform != best_before_local_search) {
    SymmetricTurns(ctx);
  }
}

}  // namespace mmba::registration::internal
