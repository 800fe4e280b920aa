#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "mmba/problem/factor_group.h"
#include "mmba/problem/scene.h"

namespace mmba {

/// Which parameters are estimated. Intrinsics are held constant unless refined; subsets
/// (focal, principal point, extra = distortion) are held with a ceres::SubsetManifold.
/// Every rotation block (image, rig frame, rig camera, scan, mount) gets the quaternion
/// manifold (geometry/pose_manifold.h); a pose held constant holds both its blocks.
struct ParameterOptions {
  bool refine_focal = false;            ///< focal length(s)
  bool refine_principal_point = false;  ///< cx, cy
  bool refine_extra = false;            ///< distortion / remaining model parameters
  bool refine_poses = true;             ///< every image pose (except constant_images)
  bool refine_points = true;            ///< every 3-D point (except constant_points)
  std::set<CameraId> constant_cameras;  ///< held fully constant whatever the flags
  /// Per camera, the intrinsics indices held instead of those of the refine flags: all of
  /// them = the camera held constant, none = every parameter estimated.
  std::map<CameraId, std::vector<int>> held_intrinsics;
  std::set<ImageId> constant_images;    ///< poses held constant
  std::set<Point3DId> constant_points;  ///< points held constant
  std::set<FrameId> constant_rig_frames;          ///< rig_from_world held constant
  std::set<CameraId> constant_cams_from_rig;      ///< cam_from_rig held constant
  std::set<ScanId> constant_scans;                ///< scan_from_world held constant
  std::set<MountId> constant_mounts;              ///< mounts held constant
  std::set<TrajectoryNodeId> constant_trajectory_nodes;  ///< node corrections held constant
};

/// How the datum (gauge) of a network without external control is fixed. A free bundle
/// adjustment has 7 degrees of freedom (rotation, translation, scale) that no observation
/// determines; they must be fixed explicitly and the report must say how.
struct GaugeOptions {
  enum class Kind {
    kNone,         ///< nothing fixed here: another group (control, GNSS) fixes the datum
    kTwoPoses,     ///< pose of `first` fixed, distance from `first` to `second` fixed
    kFixedImages,  ///< all poses of `fixed_images` held constant
  };
  Kind kind = Kind::kTwoPoses;
  ImageId first;   ///< kTwoPoses; invalid = the image with the smallest id
  ImageId second;  ///< kTwoPoses; invalid = the next image by id
  std::vector<ImageId> fixed_images;  ///< kFixedImages
};

/// Turns factor groups into one ceres::Problem over the parameters of a Scene.
///
///   ProblemBuilder builder(&scene);
///   builder.AddGroup(std::make_unique<ReprojectionGroup>(...));
///   builder.set_parameter_options(...); builder.set_gauge(...);
///   ceres::Problem& problem = builder.Build();
///   ... solve ...
///   builder.Finish();  // undoes the gauge transform of kTwoPoses
class ProblemBuilder {
 public:
  explicit ProblemBuilder(Scene* scene);
  ~ProblemBuilder();

  FactorGroup& AddGroup(std::unique_ptr<FactorGroup> group);
  void set_parameter_options(const ParameterOptions& options) { parameter_options_ = options; }
  /// The options Build() applies, for callers that add to them group by group.
  ParameterOptions& parameter_options() { return parameter_options_; }
  void set_gauge(const GaugeOptions& gauge) { gauge_ = gauge; }

  /// Adds every group, sets manifolds, constant blocks, the gauge and the Schur elimination
  /// ordering (points first). Throws InputError when the gauge names images that are not
  /// in the scene or a fixed gauge is combined with datum-fixing groups. Calling it again
  /// returns the problem already built (so a caller may Build(), adjust blocks, then Solve()).
  ceres::Problem& Build();
  bool built() const { return problem_ != nullptr; }

  /// After the solve: moves the scene back from the gauge frame (kTwoPoses solves in the
  /// frame of the first camera so that the second camera's distance is a norm constraint).
  void Finish();

  ceres::Problem& problem() { return *problem_; }
  Scene& scene() { return *scene_; }
  const std::vector<std::unique_ptr<FactorGroup>>& groups() const { return groups_; }
  /// The elimination ordering of Build(): points in group 0 (but those sharing a residual
  /// block with another point), everything else in group 1.
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering() const { return ordering_; }

  /// A sentence saying how the datum was fixed, for reports.
  const std::string& gauge_description() const { return gauge_description_; }

 private:
  /// Checks the gauge options against the groups and the scene (InputError) and, for a
  /// two-pose gauge, moves the scene into the first camera's frame.
  void CheckGauge();
  /// Points in elimination group 0 unless a residual ties them to another point (a distance,
  /// a scale bar): group 0 must be an independent set; every other block in group 1.
  void BuildOrdering();
  void ApplyParameterOptions();
  void ApplyIntrinsics();
  void ApplyImagesAndPoints();
  /// Quaternion manifold on the pose's rotation block; both blocks constant when `constant`.
  void ApplyPose(Rigid3d& pose, bool constant);
  void ApplySensorPoses();
  void ApplyGauge();

  Scene* scene_;
  std::unique_ptr<ceres::Problem> problem_;
  std::vector<std::unique_ptr<FactorGroup>> groups_;
  ParameterOptions parameter_options_;
  GaugeOptions gauge_;
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering_;
  std::string gauge_description_;
  bool gauge_transformed_ = false;
  Rigid3d gauge_from_world_;
};

}  // namespace mmba
