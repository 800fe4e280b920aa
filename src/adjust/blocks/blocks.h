// The sensor units of the joint adjustment. Each sensor kind has one file in src/adjust/blocks/
// holding its steps in the order RunAdjustment (adjust.cc) and WriteOutputs (outputs.cc) call
// them:
//   load        read the sensor's files into JointState (and the Scene), initialise its poses
//   add groups  its factor groups in the joint problem and its ProblemBuilder parameter
//               options (what is held constant), which Build() applies (BuildProblem)
//   describe    one of its observations in words (data snooping's blunder list)
//   outputs     its rows of poses.csv, its calibration files and report.json entries
// photos.cc (photo collection), rig.cc (camera rig), spherical_stereo.cc (spherical stereo
// pair), static_lidar.cc (static LiDAR: reference cloud and scans), mobile_lidar.cc (mobile
// LiDAR), network.cc (total station and GNSS). Private to mmba_adjust.
#pragma once

#include <ostream>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "../internal.h"

namespace mmba::adjust::internal {

/// Names of the factor groups of the joint problem (report.json `groups[].name`, the keys of
/// JointState::excluded and JointState::sigma_factor).
inline constexpr char kTies[] = "photos: tie points";
inline constexpr char kTargets[] = "photos: control targets";
inline constexpr char kCheck[] = "photos: check points";
inline constexpr char kGnss[] = "GNSS control";
inline constexpr char kGnssCamera[] = "photos: GNSS camera positions";
inline constexpr char kMi[] = "photos: MI pose priors";
inline constexpr char kLidar[] = "LiDAR surface (tie points)";
inline constexpr char kScanToScan[] = "LiDAR: scan-to-scan";
inline constexpr char kScanPrior[] = "LiDAR: scan registration priors";
inline constexpr char kScanTargets[] = "LiDAR: targets in the scans";
inline constexpr char kSphereLower[] = "spheres: lower";
inline constexpr char kSphereUpper[] = "spheres: upper";
inline constexpr char kBaseline[] = "spheres: baseline prior";
inline constexpr char kRig[] = "rig: tie points";
inline constexpr char kRigPrior[] = "rig: GNSS/INS frame priors";
inline constexpr char kRigMi[] = "rig: MI frame priors";
inline constexpr char kRigMiMobile[] = "rig: MI frame poses on the mobile LiDAR";
inline constexpr char kRigCalibration[] = "rig: cam_from_rig priors";
inline constexpr char kRigOnTrajectory[] = "rig: frames on the corrected trajectory";
inline constexpr char kMobile[] = "mobile LiDAR: points on the static surface";
inline constexpr char kMiExtrinsic[] = "mobile: MI camera-LiDAR calibration";
inline constexpr char kTrajectoryPrior[] = "mobile: GNSS/INS trajectory prior";
inline constexpr char kSmoothness[] = "mobile: trajectory smoothness";
inline constexpr char kExtrinsicPrior[] = "mobile: camera-LiDAR extrinsic prior";
inline constexpr char kMeasured[] = "photo measurements: image points";
inline constexpr char kMeasuredControl[] = "photo measurements: control coordinates";
inline constexpr char kScaleBars[] = "photo measurements: scale bars";

/// The observations data snooping excluded and the variance-component σ factors, by group
/// name: what a group's observation list becomes when the problem is built again.
class GroupWeights {
 public:
  explicit GroupWeights(const JointState& s) : s_(s) {}

