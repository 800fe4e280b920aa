#pragma once

// The two experiments of Kim & Hilton (3DV 2013, Sec. 4) on a scene folder with ground truth:
//   I.  every modality's full cloud registered to the LiDAR model (Table I);
//   II. every modality's part registered to every other full model (Table II, the
//       cross-modal matrix).
// Folder layout (written by `mmba simulate`, or by hand):
//   DIR/ground_truth.json     {"world_from_lidar": 4×4, "world_from_<m>": 4×4,
//                              "world_from_<m>_part": 4×4, ...}  (row-major, nested rows)
//   DIR/clouds/lidar.ply      the reference model
//   DIR/clouds/<m>.ply        each modality's full cloud, in its own frame
//   DIR/clouds/<m>_part.ply   optional: a part of it, in the same frame as <m>
//   DIR/clouds/<m>.viewpoints.txt  optional: the sensor positions of <m> in its own frame
//                              (scanner stations, camera centres, stereo stations), one
//                              "x y z" a line (# comments); a part uses its full cloud's
//                              file unless it has its own. Used for the visibility test.
// The ground truth of registering a onto b is  b_from_a = world_from_b⁻¹ · world_from_a.

#include <string>
#include <vector>

#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::registration {

/// The reference "method" of SceneEvalOptions::methods.
inline constexpr const char* kFromTruth = "from-truth";

struct SceneEvalOptions {
  /// Methods: "fpfh", "shot", "si", "sc3d" = the paper's pipeline with that descriptor
  /// (SAC-IA best + ICP); "mmba" = the robust pipeline (descriptor auto, hypotheses,
  /// max-clique, verification); "mmba-g" = the same with gravity_aligned (every cloud
  /// levelled to a few degrees, `base.up` up); "from-truth" = a reference, not a method a
  /// user has: the robust pipeline on the source moved to its true pose, searching only
  /// within truth_window_m / truth_window_deg of it. It shows what the data allow — where
  /// the fit's own optimum lies (its RMS) and whether the checks accept it (its status) —
  /// so a cell refused by every method can be told apart as data-limited (the reference
  /// ends >= accurate_m off, or is refused too) or search-limited (the reference registers
  /// it). It never counts as a cell's best method.
  std::vector<std::string> methods = {"fpfh", "shot", "si", "sc3d", "mmba", "from-truth"};
  double truth_window_m = 0.5;    ///< "from-truth": search window around the truth (> 0)
  double truth_window_deg = 5.0;  ///< "from-truth": (0, 180]
  double success_fraction = 0.1;  ///< success: RMS < this × scene extent (paper: 3 m / 30 m)
  double accurate_m = 0.05;       ///< "accurate": RMS below this (metres)
  bool cross_modal = true;        ///< run experiment II
  bool use_viewpoints = true;     ///< read clouds/<m>.viewpoints.txt when present
  /// Run only these cells, each "source:target" (e.g. "spherical_stereo_part:lidar");
  /// empty = every cell. A cell the scene does not have is an InputError.
  std::vector<std::string> cells;
  CloudRegistrationOptions base;  ///< options shared by every run
};

struct EvalRow {
  std::string experiment;  ///< "to-lidar" or "cross-modal"
  std::string source, target, method;
  std::string status, reason;
  double rms_m = 0.0;      ///< RMS of ‖T·p − T_true·p‖ over the source points
  double runtime_s = 0.0;
  double fitness = 0.0, confidence = 0.0;
  double resolution_m = 0.0;  ///< CloudRegistrationResult::resolution_m (inf: not resolved)
  double sigma_rms_m = 0.0;   ///< CloudRegistrationResult::sigma_rms_m (inf: a motion is free)
  double violation = 0.0;     ///< CloudRegistrationResult::violation (free-space test)
  bool visibility = false;    ///< the free-space test was done (sensor positions known)
  /// CloudRegistrationResult::intensity_correlation when the intensity test ran (a geometric
  /// tie, both clouds with a brightness), else −1
  double intensity_correlation = -1.0;
  bool success = false;    ///< rms < success threshold (status may still be "failed")
  bool accurate = false;   ///< rms < accurate_m
};

struct SceneEvaluation {
  std::string dir;
  std::vector<std::string> modalities;
  double extent_m = 0.0;             ///< largest bounding-box side of the LiDAR model
  double success_threshold_m = 0.0;
  double accurate_m = 0.0;
  double truth_window_m = 0.0, truth_window_deg = 0.0;  ///< the "from-truth" reference's
  std::vector<EvalRow> rows;
};

/// Sensor positions, one "x y z" (spaces or commas) a line; blank lines and '#' comments are
/// skipped. Throws InputError naming the file, line and field on anything else.
std::vector<Eigen::Vector3d> ReadViewpoints(const std::string& path);

/// The reference's start (kFromTruth): the source cloud moved by `target_from_source` — its
/// points, normals and sensor positions (`viewpoints`, in the source's frame, moved in place).
io::PointCloud PlacedAtTruth(const io::PointCloud& source,
                             const Eigen::Matrix4d& target_from_source,
                             std::vector<Eigen::Vector3d>* viewpoints);

/// Runs the experiments. Throws InputError on a bad folder (missing files, bad JSON).
SceneEvaluation EvaluateScene(const std::string& dir, const SceneEvalOptions& options);

/// Writes `out_dir`/results.csv and `out_dir`/tables.md (atomically).
void WriteSceneEvaluation(const SceneEvaluation& evaluation, const std::string& out_dir);

}  // namespace mmba::registration
