// The project file of the joint adjustment `mmba adjust` (YAML, schema in docs/project-yaml.md
// and calib/README.md). LoadProject validates the whole file — keys, types,
// ranges, units, that every referenced file exists — before any work, with errors naming the
// file, line and key (InputError, exit 2).
#pragma once

#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geodesy/crs_frame.h"
#include "mmba/geodesy/geodesy.h"
#include "mmba/geometry/rigid3d.h"
#include "mmba/io/image_measurements.h"
#include "mmba/problem/factor_group.h"

namespace mmba::adjust {

/// How a calibrated pose (a rig's cam_from_rig, the camera–LiDAR extrinsic) enters the
/// adjustment: held at its calibration, estimated with the calibration as a weighted prior, or
/// estimated freely.
enum class PoseTreatment { kFixed, kWeighted, kFree };
/// "fixed", "weighted" or "free": the project file's words.
const char* PoseTreatmentName(PoseTreatment treatment);

/// A camera rig's `mi_lidar`: which LiDAR its images are registered to by MI.
enum class MiLidar { kStatic, kMobile };
/// A camera rig's `mi_views`: its stitched panoramas or its own cameras' images.
enum class MiViews { kPanoramas, kCameras };

/// Intrinsics refined in the adjustment (each photo collection's own camera).
struct RefineIntrinsics {
  bool focal = true;
  bool principal_point = true;
  bool distortion = true;
  /// With `distortion`: how many of the model's distortion terms are free (the leading
  /// ones, k1, k2, …); 0 = all.
  int distortion_terms = 0;
};

struct PhotoCollection {
  std::string id;
  int line = 0;                       ///< of the sensor in the project file
  std::string images;                 ///< folder of the photos
  std::string calibration;            ///< camera YAML (model, width, height, params); "" = COLMAP's
  std::string colmap_model;           ///< COLMAP model folder; "" = run COLMAP on `images`
  std::string control_measurements;   ///< CSV point_id,image,x_px,y_px[,sigma_px]; "" = none
  /// Folder of `mmba register-mi` results, <image stem>.json, LiDAR frame = world: weighted
  /// pose priors (their covariance); "" = none.
  std::string mi_results;
  /// Run the MI registration (register-mi's library call, its default settings) of every
  /// photo against the static LiDAR's reference cloud at the photo's initial pose; the "ok"
  /// results become weighted pose priors, as `mi_results` files do. `mi_register: [names]`
  /// registers only those images (names or stems).
  bool mi_register = false;
  std::vector<std::string> mi_only;  ///< the list of `mi_register: [...]`; empty = every image
  /// `mi_orientation_classes`: register-mi --orientation-classes of `mi_register` (the
  /// metric conditioned on the surfaces' orientation; 0 = the plain metric, the photos'
  /// default: with the classes the adjusted photo centres were worse, gate 5.6 → 9.0 mm,
  /// cathedral 16.0 → 16.5 mm RMSE; bench/RESULTS.md "Orientation classes").
  int mi_orientation_classes = 0;
  double sigma_px = 1.0;              ///< σ of a tie-point image coordinate
  double control_sigma_px = 0.0;      ///< σ of a target measurement; 0 = the CSV's, else sigma_px
  /// GNSS antenna in the camera frame (x right, y down, z forward; metres) for the GNSS CSV's
  /// `camera` rows (the antenna position of a photo, id = image name).
  Eigen::Vector3d gnss_lever_arm_m = Eigen::Vector3d::Zero();
  /// Initialisation: the block's tie points, once placed (control, GNSS positions or the other
  /// sensors' tie points), registered to the static LiDAR's reference cloud by register-cloud's
  /// pipeline within the window below; an "ok" moves the block (the joint solve decides the rest).
  bool register_to_lidar = false;
  double registration_window_m = 2.0;
  double registration_window_deg = 10.0;
  /// A block placed by nothing else (no control, GNSS positions or other sensors' tie points)
  /// but with a static LiDAR: its tie points are registered to the LiDAR over trial scales in
  /// this range (world metres per block unit); {0, 0} = from the ratio of the two clouds'
  /// extents (1/8 to 1.5 times it).
  double lidar_scale_min = 0.0, lidar_scale_max = 0.0;
  LossOptions loss{LossType::kHuber, 3.0};
  RefineIntrinsics refine;
};

struct TotalStation {
  std::string id;
  int line = 0;
  std::string file;  ///< GNU Gama gama-local XML or the survey CSV; axes of the world frame
  LossOptions loss{LossType::kHuber, 3.0};
};

struct Gnss {
  std::string id;
  int line = 0;
  std::string file;  ///< CSV id,kind,time_s,latitude_deg,longitude_deg,height_m,sigma_{east,north,up}_m
  /// Or `photos: {folder, sigma_horizontal_m, sigma_vertical_m, geoid_undulation_m}`: the GPS
  /// position each photo's EXIF holds (io/exif_gps.h) as that photo's camera row, height =
  /// EXIF altitude + geoid_undulation_m (0 when the camera writes ellipsoidal heights).
  std::string photos;
  double photos_sigma_horizontal_m = 0;
  double photos_sigma_vertical_m = 0;
  double photos_geoid_undulation_m = 0;
  LossOptions loss{LossType::kHuber, 3.0};
};

/// One static scan: its points in the scanner's own frame and, when it is to be adjusted, its
/// registration world_from_scan (e.g. `mmba register-cloud`'s target_from_source, or the
/// scanner software's registration).
struct LidarScanFile {
  std::string file;
  int line = 0;
  bool has_pose = false;
  Rigid3d world_from_scan;
  /// world_from_scan is a rough placement (field notes, a quick manual alignment): an initial
  /// value only, not a prior; the scan-to-scan association (gate max_distance_m) refines it.
  bool approximate = false;
};

/// Static LiDAR: the registered `reference_cloud` (world frame) ties the photo block. The scans
/// of `scans` are adjusted themselves — one world_from_scan per scan, scan-to-scan
/// point-to-plane between overlapping scans, tie points on each scan's surface — when at least
/// one carries `world_from_scan` (its registration, a prior with σ scan_sigma_m / _deg, unless
/// `approximate`) or
/// `targets` are given. A scan without `world_from_scan` is placed first from its surveyed
/// targets (3 or more: a rigid fit), else by feature registration (`mmba register-cloud`'s
/// pipeline) to the scans already placed; it then has no prior.
struct LidarStatic {
  std::string id;
  int line = 0;
  std::string reference_cloud;        ///< registered cloud in the world frame
  std::vector<LidarScanFile> scans;   ///< per-scan files (see above)
  double range_sigma_m = 0.003;
  double surface_sigma_m = 0.01;      ///< σ of a tie point's distance to the LiDAR surface
  double max_distance_m = 0.3;        ///< association gate of the first outer iteration
  double scan_sigma_m = 0.01;         ///< σ of a scan's registration (prior on world_from_scan)
  double scan_sigma_deg = 0.05;
  int scan_points = 3000;             ///< points per scan sampled for scan-to-scan residuals
  /// CSV scan,point_id,x_m,y_m,z_m,sigma_m: surveyed targets (total-station points) measured in
  /// the scans' own frames (with adjusted scans).
  std::string targets;
  LossOptions loss{LossType::kHuber, 3.0};
  /// The scans stand upright (levelled scanner: z up in every scan frame): feature
  /// registration searches the heading only (Kim & Hilton's failure cases).
  bool scans_levelled = false;
  bool AdjustsScans() const {
    return !scans.empty() &&
           (!targets.empty() || std::any_of(scans.begin(), scans.end(), [](const LidarScanFile& f) { return f.has_pose; }));
  }
};

/// A spherical line-scan stereo pair on a vertical mast (Wang et al.'s setup): per station the
/// lower sphere's pose; the upper sphere shares its orientation and sits at a baseline vector
/// (in the lower sphere's frame, one for all stations, with a prior) from it; principal
/// offsets (cx, cy) of each sphere estimated. Tie-point observations refer to the point ids
/// of `tie_block` (a photo_collection).
struct SphericalStereo {
  std::string id;
  int line = 0;
  std::string images;
  std::string calibration;     ///< calib/spherical_stereo.yaml (calib/README.md)
  std::vector<std::string> stations;
  std::string stations_file;   ///< CSV station,east_m,north_m,up_m,heading_deg (initial setups)
  std::string observations;    ///< CSV image,point_id,x_px,y_px[,sigma_px]; image = <station>_lower|upper.<ext>
  std::string tie_block;       ///< id of the photo_collection whose point ids are observed
  double baseline_sigma_m = 0.001;
  double sigma_px = 0.5;
  LossOptions loss{LossType::kHuber, 3.0};
  bool refine_principal_point = true;
  bool refine_focal = false;
  bool dense_cloud = true;     ///< write each station's dense stereo cloud (outputs)
  /// Initialisation: each station's dense cloud registered to the static LiDAR (feature
  /// registration, heading-only: the mast is levelled) replaces its setup when "ok". Off by
  /// default: on the simulated scenes the stereo clouds (mostly paving, σ 7–27 cm) are refused
  /// or, once, accepted 0.32 m / 1.9° off (docs/project-yaml.md `spherical_stereo`, README "Limits").
  bool register_to_lidar = false;
  /// ... within this distance and angle of the setup (the setup's uncertainty; 0 = anywhere).
  double setup_window_m = 2.0;
  double setup_window_deg = 10.0;
};

/// A Ladybug-style multi-camera rig on a vehicle: per frame `rig_from_world`, per camera
/// `cam_from_rig` shared by all frames (fixed, weighted by a prior, or free) and its fisheye
/// intrinsics; each frame has a pose prior from the GNSS/INS trajectory through the lever arm
/// and boresight `body_from_rig` of the calibration.
struct CameraRig {
  std::string id;
  int line = 0;
  std::string images;
  std::string panoramas;       ///< folder of the stitched panoramas <frame>.<ext>, in the rig frame
  /// Folder of `mmba register-mi` results per panorama, <frame>.json (cam_from_lidar = the
  /// frame's rig_from_world, LiDAR frame = world): weighted priors on the frames; "" = none.
  std::string mi_results;
  /// Run the MI registration of each frame's panorama against the static LiDAR's reference
  /// cloud from the GNSS/INS pose; "ok" results start the frame there and are its priors.
  /// `mi_register: [frames]` registers only those frames.
  bool mi_register = false;
  std::vector<std::string> mi_only;  ///< the list of `mi_register: [...]`; empty = every frame
  /// `mi_orientation_classes`: as the photo collection's; default register-mi's (4), which
  /// registers the rigs' own cameras right far more often (bench/RESULTS.md).
  int mi_orientation_classes = 4;
  /// The cloud the panoramas' MI poses refer to (registered by `mi_register` or read from
  /// `mi_results`): "static" = the static LiDAR's reference cloud (world frame: an absolute
  /// prior on the frame), or "mobile" = the mobile LiDAR's delivered cloud (georeferenced by
  /// the GNSS/INS and its nominal mounting; the MI paper's case): the pose relative to the
  /// mobile LiDAR near the frame's time, a factor on the frame, the trajectory correction and
  /// the camera–LiDAR extrinsic. Needs a lidar_mobile with `rig` = this rig.
  MiLidar mi_lidar = MiLidar::kStatic;
  /// `mi_incidence_correction` (with mi_lidar: mobile): each frame's mobile points' intensity
  /// corrected for the angle of incidence before the MI (register-mi --incidence-correction;
  /// the exponent is fitted per frame, ≈ 0 for a scanner that normalises its reflectance);
  /// false = the values as delivered (register-mi's `off`).
  bool mi_incidence_correction = true;
  /// What `mi_register` registers of each frame: "panoramas" = its stitched panorama (two
  /// perspective cuts where the LiDAR is), or "cameras" = the rig's own images of the frame
  /// (`images`/<frame>_<camera>.*), each with its calibration and cam_from_rig, as the views
  /// of one pose: no stitching parallax. Cameras that see fewer than 1,000 LiDAR points at the
  /// start are left out.
  MiViews mi_views = MiViews::kPanoramas;
  /// With mi_lidar mobile: only mobile points captured within this many seconds of the frame
  /// are registered against (the GNSS/INS error drifts; within the window it is one rigid
  /// offset, the assumption of the factor).
  double mi_time_window_s = 2.0;
  std::string calibration;     ///< rig YAML (calib/README.md)
  std::string trajectory;      ///< CSV time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz (world_from_body)
  std::string frames_file;     ///< CSV frame,time_s
  std::string observations;    ///< CSV image,point_id,x_px,y_px[,sigma_px]; image = <frame>_<camera>.<ext>
  std::string tie_block;
  double sigma_px = 0.5;
  double trajectory_sigma_m = 0.1;
  double trajectory_sigma_deg = 1.0;
  /// Correlation time of the GNSS/INS error (first-order Gauss–Markov); 0 = independent frames.
  double trajectory_correlation_s = 30.0;
  PoseTreatment cam_from_rig = PoseTreatment::kWeighted;
  double cam_from_rig_sigma_m = 0.005;
  double cam_from_rig_sigma_deg = 0.2;
  LossOptions loss{LossType::kHuber, 3.0};
  /// By default only k1, k2 of the fisheye distortion are free: a rig's observations rarely
  /// cover the field enough to determine k3, k4, and the solver drifts along them (`refine:
  /// [focal, principal_point, distortion]` frees all).
  RefineIntrinsics refine{true, true, true, 2};
};

/// A mobile LiDAR on a vehicle: the delivered cloud (world frame, georeferenced by the vehicle's
/// GNSS/INS `trajectory` and the mounting `body_from_lidar` of `calibration`, with a time per
/// point). The adjustment un-georeferences a sample of its points, corrects the trajectory
/// smoothly (6-DoF corrections at nodes every `node_spacing_s`, linear in between, with the
/// GNSS/INS σ and drift as a Gauss–Markov prior, optionally a second-difference smoothness prior) and ties the points to the
/// static LiDAR surface (point-to-plane). With `rig` (a camera_rig on the same vehicle) the rig
/// frames follow the same corrected trajectory and the camera–LiDAR extrinsic `rig_from_lidar`
/// (lever arm and boresight, one block for all frames) is estimated.
struct LidarMobile {
  std::string id;
  int line = 0;
  std::string cloud;
  std::string trajectory;          ///< CSV time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz (world_from_body)
  std::string calibration;         ///< YAML with body_from_lidar
  std::string rig;                 ///< id of a camera_rig on the same vehicle; "" = none
  double range_sigma_m = 0.003;
  double surface_sigma_m = 0.005;  ///< σ of the static surface's local plane
  double max_distance_m = 0.5;     ///< association gate of the first outer iteration
  int points = 20000;              ///< points used, evenly over time
  /// Points farther than this from the scanner are not sampled (0 = no limit): far returns
  /// meet the reference at grazing angles and, with the trajectory's attitude still off by its
  /// σ, the wrong planes within the first gate. Negative (the default, or `auto`):
  /// MobileMaxRange — the range at which a 1σ attitude error moves a point by the first gate.
  double max_range_m = -1.0;
  double node_spacing_s = 1.0;
  double trajectory_sigma_m = 0.1;     ///< GNSS/INS position σ (prior on each node's correction)
  double trajectory_sigma_deg = 1.0;   ///< GNSS/INS attitude σ
  double trajectory_correlation_s = 30.0;  ///< GNSS/INS error correlation time (Gauss–Markov); 0 = independent nodes
  /// σ of the second difference of the corrections (per node step); 0 = off (the default: the
  /// Gauss–Markov prior already models how the GNSS/INS error drifts).
  double smoothness_sigma_m = 0.0;
  double smoothness_sigma_deg = 0.0;
  double frame_sigma_m = 0.002;        ///< rig frame ↔ trajectory (time synchronisation)
  double frame_sigma_deg = 0.01;
  PoseTreatment extrinsic = PoseTreatment::kFree;  ///< with `rig`
  double extrinsic_sigma_m = 0.05;
  double extrinsic_sigma_deg = 1.0;
  LossOptions loss{LossType::kHuber, 3.0};
};

/// The range limit of the mobile LiDAR's sample: max_range_m when ≥ 0 (0 = none), else
/// max_distance_m / tan(trajectory_sigma_deg) (0.5 m and 1° → 28.6 m): beyond it a 1σ attitude
/// error of the GNSS/INS moves a point farther than the first association gate.
double MobileMaxRange(const LidarMobile& mobile);

/// The world frame of a project: `origin` (the east-north-up tangent plane at a WGS84 point) or
/// `frame: cartesian` (the control's own local right-handed metric frame, no geodesy).
enum class WorldFrame { kLocalTangentPlane, kCartesian };

/// `control: {file, columns, sigma_m}`: surveyed points in the world frame (io/control_points.h).
struct ControlFile {
  std::string file;
  std::vector<std::string> columns;
  /// σ of every coordinate when the columns carry none (0 = fixed); negative = not given.
  double sigma_m = -1.0;
  int line = 0;
};

/// `scale_bars: [{from, to, distance_m, sigma_m}]`: a calibrated distance between two points.
struct ScaleBar {
  std::string from, to;
  double distance_m = 0.0;
  double sigma_m = 0.0;
  int line = 0;
};

/// Image measurements of targets and tie points (`type: photo_measurements`): one camera, the
/// images that measure the points, initialised without COLMAP (space resection from the
/// control, relative orientation, forward intersection) unless `prior_eo` gives the poses.
struct PhotoMeasurements {
  std::string id;
  int line = 0;
  std::string camera;                            ///< camera YAML (any mmba model)
  std::string images;                            ///< optional list: image id, file name
  std::vector<io::MeasurementFile> measurements;
  std::vector<int> measurement_lines;            ///< of each entry in the project file
  /// `refine`: the camera's parameters estimated (indices in its model's order): focal,
  /// principal_point, distortion, or single parameters by the model's names (k1, p2, …).
  std::vector<int> free_intrinsics;
  std::vector<std::string> refine;               ///< as written
  /// `prior_eo: {file, columns}`: image, x, y, z (camera centre, world metres), omega, phi,
  /// kappa (degrees, DBAT/PhotoModeler convention); "" = initialised from the measurements.
  std::string prior_eo;
  std::vector<std::string> prior_eo_columns;
  /// `gcp_list: {file, sigma_px, sigma_m}`: OpenDroneMap's gcp_list.txt (io/odm_gcp_list.h),
  /// control points in its projection with their image measurements; the projection is the
  /// project's `crs` (taken from the file when the project names none). "" = none.
  std::string gcp_list;
  int gcp_list_line = 0;        ///< of the key in the project file
  double gcp_sigma_px = 1.0;    ///< σ of each GCP image coordinate
  double gcp_sigma_m = 0.0;     ///< σ of each GCP coordinate; 0 = held fixed
  LossOptions loss{LossType::kHuber, 3.0};
};

/// A sensor the project may name that this version validates but does not adjust
/// (camera_rig, spherical_stereo without observations): reported as not used.
struct OtherSensor {
  std::string id;
  std::string type;
  int line = 0;
};

struct AdjustSettings {
  int max_iterations = 100;   ///< Levenberg–Marquardt iterations per outer iteration
  int outer_iterations = 4;   ///< re-association of LiDAR correspondences
  double confidence = 0.95;   ///< χ² test and data-snooping level
  /// An observation is a blunder when its studentized residual exceeds the critical value
  /// AND its whitened residual exceeds this (4: about 6 false alarms per 100 000 good ones).
  double outlier_sigma = 4.0;
  /// Re-weight the groups by variance-component estimation until their components are 1.
  bool variance_components = true;
};

struct Project {
  std::string path;  ///< the project file
  std::string dir;   ///< its folder (paths are relative to it)
  std::string name;
  WorldFrame frame = WorldFrame::kLocalTangentPlane;
  /// World = ENU tangent plane here (frame: local tangent plane): latitude, longitude on the
  /// datum of `crs` when one is given (WGS84 otherwise), ellipsoidal height.
  geodesy::Geodetic origin;
  /// `crs:` the coordinate reference system of the control, the total-station network's
  /// coordinates and the outputs' CRS columns (EPSG code, EPSG:h+v, PROJ string or WKT; with
  /// `geoid_grid:` orthometric heights through the grid); null = none (WGS84 and UTM only).
  std::shared_ptr<const geodesy::Crs> crs;
  int crs_line = 0;
  /// How the origin was set: "origin" (the key) or, with `crs` and no `origin`, the mean of
  /// the network's (else the control file's) CRS coordinates ("mean of N point(s) of FILE in the crs").
  std::string origin_source = "origin";
  /// Surveyed points withheld from the adjustment: of the total-station network, or of
  /// `control`.
  std::vector<std::string> check_points;
  std::optional<ControlFile> control;
  std::vector<ScaleBar> scale_bars;
  AdjustSettings settings;
  std::vector<PhotoCollection> photos;
  std::vector<TotalStation> total_stations;
  std::vector<Gnss> gnss;
  std::vector<LidarStatic> lidar_static;
  std::vector<SphericalStereo> spherical;  ///< with observations (adjusted)
  std::vector<CameraRig> rigs;             ///< with observations (adjusted)
  std::vector<LidarMobile> lidar_mobile;
  std::vector<PhotoMeasurements> photo_measurements;
  std::vector<OtherSensor> other_sensors;
  std::string truth;  ///< simulations: truth JSON (evaluation only, never used to adjust)
};

/// Reads and validates `path` (see above). Throws InputError.
Project LoadProject(const std::string& path);

/// The project's world frame tied to its CRS (CrsFrame::CrsFromWorld turns world coordinates
/// into the CRS, e.g. for a LAS or GeoJSON writer); std::nullopt without `crs`.
std::optional<geodesy::CrsFrame> ProjectCrsFrame(const Project& project);

}  // namespace mmba::adjust