  /// The group's σ factor from the variance components (1 when not re-weighted).
  double Factor(const char* name) const {
    const auto it = s_.sigma_factor.find(name);
    return it == s_.sigma_factor.end() ? 1.0 : it->second;
  }
  /// `all` without the observations excluded from group `name` (indices into `all`).
  template <typename T>
  std::vector<T> Kept(const char* name, const std::vector<T>& all) const {
    const auto it = s_.excluded.find(name);
    std::vector<T> out;
    for (size_t i = 0; i < all.size(); ++i) {
      if (it == s_.excluded.end() || !it->second.count(i)) out.push_back(all[i]);
    }
    return out;
  }
  /// Kept(name, all) with each observation's σ multiplied by Factor(name).
  template <typename T>
  std::vector<T> Scaled(const char* name, const std::vector<T>& all) const {
    const double f = Factor(name);
    std::vector<T> list = Kept(name, all);
    for (T& o : list) {
      if constexpr (std::is_same_v<T, ReprojectionObservation> || std::is_same_v<T, TargetMeasurement> ||
                    std::is_same_v<T, UpperSphereObservation> || std::is_same_v<T, RigObservation>) {
        o.sigma_px *= f;
      } else if constexpr (std::is_same_v<T, SurfacePlane> || std::is_same_v<T, MobilePoint> ||
                           std::is_same_v<T, ScanPairPoint>) {
        o.sigma_m *= f;
      } else {
        o.sigma *= f;
      }
    }
    return list;
  }

