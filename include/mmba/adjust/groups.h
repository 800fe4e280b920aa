// Factor groups of the joint adjustment that join the image blocks to the survey network and
// to the LiDAR: image measurements of surveyed targets, GNSS coordinates of marks, and
// tie points on the LiDAR surface (point-to-plane).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/ids.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/problem/factor_group.h"
#include "mmba/survey/network.h"

namespace mmba::adjust {

/// An image measurement of a surveyed point (a target, a control mark).
struct TargetMeasurement {
  std::string point_id;
  ImageId image_id;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  double sigma_px = 1.0;
  std::string source;  ///< "file:line", for reports
};

/// Reprojection of survey points (world ENU coordinates, two parameter blocks east-north and
/// up as the survey groups use them) into the images of a Scene: the residual that makes the
/// total-station control and the photo block one adjustment. The network's coordinates must
/// be in the project's world frame (local ENU at the project origin).
class TargetReprojectionGroup : public FactorGroup {
 public:
  TargetReprojectionGroup(survey::SurveyNetwork* network, std::vector<TargetMeasurement> measurements,
                          LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<TargetMeasurement>& measurements() const { return measurements_; }

 private:
  survey::SurveyNetwork* network_;
  std::vector<TargetMeasurement> measurements_;
};

/// Observations of the upper sphere of a vertical stereo pair: the upper sphere has the lower
/// sphere's orientation and sits at `baseline` (lower sphere frame) from it, so its point in
/// the camera frame is R·X + t − baseline (R, t: the lower sphere's cam_from_world). Spherical
/// residual on the sphere (factors/reprojection_error.h). `image_id` = the LOWER sphere's
/// image in the Scene; `camera_id` = the upper sphere's camera.
struct UpperSphereObservation {
  ImageId lower_image_id;
  CameraId camera_id;
  Point3DId point3D_id;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  double sigma_px = 0.5;
};

class UpperSphereGroup : public FactorGroup {
 public:
  UpperSphereGroup(std::vector<UpperSphereObservation> observations, Eigen::Vector3d* baseline,
                   LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<UpperSphereObservation>& observations() const { return observations_; }

 private:
  std::vector<UpperSphereObservation> observations_;
  Eigen::Vector3d* baseline_;
};

/// Prior on a vector parameter: (x − prior)/σ per component (3 blocks of one residual).
class VectorPriorGroup : public FactorGroup {
 public:
  VectorPriorGroup(Eigen::Vector3d* value, const Eigen::Vector3d& prior, double sigma, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  Eigen::Vector3d* value_;
  Eigen::Vector3d prior_;
  double sigma_;
};

/// A tie-point observation in camera `camera` of a rig at frame `frame`:
/// x = π(cam_from_rig · rig_from_world · X), the Scene's rig frame FrameId(frame) and the
/// cam_from_rig of the group's camera `camera`.
struct RigObservation {
  size_t frame = 0;
  size_t camera = 0;
  Point3DId point3D_id;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  double sigma_px = 0.5;
};

class RigReprojectionGroup : public FactorGroup {
 public:
  /// `cameras` is the Scene camera of each rig camera (its intrinsics and cam_from_rig).
  RigReprojectionGroup(std::vector<RigObservation> observations, std::vector<CameraId> cameras, LossOptions loss,
                       std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<RigObservation>& observations() const { return observations_; }

 private:
  std::vector<RigObservation> observations_;
  std::vector<CameraId> cameras_;
};

/// A prior on poses (target_from_source): 3 position residuals (the source origin in the
/// target, σ_m) and 3 rotation residuals (angle-axis of prior⁻¹·pose, σ_rad) per pose.
///
/// With `times` and a correlation time τ > 0 the prior errors are a first-order Gauss–Markov
/// process, as a GNSS/INS solution's drift is (Gelb 1974, Applied Optimal Estimation, §3.8):
/// e_k = φ_k e_{k−1} + w_k, φ_k = exp(−(t_k − t_{k−1})/τ), Var(w_k) = σ²(1 − φ_k²). The
/// residuals are then the whitened innovations e₀/σ and (e_k − φ_k e_{k−1})/(σ√(1 − φ_k²)), in
/// time order: the poses' common offset from the prior counts once, not once per pose.
class PosePriorGroup : public FactorGroup {
 public:
  PosePriorGroup(std::vector<Rigid3d*> poses, std::vector<Rigid3d> priors, double sigma_m, double sigma_rad,
                 LossOptions loss, std::string name, std::vector<double> times = {}, double correlation_s = 0.0);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  std::vector<Rigid3d*> poses_;
  std::vector<Rigid3d> priors_;
  double sigma_m_, sigma_rad_;
  std::vector<double> times_;
  double correlation_s_;
};

/// φ = exp(−Δt/τ) of a first-order Gauss–Markov process (0 when τ ≤ 0: independent epochs).
double GaussMarkovFactor(double dt_s, double correlation_s);

/// A mutual-information registration result of an image against the (world-frame) LiDAR:
/// the camera pose and its 6×6 covariance (m², deg²; tx ty tz roll pitch yaw), used as a
/// weighted pose prior (registration/mi/mi_prior.h). The prior is on the Scene image
/// `image_id`, or on `pose` when set (a camera pose stored outside the Scene: a rig frame's
/// rig frame's rig_from_world, whose stitched panorama is in the rig frame).
struct MiResult {
  ImageId image_id;
  Rigid3d* pose = nullptr;
  Rigid3d cam_from_world;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  std::string source;
};

class MiPriorGroup : public FactorGroup {
 public:
  /// `covariance_scale` multiplies every covariance (variance-component factor²).
  MiPriorGroup(std::vector<MiResult> results, double covariance_scale, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  std::vector<MiResult> results_;
  double covariance_scale_;
};

/// GNSS coordinates of a surveyed mark in the world ENU frame with σ per axis: three
/// residual blocks (east, north, up) per mark.
struct GnssPoint {
  std::string point_id;
  Eigen::Vector3d enu = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  ///< east, north, up [m]
  std::string source;
};

class GnssPointGroup : public FactorGroup {
 public:
  GnssPointGroup(survey::SurveyNetwork* network, std::vector<GnssPoint> points, LossOptions loss,
                 std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<GnssPoint>& points() const { return points_; }
  /// Observation index i of a block = 3·point + axis.

 private:
  survey::SurveyNetwork* network_;
  std::vector<GnssPoint> points_;
};

/// A GNSS antenna position of a photo (the GNSS CSV's `camera` rows; id = image name), in
/// the local ENU frame, with the antenna's lever arm in the camera frame.
struct GnssCamera {
  ImageId image_id;
  std::string image;
  Eigen::Vector3d enu = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  ///< east, north, up [m]
  Eigen::Vector3d lever_arm = Eigen::Vector3d::Zero();  ///< antenna in the camera frame [m]
  std::string source;
};

/// (R_camᵀ·(lever − t_cam) − enu)/σ per axis: the antenna of a photo (its camera centre plus
/// the lever arm turned into the world) against its GNSS position. Observation index of a
/// block = 3·camera + axis.
class GnssCameraGroup : public FactorGroup {
 public:
  GnssCameraGroup(std::vector<GnssCamera> cameras, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<GnssCamera>& cameras() const { return cameras_; }

 private:
  std::vector<GnssCamera> cameras_;
};

/// A tie point's plane on the LiDAR surface: n·(X − p) = 0.
struct SurfacePlane {
  Point3DId point3D_id;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double sigma_m = 0.01;
  int scan = -1;  ///< −1: the reference cloud (world frame); else the Scene scan ScanId(scan) (normal, point in its frame)
};

/// Tie points on the LiDAR surface: n·(X − q)/σ against the reference cloud, or
/// n·(scan_from_world·X − q)/σ against a scan's own plane, its pose a parameter block.
class LidarSurfaceGroup : public FactorGroup {
 public:
  LidarSurfaceGroup(std::vector<SurfacePlane> planes, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<SurfacePlane>& planes() const { return planes_; }

 private:
  std::vector<SurfacePlane> planes_;
};

/// A surveyed target measured in a static scan (its centre in the frame of the Scene scan
/// ScanId(scan)).
struct ScanTarget {
  size_t scan = 0;
  std::string point_id;
  Eigen::Vector3d measured = Eigen::Vector3d::Zero();
  double sigma = 0.002;  ///< per axis [m]
  std::string source;
};

/// LiDAR targets: (scan_from_world·X − x)/σ, X the survey point of the network (its east-north
/// and up blocks), x the target's centre measured in the scan — the tie between the scans and
/// the total-station control.
class ScanTargetGroup : public FactorGroup {
 public:
  ScanTargetGroup(survey::SurveyNetwork* network, std::vector<ScanTarget> targets, LossOptions loss,
                  std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  survey::SurveyNetwork* network_;
  std::vector<ScanTarget> targets_;
};

/// A point of scan `from` (its own frame) on the local plane of scan `to` (that scan's frame);
/// the scans are the Scene scans ScanId(from), ScanId(to).
struct ScanPairPoint {
  size_t from = 0, to = 0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d plane_point = Eigen::Vector3d::Zero();
  double sigma_m = 0.005;
};

/// Scan-to-scan point-to-plane (Chen & Medioni 1992) between overlapping static scans:
/// n_to·(scan_to_from_world · world_from_scan_from · p − q_to)/σ; both poses are blocks.
class ScanToScanGroup : public FactorGroup {
 public:
  ScanToScanGroup(std::vector<ScanPairPoint> points, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<ScanPairPoint>& points() const { return points_; }

 private:
  std::vector<ScanPairPoint> points_;
};

/// The LiDAR surface near a set of points: a k-d tree over the reference cloud (cropped to
/// the region of interest so memory stays bounded) and local plane fits.
class LidarSurface {
 public:
  /// Reads `path`, keeping points p with roi_from_file·p inside [min − margin, max + margin];
  /// the surface stays in the file's frame (a scan's own frame, or the world).
  LidarSurface(const std::string& path, const Eigen::Vector3d& roi_min,
               const Eigen::Vector3d& roi_max, double margin, const Rigid3d& roi_from_file = Rigid3d());
  ~LidarSurface();
  LidarSurface(const LidarSurface&) = delete;
  LidarSurface& operator=(const LidarSurface&) = delete;

