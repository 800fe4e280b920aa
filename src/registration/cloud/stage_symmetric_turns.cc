// The pseudo-symmetric turns of the best pose (Kim & Hilton, Sec. 5).

#include "registration/cloud/registration_stages.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "mmba/core/logging.h"
#include "registration/cloud/fit_uncertainty.h"
#include "registration/cloud/point_to_plane_icp.h"

namespace mmba::registration::internal {

namespace {

// Rounds of the pseudo-symmetric turns of the best pose: each turns the best of the round
// before when a turn became the best.
constexpr int kSymmetryTurnRounds = 4;

// The turns to try about the registered source's centroid, in groups; each group gives at most
// one finalist (its best on the coarse level). Levelled clouds: quarter, half and
// three-quarter turns about the up axis. Otherwise half turns about each principal axis of the
// registered source (`cov`) and about the axes around it: the 180° twin's axis is the
// object's symmetry axis, which a principal axis of the source only approximates (a gate's
// multi-view cloud, full gate, seed 1, has its up axis 5° from the twin's, and a turn about an
// axis θ off is 2θ off, beyond the coarse ICP's reach), so each principal axis a is tried
// with the axes around it, in rings every symmetry_cone_step_deg up to symmetry_cone_deg (6
// axes on the first ring, 12 on the second, …).
std::vector<std::vector<Vector6d>> CandidateTurns(const CloudRegistrationOptions& options,
                                                  const Eigen::Matrix3d& cov) {
  std::vector<std::vector<Vector6d>> turns;
  if (options.gravity_aligned) {
    for (double angle : {0.5 * M_PI, M_PI, 1.5 * M_PI}) {
      Vector6d xi = Vector6d::Zero();
      xi.head<3>() = angle * options.up;
      turns.push_back({xi});
    }
    return turns;
  }
  std::vector<Eigen::Vector3d> axes;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  for (int k = 0; k < 3; ++k) axes.push_back(eig.eigenvectors().col(k));
  const double step = options.symmetry_cone_step_deg * M_PI / 180.0;
  const int rings = static_cast<int>(
      std::floor(options.symmetry_cone_deg / options.symmetry_cone_step_deg + 1e-9));
  for (const Eigen::Vector3d& a : axes) {
    const Eigen::Vector3d u = a.unitOrthogonal(), v = a.cross(u);
    std::vector<Vector6d> group;
    for (int ring = 0; ring <= rings; ++ring) {
      const int around = ring == 0 ? 1 : 6 * ring;
      for (int j = 0; j < around; ++j) {
        const double phi = 2.0 * M_PI * j / around, theta = ring * step;
        Vector6d xi = Vector6d::Zero();
        xi.head<3>() = M_PI * (std::cos(theta) * a + std::sin(theta) * (std::cos(phi) * u +
                                                                         std::sin(phi) * v));
        group.push_back(xi);
      }
    }
    turns.push_back(std::move(group));
  }
  return turns;
}

// A hypothesis fitted and scored on the coarse level (ICP and score as for the hypotheses).
void CoarseFit(RegistrationContext& ctx, Hypothesis* h) {
  const CloudRegistrationOptions& options = ctx.options;
  const Level& tgt_coarse = ctx.tgt_coarse;
  const PointIndex& tgt_coarse_index = *ctx.tgt_coarse_index;
  if (options.icp) {
    h->transform = PointToPlaneIcp(ctx.icp_src, tgt_coarse.points, tgt_coarse.normals,
                                   tgt_coarse_index, h->transform, ctx.support_radius / 2.0,
                                   options.icp_distance_spacing * ctx.spacing,
                                   std::min(options.icp_iterations, 20), ctx.up);
  }
  Verify(ctx.icp_src, ctx.icp_src_n, tgt_coarse.normals, tgt_coarse_index, h->transform, ctx.tau, h);
}

// Where a turn is placed: turned about c (an object symmetric about an axis through its
// centroid maps onto itself), and for the group's central turn (`central`) also by the two
// strongest modes of the descriptor matches' displacement vote (for a part whose object's axis
// does not pass through c) and turned about the target's centroid. The vote alone is not
// enough: where the twin's matches outnumber the right ones they vote along a line (full gate,
// multi-view → LiDAR: every mode 1.7 m off, the gate's thickness, while the turn about c was
// within the coarse ICP's reach). The cone's other axes are placed about c only (the coarse
// ICP is the dear part here).
std::vector<std::pair<Eigen::Vector3d, std::string>> Placements(RegistrationContext& ctx, const Vector6d& xi,
                                                                const Eigen::Vector3d& c,
                                                                const Eigen::Matrix4d& turned, bool central) {
  std::vector<std::pair<Eigen::Vector3d, std::string>> placements = {
      {Eigen::Vector3d::Zero(), "about the centroid"}};
  if (!central) return placements;
  for (const auto& [count, shift] : DisplacementModes(ctx, turned, -1.0, 2)) {
    std::ostringstream how;
    how << std::setprecision(3) << "shift of " << shift.norm() << " m, " << count
        << " votes";
    placements.emplace_back(shift, how.str());
  }
  // Turned about the target's centroid: a part registered onto its whole symmetric object,
  // whose axis passes through the object's centroid, not the part's (full gate, plane-proxy
  // part → stereo cloud, levelled: the turn about the part's centroid was 4.5 m off, no vote
  // mode, and the twin was reported ok).
  // MotionAbout(ξ, c_t) = MotionAbout(ξ, c) shifted by (I − R)(c_t − c).
  const Eigen::Matrix3d r = MotionAbout(xi, c).topLeftCorner<3, 3>();
  placements.emplace_back((Eigen::Matrix3d::Identity() - r) * (ctx.target_centroid - c),
                          "about the target's centroid");
  return placements;
}

// A group's best placed turn on the coarse level.
struct TurnPick {
  Hypothesis h;
  bool picked = false;
  std::string how;  // how the pick was placed, for its origin text
  Vector6d xi = Vector6d::Zero();
};

// Compares each turn's placements of the group on the coarse level; only the group's best is
// refined at the fine level. The cone refines an axis whose turn nearly fits; a central turn
// that fits the coarse level less than a quarter as well as the best is not tried around (the
// coarse ICPs of the cone were 0.75 s of a Stanford pair's 2.2 s).
TurnPick PickTurn(RegistrationContext& ctx, const std::vector<Vector6d>& group, const Eigen::Matrix4d& best_t,
                  const Eigen::Vector3d& c, const Hypothesis& best_coarse) {
  TurnPick pick;
  for (size_t g = 0; g < group.size(); ++g) {
    if (g == 1 && pick.h.score < 0.25 * best_coarse.score) break;
    const Vector6d& xi = group[g];
    const Eigen::Matrix4d turned = MotionAbout(xi, c) * best_t;
    for (const auto& [shift, how] : Placements(ctx, xi, c, turned, g == 0)) {
      Hypothesis h = ctx.finalists.front().h;
      h.transform = turned;
      h.transform.topRightCorner<3, 1>() += shift;
      CoarseFit(ctx, &h);
      if (!pick.picked || h.score > pick.h.score) {
        pick.picked = true;
        pick.h = h;
        pick.how = how;
        pick.xi = xi;
      }
    }
  }
  return pick;
}

// The pick as a finalist, when it fits the coarse level at least half as well as the best
// pose; true when it changed the finalists.
bool AddTurnFinalist(RegistrationContext& ctx, const TurnPick& pick, const Hypothesis& best_coarse) {
  const Vector6d& xi = pick.xi;
  spdlog::debug("registration: symmetric turn {:.3g} deg about ({:.3f}, {:.3f}, {:.3f}): "
                "{}, coarse score {:.3g} (best {:.3g})",
                xi.head<3>().norm() * 180.0 / M_PI, xi(0) / xi.head<3>().norm(),
                xi(1) / xi.head<3>().norm(), xi(2) / xi.head<3>().norm(), pick.how,
                pick.h.score, best_coarse.score);
  if (!pick.picked || pick.h.score < 0.5 * best_coarse.score) return false;
  Finalist f;
  f.h = pick.h;
  std::ostringstream origin;
  const Eigen::Vector3d axis = xi.head<3>().normalized();
  origin << std::setprecision(3) << "symmetric turn of " << xi.head<3>().norm() * 180.0 / M_PI
         << " deg about (" << axis.x() << ", " << axis.y() << ", " << axis.z()
         << "), " << pick.how;
  f.h.origin = origin.str();
  return AddFinalist(ctx, std::move(f), ctx.support_radius / 2.0, /*replace_worse=*/true);
}

}  // namespace

void SymmetricTurns(RegistrationContext& ctx) {
  std::vector<Finalist>& finalists = ctx.finalists;
  const CloudRegistrationOptions& options = ctx.options;
  for (int round = 0;
       round < kSymmetryTurnRounds && !options.paper_only && options.symmetry_turns && !finalists.empty();
       ++round) {
    const Eigen::Matrix4d best_t = finalists.front().h.transform;
    Eigen::Vector3d c;
    Eigen::Matrix3d cov;
    RegisteredMoments(ctx.fine_src, best_t, &c, &cov);
    const std::vector<std::vector<Vector6d>> turns = CandidateTurns(options, cov);
    bool turns_changed = false;
    // The best pose's coarse score: a turn that fits the coarse level less than half as well
    // is no rival (the fine refinement, a crop of the target with its normals, is the dear
    // part).
    Hypothesis best_coarse = finalists.front().h;
    Verify(ctx.icp_src, ctx.icp_src_n, ctx.tgt_coarse.normals, *ctx.tgt_coarse_index, best_t, ctx.tau,
           &best_coarse);
    for (const std::vector<Vector6d>& group : turns) {
      const TurnPick pick = PickTurn(ctx, group, best_t, c, best_coarse);
      turns_changed = AddTurnFinalist(ctx, pick, best_coarse) || turns_changed;
    }
    if (turns_changed) {
      SortFinalists(ctx);
    }
    if (finalists.front().h.transform == best_t) break;
  }
}

}  // namespace mmba::registration::internal
