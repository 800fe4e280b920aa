#pragma once

// `mmba simulate`: a whole survey of one scene with exact ground truth, written as a folder a
// user would recognise (docs/commands/simulate.md lists the layout and the schemas):
//   images/{photos,spherical,rig,rig_panoramas}/*.png   clouds/*.ply   survey/network.xml
//   gnss.csv   trajectory_ins.csv   calib/*.yaml   colmap/photos/   project.yaml
//   ground_truth.json (registration)   truth/ (everything exact, truth.json + files)

#include <cstdint>
#include <string>

#include "mmba/geodesy/geodesy.h"
#include "mmba/sim/lidar.h"
#include "mmba/sim/render.h"
#include "mmba/sim/scenes.h"

namespace mmba::sim {

struct PhotoOptions {
  int count = 30;                  ///< photos in the collection
  int width = 640;
  int height = 480;
  double focal_px = 560.0;         ///< fx; fy = 1.002·fx
  double k1 = -0.08, k2 = 0.015, p1 = 0.0006, p2 = -0.0004;  ///< OPENCV distortion (truth)
  int tie_points = 1500;           ///< surface points observed in the true COLMAP model
  double observation_sigma_px = 0.5;   ///< noise of the perturbed model's observations
  double pose_sigma_m = 0.10;      ///< perturbed model: position σ
  double pose_sigma_deg = 0.5;     ///< perturbed model: rotation σ
  double point_sigma_m = 0.05;     ///< perturbed model: tie point σ
  double nominal_focal_error = 0.01;   ///< nominal calibration: f·(1 + this), distortion 0
};

struct SphereOptions {
  int stations = 3;
  int width = 1024;                ///< panorama width; height = width / 2
  double baseline_m = 0.6;         ///< vertical, lower to upper sphere
  double lower_height_m = 1.5;
  double principal_offset_px = 2.0;    ///< true cx, cy = nominal + U(−a, a)
  double axis_tilt_deg = 0.05;     ///< true mast tilt, U(−a, a) about two horizontal axes
};

struct RigOptions {
  int frames = 4;                  ///< rig frames along the mobile trajectory
  int width = 320;                 ///< per camera (portrait: height = 1.25·width)
  double focal_px = 130.0;         ///< equidistant fisheye focal length (≈ 140° across the width)
  int panorama_width = 1024;       ///< stitched panorama, height = width / 2
  double stitch_distance_m = 10.0;
};

struct TotalStationOptions {
  int setups = 3;                  ///< instrument setups on the first marks
  double direction_sigma_cc = 10.0;    ///< 1 cc = 1e-4 gon
  double zenith_sigma_cc = 10.0;
  double distance_sigma_mm = 2.0;
  double distance_sigma_ppm = 2.0;
  double instrument_height_m = 1.55;   ///< ± 0.1 m per setup
  double pole_height_m = 1.8;      ///< prism pole on marks; surface targets: 0
  double approximate_sigma_m = 0.3;    ///< noise of approximate coordinates in network.xml
};

struct GnssOptions {
  double control_sigma_horizontal_m = 0.01;
  double control_sigma_vertical_m = 0.02;
  double trajectory_rate_hz = 10.0;
  double ins_position_error_m = 0.1;   ///< amplitude scale of the GNSS/INS drift
  double ins_attitude_error_deg = 1.0;
};

struct CloudOptions {
  int surface_samples = 200000;    ///< object surface samples behind the modality clouds
  double stereo_disparity_sigma_px = 0.5;
  /// Panorama width (px) of the stereo matching behind the dense cloud: a line-scan camera
  /// matched at full resolution, independent of the preview panoramas rendered to images/.
  int stereo_width_px = 6284;
  double multi_view_sigma_m = 0.02;    ///< at 10 m, grows linearly with distance
  double multi_view_keep = 0.35;   ///< fraction of surface samples kept (coarser)
  int multi_view_holes = 6;
  double multi_view_outliers = 0.01;
  double plane_bin_m = 0.5;        ///< plane proxy: coordinate bins of the axis-aligned planes
  double plane_voxel_m = 0.25;     ///< plane proxy: sub-sampling voxel
  double part_fraction = 0.55;     ///< partial crops keep this fraction of the x extent
};

struct SimulateOptions {
  std::string scene = "gate";      ///< gate | cathedral | path of a .yaml scene file or mesh
  std::string mesh_path;           ///< set when the scene is a mesh
  GateOptions gate;
  CathedralOptions cathedral;
  uint64_t seed = 1;
  std::string preset = "small";    ///< small | full
  int threads = 2;
  geodesy::Geodetic origin{45.50480, -73.57720, 60.0};  ///< WGS84 origin of the world ENU
  RenderOptions render;
  PhotoOptions photos;
  SphereOptions spheres;
  RigOptions rig;
  int static_scans = 3;
  StaticScanOptions static_scan;
  MobileScanOptions mobile_scan;
  int mobile_revolutions = 20;
  double mobile_speed_mps = 3.0;
  /// Length of the drive past the object, centred on it (0: the object's width + 8 m). The
  /// LiDAR turns `mobile_revolutions` times from the start; the rig frames spread over it.
  double mobile_drive_m = 0.0;
  TotalStationOptions total_station;
  GnssOptions gnss;
  CloudOptions clouds;

  /// Sets image sizes and densities of a preset: "small" (the defaults: well under a minute
  /// on 2 cores), "full" (6284×3142 panoramas, ≥ 10 M LiDAR points, 1600×1200 photos) or
  /// "drive" (the scale case: a 100 m drive with 200 rig frames and panoramas and ≥ 50 M
  /// mobile LiDAR points, the other sensors as in "small"). Returns false for an unknown name.
  bool ApplyPreset(const std::string& name);
  bool Check(std::string* error) const;
};

struct SimulateResult {
  std::string out_dir;
  size_t triangles = 0;
  size_t photos = 0, sphere_images = 0, rig_images = 0, panoramas = 0;
  size_t tie_points = 0, tie_observations = 0;
  size_t static_points = 0, mobile_points = 0, ghost_points = 0;
  size_t ts_setups = 0, ts_observations = 0, gnss_rows = 0;
  double seconds = 0.0;
  std::string BriefReport() const;
};

/// Reads a scene file (YAML, schema in docs/commands/simulate.md) into `options` (fields present override).
/// Throws InputError naming the file, the key and the value.
void ReadSceneFile(const std::string& path, SimulateOptions* options);

/// Runs the whole simulation into `out_dir` (created). Throws InputError on impossible
/// options or a bad mesh.
SimulateResult Simulate(const SimulateOptions& options, const std::string& out_dir);

}  // namespace mmba::sim
