// Feature-based registration pipeline (Kim & Hilton 3DV 2013, Sec. 3) and its robust
// extensions; see include/mmba/registration/cloud/feature_registration.h.

#include "mmba/registration/cloud/feature_registration.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <exception>
#include <iomanip>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <tuple>
#include <unordered_map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/core/progress.h"
#include "mmba/registration/cloud/robust_estimators.h"
#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/descriptor_matching.h"
#include "registration/cloud/fit_uncertainty.h"
#include "registration/cloud/free_space.h"
#include "registration/cloud/hypotheses.h"
#include "registration/cloud/intensity_test.h"
#include "registration/cloud/keypoints.h"
#include "registration/cloud/normal_orientation.h"
#include "registration/cloud/pcl_backend.h"
#include "registration/cloud/point_to_plane_icp.h"
#include "registration/cloud/pose_resolution.h"
#include "registration/cloud/score_significance.h"
#include "registration/cloud/verification.h"

namespace mmba::registration {

using internal::AlignmentCost;
using internal::Apply;
using internal::BoundTest;
using internal::CheckCloud;
using internal::CliqueHypotheses;
using internal::CropIndices;
using internal::CropTarget;
using internal::DescribeMotion;
using internal::Descriptors;
using internal::DropInvalidNormals;
using internal::EstimateFitUncertainty;
using internal::FineResiduals;
using internal::FitUncertainty;
using internal::FreeSpaceViolations;
using internal::HashIndices;
using internal::Hypothesis;
using internal::HypothesisPool;
using internal::IsolatedPoints;
using internal::Level;
using internal::Matching;
using internal::MatchDescriptors;
using internal::Matrix6d;
using internal::MedianSpacing;
using internal::MotionAbout;
using internal::OffTheSurface;
using internal::Pick;
using internal::PointIndex;
using internal::PointToPlaneIcp;
using internal::PoseResolution;
using internal::RegisteredMoments;
using internal::RobustScale;
using internal::SacIa;
using internal::SameTransform;
using internal::ScoreFine;
using internal::ScoreSignificance;
using internal::SelectKeypoints;
using internal::SpacingQuantiles;
using internal::TargetCrop;
using internal::Vector6d;
using internal::Verify;
using internal::VoxelCount;
using internal::VoxelDownsample;
using internal::VoxelForBudget;
using internal::VoxelKey;
using internal::VoxelKeyHash;

namespace {

using internal::StrideSample;

// Rounds of the pseudo-symmetric turns of the best pose: each turns the best of the round
// before when a turn became the best.
constexpr int kSymmetryTurnRounds = 4;
// Below this many points in a cloud, a failure's reason says the cloud has too few points
// (PCL's bunny thinned to 10-20 points fails, to 30 registers: bench/RESULTS.md, session 41).
constexpr size_t kFewPointsForDescriptors = 30;
// Rounds of the local search (CloudRegistrationOptions::local_search): each starts from the
// move of the round before that scored above the best.
constexpr int kLocalSearchRounds = 4;
// ICP iterations and source points of each move's screening in the local search.
constexpr int kLocalSearchIterations = 10;
constexpr size_t kLocalSearchScreenPoints = 2000;

// RegisterClouds on clouds whose coordinates are small (see RegisterClouds below):
// `source_viewpoint` / `target_viewpoint` = each cloud's own origin in these coordinates,
// towards which its normals are oriented (the scanner of a scan in its own frame).
// `past_normals` (optional): set when the normals were estimated (the input passed its checks).
CloudRegistrationResult RegisterCloudsNearOrigin(const io::PointCloud& source_in,
                                                 const io::PointCloud& target_in,
                                                 const CloudRegistrationOptions& options,
                                                 const Eigen::Vector3d& source_viewpoint,
                                                 const Eigen::Vector3d& target_viewpoint,
                                                 bool* past_normals = nullptr) {
  std::string option_error;
  if (!options.Check(&option_error)) throw InputError::Message("registration options", option_error);
  CloudRegistrationResult result;
  Timer stage_timer;
  std::clock_t stage_cpu = std::clock();
  // Long work shows progress: once a registration has run 10 s (large clouds), each stage
  // is logged as it ends; a quick one stays silent.
  const Timer total_timer;
  if (source_in.size() + target_in.size() > 4000000) {
    spdlog::info("registration: {} source and {} target points; thinning them to the coarse "
                 "and fine levels first", source_in.size(), target_in.size());
  }
  auto end_stage = [&](const std::string& name) {
    const std::clock_t now = std::clock();
    result.runtime.push_back({name, stage_timer.ElapsedSeconds(),
                              static_cast<double>(now - stage_cpu) / CLOCKS_PER_SEC});
    if (total_timer.ElapsedSeconds() > 10.0) {
      spdlog::info("registration: {} done ({:.1f} s, {:.1f} s in all)", name,
                   stage_timer.ElapsedSeconds(), total_timer.ElapsedSeconds());
    }
    stage_timer.Restart();
    stage_cpu = now;
  };
  auto fail = [&](const std::string& reason) {
    result.status = "failed";
    result.reason = reason;
    return result;
  };
  for (const auto& [cloud, which] : {std::pair{&source_in, "source"}, std::pair{&target_in, "target"}}) {
    const std::string problem = CheckCloud(*cloud, which);
    if (!problem.empty()) return fail(problem);
  }

  // --- Each cloud's spacing (median nearest-neighbour distance) and (options.remove_blunders)
  // its scattered blunders, from one kd-tree per cloud: on tens of millions of points each
  // tree takes seconds. The source's spacing on 20,000 and (for the fine level's budget
  // search below) on 5,000 samples.
  double s_src = 0.0, s_src_5000 = 0.0, s_tgt = 0.0;
  io::PointCloud kept_source, kept_target;
  const io::PointCloud* source_ptr = &source_in;
  const io::PointCloud* target_ptr = &target_in;
  for (const bool is_source : {true, false}) {
    const io::PointCloud& cloud = is_source ? source_in : target_in;
    if (cloud.size() < 2) continue;
    const PointIndex index(cloud.points);
    const std::vector<double> spacing = SpacingQuantiles(index, cloud.points, 20000, {0.5, 0.9});
    (is_source ? s_src : s_tgt) = spacing[0];
    if (is_source) s_src_5000 = MedianSpacing(index, cloud.points, 5000);
    if (options.paper_only || !options.remove_blunders) continue;
    const double cell = options.isolated_cell_spacing * spacing[1];
    if (!(cell > 0)) continue;
    // The surface test's constants (CloudRegistrationOptions::remove_blunders): 8 neighbours,
    // thickness 0.25, offset 0.3.
    const std::vector<char> isolated = OffTheSurface(
        index, cloud.points, IsolatedPoints(cloud.points, cell, options.isolated_min_neighbours),
        /*neighbours=*/8, /*max_thickness=*/0.25, /*max_offset=*/0.3);
    const size_t removed = static_cast<size_t>(std::count(isolated.begin(), isolated.end(), 1));
    if (removed == 0 || removed == cloud.size() ||
        static_cast<double>(removed) < options.isolated_min_fraction * static_cast<double>(cloud.size())) {
      continue;
    }
    (is_source ? kept_source : kept_target) = io::WithoutMarked(cloud, isolated);
    (is_source ? source_ptr : target_ptr) = is_source ? &kept_source : &kept_target;
    (is_source ? result.blunders_removed_source : result.blunders_removed_target) = removed;
    std::ostringstream note;
    note << "removed " << removed << " scattered point" << (removed == 1 ? "" : "s") << " of "
         << cloud.size() << " from the " << (is_source ? "source" : "target") << " (fewer than "
         << options.isolated_min_neighbours << " others in the 3 x 3 x 3 cells of " << cell
         << " m around, and off the surface of their 8 nearest)";
    result.notes.push_back(note.str());
  }
  const io::PointCloud& source = *source_ptr;
  const io::PointCloud& target = *target_ptr;

  // --- Levels: a common coarse voxel for the features (clouds of different density are
  // matched at the density of the sparser one; the larger cloud may keep
  // larger_cloud_factor × as many points), a finer one for ICP (the target is cropped to each
  // hypothesis there).
  if (s_src <= 0 || s_tgt <= 0) return fail("all points of a cloud coincide (spacing 0)");
  const bool source_larger = source.size() > target.size();
  const size_t small_budget = static_cast<size_t>(options.max_points_features);
  const size_t large_budget =
      static_cast<size_t>(options.larger_cloud_factor * options.max_points_features);
  double coarse_voxel = std::max(s_src, s_tgt);
  {
    // Coarser by coarse_voxel_spacing while the smaller cloud keeps enough points to describe.
    const io::PointCloud& smaller = source_larger ? target : source;
    const double candidate = options.coarse_voxel_spacing * coarse_voxel;
    if (VoxelCount(smaller.points, candidate) >=
        static_cast<size_t>(options.min_points_coarse)) {
      coarse_voxel = candidate;
    }
  }
  coarse_voxel = std::max(coarse_voxel, VoxelForBudget(source, coarse_voxel,
                                                       source_larger ? large_budget : small_budget));
  coarse_voxel = std::max(coarse_voxel, VoxelForBudget(target, coarse_voxel,
                                                       source_larger ? small_budget : large_budget));
  const bool src_normals = options.use_existing_normals && source.has_normals();
  const bool tgt_normals = options.use_existing_normals && target.has_normals();
  Level src_coarse = VoxelDownsample(source.points, src_normals ? source.normals : std::vector<Eigen::Vector3d>{}, coarse_voxel);
  Level tgt_coarse = VoxelDownsample(target.points, tgt_normals ? target.normals : std::vector<Eigen::Vector3d>{}, coarse_voxel);
  const double fine_voxel_src = VoxelForBudget(source, 0.0, options.max_points_icp, s_src_5000);
  Level src_fine = VoxelDownsample(source.points, src_normals ? source.normals : std::vector<Eigen::Vector3d>{}, fine_voxel_src);
  const double src_fine_spacing = MedianSpacing(src_fine.points, 20000);
  const double spacing = std::max(MedianSpacing(src_coarse.points, 20000),
                                  MedianSpacing(tgt_coarse.points, 20000));
  result.point_spacing_m = spacing;
  const double normal_radius = options.normal_radius_m > 0 ? options.normal_radius_m
                                                           : options.normal_radius_spacing * spacing;
  const double support_radius = options.support_radius_m > 0
                                    ? options.support_radius_m
                                    : options.support_radius_spacing * spacing;
  result.normal_radius_m = normal_radius;
  result.support_radius_m = support_radius;
  spdlog::debug("registration: spacing {:.4g} m (fine source {:.4g}), R_n {:.4g} m, R_s {:.4g} m, "
                "coarse {} / {} points, fine source {}",
                spacing, src_fine_spacing, normal_radius, support_radius, src_coarse.points.size(),
                tgt_coarse.points.size(), src_fine.points.size());
  end_stage("downsample");

  // --- Normals within R_n, oriented towards each cloud's sensors when they are given
  // (internal::OrientTowardsNearest), else towards its origin (the scanner of a scan) and,
  // with NormalOrientation::kConsistent(Turned), then made consistent over the neighbour
  // graph (and the source's turned). Only the coarse level's signs matter: the fine
  // verification and ICP use |n_s·n_t| and squared point-to-plane residuals.
  for (Level* level : {&src_coarse, &tgt_coarse}) {
    if (level->normals.empty()) {
      const bool is_source = level == &src_coarse;
      const std::vector<Eigen::Vector3d>& sensors =
          is_source ? options.source_viewpoints : options.target_viewpoints;
      level->normals = internal::EstimateNormals(level->points, normal_radius,
                                                 is_source ? source_viewpoint : target_viewpoint);
      internal::OrientTowardsNearest(level->points, sensors, &level->normals);
      if (sensors.empty() && (options.normal_orientation == NormalOrientation::kConsistent ||
                              options.normal_orientation == NormalOrientation::kConsistentTurned)) {
        const size_t turned = internal::OrientConsistently(level->points, 10, &level->normals);
        std::ostringstream note;
        note << (is_source ? "source" : "target") << " normals oriented consistently over the "
             << "neighbour graph: " << turned << " of " << level->points.size() << " turned";
        result.notes.push_back(note.str());
      }
    }
    if (options.normal_orientation == NormalOrientation::kConsistentTurned &&
        level == &src_coarse) {
      for (Eigen::Vector3d& n : level->normals) n = -n;
    }
    const size_t before = level->points.size();
    if (before < 10) {
      // Both clouds are thinned to the sparser one's spacing: a cloud that collapses to a few
      // points there is much smaller than the other, as a cloud in millimetres against one in
      // metres is (the normal radius is not the cause, and a larger one would not help).
      auto extent = [](const std::vector<Eigen::Vector3d>& points) {
        Eigen::AlignedBox3d box;
        for (const Eigen::Vector3d& p : points) box.extend(p);
        return points.empty() ? 0.0 : box.diagonal().norm();
      };
      const bool is_source = level == &src_coarse;
      const double own = extent(level->points), other = extent((is_source ? tgt_coarse : src_coarse).points);
      std::ostringstream s;
      s << (is_source ? "source" : "target") << " cloud thins to only " << before
        << " points at the common point spacing " << spacing << " m (the sparser cloud's)";
      if (other > 10 * own) {
        s << ": its extent is " << other / std::max(own, 1e-300) << "x smaller than the "
          << (is_source ? "target" : "source") << "'s (" << own << " against " << other
          << "): are they in different units (millimetres against metres)? Convert one, or give "
             "--scale-range";
      } else {
        s << ": too few points to register";
      }
      return fail(s.str());
    }
    DropInvalidNormals(level);
    if (level->points.size() < before / 2 || level->points.size() < 10) {
      std::ostringstream s;
      s << "cloud too sparse for the normal radius " << normal_radius << " m: "
        << before - level->points.size() << " of " << before
        << " points have too few neighbours (give a larger --normal-radius)";
      return fail(s.str());
    }
  }
  // The fine level's normals are needed only at its sample for the fine verification (up to
  // 8000 points); their neighbourhoods are taken from the whole fine level.
  const std::vector<size_t> fine_idx = StrideSample(src_fine.points.size(), 8000);
  const std::vector<Eigen::Vector3d> fine_src = Pick(src_fine.points, fine_idx);
  std::vector<Eigen::Vector3d> fine_src_n =
      src_fine.normals.empty()
          ? internal::EstimateNormals(
                src_fine.points,
                std::min(normal_radius, options.normal_radius_spacing * src_fine_spacing),
                source_viewpoint, &fine_idx)
          : Pick(src_fine.normals, fine_idx);
  if (src_fine.normals.empty()) {
    internal::OrientTowardsNearest(fine_src, options.source_viewpoints, &fine_src_n);
  }
  end_stage("normals");
  if (past_normals != nullptr) *past_normals = true;

  // --- Keypoints.
  // The larger cloud gets keypoints in proportion to its coarse size (at most
  // min(4, larger_cloud_factor) × max_keypoints), so the part the smaller one overlaps is not
  // starved.
  const double size_ratio = static_cast<double>(std::max(src_coarse.points.size(), tgt_coarse.points.size())) /
                            static_cast<double>(std::max<size_t>(1, std::min(src_coarse.points.size(), tgt_coarse.points.size())));
  const int max_kp_large = static_cast<int>(options.max_keypoints *
                                            std::clamp(size_ratio, 1.0, std::min(4.0, options.larger_cloud_factor)));
  const bool src_is_large = src_coarse.points.size() > tgt_coarse.points.size();
  const std::vector<int> src_kp =
      SelectKeypoints(src_coarse, normal_radius, options,
                      src_is_large ? max_kp_large : options.max_keypoints, "source", &result.notes);
  const std::vector<int> tgt_kp =
      SelectKeypoints(tgt_coarse, normal_radius, options,
                      src_is_large ? options.max_keypoints : max_kp_large, "target", &result.notes);
  result.num_keypoints_source = src_kp.size();
  result.num_keypoints_target = tgt_kp.size();
  end_stage("keypoints");
  if (src_kp.size() < 3 || tgt_kp.size() < 3) {
    return fail("too few keypoints (" + std::to_string(src_kp.size()) + " source, " +
                std::to_string(tgt_kp.size()) + " target; need 3)");
  }
  // Sparse for the support radius?
  {
    PointIndex tgt_coarse_index(tgt_coarse.points);
    std::vector<int> neighbours;
    std::vector<size_t> counts;
    for (size_t i = 0; i < tgt_kp.size(); i += std::max<size_t>(1, tgt_kp.size() / 50)) {
      tgt_coarse_index.Radius(tgt_coarse.points[tgt_kp[i]], support_radius, &neighbours);
      counts.push_back(neighbours.size());
    }
    std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
    if (counts[counts.size() / 2] < 16) {
      return fail("cloud too sparse for the support radius " + std::to_string(support_radius) +
                  " m: median " + std::to_string(counts[counts.size() / 2]) +
                  " neighbours at the keypoints (need 16; give a larger --support-radius)");
    }
  }

  // --- Descriptors and matching.
  std::vector<Descriptor> descriptors;
  if (options.descriptor == Descriptor::kAuto) {
    descriptors = {Descriptor::kFpfh, Descriptor::kShot};
  } else {
    descriptors = {options.descriptor};
  }
  const Eigen::Vector3d* up = options.gravity_aligned ? &options.up : nullptr;
  std::vector<Matching> matchings;
  for (Descriptor d : descriptors) {
    Descriptors ds, dt;
    try {
      ds = internal::ComputeDescriptors(d, src_coarse.points, src_coarse.normals, src_kp,
                                        support_radius, up);
      dt = internal::ComputeDescriptors(d, tgt_coarse.points, tgt_coarse.normals, tgt_kp,
                                        support_radius, up);
    } catch (const std::exception& e) {  // PCL reports degenerate input by exceptions
      return fail("descriptor " + DescriptorName(d) + " could not be computed: " + e.what());
    }
    end_stage("descriptors " + DescriptorName(d));
    matchings.push_back(MatchDescriptors(DescriptorName(d), src_coarse, tgt_coarse, src_kp,
                                         tgt_kp, ds, dt, options.sac_ia_randomness,
                                         options.max_correspondences));
    result.num_correspondences += matchings.back().best_pairs.size();
    end_stage("matching " + DescriptorName(d));
  }

  // --- Hypotheses: SAC-IA and the maximum consistent clique.
  PointIndex tgt_coarse_index(tgt_coarse.points);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : src_coarse.points) centre += p;
  centre /= static_cast<double>(src_coarse.points.size());
  const std::vector<size_t> score_idx = StrideSample(src_coarse.points.size(), 300);
  std::vector<Eigen::Vector3d> score_sample = Pick(src_coarse.points, score_idx);
  std::shuffle(score_sample.begin(), score_sample.end(), std::mt19937_64(options.seed + 1));
  std::mt19937_64 rng(options.seed);
  const double tau_coarse = normal_radius;
  HypothesisPool pool(static_cast<size_t>(options.num_hypotheses), centre, normal_radius);
  for (const Matching& m : matchings) {
    SacIa(m, score_sample, tgt_coarse_index, options, spacing, support_radius / 2.0, tau_coarse,
          &rng, &pool);
  }
  end_stage("sac-ia");
  std::vector<Hypothesis> hypotheses = pool.hypotheses();
  if (options.paper_only && hypotheses.size() > 1) hypotheses.resize(1);
  if (!options.paper_only && options.use_max_clique) {
    for (const Matching& m : matchings) {
      std::vector<Hypothesis> cliques;
      CliqueHypotheses(m, options, spacing, options.num_cliques, &cliques, &result.notes);
      for (Hypothesis& h : cliques) {
        h.cost = AlignmentCost(score_sample, tgt_coarse_index, h.transform, tau_coarse);
        hypotheses.push_back(h);
      }
    }
    end_stage("max-clique");
  }
  // A known approximate pose (search window): it is a hypothesis itself — descriptors may
  // find nothing on a poor overlap — and every hypothesis outside the window is dropped.
  const bool windowed = options.search_window_m > 0.0;
  const auto inside = [&](const Eigen::Matrix4d& t) {
    if (!windowed) return true;
    const Eigen::Vector3d moved = t.topLeftCorner<3, 3>() * centre + t.topRightCorner<3, 1>() - centre;
    const double angle = Eigen::AngleAxisd(Eigen::Matrix3d(t.topLeftCorner<3, 3>())).angle() * 180.0 / M_PI;
    return moved.norm() <= options.search_window_m && angle <= options.search_window_deg;
  };
  if (windowed && !options.paper_only) {
    Hypothesis h;
    h.origin = "approximate pose";
    h.descriptor = matchings.empty() ? "" : matchings.front().descriptor;
    h.cost = AlignmentCost(score_sample, tgt_coarse_index, h.transform, tau_coarse);
    hypotheses.push_back(h);
  }
  if (hypotheses.empty()) {
    return fail("no hypothesis: no consistent descriptor matches (" +
                std::to_string(result.num_correspondences) + " correspondences)");
  }