 private:
  const JointState& s_;
};

/// What the sensor units write into while WriteOutputs runs: the staging folder, poses.csv's
/// rows, report.json's pose corrections, calibration tables and entries.
struct OutputSink {
  std::filesystem::path stage;                              ///< the staging folder
  std::ostringstream* poses = nullptr;                      ///< poses.csv, header written
  nlohmann::json corrections = nlohmann::json::array();     ///< report.json `pose_corrections`
  nlohmann::json calibrations = nlohmann::json::array();    ///< report.json `calibrations`
  nlohmann::json* report = nullptr;                         ///< report.json
};

// ---- photo collection (blocks/photos.cc) ---------------------------------------------------

/// Reads the photo collection (its COLMAP model, or COLMAP run on its images into `work_dir`),
/// the GNSS camera rows, control and check measurements and MI results, and georeferences the
/// block by a similarity on its control targets when 3 or more are intersected.
void LoadPhotos(JointState* s, const std::string& work_dir);
/// A block without control placed by GNSS, the tie points other sensors see, or the LiDAR;
/// AdjustFailure when nothing places it.
void PlacePhotoBlock(JointState* s);
/// Tie points, control targets, MI priors, check points (role constraint), GNSS camera
/// positions; the photo cameras' intrinsics refine list. Sets s->check_group.
void AddPhotoGroups(JointState* s, const GroupWeights& w);
/// The observation `index` of a photo group, or "" when `name` is not one.
std::string DescribePhotoObservation(const JointState& s, const std::string& name, size_t index);
/// poses.csv rows and corrections of the photos, the adjusted COLMAP model, the camera
/// calibration YAML, tie_points.ply and error_map_lidar.ply.
void WritePhotoOutputs(const JointState& s, OutputSink* out);

// ---- camera rig (blocks/rig.cc) -------------------------------------------------------------

/// Reads the rig calibration (cameras become Scene cameras), its frames with their GNSS/INS
/// priors and its observations of the photo block's tie points.
void LoadRig(JointState* s);
/// Rig tie points, frame priors (or the frames on the mobile LiDAR's trajectory), MI frame
/// priors, cam_from_rig priors; the parameter options: cam_from_rig constant when fixed, the
/// cameras' intrinsics by the rig's refine list (all held for a camera with fewer than 200
/// observations).
void AddRigGroups(JointState* s, const GroupWeights& w);
/// Once the problem is built: a warning for each rig camera in it whose intrinsics are held
/// for too few observations.
void WarnHeldRigIntrinsics(JointState* s);
std::string DescribeRigObservation(const JointState& s, const std::string& name, size_t index);
/// poses.csv rows (each camera of each frame), frame corrections, calibration/<id>_rig.yaml.
void WriteRigOutputs(const JointState& s, OutputSink* out);

// ---- spherical stereo pair (blocks/spherical_stereo.cc) -----------------------------------

/// Lower and upper sphere observations and the baseline prior; the parameter options of the
/// line-scan calibration (free: cy of both spheres, cx of the upper one, f when asked).
void AddSphereGroups(JointState* s, const GroupWeights& w);
std::string DescribeSphereObservation(const JointState& s, const std::string& name, size_t index);
/// poses.csv rows of both spheres of each station, corrections, calibration/<id>_spherical.yaml.
void WriteSphereOutputs(const JointState& s, OutputSink* out);

// ---- static LiDAR (blocks/static_lidar.cc, scans.cc) --------------------------------------

/// Reads the reference cloud around the photo block (LidarSurface) and the scans to adjust.
void LoadLidar(JointState* s);
/// Ties the photo block's tie points to planes of the LiDAR surface within `gate` metres;
/// returns how many.
size_t AssociateTiePoints(JointState* s, double gate);
/// Tie points on the LiDAR surface, scan-to-scan pairs, targets in the scans, scan priors.
void AddStaticLidarGroups(JointState* s, const GroupWeights& w);
std::string DescribeStaticLidarObservation(const JointState& s, const std::string& name, size_t index);
/// scans.csv, the scans' calibration tables and report.json `static_scans`.
void WriteScanOutputs(const JointState& s, OutputSink* out);

// ---- mobile LiDAR (blocks/mobile_lidar.cc, mobile.cc) --------------------------------------

/// Trajectory prior and smoothness, mobile points on the static surface, the MI frame poses on
/// the mobile LiDAR and the MI calibration, the extrinsic prior; the extrinsic held constant
/// without a rig or when fixed.
void AddMobileGroups(JointState* s, const GroupWeights& w);
std::string DescribeMobileObservation(const JointState& s, const std::string& name, size_t index);
/// The AdjustFailure message when fewer than 100 mobile points lie on the static surface
/// (with a hint when the sample, scaled as millimetres, centimetres or feet, would).
std::string MobileOverlapFailure(const JointState& s, size_t on_surface, double gate);
/// calibration/<id>_camera_lidar.yaml, <id>_trajectory.csv, <id>_corrected.ply (coloured),
/// error_map_<id>.ply, report.json `mobile_lidar` (and `mobile_lidar_coloured`); a warning for
/// nodes that nothing observes.
void WriteMobileOutputs(JointState& s, int num_threads, OutputSink* out);

// ---- image measurements with control (blocks/photo_measurements.cc) ------------------------

/// Reads the photo_measurements sensor (camera, images, measurements, control, check points,
/// scale bars), initialises its images and points (orientation/block_initialisation.h) and
/// puts them in the Scene. InputError for bad files; AdjustFailure when no image is oriented.
void LoadPhotoMeasurements(JointState* s);
/// Image points, control coordinates and scale bars; held control points and intrinsics.
void AddPhotoMeasurementGroups(JointState* s, const GroupWeights& w);
/// The gauge of a block without control (one pose and a distance, or one pose with a scale
/// bar); kNone otherwise.
GaugeOptions PhotoMeasurementGauge(const JointState& s);
std::string DescribePhotoMeasurement(const JointState& s, const std::string& name, size_t index);
/// The name of one of the block's images ("" when `id` is not one).
std::string PhotoMeasurementImageName(const JointState& s, ImageId id);
/// Without control: moves the solved block into the inner-constraints datum (before the
/// statistics; blocks/photo_measurements_datum.cc). No-op otherwise.
void MovePhotoMeasurementsToDatum(JointState* s);
/// After the statistics: every eliminated point's covariance and, without control, the
/// S-transformation of the statistics' cofactor into the inner-constraints datum.
void TransformPhotoMeasurementCovariance(JointState* s, stats::NetworkStatistics* st);
/// images.csv and points.csv of the block, poses.csv rows, its calibration and report.json
/// `photo_measurements` (initialisation, datum, per-image RMS, check points).
void WritePhotoMeasurementOutputs(JointState& s, OutputSink* out);

// ---- total station and GNSS (blocks/network.cc) --------------------------------------------

/// The network adjusted alone (control), then the joint network with check points withheld.
void LoadNetwork(JointState* s);
/// The GNSS files: control marks (GnssPoint), photos' antenna positions (GnssCamera rows).
void LoadGnss(JointState* s);
/// The survey groups of the joint network and the GNSS control marks.
void AddNetworkGroups(JointState* s, const GroupWeights& w);
std::string DescribeNetworkObservation(const JointState& s, const FactorGroup& group, size_t block);

}  // namespace mmba::adjust::internal
