// Shared state of the joint adjustment: JointState, filled by the sensor units (blocks/*.cc,
// blocks/blocks.h) and the initialisation steps, solved by adjust.cc, written by outputs.cc.
// Private to mmba_adjust.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mmba/adjust/adjust.h"
#include "mmba/adjust/groups.h"
#include "mmba/core/output_folder.h"
#include "mmba/geodesy/geodesy.h"
#include "mmba/io/colmap_model.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/io/trajectory.h"
#include "mmba/io/yaml_reader.h"
#include "mmba/problem/problem_builder.h"
#include "mmba/problem/reprojection_group.h"
#include "mmba/problem/solve.h"
#include "mmba/stats/statistics.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/network.h"

namespace mmba::adjust::internal {

/// Outcome of an optional step of the initialisation or the outputs (a photo block's or a
/// spherical station's registration to the LiDAR, a station's dense cloud). report.json gives
/// it as text with its reason (StepStatusText).
enum class StepStatus { kNotAttempted, kOk, kAsGiven, kFailed };
/// "ok", "as given", "failed: <reason>", "not attempted: <reason>".
std::string StepStatusText(StepStatus status, const std::string& reason = "");

/// Check points live in the Scene as ordinary 3-D points with ids from here up.
constexpr uint64_t kCheckPointIdBase = 4000000000ULL;
/// Points per chunk when the mobile cloud is streamed (≈ 40 MB of PLY records).
constexpr size_t kMobileChunkPoints = 1000000;

struct PhotoBlock {
  const PhotoCollection* config = nullptr;
  io::ColmapModel model;                       ///< as read (initial values)
  std::vector<ReprojectionObservation> ties;   ///< tie-point observations
  std::vector<TargetMeasurement> control;      ///< measurements of control targets
  std::vector<ReprojectionObservation> check;  ///< measurements of check points (scene points)
  std::map<std::string, Point3DId> check_ids;  ///< check point → scene point
  std::vector<MiResult> mi;                    ///< MI registration results (pose priors)
  std::map<ImageId, Rigid3d> initial_poses;    ///< after the initial georeference
  std::vector<double> initial_params;          ///< intrinsics after initialisation
  std::string georeference;                    ///< how the block was put into the world
  size_t control_targets_intersected = 0;      ///< control targets seen in 2+ photos (< 3: no similarity)
  std::vector<GnssCamera> gnss;                ///< GNSS antenna positions of photos (the GNSS CSV's camera rows)
  nlohmann::json registration;                 ///< register_to_lidar: the tie points' registration (report.json)
  StepStatus registration_status = StepStatus::kNotAttempted;  ///< the status of `registration`
};

/// The spherical stereo pair: lower poses are Scene images, the upper sphere follows from
/// the shared baseline vector.
struct SphereBlock {
  const SphericalStereo* config = nullptr;
  CameraId lower_camera{1000001};
  CameraId upper_camera{1000002};
  std::vector<std::string> stations;
  std::map<std::string, ImageId> lower_image;  ///< station → its lower sphere's Scene image
  Eigen::Vector3d baseline = Eigen::Vector3d::Zero();        ///< upper centre in the lower frame
  Eigen::Vector3d baseline_prior = Eigen::Vector3d::Zero();
  std::vector<ReprojectionObservation> lower;
  std::vector<UpperSphereObservation> upper;
  std::vector<std::string> lower_source, upper_source;  ///< "file:line" per observation
  std::vector<double> initial_lower_params, initial_upper_params;
  std::map<ImageId, Rigid3d> initial_poses;   ///< the setups (or their registration to the LiDAR)
  std::map<ImageId, Rigid3d> setup_poses;     ///< as given in stations_file
  /// Per station: the dense cloud's registration to the LiDAR (report.json
  /// `spherical_registration`), empty when not attempted.
  std::map<std::string, nlohmann::json> registration;
  std::map<std::string, StepStatus> registration_status;  ///< per station: the status of its `registration`
};

/// The camera rig: frame f is the Scene rig frame FrameId(f) (its rig_from_world), camera k
/// the Scene camera cameras[k] (intrinsics and cam_from_rig).
struct RigBlock {
  const CameraRig* config = nullptr;
  std::vector<std::string> frame_names;
  std::vector<double> frame_times;
  std::vector<Rigid3d> rig_prior;        ///< per frame, from the GNSS/INS trajectory
  std::vector<std::string> camera_names;
  std::vector<CameraId> cameras;         ///< Scene cameras
  std::vector<Rigid3d> cam_from_rig_initial;
  std::vector<std::vector<double>> initial_params;
  Rigid3d body_from_rig;
  /// MI results of the frames' stitched panoramas (pose = nullptr here; BuildProblem points
  /// each at the Scene rig frame mi_frame[i]).
  std::vector<MiResult> mi;
  std::vector<size_t> mi_frame;
  /// With `mi_lidar: mobile`: the panoramas' MI poses against the mobile LiDAR's delivered
  /// cloud (factors on the frame, the trajectory correction and the extrinsic).
  std::vector<MobileMiFrame> mi_mobile;
  std::vector<RigObservation> observations;
  std::vector<std::string> sources;
};

/// The mobile LiDAR: a sample of its points in the LiDAR frame; the trajectory correction
/// nodes (the Scene's trajectory nodes) and the extrinsic vehicle_from_lidar (the Scene mount
/// `mount`). `vehicle` = the rig frame when a rig shares the vehicle, else the GNSS/INS body.
struct MobileBlock {
  const LidarMobile* config = nullptr;
  size_t num_points = 0;                               ///< in the delivered cloud (streamed, never held)
  std::string format;                                  ///< of the delivered cloud, for the log
  std::vector<std::pair<double, Rigid3d>> trajectory;  ///< GNSS/INS world_from_body
  Rigid3d body_from_lidar_nominal;
  Rigid3d body_from_vehicle;                           ///< constant
  MountId mount{0};                                    ///< vehicle_from_lidar: estimated (the camera–LiDAR extrinsic with a rig)
  Rigid3d vehicle_from_lidar_initial;
  bool with_rig = false;
  std::vector<size_t> sample;                  ///< point indices in the delivered cloud
  std::vector<double> sample_time;             ///< their times
  std::vector<Eigen::Vector3d> sample_lidar;   ///< sample points in the LiDAR frame
  std::vector<Rigid3d> sample_ins;             ///< GNSS/INS world_from_body at their times
  std::vector<NodeWeight> sample_weight;
  std::vector<MobilePoint> points;             ///< associated with the static surface
  std::vector<FrameOnTrajectory> frames;       ///< rig frames on the trajectory
  /// The MI rig calibration (mi_lidar: mobile): rig_from_lidar with its covariance from the
  /// rig's panoramas registered jointly to the mobile cloud; empty when not run or not "ok".
  std::vector<MiResult> mi_extrinsic;
};

struct Blunder {
  std::string group;
  std::string observation;
  double whitened = 0.0;
  double studentized = 0.0;
};

/// How a static scan's world_from_scan was first placed: the project's world_from_scan as an
/// initial value only, the registration given (a prior), by its targets, or by feature
/// registration.
enum class ScanPlacement { kApproximate, kGiven, kTargets, kFeatureRegistration };
/// "approximate", "given", "targets", "feature registration" (report.json `initialisation`).
const char* ScanPlacementName(ScanPlacement method);

struct ScanInitialisation {
  ScanPlacement method = ScanPlacement::kGiven;
  std::string detail;  ///< counts, RMS, fitness … for the report
};

/// A static scan adjusted on its own: its surface in its own frame, its registration.

struct ScanBlock {
  std::string name;
  std::string file;
  std::unique_ptr<LidarSurface> surface;  ///< scan frame, cropped to the photo block
  Rigid3d prior;                          ///< scan_from_world initially (the registration given,
                                          ///< or the targets' / feature registration's placement)
  bool has_prior = true;                  ///< only a registration given is a prior observation
  ScanInitialisation initialisation;
  std::vector<Eigen::Vector3d> sample;    ///< scan frame: the scan-to-scan points
};

struct MeasurementBlock;  // blocks/photo_measurements.h

struct JointState {
  const Project* project = nullptr;
  geodesy::LocalTangentPlane plane{geodesy::Geodetic{}};
  std::optional<survey::SurveyNetwork> surveyed;     ///< network-only adjustment (control)
  survey::SurveyAdjustment surveyed_adjustment;
  /// Points whose coordinates the network determines (fixed, or with an active observation):
  /// only these serve as control or are compared as check points.
  std::set<std::string> surveyed_ids;
  std::optional<survey::SurveyNetwork> joint;        ///< the network in the joint problem
  std::vector<GnssPoint> gnss_points;
  std::vector<GnssCamera> gnss_camera_rows;  ///< `camera` rows of the GNSS files (image = id), resolved by LoadPhotos
  size_t gnss_trajectory_rows = 0;
  std::optional<PhotoBlock> photos;
  std::optional<SphereBlock> spheres;
  std::optional<RigBlock> rig;
  std::optional<MobileBlock> mobile;
  std::shared_ptr<MeasurementBlock> measured;  ///< a photo_measurements sensor
  Scene scene;
  std::unique_ptr<LidarSurface> surface;
  std::vector<SurfacePlane> planes;
  std::vector<ScanBlock> scans;               ///< static scans adjusted (empty: reference cloud fixed); scan k = Scene scan ScanId(k)
  std::vector<ScanPairPoint> scan_pairs;      ///< scan-to-scan associations
  std::vector<ScanTarget> scan_targets;       ///< surveyed targets measured in the scans
  // Excluded by data snooping: group name → observation indices.
  std::map<std::string, std::set<size_t>> excluded;
  std::vector<Blunder> blunders;
  std::unique_ptr<ProblemBuilder> builder;
  const FactorGroup* check_group = nullptr;  ///< the photos' check points in `builder` (evaluated, never weighted)
  SolveResult solve;
  int outer_iterations = 0;
  double seconds = 0.0;
  stats::NetworkStatistics statistics;    ///< final (after variance components)
  stats::NetworkStatistics given_weights;  ///< with the project's σ (no rows, no cofactor)
  std::map<std::string, double> sigma_factor;  ///< estimated σ / given σ per group
  int total_iterations = 0;
  std::vector<std::string> warnings;
  std::vector<std::string> log;  ///< stages, for the report
  /// MI registrations run by the adjustment (report.json `mi_registration`) and their
  /// register-mi result files (written to mi/<name>.json).
  nlohmann::json mi_registration = nlohmann::json::array();
  std::vector<Rigid3d> mi_registered;  ///< per mi_registration entry: the pose it found
  std::vector<std::pair<std::string, nlohmann::json>> mi_files;
};

/// The LiDAR plane at a world point: the reference cloud's, or with adjusted scans the plane of
/// the scan nearest to its scanner among those that see it there (in that scan's frame,
/// `plane->scan` its index). False when no surface lies within `gate`.
bool FitSurfacePlane(const JointState& s, const Eigen::Vector3d& world, double gate, double sigma, SurfacePlane* plane);
/// Scan-to-scan associations (each scan's sample on every other scan's surface, within `gate`).
size_t AssociateScans(JointState* s, double gate);
/// Loads the static scans to be adjusted (LidarStatic::AdjustsScans), placing those without a
/// registration by their targets or by feature registration. Throws AdjustFailure when one
/// cannot be placed.
void LoadScans(JointState* s, const Eigen::Vector3d& roi_min, const Eigen::Vector3d& roi_max);

/// The status of one solve: converged; no convergence when Ceres stopped at its iteration or
/// time limit with a finite cost; failed otherwise (problem/solve.h `status` in typed form).
AdjustStatus StatusOfSolve(const SolveResult& solve);

/// A stage's result: logged now and listed in the report (JointState::log).
void Note(JointState* s, const std::string& text);

/// "PROJECT.yaml:LINE: key", the place an InputError about the project file names.
std::string ProjectKey(const Project& project, int line, const std::string& key);

/// Thrown when the adjustment cannot produce a result (exit 3): `status` and the reason.
class AdjustFailure : public std::runtime_error {
 public:
  AdjustFailure(AdjustStatus status, const std::string& reason) : std::runtime_error(reason), status_(status) {}
  AdjustStatus status() const { return status_; }