  size_t size() const;
  size_t num_read() const { return num_read_; }
  /// Bounding box of every point read (in the region-of-interest frame), kept or not.
  const Eigen::Vector3d& read_min() const { return read_min_; }
  const Eigen::Vector3d& read_max() const { return read_max_; }
  /// `n` of the kept points, evenly spread over the cloud's order (file frame).
  std::vector<Eigen::Vector3d> Sample(size_t n) const;
  /// The plane through the `k` nearest LiDAR points of `query` (PCA), when the neighbourhood
  /// is planar (smallest eigenvalue ≤ 10 % of the middle one), |n·(query − centroid)| ≤
  /// max_distance and the query lies over the patch (its in-plane distance from the centroid
  /// ≤ the patch's RMS in-plane radius) — the gate is on the distance to the surface, not to the
  /// nearest sample, so a sparse cloud (far from the scanner) keeps its valid associations.
  /// `roughness` (optional): the RMS distance of the k points from their plane (√λ₀), the
  /// plane's own uncertainty at the query, to be added to the residual's σ.
  bool FitPlane(const Eigen::Vector3d& query, double max_distance, int k, Eigen::Vector3d* normal,
                Eigen::Vector3d* centroid, double* roughness = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  size_t num_read_ = 0;
  Eigen::Vector3d read_min_ = Eigen::Vector3d::Constant(1e300), read_max_ = Eigen::Vector3d::Constant(-1e300);
};

/// Why a cloud with bounding box [cloud_min, cloud_max] may miss the region [block_min,
/// block_max] of the project's world (local ENU, metres): "" when no simple cause fits, else
/// e.g. "its coordinates look like millimetres" (scaled by 0.001, 0.01 or 0.3048 (foot) its
/// horizontal box matches the block's far better than as given) or "… look projected (UTM …)".
std::string CoordinateHint(const Eigen::Vector3d& cloud_min, const Eigen::Vector3d& cloud_max,
                           const Eigen::Vector3d& block_min, const Eigen::Vector3d& block_max);

// ---- mobile LiDAR and the vehicle trajectory ----------------------------------------------

// TrajectoryNode (the correction of a GNSS/INS trajectory at one time) is a Scene parameter:
// mmba/problem/scene.h.

/// Where a time falls between nodes: node `node` and `node + 1`, weight `alpha` of the second.
struct NodeWeight {
  size_t node = 0;
  double alpha = 0.0;
};
/// `nodes` sorted by time, at least two; times outside are clamped to the first/last interval.
NodeWeight WeightAt(const std::vector<TrajectoryNode>& nodes, double time_s);
/// The corrected world_from_body at a time whose GNSS/INS pose is `ins`.
Rigid3d CorrectedPose(const std::vector<TrajectoryNode>& nodes, const NodeWeight& w, const Rigid3d& ins);

/// A mobile LiDAR point (in the LiDAR frame) tied to a plane of the static surface:
/// n·(world_from_body(t)·body_from_vehicle·vehicle_from_lidar·p − q) = 0.
struct MobilePoint {
  Eigen::Vector3d point_lidar = Eigen::Vector3d::Zero();
  NodeWeight weight;
  Rigid3d ins;  ///< GNSS/INS world_from_body at the point's time
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d plane_point = Eigen::Vector3d::Zero();
  double sigma_m = 0.005;
  size_t source = 0;  ///< index of the point in the delivered cloud
  double time_s = 0.0;  ///< its acquisition time
  int scan = -1;      ///< −1: plane in the world (reference cloud); else the plane of Scene scan ScanId(scan) in its frame
};

class MobileLidarGroup : public FactorGroup {
 public:
  /// `vehicle_from_lidar` is the estimated extrinsic (the rig frame when a rig shares the
  /// vehicle, else the body); `body_from_vehicle` is constant.
  /// A point on an adjusted scan's plane (`scan` ≥ 0) has that Scene scan's pose as a block too.
  MobileLidarGroup(std::vector<MobilePoint> points, std::vector<TrajectoryNode>* nodes, Rigid3d* vehicle_from_lidar,
                   const Rigid3d& body_from_vehicle, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;
  const std::vector<MobilePoint>& points() const { return points_; }

 private:
  std::vector<MobilePoint> points_;
  std::vector<TrajectoryNode>* nodes_;
  Rigid3d* vehicle_from_lidar_;
  Rigid3d body_from_vehicle_;
};

/// The GNSS/INS prior on the nodes' corrections c = (ω, δ): the trajectory as delivered. The
/// GNSS/INS error drifts, so the corrections are a first-order Gauss–Markov process with
/// correlation time τ (Gelb 1974, §3.8): residuals c₀/σ and (c_k − φ c_{k−1})/(σ√(1 − φ²)),
/// φ = exp(−Δt/τ); τ ≤ 0 gives an independent prior c_k/σ per node.
class TrajectoryPriorGroup : public FactorGroup {
 public:
  TrajectoryPriorGroup(std::vector<TrajectoryNode>* nodes, double sigma_m, double sigma_rad, double correlation_s,
                       LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  std::vector<TrajectoryNode>* nodes_;
  double sigma_m_, sigma_rad_, correlation_s_;
};

/// Smoothness: the second difference of consecutive nodes' corrections (c₋ − 2c + c₊)/σ —
/// GNSS/INS errors drift slowly, a correction that bends between nodes is penalised.
class TrajectorySmoothnessGroup : public FactorGroup {
 public:
  TrajectorySmoothnessGroup(std::vector<TrajectoryNode>* nodes, double sigma_m, double sigma_rad, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  std::vector<TrajectoryNode>* nodes_;
  double sigma_m_, sigma_rad_;
};

/// A rig frame taken at a time on the corrected trajectory: the Scene rig frame
/// FrameId(frame) ≈ (world_from_body(t)·body_from_rig)⁻¹, σ of the time synchronisation
/// (position, rotation).
struct FrameOnTrajectory {
  size_t frame = 0;
  NodeWeight weight;
  Rigid3d ins;
};

class RigTrajectoryGroup : public FactorGroup {
 public:
  RigTrajectoryGroup(std::vector<FrameOnTrajectory> frames, std::vector<TrajectoryNode>* nodes,
                     const Rigid3d& body_from_rig, double sigma_m,
                     double sigma_rad, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  std::vector<FrameOnTrajectory> frames_;
  std::vector<TrajectoryNode>* nodes_;
  Rigid3d body_from_rig_;
  double sigma_m_, sigma_rad_;
};

/// The mobile LiDAR's delivered cloud near time t (georeferenced by the GNSS/INS pose `ins` at
/// t and the nominal mounting) mapped into the adjusted world, as one rigid transform:
/// world_from_delivered = C(t)·T_ins(t)·body_from_vehicle·vehicle_from_lidar·(T_ins(t)·
/// body_from_lidar_nominal)⁻¹, C(t) the trajectory correction (`CorrectedPose`). Exact for
/// points captured at t; for points captured near t, as far as the GNSS/INS error and the
/// correction stay constant over that time.
Rigid3d WorldFromDelivered(const std::vector<TrajectoryNode>& nodes, const NodeWeight& w, const Rigid3d& ins,
                           const Rigid3d& body_from_vehicle, const Rigid3d& vehicle_from_lidar,
                           const Rigid3d& body_from_lidar_nominal);

/// A rig frame's stitched panorama registered by MI to the mobile LiDAR's delivered cloud
/// (the MI paper's setting): `rig_from_delivered` with its 6×6 covariance (register-mi's
/// convention, m and °).
struct MobileMiFrame {
  size_t frame = 0;    ///< the Scene rig frame FrameId(frame)
  NodeWeight weight;   ///< the frame's time on the trajectory nodes
  Rigid3d ins;         ///< GNSS/INS world_from_body at the frame's time
  Rigid3d rig_from_delivered;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
  std::string source;
};

/// MI pose priors against the mobile cloud: the predicted rig_from_delivered =
/// rig_from_world · world_from_delivered(nodes, vehicle_from_lidar) against the MI pose,
/// whitened as registration/mi/mi_prior.h does. With the frames on the trajectory the
/// correction cancels to first order and the residual constrains the camera–LiDAR extrinsic:
/// the rig calibration of Wang, Ferrie & Macfarlane (CVPRW 2012) over many frames.
class MobileMiPriorGroup : public FactorGroup {
 public:
  /// `covariance_scale` multiplies every covariance (variance-component factor²).
  MobileMiPriorGroup(std::vector<MobileMiFrame> frames, std::vector<TrajectoryNode>* nodes,
                     Rigid3d* vehicle_from_lidar, const Rigid3d& body_from_vehicle,
                     const Rigid3d& body_from_lidar_nominal, double covariance_scale, LossOptions loss, std::string name);
  void AddResiduals(Scene& scene, ceres::Problem& problem) override;

 private:
  std::vector<MobileMiFrame> frames_;
  std::vector<TrajectoryNode>* nodes_;
  Rigid3d* vehicle_from_lidar_;
  Rigid3d body_from_vehicle_, body_from_lidar_nominal_;
  double covariance_scale_;
};

}  // namespace mmba::adjust