  // --- Refine each hypothesis with ICP on the coarse level, then verify.
  const std::vector<size_t> icp_idx = StrideSample(src_coarse.points.size(), 1500);
  const std::vector<Eigen::Vector3d> icp_src = Pick(src_coarse.points, icp_idx);
  const std::vector<Eigen::Vector3d> icp_src_n = Pick(src_coarse.normals, icp_idx);
  const double tau = options.inlier_distance_spacing * spacing;
  for (Hypothesis& h : hypotheses) {
    if (options.icp) {
      h.transform = PointToPlaneIcp(icp_src, tgt_coarse.points, tgt_coarse.normals,
                                    tgt_coarse_index, h.transform, support_radius / 2.0,
                                    options.icp_distance_spacing * spacing,
                                    std::min(options.icp_iterations, 20), up);  // ranking only
    }
    Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, h.transform, tau, &h);
  }
  hypotheses.erase(std::remove_if(hypotheses.begin(), hypotheses.end(),
                                  [&](const Hypothesis& h) { return !inside(h.transform); }),
                   hypotheses.end());
  if (hypotheses.empty()) return fail("no hypothesis within the search window");
  std::stable_sort(hypotheses.begin(), hypotheses.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.score > b.score; });
  end_stage("icp+verify coarse");

  // --- Fine ICP and verification of the best distinct coarse hypotheses (coarse-to-fine:
  // a loose coarse inlier distance cannot tell a shifted repetitive structure or a
  // pseudo-symmetric turn from the truth; the fine level can). The target is cropped to
  // each hypothesis' footprint and kept at up to max_points_icp points there.
  struct Finalist {
    Hypothesis h;
    std::vector<double> residuals;
    std::vector<bool> agree;
    double sigma = 0.0, spacing = 0.0;
    double icp_end = 0.0;  // the last correspondence distance of its fine ICP (0: no ICP)
    std::shared_ptr<TargetCrop> crop;
    std::vector<bool> violates;  // FreeSpaceViolations (empty: no sensor positions known)
    // Coarse score of the hypothesis it was refined from (the best of those merged into it);
    // NaN for finalists made at the fine level (symmetric turns, period shifts).
    double coarse_score = std::numeric_limits<double>::quiet_NaN();
  };
  // Visibility: z-buffers of each cloud from its own sensors (given in its own frame), the
  // whole target's (an occluder outside a hypothesis' crop still hides what lies behind it)
  // and the fine source sample's.
  const bool visibility = !options.paper_only &&
                          (!options.source_viewpoints.empty() || !options.target_viewpoints.empty());
  std::unique_ptr<internal::FreeSpace> src_free, tgt_free;
  std::unique_ptr<PointIndex> fine_src_index;
  Eigen::AlignedBox3d src_box;
  if (visibility) {
    fine_src_index = std::make_unique<PointIndex>(fine_src);
    for (const Eigen::Vector3d& p : fine_src) src_box.extend(p);
    if (!options.source_viewpoints.empty()) {
      src_free = std::make_unique<internal::FreeSpace>(fine_src, options.source_viewpoints,
                                                       MedianSpacing(fine_src, 20000));
    }
    if (!options.target_viewpoints.empty()) {
      tgt_free = std::make_unique<internal::FreeSpace>(target.points, options.target_viewpoints,
                                                       s_tgt);
    }
  }
  // The target around a hypothesis; a target within the budget is prepared once, whole.
  std::shared_ptr<TargetCrop> whole_target;
  struct CachedCrop {
    size_t count;
    uint64_t hash;
    std::shared_ptr<TargetCrop> crop;
  };
  std::vector<CachedCrop> crop_cache;
  auto crop_for = [&](const Eigen::Matrix4d& t) {
    if (whole_target) return whole_target;
    const bool whole = target.size() <= static_cast<size_t>(options.max_points_icp);
    const std::vector<size_t> inside = CropIndices(
        target, fine_src, t, whole ? std::numeric_limits<double>::infinity() : support_radius);
    // Finalists near one pose often crop the same target points (a room the source spans:
    // eight finalists, five of them the same 98 k points). A crop depends on its points
    // alone, so those share one, normals included (0.2–0.3 s each there).
    const uint64_t key = HashIndices(inside);
    for (const CachedCrop& cached : crop_cache) {
      if (cached.count == inside.size() && cached.hash == key) return cached.crop;
    }
    auto c = std::make_shared<TargetCrop>(CropTarget(
        target, tgt_normals, inside, static_cast<size_t>(options.max_points_icp),
        0.5 * src_fine_spacing));
    // The crop's normals within a few of its spacings, and wider where that is a line, not a
    // surface. Near a scanner the nearest-neighbour spacing is the spacing along a scan line,
    // and a radius of a few of those spans one line or two (normals that disagreed with the
    // source's at the truth, and a fine ICP that slid along them: the full-preset gate's
    // stereo cloud onto its LiDAR model went to its 180° twin). So the spacing is at least
    // the area spacing over 2.2, its ratio to the nearest-neighbour spacing on a uniformly
    // random sample (1.5–1.7 on an even voxel-centroid sample: neither is changed; 3.3 next
    // to the simulated gate's scanner), and a normal whose neighbourhood is still a line is
    // estimated wider.
    if (c->level.normals.empty() && c->level.points.size() >= 10) {
      const double area_spacing = internal::AreaSpacing(c->level.points, normal_radius);
      const double radius =
          std::min(normal_radius,
                   options.normal_radius_spacing * std::max(c->level.spacing, area_spacing / 2.2));
      const size_t repaired = internal::SurfaceNormals(c->level.points, *c->index, radius,
                                                       normal_radius, target_viewpoint,
                                                       &c->level.normals);
      spdlog::debug("registration: target crop of {} points, spacing {:.4g} m, normals within "
                    "{:.4g} m, {} of them wider (a line at that radius)",
                    c->level.points.size(), c->level.spacing, radius, repaired);
    }
    if (whole) whole_target = c;
    crop_cache.push_back({inside.size(), key, c});
    return c;
  };
  // The clouds' noise, once known: the smallest robust residual scale of the finalists
  // refined from the coarse hypotheses (set below; see fine_tau).
  double noise_sigma = std::numeric_limits<double>::infinity();
  // The fine ICP: plane-to-plane from both clouds' normals, ending at its own distance, or
  // point-to-plane ending at the coarse levels' distance.
  const std::vector<Eigen::Vector3d>* plane_to_plane_normals =
      options.icp_plane_to_plane ? &fine_src_n : nullptr;
  const double fine_end_spacing = options.icp_plane_to_plane ? options.icp_plane_distance_spacing
                                                             : options.icp_distance_spacing;
  // A finalist refined on its own crop of the target: fine ICP from `icp_start`, then its fine
  // residuals and their robust scale. False when the pose puts the source off the target.
  auto refine = [&](Finalist* f, double icp_start) {
    const std::shared_ptr<TargetCrop> crop = crop_for(f->h.transform);
    const TargetCrop& c = *crop;
    if (c.level.points.size() < 10) return false;
    f->spacing = std::max(src_fine_spacing, c.level.spacing);
    if (options.icp) {
      f->h.transform = PointToPlaneIcp(fine_src, c.level.points, c.level.normals, *c.index,
                                       f->h.transform, icp_start,
                                       fine_end_spacing * f->spacing,
                                       options.icp_iterations, nullptr,  // free: levelled ≠ exact
                                       plane_to_plane_normals);
      f->icp_end = fine_end_spacing * f->spacing;
    }
    const double reach = std::min(normal_radius, options.normal_radius_spacing * f->spacing);
    FineResiduals(fine_src, fine_src_n, c, f->h.transform, reach, &f->residuals, &f->agree);
    f->sigma = RobustScale(f->residuals);
    // A noisy cloud (a stereo reconstruction's range noise can be several spacings): a final
    // correspondence distance below its noise keeps only the residuals that happen to be
    // small, and the pose drifts to wherever those are. Again with the distance at
    // icp_noise_sigmas × the robust residual scale (at most the reach). Once the noise is
    // known (a period shift or turn of the best pose), a larger scale is the pose's misfit,
    // not noise: the second pass then runs within the noise alone.
    const double noise_distance =
        std::min(reach, options.icp_noise_sigmas * std::min(f->sigma, noise_sigma));
    if (options.icp && !options.paper_only &&
        noise_distance > fine_end_spacing * f->spacing) {
      f->h.transform = PointToPlaneIcp(fine_src, c.level.points, c.level.normals, *c.index,
                                       f->h.transform, noise_distance, noise_distance,
                                       options.icp_iterations, nullptr, plane_to_plane_normals);
      f->icp_end = noise_distance;
      FineResiduals(fine_src, fine_src_n, c, f->h.transform, reach, &f->residuals, &f->agree);
      f->sigma = RobustScale(f->residuals);
    }
    f->crop = crop;
    return true;
  };
  std::vector<Finalist> finalists;
  const size_t max_finalists = options.paper_only ? 1 : 4;
  for (const Hypothesis& h : hypotheses) {
    if (finalists.size() >= max_finalists) break;
    bool duplicate = false;
    for (const Finalist& f : finalists) {
      duplicate = duplicate || SameTransform(f.h.transform, h.transform, centre, 2.0, 2.0 * tau);
    }
    if (duplicate) continue;
    Finalist f;
    f.h = h;
    f.coarse_score = h.score;
    // Levelled hypotheses were turned about `up` only: the tilt left to the free fine ICP
    // needs a wider start.
    const double start = options.gravity_aligned ? support_radius / 2.0
                                                 : options.icp_distance_spacing * spacing;
    if (!refine(&f, start) || !inside(f.h.transform)) continue;
    finalists.push_back(std::move(f));
  }
  if (finalists.empty()) return fail("no hypothesis puts the source onto the target");
  for (const Finalist& f : finalists) noise_sigma = std::min(noise_sigma, f.sigma);
  // One inlier threshold for all finalists: inlier_sigma × the smallest robust residual scale
  // (the best-fitting hypothesis sees the clouds' noise; a wrong one sees its misfit too),
  // at least a quarter of the fine spacing.
  double fine_tau = std::numeric_limits<double>::infinity();
  for (const Finalist& f : finalists) {
    fine_tau = std::min(fine_tau, std::max(options.inlier_sigma * f.sigma, 0.25 * f.spacing));
  }
  if (!std::isfinite(fine_tau)) fine_tau = tau;
  auto violations_of = [&](const Finalist& f) -> std::vector<bool> {
    if (!visibility) return {};
    // A point counts as in free space only beyond the noise: two inlier distances (6 robust
    // σ of the best fit) in front of the first surface, and no point of the other cloud
    // within that distance.
    const double margin = 2.0 * fine_tau;
    return FreeSpaceViolations(fine_src, *fine_src_index, src_free.get(), src_box, *f.crop,
                               tgt_free.get(), f.h.transform, margin, margin);
  };
  double fine_spacing = 0.0;
  for (Finalist& f : finalists) {
    f.violates = violations_of(f);
    ScoreFine(f.residuals, f.agree, fine_tau, f.violates, &f.h);
    fine_spacing = std::max(fine_spacing, f.spacing);
  }
  // Best score first (stable: ties keep their order).
  auto sort_finalists = [&] {
    std::stable_sort(finalists.begin(), finalists.end(),
                     [](const Finalist& a, const Finalist& b) { return a.h.score > b.h.score; });
  };
  sort_finalists();
  // Finalists that converged to the same transform are one hypothesis.
  // The one kept takes the better coarse score of the two (the scale-agreement test below).
  for (size_t i = 1; i < finalists.size();) {
    size_t same = i;
    for (size_t j = 0; j < i && same == i; ++j) {
      // Noisy clouds leave ICP in slightly different spots of one basin.
      if (SameTransform(finalists[i].h.transform, finalists[j].h.transform, centre, 10.0,
                        std::max(10.0 * fine_tau, 2.0 * fine_spacing))) {
        same = j;
      }
    }
    if (same < i) {
      finalists[same].coarse_score = std::fmax(finalists[same].coarse_score, finalists[i].coarse_score);
      finalists.erase(finalists.begin() + static_cast<long>(i));
    } else {
      ++i;
    }
  }
  // The displacement modes of the descriptor matches under a pose T, strongest first: at most
  // `max_modes`, each with at least 3 votes and longer than `min_norm`.
  auto displacement_modes = [&](const Eigen::Matrix4d& t, double min_norm, size_t max_modes) {
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
  };
  // A candidate finalist refined from `start`, scored, and kept when it is inside the search
  // window and distinct from every finalist so far.
  // Adds a refined, scored finalist unless it is the same pose as one already there (within
  // 10° and 10 τ). With `replace_worse`, a same pose that scores higher takes the other's
  // place: 10 τ can span a pose and one part of a metre off it (the symmetric gate's part:
  // τ 0.19 m, a turn's pose 0.6 m off the truth kept and the truth, scoring 0.84 against
  // 0.49, dropped). Returns true when the finalists changed.
  auto add_finalist = [&](Finalist f, double start, bool replace_worse = false) {
    if (!refine(&f, start) || !inside(f.h.transform)) return false;
    f.violates = violations_of(f);
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
  };
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
        displacement_modes(finalists.front().h.transform, support_radius,
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
      add_finalist(std::move(f), options.icp_distance_spacing * spacing);
    }
    if (finalists.size() > before_shifts) {
      sort_finalists();
    }
  }
  // Pseudo-symmetric turns of the best pose (Kim & Hilton, Sec. 5: pseudo-symmetric parts
  // registered upside down or turned 180°). As with the period shifts, the hypotheses need
  // not contain the turned pose, and then the ambiguity test has nothing to compare with: a
  // plane proxy's gate part turned 180° about up fits the stereo cloud at fitness 0.79 (gate,
  // seed 2) with no finalist near the truth. Under the best pose T the source is turned about
  // its registered centroid c — levelled: by 90°, 180°, 270° about up; else by 180° about each
  // principal axis of the registered source and the axes in a cone around it — and placed
  // there or by the descriptor matches' displacement vote under it (the object's symmetry axis
  // need not pass through c): of the placements and cone axes, the one scoring best on the
  // coarse level is refined by the fine ICP from R_s/2 (the vote's cells are 2 R_n wide) and
  // scored like the other finalists, unless it scores below half the best's coarse score; a
  // distinct one enters the ambiguity test, and one that scores better becomes the best.
  // A turn that becomes the best is turned in its turn, up to kSymmetryTurnRounds times in
  // all: the first best may be neither pose (a wrong hypothesis whose turn lands on the twin;
  // the symmetric gate's part with three keypoints, test PartTurnedAboutTheTargetsCentroid),
  // and the twin's own turn is then the rival that makes the result ambiguous. The turn of a
  // pose that is neither may itself be neither (the gate's part turned +1 rad: sac-ia's pose
  // 1.6 m off, its turn about the centroid 0.6 m off the truth, that one's turn the twin,
  // reported "ok" when the turns stopped after two rounds; test
  // EverySymmetricTurnOfTheGatesPartIsRefused).
  Eigen::Vector3d target_centroid = Eigen::Vector3d::Zero();  // for the turns about it
  for (const Eigen::Vector3d& p : tgt_coarse.points) target_centroid += p;
  target_centroid /= static_cast<double>(std::max<size_t>(1, tgt_coarse.points.size()));
  auto symmetric_turns = [&]() {
    for (int round = 0;
         round < kSymmetryTurnRounds && !options.paper_only && options.symmetry_turns && !finalists.empty();
         ++round) {
      const Eigen::Matrix4d best_t = finalists.front().h.transform;
      Eigen::Vector3d c;
      Eigen::Matrix3d cov;
      RegisteredMoments(fine_src, best_t, &c, &cov);
      // Groups of turns; each group gives at most one finalist (its best on the coarse level).
      std::vector<std::vector<Vector6d>> turns;
      if (options.gravity_aligned) {
        for (double angle : {0.5 * M_PI, M_PI, 1.5 * M_PI}) {
          Vector6d xi = Vector6d::Zero();
          xi.head<3>() = angle * options.up;
          turns.push_back({xi});
        }
      } else {
        // The 180° twin's axis is the object's symmetry axis, which a principal axis of the
        // source only approximates: a gate's multi-view cloud (full gate, seed 1) has its up
        // axis 5° from the twin's, and a turn about an axis θ off is 2θ off, beyond the coarse
        // ICP's reach. So each principal axis a is tried with the axes around it, in rings
        // every symmetry_cone_step_deg up to symmetry_cone_deg (6 axes on the first ring, 12 on
        // the second, …).
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
      }
      bool turns_changed = false;
      // The best pose's coarse score: a turn that fits the coarse level less than half as well
      // is no rival (the fine refinement, a crop of the target with its normals, is the dear
      // part).
      Hypothesis best_coarse = finalists.front().h;
      Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, best_t, tau, &best_coarse);
      auto coarse_fit = [&](Hypothesis* h) {
        if (options.icp) {
          h->transform = PointToPlaneIcp(icp_src, tgt_coarse.points, tgt_coarse.normals,
                                         tgt_coarse_index, h->transform, support_radius / 2.0,
                                         options.icp_distance_spacing * spacing,
                                         std::min(options.icp_iterations, 20), up);
        }
        Verify(icp_src, icp_src_n, tgt_coarse.normals, tgt_coarse_index, h->transform, tau, h);
      };
      for (const std::vector<Vector6d>& group : turns) {
        // Each turn's placements (below) are compared on the coarse level (ICP and score as for
        // the hypotheses); only the group's best is refined at the fine level.
        Hypothesis pick;
        bool picked = false;
        std::string pick_how;  // how the pick was placed, for its origin text
        Vector6d pick_xi = Vector6d::Zero();
        for (size_t g = 0; g < group.size(); ++g) {
          // The cone refines an axis whose turn nearly fits; a central turn that fits the
          // coarse level less than a quarter as well as the best is not tried around (the
          // coarse ICPs of the cone were 0.75 s of a Stanford pair's 2.2 s).
          if (g == 1 && pick.score < 0.25 * best_coarse.score) break;
          const Vector6d& xi = group[g];
          const Eigen::Matrix4d turned = MotionAbout(xi, c) * best_t;
          // Placed as turned about c (an object symmetric about an axis through its centroid
          // maps onto itself), and by the two strongest modes of the descriptor matches'
          // displacement vote (for a part whose object's axis does not pass through c). The
          // vote alone is not enough: where the twin's matches outnumber the right ones they
          // vote along a line (full gate, multi-view → LiDAR: every mode 1.7 m off, the gate's
          // thickness, while the turn about c was within the coarse ICP's reach). The cone's
          // other axes are placed about c only (the coarse ICP is the dear part here).
          std::vector<std::pair<Eigen::Vector3d, std::string>> placements = {
              {Eigen::Vector3d::Zero(), "about the centroid"}};
          if (g == 0) {
            for (const auto& [count, shift] : displacement_modes(turned, -1.0, 2)) {
              std::ostringstream how;
              how << std::setprecision(3) << "shift of " << shift.norm() << " m, " << count
                  << " votes";
              placements.emplace_back(shift, how.str());
            }
            // And turned about the target's centroid: a part registered onto its whole
            // symmetric object, whose axis passes through the object's centroid, not the
            // part's (full gate, plane-proxy part → stereo cloud, levelled: the turn about the
            // part's centroid was 4.5 m off, no vote mode, and the twin was reported ok).
            // MotionAbout(ξ, c_t) = MotionAbout(ξ, c) shifted by (I − R)(c_t − c).
            const Eigen::Matrix3d r = MotionAbout(xi, c).topLeftCorner<3, 3>();
            placements.emplace_back((Eigen::Matrix3d::Identity() - r) * (target_centroid - c),
                                    "about the target's centroid");
          }
          for (const auto& [shift, how] : placements) {
            Hypothesis h = finalists.front().h;
            h.transform = turned;
            h.transform.topRightCorner<3, 1>() += shift;
            coarse_fit(&h);
            if (!picked || h.score > pick.score) {
              picked = true;
              pick = h;
              pick_how = how;
              pick_xi = xi;
            }
          }
        }
        const Vector6d& xi = pick_xi;
        spdlog::debug("registration: symmetric turn {:.3g} deg about ({:.3f}, {:.3f}, {:.3f}): "
                      "{}, coarse score {:.3g} (best {:.3g})",
                      xi.head<3>().norm() * 180.0 / M_PI, xi(0) / xi.head<3>().norm(),
                      xi(1) / xi.head<3>().norm(), xi(2) / xi.head<3>().norm(), pick_how,
                      pick.score, best_coarse.score);
        if (!picked || pick.score < 0.5 * best_coarse.score) continue;
        Finalist f;
        f.h = pick;
        std::ostringstream origin;
        const Eigen::Vector3d axis = xi.head<3>().normalized();
        origin << std::setprecision(3) << "symmetric turn of " << xi.head<3>().norm() * 180.0 / M_PI
               << " deg about (" << axis.x() << ", " << axis.y() << ", " << axis.z()
               << "), " << pick_how;
        f.h.origin = origin.str();
        turns_changed = add_finalist(std::move(f), support_radius / 2.0, /*replace_worse=*/true) || turns_changed;
      }
      if (turns_changed) {
        sort_finalists();
      }
      if (finalists.front().h.transform == best_t) break;
    }
  };
  symmetric_turns();
  const Eigen::Matrix4d best_before_local_search =
      finalists.empty() ? Eigen::Matrix4d::Zero() : Eigen::Matrix4d(finalists.front().h.transform);
  // Local search (options.local_search): a best pose that slides along or about a principal
  // axis of the source at the resolution bound may sit off the score's maximum — the
  // hypotheses' ICP stopped short on a noisy or planar overlap (the gate's multi-view part on
  // the stereo cloud, seed 8: every hypothesis 0.7–1.4 m along the gate, the truth scoring
  // 0.66 against 0.47). The pose is moved along each open direction by δ = bound, 2·bound, …
  // up to R_s, each move screened by a short ICP from δ, and the best move, refined in full,
  // joins the finalists (or replaces the one it converged to) when it scores above the best.
  // A resolved best has no open direction: nothing changes. Repeated from the new best, up
  // to kLocalSearchRounds times.
  // The local search's last test at the bound, of the pose and crop it was made for.
  struct {
    Eigen::Matrix4d transform = Eigen::Matrix4d::Zero();
    const TargetCrop* crop = nullptr;
    double spacing = 0.0;
    BoundTest test;
  } best_tested;
  for (int round = 0; !options.paper_only && options.local_search && !finalists.empty() &&
                      round < kLocalSearchRounds;
       ++round) {
    const Finalist& f0 = finalists.front();
    const double bound = options.max_resolution_spacing * f0.spacing;
    const double reach = std::min(normal_radius, options.normal_radius_spacing * f0.spacing);
    BoundTest test;
    PoseResolution(fine_src, fine_src_n, *f0.crop, f0.h.transform, f0.residuals, f0.agree, reach,
                   fine_tau, support_radius, bound, support_radius, options.resolution_t, true, {},
                   &test);
    best_tested = {f0.h.transform, f0.crop.get(), f0.spacing, std::move(test)};
    const std::vector<Vector6d>& open = best_tested.test.directions;
    Eigen::Vector3d c;
    Eigen::Matrix3d cov;
    RegisteredMoments(fine_src, f0.h.transform, &c, &cov);
    // The moves are screened on the best's crop (no new crops) with a sample of the fine
    // source (kLocalSearchScreenPoints): a short ICP from δ (kLocalSearchIterations), scored
    // against the best's score on the same sample (free space left out). The move screening
    // best is then refined in full on its own crop and scored like every finalist.
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
        if (!inside(moved)) continue;
        const double score = screen_score(moved);
        if (score <= top_screen) continue;
        top_screen = score;
        top.emplace();
        top->h = f0.h;
        top->h.transform = moved;
      }
    }
    if (top) {
      if (refine(&*top, bound) && inside(top->h.transform)) {
        top->violates = violations_of(*top);
        ScoreFine(top->residuals, top->agree, fine_tau, top->violates, &top->h);
      } else {
        top.reset();
      }
    }
    spdlog::debug("registration: local search round {}: {} open directions, best move scores "
                  "{:.4g} (best {:.4g})",
                  round + 1, open.size(), top ? top->h.score : 0.0, f0.h.score);
    if (top && top->h.score > f0.h.score) {
      if (round == 0) top->h.origin = f0.h.origin + ", local search";
      top->coarse_score = f0.coarse_score;  // a refinement of the best
      // It replaces a finalist it converged to (scoring below it), else joins them.
      auto same = std::find_if(finalists.begin(), finalists.end(), [&](const Finalist& g) {
        return SameTransform(top->h.transform, g.h.transform, centre, 10.0,
                             std::max(10.0 * fine_tau, 2.0 * fine_spacing));
      });
      if (same == finalists.end()) {
        finalists.push_back(std::move(*top));
      } else if (top->h.score > same->h.score) {
        *same = std::move(*top);
      }
      sort_finalists();
    } else {
      break;
    }
  }
  // A best pose the local search moved is turned again: the turns above turned the pose it
  // started from, and a turn of a pose some decimetres off lands as far off the twin, beyond
  // the fine ICP's reach (the symmetric gate's part at −0.6 rad: the truth found by the local
  // search, the twin never, "ok"; test EverySymmetricTurnOfTheGatesPartIsRefused).
  if (!finalists.empty() && finalists.front().h.transform != best_before_local_search) {
    symmetric_turns();
  }
  // A finalist that the visibility test contradicts (the verdict below would fail it as the
  // best) is no alternative in the ambiguity test.
  auto contradicted = [&](const Hypothesis& h) {
    return visibility && h.violation > options.max_violation_ratio * h.fitness;
  };
  // The ambiguity test's rivals: every distinct finalist scoring above max_ambiguity × the
  // best that the visibility test does not contradict, with the paired block t of the best
  // over it. The t statistic itself is geometric (without the −1 terms of the free-space
  // violations): one region where a sensor sees through a real surface — glass for a LiDAR,
  // which a camera reconstructs — would otherwise dominate the block variance.
  std::vector<std::pair<size_t, double>> rivals;  // (finalist, geometric t)
  for (size_t k = 1; k < finalists.size(); ++k) {
    if (!(finalists[k].h.score > options.max_ambiguity * finalists[0].h.score)) continue;
    if (contradicted(finalists[k].h)) continue;
    rivals.emplace_back(k, ScoreSignificance(fine_src, finalists[0].residuals, finalists[0].agree,
                                             finalists[k].residuals, finalists[k].agree, fine_tau,
                                             support_radius));
  }
  // Intensity test (intensity_test.h). Only where the geometry leaves a tie (some rival within
  // min_significance of the best) and both clouds carry a brightness: the intensity t of the
  // best over each rival (jackknifed over the same blocks) joins the geometric one
  // (internal::CombinedSignificance). It only ever adds evidence for the geometric best:
  // letting it pick a geometric runner-up instead was tried, and on a fresh cathedral (seed 4)
  // it picked a plane-proxy part's pose 23.6 m off over one 0.68 m off (a proxy's per-face
  // brightness can fit a wrong placement best).
  std::vector<internal::IntensityBlocks> photo;  // per finalist; empty: not tested
  const bool tie = std::any_of(rivals.begin(), rivals.end(), [&](const auto& r) {
    return r.second < options.min_significance;
  });
  if (!options.paper_only && options.intensity_test && tie) {
    const internal::IntensityAgreement brightness(source, target, fine_src, support_radius);
    if (brightness.available()) {
      for (const Finalist& f : finalists) {
        std::vector<bool> inlier(f.residuals.size());
        for (size_t i = 0; i < inlier.size(); ++i) {
          inlier[i] =
              std::isfinite(f.residuals[i]) && std::abs(f.residuals[i]) < fine_tau && f.agree[i];
        }
        photo.push_back(brightness.Measure(f.h.transform, inlier));
      }
      result.intensity_tested = true;
      result.intensity_correlation = photo[0].AbsCorrelation();
    }
  }
  spdlog::debug("registration: fine τ {:.4g} m, {} distinct finalists", fine_tau, finalists.size());
  Hypothesis best = finalists.front().h;
  const Hypothesis fine_check = best;
  end_stage("icp+verify fine");
  double axis_resolution = std::numeric_limits<double>::infinity();
  std::string weak_motion;
  if (!options.paper_only) {
    const Finalist& f = finalists.front();
    result.fine_spacing_m = f.spacing;
    const double reach = std::min(normal_radius, options.normal_radius_spacing * f.spacing);
    const FitUncertainty u = EstimateFitUncertainty(fine_src, *f.crop, f.h.transform, f.residuals,
                                                    f.agree, reach, fine_tau, support_radius);
    result.covariance = u.covariance;
    result.covariance_centre = u.centre;
    result.sigma_rms_m = u.sigma_rms;
    result.constraint_ratio = u.constraint_ratio;
    Vector6d weakest = u.weakest;
    // The fit's dependence on its last correspondence distance and on its objective, a
    // systematic error the residuals' covariance does not contain: point-to-plane ICP ended
    // at half and at twice that distance (at most the reach); after a plane-to-plane fit
    // (`icp_plane_to_plane`) also point-to-plane's own answer, which differs where the two
    // clouds' surfaces differ in detail (a plane proxy against a scan). On the simulated
    // cathedral's plane proxy → LiDAR the point-to-plane pose moved 3.1 cm (twice) and
    // 18.6 cm (half) from one 8 cm off the truth whose covariance said 0.7 cm.
    // Without ICP (--no-icp) the pose is a sample consensus's, not the fit's optimum: its
    // distance to that optimum (the same ICP it skipped) enters whole, so that the stated σ
    // covers the error it left (Stanford bun000 → bun045: 0.66 mm RMS off, σ 0.09 mm without
    // this term).
    std::vector<std::pair<double, double>> moves =  // (ICP end distance, weight)
        options.icp ? std::vector<std::pair<double, double>>{{0.5 * f.icp_end, 0.5},
                                                             {2.0 * f.icp_end, 0.5}}
                    : std::vector<std::pair<double, double>>{
                          {options.icp_distance_spacing * f.spacing, 1.0}};
    // After a plane-to-plane fit, also point-to-plane's own answer, whole.
    if (options.icp && options.icp_plane_to_plane) {
      moves.push_back({options.icp_distance_spacing * f.spacing, 1.0});
    }
    if ((!options.icp || f.icp_end > 0) && std::isfinite(u.sigma_rms)) {
      const Eigen::Matrix4d inv = f.h.transform.inverse();
      const Matrix6d& metric = u.metric;
      Matrix6d systematic = Matrix6d::Zero();
      double sum_sq = 0.0;
      for (const auto& [distance, weight] : moves) {
        const double end = std::min(reach, distance);
        const Eigen::Matrix4d moved = PointToPlaneIcp(
            fine_src, f.crop->level.points, f.crop->level.normals, *f.crop->index, f.h.transform,
            options.icp ? end : std::max(end, reach), end,
            options.icp_iterations, nullptr);
        const Eigen::Matrix4d delta = moved * inv;  // as MotionAbout(ξ, centre)
        const Eigen::Matrix3d r = delta.topLeftCorner<3, 3>();
        const Eigen::AngleAxisd aa(r);
        Vector6d xi;
        xi.head<3>() = aa.angle() * aa.axis();
        xi.tail<3>() = delta.topRightCorner<3, 1>() - u.centre + r * u.centre;
        systematic += weight * xi * xi.transpose();
        sum_sq += weight * xi.dot(metric * xi);
      }
      result.gate_sensitivity_m = std::sqrt(sum_sq);
      result.covariance += systematic;
      if (!options.icp) {
        std::ostringstream note;
        note << std::setprecision(3) << "not refined by ICP (--no-icp): the pose is "
             << result.gate_sensitivity_m
             << " m RMS over the source from the fit's optimum; its covariance includes that";
        result.notes.push_back(note.str());
      }
      const Eigen::LLT<Matrix6d> llt(metric);
      if (llt.info() == Eigen::Success) {
        const Matrix6d l = llt.matrixL();
        const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(l.transpose() * result.covariance * l);
        result.sigma_rms_m = std::sqrt(std::max(0.0, eig.eigenvalues()(5)));
        weakest = l.transpose().triangularView<Eigen::Upper>().solve(eig.eigenvectors().col(5));
      } else {
        result.sigma_rms_m = std::hypot(u.sigma_rms, result.gate_sensitivity_m);
      }
    }
    for (int k = 0; k < 3; ++k) {
      result.sigma_rotation_deg(k) = std::sqrt(result.covariance(k, k)) * 180.0 / M_PI;
      result.sigma_translation_m(k) = std::sqrt(result.covariance(3 + k, 3 + k));
    }
    const double bound = options.max_resolution_spacing * f.spacing;
    std::ostringstream at_bound;
    at_bound << std::setprecision(3) << " (unconstrained; shown for " << bound
             << " m RMS, the resolution bound)";
    if (!weakest.isZero()) {
      result.weakest_motion =
          std::isfinite(u.sigma_rms) ? DescribeMotion(weakest, result.sigma_rms_m) + " (1 sigma)"
                                     : DescribeMotion(weakest, bound) + at_bound.str();
    }
    // The local search tested this pose at the bound already when it left it as the best.
    const bool tested = best_tested.crop == f.crop.get() && best_tested.spacing == f.spacing &&
                        best_tested.transform == f.h.transform;
    axis_resolution = PoseResolution(fine_src, fine_src_n, *f.crop, f.h.transform, f.residuals,
                                     f.agree, reach, fine_tau, support_radius, bound,
                                     support_radius, options.resolution_t, true, {}, nullptr,
                                     tested ? &best_tested.test : nullptr);
    if (options.probe_weak_motions && !u.weak_directions.empty()) {
      // Probed first at its own bound (the δ grid ·2 / ÷2 from there).
      const double weak_bound = options.max_weak_motion_resolution_spacing * f.spacing;
      result.weak_motion_resolution_m = PoseResolution(
          fine_src, fine_src_n, *f.crop, f.h.transform, f.residuals, f.agree, reach, fine_tau,
          support_radius, weak_bound, support_radius, options.resolution_t, false,
          u.weak_directions);
      weak_motion = DescribeMotion(u.weak_directions.front(), bound);
    }
    result.resolution_m = std::max(axis_resolution, result.weak_motion_resolution_m);
    spdlog::debug("registration: pose resolution {:.4g} m (axes {:.4g} m, weak motions {:.4g} m; "
                  "fine spacing {:.4g} m), sigma {:.4g} m RMS over {} blocks, {:.4g} m with the "
                  "ICP distance's {:.4g} m, constraint ratio {:.3g}, weakest motion {}",
                  result.resolution_m, axis_resolution, result.weak_motion_resolution_m, f.spacing,
                  u.sigma_rms, u.blocks, result.sigma_rms_m, result.gate_sensitivity_m,
                  u.constraint_ratio, result.weakest_motion);
    end_stage("resolution");
  }

  // --- Verdict.
  result.descriptor = best.descriptor;
  result.target_from_source = best.transform;
  result.fitness = fine_check.fitness;
  result.inlier_rmse = fine_check.rmse;
  result.normal_agreement = fine_check.normal_agreement;
  result.num_inliers = static_cast<size_t>(
      std::llround(fine_check.fitness * static_cast<double>(src_fine.points.size())));
  result.fine_inlier_distance_m = fine_tau;
  result.conflict = fine_check.conflict;
  result.visibility_tested = visibility;
  result.violation = fine_check.violation;
  double runner_up = 0.0;
  const RegistrationHypothesis* runner = nullptr;
  for (size_t k = 0; k < finalists.size(); ++k) {
    const Hypothesis& h = finalists[k].h;
    RegistrationHypothesis r;
    r.origin = h.origin + " (fine)";
    if (!photo.empty()) r.intensity_correlation = photo[k].AbsCorrelation();
    r.target_from_source = h.transform;
    r.fitness = h.fitness;
    r.inlier_rmse = h.rmse;
    r.normal_agreement = h.normal_agreement;
    r.score = h.score;
    r.conflict = h.conflict;
    r.violation = h.violation;
    result.hypotheses.push_back(r);
    spdlog::debug("registration: finalist {}: score {:.4g}, fitness {:.3g}, normals {:.3g}, "
                  "free-space violations {:.3g}",
                  h.origin, h.score, h.fitness, h.normal_agreement, h.violation);
  }
  for (const Hypothesis& h : hypotheses) {
    RegistrationHypothesis r;
    r.origin = h.origin + " (coarse)";
    r.target_from_source = h.transform;
    r.fitness = h.fitness;
    r.inlier_rmse = h.rmse;
    r.normal_agreement = h.normal_agreement;
    r.score = h.score;
    result.hypotheses.push_back(r);
  }
  // Ambiguity: the best pose must beat every distinct finalist that scores above
  // max_ambiguity × its score by at least min_significance standard errors of the paired block
  // score difference — the test PoseResolution applies to small displacements, applied here to
  // the distinct poses found: a pseudo-symmetric turn, or a shift by one period of a repeated
  // structure (the runner-up need not score close to the best: a noisy source shifted by one
  // bay may score 70 % of the truth and still not be told from it). `significance` is the
  // smallest of these t statistics (+inf when no distinct finalist is left).
  result.significance = std::numeric_limits<double>::infinity();
  if (finalists.size() > 1) runner_up = finalists[1].h.score;
  double runner_geometric_t = 0.0, runner_intensity_t = 0.0;
  for (const auto& [k, tg] : rivals) {
    const double ti =
        photo.empty() ? 0.0 : internal::IntensityAgreement::Significance(photo[0], photo[k]);
    const double t = photo.empty() ? tg : internal::CombinedSignificance(tg, ti);
    if (t < result.significance) {
      result.significance = t;
      runner = &result.hypotheses[k];
      runner_geometric_t = tg;
      runner_intensity_t = ti;
    }
  }
  if (!photo.empty() && runner != nullptr) result.intensity_significance = runner_intensity_t;
  const double best_score = best.score;
  result.confidence = best_score > 0 ? std::clamp(1.0 - runner_up / best_score, 0.0, 1.0) : 0.0;
  std::ostringstream why;
  why << std::setprecision(3);
  // With the target's sensors known, a small overlap is not by itself evidence against the
  // pose: the source points off the target are checked against the target's free space
  // (they must lie where its sensors did not look). The pose is contradicted when the points
  // in observed free space exceed max_violation_ratio × the inliers, and then only a floor of
  // min_fitness_visible remains for the statistics. Without the target's sensors (a plane
  // proxy has none) the source's sensors test only the other direction — target points off
  // the source — and the overlap floor min_fitness stays: a stereo part moved 30 m along the
  // cathedral's bays onto the proxy (fitness 0.26) contradicts none of its stations' rays.
  const double fitness_floor = visibility && !options.target_viewpoints.empty()
                                   ? options.min_fitness_visible
                                   : options.min_fitness;
  if (fine_check.fitness < fitness_floor) {
    why << "best hypothesis (" << best.origin << ") makes only " << 100 * fine_check.fitness
        << "% of the source lie within " << fine_tau << " m of the target (need "
        << 100 * fitness_floor << "%): the clouds do not overlap, no hypothesis is right, or they overlap "
        << "less than that (--min-fitness lowers the bar, at the risk of a wrong pose on a partial fit)";
    return fail(why.str());
  }
  if (contradicted(fine_check)) {
    why << "visibility: " << 100 * fine_check.violation
        << "% of the source lies in space a sensor observed as empty (allowed: "
        << options.max_violation_ratio << " x the " << 100 * fine_check.fitness
        << "% inliers): the pose contradicts the data";
    return fail(why.str());
  }
  if (!options.paper_only && fine_check.normal_agreement < options.min_normal_agreement) {
    why << "normals disagree: only " << 100 * fine_check.normal_agreement
        << "% of the inliers have matching normals (need "
        << 100 * options.min_normal_agreement << "%)";
    return fail(why.str());
  }
  // The best pose fits; what follows asks whether it is the only one and whether it is fixed.
  result.best_pose_fits = true;
  if (!options.paper_only && runner != nullptr && result.significance < options.min_significance) {
    const Eigen::Matrix3d r = runner->target_from_source.topLeftCorner<3, 3>().transpose() *
                              best.transform.topLeftCorner<3, 3>();
    const double shift =
        (Apply(runner->target_from_source, centre) - Apply(best.transform, centre)).norm();
    why << "ambiguous: a different pose fits almost as well (scores " << best_score << " and "
        << runner->score << "; " << RotationAngleDeg(r) << "° and " << shift
        << " m apart at the source centre); the best is better by only " << result.significance
        << " standard errors (need " << options.min_significance << ")";
    if (!photo.empty()) {
      why << " with the intensity test (geometry " << runner_geometric_t << ", intensity "
          << runner_intensity_t << ")";
    }
    why << ": a (pseudo-)symmetric or repeated structure — give "
        << (options.gravity_aligned ? "" : "--gravity-aligned, ")
        << "more overlap or an approximate pose (--search-window)";
    return fail(why.str());
  }
  // Scale agreement: a chosen pose that the coarse level ranked well below another distinct
  // finalist is contradicted by the coarse evidence (fine ICP can leave a good coarse start on
  // a dense, noisy cloud; the fine score then sees a symmetric twin fit better).
  if (!options.paper_only && options.min_coarse_agreement > 0 &&
      std::isfinite(finalists[0].coarse_score)) {
    size_t leader = 0;
    for (size_t k = 1; k < finalists.size(); ++k) {
      // A pose the visibility test contradicts is no evidence against the chosen one (as in
      // the ambiguity test).
      if (std::isfinite(finalists[k].coarse_score) && !contradicted(finalists[k].h) &&
          !(finalists[k].coarse_score <= finalists[leader].coarse_score)) {
        leader = k;
      }
    }
    if (leader != 0 &&
        finalists[0].coarse_score < options.min_coarse_agreement * finalists[leader].coarse_score) {
      const Finalist& l = finalists[leader];
      const Eigen::Matrix3d r =
          l.h.transform.topLeftCorner<3, 3>().transpose() * best.transform.topLeftCorner<3, 3>();
      const double shift = (Apply(l.h.transform, centre) - Apply(best.transform, centre)).norm();
      why << "scales disagree: the coarse level prefers a pose " << RotationAngleDeg(r) << "° and "
          << shift << " m away (coarse scores " << l.coarse_score << " against "
          << finalists[0].coarse_score << " for this one), the fine level this one (fine scores "
          << best_score << " against " << l.h.score
          << "): a dense noisy cloud or a (pseudo-)symmetric structure — give an approximate "
             "pose (--search-window)";
      return fail(why.str());
    }
  }
  if (!options.paper_only &&
      !(axis_resolution <= options.max_resolution_spacing * result.fine_spacing_m)) {
    why << "pose not resolved: the fine verification cannot tell it from displacements of "
        << axis_resolution << " m RMS (need <= " << options.max_resolution_spacing
        << " x the fine spacing " << result.fine_spacing_m
        << " m); a noisy, planar or featureless overlap";
    return fail(why.str());
  }
  // The fit's least-constrained motion must be told apart within its bound. Not at all up to
  // R_s: the data leave it free (or the pose is off the score's maximum along it). Only
  // beyond the bound: it is fixed by too little (a few edges or steps) to call the pose
  // known — on the simulated cathedral a proxy part slid along the facade was "ok"
  // 0.46–0.58 m off, resolved to 1.28–2.56 m (bench/RESULTS.md, session 17).
  const double weak_bound = options.max_weak_motion_resolution_spacing * result.fine_spacing_m;
  if (!options.paper_only && !(result.weak_motion_resolution_m <= weak_bound)) {
    why << "pose not determined: the fit's least-constrained motion (" << weak_motion
        << ", " << options.max_resolution_spacing * result.fine_spacing_m
        << " m RMS over the source) is ";
    if (std::isfinite(result.weak_motion_resolution_m)) {
      why << "told apart by the fine verification only at " << result.weak_motion_resolution_m
          << " m RMS (need <= " << options.max_weak_motion_resolution_spacing
          << " x the fine spacing " << result.fine_spacing_m << " m = " << weak_bound
          << " m); the overlap fixes it by a few edges or steps only";
    } else {
      why << "not told apart by the fine verification at any displacement up to R_s = "
          << support_radius << " m; a planar or featureless overlap";
    }
    return fail(why.str());
  }
  if (!options.paper_only && options.check_fit_uncertainty &&
      !(options.resolution_t * result.sigma_rms_m <=
                               options.max_resolution_spacing * result.fine_spacing_m)) {
    why << "pose not determined: the inliers of the fit leave " << result.weakest_motion
        << " (" << result.sigma_rms_m << " m RMS over the source; need " << options.resolution_t
        << " sigma <= " << options.max_resolution_spacing << " x the fine spacing "
        << result.fine_spacing_m << " m): a planar or featureless overlap";
    return fail(why.str());
  }
  if (options.paper_only) {
    // The paper's pipeline has no verification: its result is not claimed as "ok".
    result.status = "unverified";
    result.reason = "paper pipeline (best SAC-IA + ICP) without hypothesis verification";
    return result;
  }
  result.status = "ok";
  result.reason.clear();
  return result;
}