 private:
  AdjustStatus status_;
};

/// GNSS/INS trajectories (world_from_body rows): mmba/io/trajectory.h.
using io::InterpolateTrajectory;
using io::ReadTrajectory;

/// Reads the mobile LiDAR (cloud, trajectory, calibration), samples its points evenly over
/// time and places the trajectory nodes. Needs the rig loaded first when it shares the vehicle.
void LoadMobile(JointState* s);
/// Ties the sample points to planes of the static surface within `gate` metres at the current
/// trajectory and extrinsic. Returns the number associated.
size_t AssociateMobile(JointState* s, double gate);

/// Writes every output file into `stage` (the OutputFolder's staging folder of
/// options.output_dir, swapped in by the caller) and fills outcome.report / summary.
void WriteOutputs(JointState& state, const AdjustOptions& options, const std::filesystem::path& stage,
                  AdjustOutcome* outcome);

/// Every file and folder the project reads (the project file and each path it names): the
/// output folder must hold none of them.
std::vector<NamedPath> ProjectInputs(const Project& project);

/// The file of `folder` whose stem is `stem` ("" when there is none).
std::string FindImage(const std::string& folder, const std::string& stem);

/// Initialisation of the spherical stations from their dense clouds: each station's
/// vertical-baseline stereo cloud registered to the static LiDAR (register-cloud's pipeline) moves its
/// setup pose when the registration is "ok"; the outcome per station is kept for the report.
void RegisterSphereStations(JointState* s);
/// Loads the spherical stereo pair (blocks/spherical_stereo.cc): its calibration as two Scene
/// cameras, the station setups as Scene images, the observations of the photo block's tie
/// points. Throws InputError for a second pair, a wrong tie block or a bad row.
void LoadSpheres(JointState* s);
/// The dense cloud of every spherical station (vertical-baseline stereo on the adjusted pair),
/// georeferenced and written to `stage` as <id>_<station>_dense.ply (listed in `files`).
/// Returns report.json's `spherical_dense` entries; `statuses` gets one status per entry.
nlohmann::json WriteSphereDense(const JointState& s, const std::filesystem::path& stage, nlohmann::json* files,
                                std::vector<StepStatus>* statuses);

/// The similarity to_from_from of the pairs `use` (Umeyama 1991, with scale; ≥ 3 pairs not on
/// one line).
Sim3d SimilarityFrom(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                     const std::vector<size_t>& use);
/// Least-squares intersection of rays (centre, unit direction) in the world.
Eigen::Vector3d Triangulate(const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& rays);

/// Initialisation of a photo block without control (fewer than 3 surveyed targets measured):
/// its tie points observed by the rig (at the frames' GNSS/INS poses) and the spherical
/// stations (at their setups) are intersected in the world from those rays alone, and the
/// similarity block → world (Umeyama inside a RANSAC over triples) moves the block's images
/// and points. False (the block left as it is, a note logged) when fewer than 3 such points
/// intersect or they agree on no similarity.
bool PlacePhotoBlockByTiePoints(JointState* s);
/// The same from the photos' GNSS antenna positions (≥ 3 photos, camera centres → GNSS,
/// the lever arm left to the adjustment). False (block unchanged) when too few or inconsistent.
bool PlacePhotoBlockByGnss(JointState* s);
/// A block placed by nothing else, with a static LiDAR: kept as given when half its tie points
/// already lie on the LiDAR; else its tie points are registered to the LiDAR's reference cloud
/// by register-cloud's pipeline at trial scales 5 % apart (PhotoCollection::lidar_scale_min
/// … max, or from the clouds' extents), each "ok" refined as a similarity (point-to-plane ICP
/// with scale), and the best placement moves the block unless another trial fits almost as
/// well elsewhere. False with `reason` (the block unchanged) when none does.
bool PlacePhotoBlockByLidar(JointState* s, std::string* reason);
/// register_to_lidar: the placed block's tie points registered to the static LiDAR's reference
/// cloud (register-cloud's pipeline, levelled, inside the registration window, the photos'
/// centres as viewpoints); an "ok" moves the block rigidly. The outcome goes to
/// PhotoBlock::registration either way.
void RegisterPhotoBlockToLidar(JointState* s);

/// Reads a `mmba register-mi` result file as a pose prior. False when the file does not exist,
/// or, with a warning in s->warnings, when it is not usable (status not "ok", no valid
/// covariance); InputError when it is malformed.
bool ReadMiResultFile(JointState* s, const std::string& file, MiResult* result);
/// The initialisation step "MI → camera corrections": with `mi_register`, images are registered
/// to the static LiDAR's reference cloud by register-mi's library call with its default
/// settings; "ok" results become MI pose priors. Stage kRigFrames (before the first solve):
/// each rig frame's stitched panorama from its GNSS/INS pose (the frame also starts at an "ok"
/// pose), and the rig's `mi_results` files; every image of both stages is read and checked.
/// Stage kPhotos (after the first solve, the block on its control): each photo from its solved
/// pose with the solved intrinsics — MI cannot tell an intrinsics error from a pose error
/// (measured: from the initial intrinsics, focal 1 % off, 3 of 3 "ok" were 0.57–0.79 m off).
/// The rig's own cameras (mi_views: cameras) are registered at kPhotos too, for that reason.
enum class MiStage { kRigFrames, kPhotos };
void RegisterImagesByMi(JointState* s, MiStage stage);

/// Why a factor group's σ is not re-weighted by the variance components (the one rule
/// ApplyVarianceComponents and the report use): "variance_components: false" (the project's
/// setting), "check points", "constraint" (FactorRole::kConstraint), "prior"
/// (FactorRole::kPrior: a prior on parameters, whose σ is the user's or the registration's
/// statement) or "redundancy below 5"; empty for a group that is re-weighted.
std::string VarianceComponentExemption(const JointState& s, const FactorGroup& group, double redundancy);

/// Writes lidar_coloured.ply (the static LiDAR around the photo block coloured from the
/// adjusted photos, with a z-buffer visibility test) into `stage`; returns the report entry
/// (empty without photos or static LiDAR).
nlohmann::json WriteColouredLidar(const JointState& s, const std::filesystem::path& stage, nlohmann::json* files);

/// Colours the mobile cloud, streamed in chunks, from the adjusted rig images (the frames
/// nearest the point's time: 2 before and 2 after, when the rig shares the vehicle) and the
/// photos (points in the photo block's box), in two passes over the same chunks in the same
/// order: AddDepths on every chunk (each image's coarse z-buffer of the cloud itself), then
/// Colour on every chunk. Memory: the z-buffers of all images within 256 MB (their cell grows
/// to fit), the images of 5 rig frames and one photo, per-chunk accumulators. `threads`
/// split the z-buffers (pass 1) and the points (pass 2).
class MobileColouring {
 public:
  MobileColouring(const JointState& s, int threads);
  ~MobileColouring();
  MobileColouring(const MobileColouring&) = delete;
  MobileColouring& operator=(const MobileColouring&) = delete;

