#pragma once

// The stages of the cloud registration (Kim & Hilton 3DV 2013, Sec. 3, and the verification
// past the failures it reports, Sec. 5), each a function of the RegistrationContext. A stage
// returning false has failed the registration (ctx.result holds the reason). In order:
//   PrepareClouds → BuildLevels → EstimateLevelNormals → DetectKeypoints → DescribeAndMatch
//   → GenerateHypotheses → RefineCoarseHypotheses → PrepareFineLevel → SelectFinalists
//   → SearchAlternatives → TestAmbiguity → EstimateUncertainty → ReportFinalists → Verdict.

#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "registration/cloud/registration_context.h"

namespace mmba::registration::internal {

/// Checks both clouds; measures each one's spacing (median nearest-neighbour distance, on
/// 20,000 and, for the source, 5,000 samples) and (options.remove_blunders) removes its
/// scattered blunders when they are at least isolated_min_fraction of it — one kd-tree per
/// cloud for both.
bool PrepareClouds(RegistrationContext& ctx);

/// The levels: a common coarse voxel for the features (clouds of different density are
/// matched at the density of the sparser one; the larger cloud may keep larger_cloud_factor ×
/// as many points), a finer one of the source for ICP; the spacing s and the radii R_n, R_s.
bool BuildLevels(RegistrationContext& ctx);

/// Normals of the coarse levels within R_n (oriented towards the sensors, else the origin,
/// optionally made consistent), and of the fine verification's source sample.
bool EstimateLevelNormals(RegistrationContext& ctx);

/// Keypoints of both coarse levels, and the test that the target is dense enough for R_s.
bool DetectKeypoints(RegistrationContext& ctx);

/// Descriptors of the keypoints (FPFH and SHOT for Descriptor::kAuto) and their matches.
bool DescribeAndMatch(RegistrationContext& ctx);

/// Hypotheses: SAC-IA and the maximum consistent cliques of each descriptor's matches, and
/// with a search window the approximate pose itself.
bool GenerateHypotheses(RegistrationContext& ctx);

/// Each hypothesis refined by ICP on the coarse level and verified; those outside the search
/// window dropped; best score first.
bool RefineCoarseHypotheses(RegistrationContext& ctx);

/// The fine level's visibility test (z-buffers of each cloud from its own sensors) and ICP
/// settings.
bool PrepareFineLevel(RegistrationContext& ctx);

/// The target around the pose `t`: its points within R_s of the box of the registered fine
/// source, thinned to max_points_icp, with normals; a target within the budget is prepared
/// once, whole; finalists that crop the same points share one crop.
std::shared_ptr<TargetCrop> CropFor(RegistrationContext& ctx, const Eigen::Matrix4d& t);

/// A finalist refined on its own crop of the target: fine ICP from `icp_start`, then its fine
/// residuals and their robust scale (and on a noisy cloud a second ICP within the noise).
/// False when the pose puts the source off the target.
bool RefineFinalist(RegistrationContext& ctx, Finalist* f, double icp_start);

/// The fine source points `f` puts in observed free space (empty without sensor positions).
std::vector<bool> Violations(RegistrationContext& ctx, const Finalist& f);

/// Finalists by score, best first (stable: ties keep their order).
void SortFinalists(RegistrationContext& ctx);

/// Fine ICP and verification of the best distinct coarse hypotheses (coarse-to-fine: a loose
/// coarse inlier distance cannot tell a shifted repetitive structure or a pseudo-symmetric
/// turn from the truth; the fine level can); the fine inlier distance τ; finalists that
/// converged to the same pose merged.
bool SelectFinalists(RegistrationContext& ctx);

/// The displacement modes of the descriptor matches under a pose `t`, strongest first: at most
/// `max_modes`, each with at least 3 votes and longer than `min_norm` (votes, mean shift).
std::vector<std::pair<int, Eigen::Vector3d>> DisplacementModes(RegistrationContext& ctx,
                                                               const Eigen::Matrix4d& t,
                                                               double min_norm, size_t max_modes);

/// Adds a refined, scored finalist unless it is the same pose as one already there (within
/// 10° and 10 τ). With `replace_worse`, a same pose that scores higher takes the other's
/// place: 10 τ can span a pose and one part of a metre off it (the symmetric gate's part:
/// τ 0.19 m, a turn's pose 0.6 m off the truth kept and the truth, scoring 0.84 against
/// 0.49, dropped). Returns true when the finalists changed.
bool AddFinalist(RegistrationContext& ctx, Finalist f, double start, bool replace_worse = false);

/// Pseudo-symmetric turns of the best pose (Kim & Hilton, Sec. 5: pseudo-symmetric parts
/// registered upside down or turned 180°). The hypotheses need not contain the turned pose,
/// and then the ambiguity test has nothing to compare with: a plane proxy's gate part turned
/// 180° about up fits the stereo cloud at fitness 0.79 (gate, seed 2) with no finalist near the
/// truth. Under the best pose T the source is turned about its registered centroid c —
/// levelled: by 90°, 180°, 270° about up; else by 180° about each principal axis of the
/// registered source and the axes in a cone around it — and placed there or by the descriptor
/// matches' displacement vote under it (the object's symmetry axis need not pass through c):
/// of the placements and cone axes, the one scoring best on the coarse level is refined by the
/// fine ICP from R_s/2 (the vote's cells are 2 R_n wide) and scored like the other finalists,
/// unless it scores below half the best's coarse score; a distinct one enters the ambiguity
/// test, and one that scores better becomes the best. A turn that becomes the best is turned
/// in its turn, up to 4 rounds in all: the first best may be neither pose (a wrong hypothesis
/// whose turn lands on the twin; test PartTurnedAboutTheTargetsCentroid), and the twin's own
/// turn is then the rival that makes the result ambiguous; the turn of a pose that is neither
/// may itself be neither (test EverySymmetricTurnOfTheGatesPartIsRefused).
void SymmetricTurns(RegistrationContext& ctx);

/// Local search (options.local_search): a best pose that slides along or about a principal
/// axis of the source at the resolution bound may sit off the score's maximum — the
/// hypotheses' ICP stopped short on a noisy or planar overlap (the gate's multi-view part on
/// the stereo cloud, seed 8: every hypothesis 0.7–1.4 m along the gate, the truth scoring
/// 0.66 against 0.47). The pose is moved along each open direction by δ = bound, 2·bound, …
/// up to R_s, each move screened by a short ICP from δ, and the best move, refined in full,
/// joins the finalists (or replaces the one it converged to) when it scores above the best.
/// A resolved best has no open direction: nothing changes. Repeated from the new best, up to
/// 4 rounds.
void LocalSearch(RegistrationContext& ctx);

/// Poses the hypotheses may lack: period shifts of the best pose, its symmetric turns, the
/// local search, and the turns again of a best the local search moved.
void SearchAlternatives(RegistrationContext& ctx);

/// The ambiguity test's rivals of the best finalist (paired block t) and, where they tie and
/// both clouds carry a brightness, the intensity test; the best and its fine check.
void TestAmbiguity(RegistrationContext& ctx);

/// The chosen pose's covariance (with the ICP distance's systematic part), its weakest motion,
/// and its resolution along the principal axes and the fit's weak motions.
void EstimateUncertainty(RegistrationContext& ctx);

/// The result's figures from the best finalist, and every finalist and coarse hypothesis.
void ReportFinalists(RegistrationContext& ctx);

/// The verdict: overlap, visibility, normals, ambiguity, scale agreement, resolution and
/// determination; "ok" (or "unverified" for paper_only) when every check passes.
bool Verdict(RegistrationContext& ctx);

}  // namespace mmba::registration::internal