io::PointCloud Shifted(const io::PointCloud& cloud, const Eigen::Vector3d& offset) {
  io::PointCloud out = cloud;
  for (Eigen::Vector3d& p : out.points) p += offset;
  return out;
}

}  // namespace

// Each cloud is registered about its own centre c (io::MedianCentre: a blunder far away does
// not move it), and the result is mapped back: T = [I | c_t] · T_local · [I | −c_s]. The
// floats of the kd-trees and PCL then resolve a cloud at its own size (map-grid coordinates,
// 10^5–10^7 m, left them 0.01–0.5 m), and no step but the normals' orientation (below)
// depends on where the frame's origin lies.
// Before session 40 a cloud within 500 m of its origin was registered as given, and an object
// far from that origin against its size (the bunny 30 m above it) failed: the ICP turned it
// about the origin, so each step moved it by the turn's second-order term at that distance
// (10° at 30 m: 0.46 m). The ICP now also turns the source about its own centroid.
// With a search window both clouds share the target's c, so that the given (identity) pose
// stays the identity.
// The normals of a cloud within 500 m of its origin (io::LocalOrigin is zero) are oriented
// towards that origin, its scanner when it is a scan in its own frame. Those of a cloud in a
// grid cannot be (its origin is thousands of km away, nearly level: ground normals would flip
// at random); they are oriented towards a point high above its centroid along `up` instead —
// ground up, walls towards the middle of the cloud, as a levelled scanner standing inside it
// sees them.
namespace {
// A levelled pair whose registered pose tilts the source by more than this gets a note.
constexpr double kLevelledTiltNote = 2.0 * M_PI / 180.0;

// In the cloud's coordinates about its centre (io::MedianCentre): high above it, ten times the
// cloud's robust extent (a blunder far away does not send the viewpoint there), measured on
// at most 100,000 evenly strided points (it runs once per cloud and per trial scale).
Eigen::Vector3d GridViewpoint(const io::PointCloud& cloud, const Eigen::Vector3d& up) {
  const double extent = RobustExtent(Pick(cloud.points, StrideSample(cloud.size(), 100000)));
  return std::max(100.0, 10.0 * extent) * up.normalized();
}

// NormalOrientation::kAuto: RegisterCloudsNearOrigin with the normals towards each cloud's
// origin (or sensors). When that fails after the normals stage with no pose that fits, and
// the two clouds do not both have sensor positions, it is tried again with kConsistentTurned
// (a scan moved into another frame, its origin behind its surfaces: bench/RESULTS.md, issue 5,
// "Normals retried") and, when a cloud's normals are estimated without sensors, with
// kConsistent (part of a cloud turned against the rest). A retry's result is taken only when
// it is "ok"; the runtime counts every try.
CloudRegistrationResult RegisterCloudsNearOriginRetrying(const io::PointCloud& source,
                                                         const io::PointCloud& target,
                                                         const CloudRegistrationOptions& options,
                                                         const Eigen::Vector3d& source_viewpoint,
                                                         const Eigen::Vector3d& target_viewpoint) {
  if (options.normal_orientation != NormalOrientation::kAuto) {
    return RegisterCloudsNearOrigin(source, target, options, source_viewpoint, target_viewpoint);
  }
  CloudRegistrationOptions first_options = options;
  first_options.normal_orientation = NormalOrientation::kViewpoint;
  bool past_normals = false;
  CloudRegistrationResult first = RegisterCloudsNearOrigin(
      source, target, first_options, source_viewpoint, target_viewpoint, &past_normals);
  // A first try whose best pose fits (overlap, normals, visibility) and was refused as
  // ambiguous or not fixed found its poses: a retry would only draw other hypotheses, and an
  // "ok" among them would lack the competitor the first try saw (on the simulated gate, seed 2,
  // the multi-view part onto the proxy: its 180° twin, refused at t 2.5 against the right
  // pose, became a wrong "ok" 5.9 m off on the retry, where the right pose came out worse).
  if (first.status != "failed" || !past_normals || first.best_pose_fits ||
      (!options.source_viewpoints.empty() && !options.target_viewpoints.empty())) {
    return first;
  }
  const auto estimated = [&](const io::PointCloud& cloud, const std::vector<Eigen::Vector3d>& sensors) {
    return sensors.empty() && !(options.use_existing_normals && cloud.has_normals());
  };
  const bool any_estimated =
      estimated(source, options.source_viewpoints) || estimated(target, options.target_viewpoints);
  // One stage per try that did not give the result, so runtime_seconds counts every try.
  const auto as_stage = [](const std::string& name, const CloudRegistrationResult& r) {
    StageTime t{name, 0.0, 0.0};
    for (const StageTime& s : r.runtime) {
      t.seconds += s.seconds;
      t.cpu_seconds += s.cpu_seconds;
    }
    return t;
  };
  CloudRegistrationOptions retry_options = options;
  std::vector<StageTime> tries = {as_stage("first try (normals towards the origin)", first)};
  for (const bool turn : {true, false}) {
    if (!turn && !any_estimated) break;
    const std::string what = any_estimated
                                 ? (turn ? "consistent normals (Hoppe et al. 1992), the source's turned"
                                         : "consistent normals (Hoppe et al. 1992)")
                                 : "the source's normals turned";
    retry_options.normal_orientation =
        turn ? NormalOrientation::kConsistentTurned : NormalOrientation::kConsistent;
    CloudRegistrationResult retry = RegisterCloudsNearOrigin(
        source, target, retry_options, source_viewpoint, target_viewpoint);
    if (retry.ok()) {
      retry.notes.insert(retry.notes.begin(),
                         "registered with " + what + "; with the normals towards each "
                         "cloud's origin it failed: " + first.reason);
      retry.runtime.insert(retry.runtime.begin(), tries.begin(), tries.end());
      return retry;
    }
    first.notes.push_back("retried with " + what + ": failed too (" + retry.reason + ")");
    tries.push_back(as_stage("retry (" + what + ")", retry));
  }
  first.runtime.insert(first.runtime.end(), tries.begin() + 1, tries.end());
  return first;
}
}  // namespace