  /// False when there is no image to colour from (Colour then leaves the chunk uncoloured).
  bool active() const;
  /// Pass 1: enters the chunk's points (world frame, with times) into the z-buffers.
  void AddDepths(const io::PointCloud& chunk);
  /// Pass 2: fills chunk->colors (grey 128 where no image sees the point).
  void Colour(io::PointCloud* chunk);
  /// report.json entry: points, coloured, by rig images / photos, images used, timings.
  nlohmann::json Report(const std::string& file) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Keeps every k-th point so that at most `cap` remain (evenly over the input order).
inline void ThinEvenly(std::vector<Eigen::Vector3d>* points, size_t cap) {
  if (points->size() <= cap) return;
  const size_t stride = (points->size() + cap - 1) / cap;
  size_t n = 0;
  for (size_t i = 0; i < points->size(); i += stride) (*points)[n++] = (*points)[i];
  points->resize(n);
}

/// Camera centre in the world.
inline Eigen::Vector3d CameraCentre(const Rigid3d& cam_from_world) {
  return cam_from_world.Inverse().translation;
}

/// World ENU coordinates of a survey point (SurveyPoint::coords are ENU whatever the input axes).
Eigen::Vector3d WorldFromSurvey(const survey::SurveyNetwork& network, const survey::SurveyPoint& p);
/// Covariance (ENU) of a survey point's coordinates from statistics over its blocks.
Eigen::Matrix3d SurveyPointCovariance(const stats::NetworkStatistics& st,
                                      const survey::SurveyNetwork& network, const survey::SurveyPoint& p);

}  // namespace mmba::adjust::internal
