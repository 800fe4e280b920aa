#pragma once

// The state of one run of the cloud registration (RegisterClouds on clouds about their
// centres), filled stage by stage: preprocess (spacing, blunders, levels), normals,
// keypoints, descriptors and matching, hypotheses (SAC-IA, max-clique), coarse ICP and
// verification, fine finalists, their alternatives (period shifts, symmetric turns, local
// search), the ambiguity and intensity tests, the pose's uncertainty and resolution, and the
// verdict. Each stage is a function of this context (registration_stages.h).

#include <cstdint>
#include <ctime>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mmba/core/progress.h"
#include "mmba/geometry/point_index.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/registration/cloud/feature_registration.h"
#include "registration/cloud/cloud_levels.h"
#include "registration/cloud/descriptor_matching.h"
#include "registration/cloud/free_space.h"
#include "registration/cloud/hypotheses.h"
#include "registration/cloud/intensity_test.h"
#include "registration/cloud/pose_resolution.h"
#include "registration/cloud/verification.h"

namespace mmba::registration::internal {

/// A hypothesis refined and verified at the fine level, on its own crop of the target.
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

/// A crop of the target shared by the finalists that crop the same points.
struct CachedCrop {
  size_t count;
  uint64_t hash;
  std::shared_ptr<TargetCrop> crop;
};

/// The local search's last test at the resolution bound, of the pose and crop it was made for.
struct BestTested {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Zero();
  const TargetCrop* crop = nullptr;
  double spacing = 0.0;
  BoundTest test;
};

struct RegistrationContext {
  /// `source_viewpoint` / `target_viewpoint`: each cloud's own origin in the coordinates of
  /// the run, towards which its normals are oriented (the scanner of a scan in its own frame).
  RegistrationContext(const io::PointCloud& source_in, const io::PointCloud& target_in,
                      const CloudRegistrationOptions& options,
                      const Eigen::Vector3d& source_viewpoint,
                      const Eigen::Vector3d& target_viewpoint);

  /// Records the stage `name` as ended (wall and CPU time since the last one); once the run
  /// has taken 10 s, logs it.
  void EndStage(const std::string& name);
  /// Sets the result "failed" with `reason`; returns false (a stage's failed return).
  bool Fail(const std::string& reason);
  /// The pose `t` moves the source's centre and turns it within the search window (true
  /// without one).
  bool Inside(const Eigen::Matrix4d& t) const;
  /// The visibility test contradicts `h` (the verdict would fail it as the best).
  bool Contradicted(const Hypothesis& h) const;

  const io::PointCloud& source_in;
  const io::PointCloud& target_in;
  const CloudRegistrationOptions& options;
  const Eigen::Vector3d source_viewpoint, target_viewpoint;
  CloudRegistrationResult result;
  Timer stage_timer;
  std::clock_t stage_cpu;
  const Timer total_timer;

  // Preprocess: the clouds without their scattered blunders, their spacings.
  io::PointCloud kept_source, kept_target;
  const io::PointCloud* source = nullptr;  // source_in or kept_source
  const io::PointCloud* target = nullptr;  // target_in or kept_target
  double s_src = 0.0, s_src_5000 = 0.0, s_tgt = 0.0;

  // Levels and radii.
  bool tgt_normals = false;  // the target's own normals are used
  Level src_coarse, tgt_coarse, src_fine;
  double src_fine_spacing = 0.0;
  double spacing = 0.0;  // s: the coarse levels' spacing
  double normal_radius = 0.0, support_radius = 0.0;

  // Normals: the fine verification's source sample and its normals.
  std::vector<Eigen::Vector3d> fine_src, fine_src_n;

  // Keypoints and matches.
  std::vector<int> src_kp, tgt_kp;
  const Eigen::Vector3d* up = nullptr;  // options.up when levelled
  std::vector<Matching> matchings;

  // Coarse hypotheses.
  std::unique_ptr<PointIndex> tgt_coarse_index;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // the coarse source's centroid
  std::vector<Eigen::Vector3d> score_sample;
  double tau_coarse = 0.0;
  std::vector<Hypothesis> hypotheses;
  std::vector<Eigen::Vector3d> icp_src, icp_src_n;
  double tau = 0.0;  // the coarse inlier distance

  // Fine finalists.
  bool visibility = false;
  std::unique_ptr<FreeSpace> src_free, tgt_free;
  std::unique_ptr<PointIndex> fine_src_index;
  Eigen::AlignedBox3d src_box;
  std::shared_ptr<TargetCrop> whole_target;
  std::vector<CachedCrop> crop_cache;
  /// The clouds' noise, once known: the smallest robust residual scale of the finalists
  /// refined from the coarse hypotheses (see fine_tau).
  double noise_sigma = std::numeric_limits<double>::infinity();
  const std::vector<Eigen::Vector3d>* plane_to_plane_normals = nullptr;
  double fine_end_spacing = 0.0;
  std::vector<Finalist> finalists;
  double fine_tau = std::numeric_limits<double>::infinity();
  double fine_spacing = 0.0;
  Eigen::Vector3d target_centroid = Eigen::Vector3d::Zero();
  BestTested best_tested;

  // Ambiguity and intensity tests.
  std::vector<std::pair<size_t, double>> rivals;  // (finalist, geometric t)
  std::vector<IntensityBlocks> photo;  // per finalist; empty: not tested
  Hypothesis best, fine_check;

  // Uncertainty and resolution.
  double axis_resolution = std::numeric_limits<double>::infinity();
  std::string weak_motion;
};

}  // namespace mmba::registration::internal