CloudRegistrationResult RegisterClouds(const io::PointCloud& source,
                                       const io::PointCloud& target,
                                       const CloudRegistrationOptions& options) {
  Eigen::Vector3d o_t = io::MedianCentre(target.points);
  Eigen::Vector3d o_s = options.search_window_m > 0.0 ? o_t : io::MedianCentre(source.points);
  if (!o_t.allFinite() || !o_s.allFinite()) o_t = o_s = Eigen::Vector3d::Zero();  // NaN: fails
  CloudRegistrationOptions local = options;
  for (Eigen::Vector3d& v : local.source_viewpoints) v -= o_s;
  for (Eigen::Vector3d& v : local.target_viewpoints) v -= o_t;
  const auto viewpoint = [&](const io::PointCloud& cloud, const Eigen::Vector3d& o) {
    return io::LocalOrigin(cloud.points).isZero() ? Eigen::Vector3d(-o)
                                                  : GridViewpoint(cloud, options.up);
  };
  const Eigen::Vector3d v_s = viewpoint(source, o_s);
  const Eigen::Vector3d v_t = viewpoint(target, o_t);
  CloudRegistrationResult result = RegisterCloudsNearOriginRetrying(
      Shifted(source, -o_s), Shifted(target, -o_t), local, v_s, v_t);
  const auto back = [&](const Eigen::Matrix4d& t) {
    Eigen::Matrix4d out = t;
    out.topRightCorner<3, 1>() = t.topRightCorner<3, 1>() + o_t - t.topLeftCorner<3, 3>() * o_s;
    return out;
  };
  result.target_from_source = back(result.target_from_source);
  for (RegistrationHypothesis& h : result.hypotheses) {
    h.target_from_source = back(h.target_from_source);
  }
  result.covariance_centre += o_t;
  // A failure with a cloud of a few points (above the hard minimum of 10) is most likely that:
  // say so, rather than leave only the symptom ("do not overlap", "not resolved").
  const size_t fewest = std::min(source.size(), target.size());
  if (!result.ok() && fewest >= 10 && fewest < kFewPointsForDescriptors) {
    std::ostringstream hint;
    hint << "; the " << (source.size() <= target.size() ? "source" : "target") << " has only " << fewest
         << " points: too few for local descriptors (a few dozen at least in each cloud)";
    result.reason += hint.str();
  }
  // Levelled clouds were assumed (--gravity-aligned): the hypotheses turn about `up` only, but
  // the fine ICP is free, so a pose that tilts the source says the assumption did not hold.
  if (options.gravity_aligned && result.ok()) {
    const Eigen::Vector3d up = options.up.normalized();
    const double tilt = std::acos(std::clamp(
        (result.target_from_source.topLeftCorner<3, 3>() * up).normalized().dot(up), -1.0, 1.0));
    if (tilt > kLevelledTiltNote) {
      std::ostringstream note;
      note << std::setprecision(3) << "--gravity-aligned: the pose tilts the source by "
           << tilt * 180.0 / M_PI << " deg against --up; the clouds were not both levelled "
           << "about that axis (the result was found all the same)";
      result.notes.push_back(note.str());
    }
  }
  return result;
}

}  // namespace mmba::registration
