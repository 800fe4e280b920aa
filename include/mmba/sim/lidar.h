#pragma once

// Simulated LiDAR: static terrestrial panoramic scans and a mobile 64-beam scan along a
// vehicle trajectory, with the error model of lidar.cc:
//  * range noise σ = range_sigma_m + range_sigma_ppm·1e-6·range (Gaussian);
//  * intensity I = albedo·cos(incidence) + N(0, intensity_sigma) (Lambertian), in [0, 1];
//  * dropouts: with probability dropout_probability, more at grazing incidence
//    (+ grazing_dropout·((θ−60°)/30°)² for θ > 60°) and always when I < min_intensity;
//  * max/min range;
//  * glass: the pulse passes through with glass_pass_probability (the point lies behind
//    the pane), else returns a mirror ghost with ghost_probability (range = path length
//    via the mirror, placed along the original beam: a point that does not exist), else
//    a weak return from the pane; reflective surfaces ghost with ghost_probability too.
//    These are the "spurious features on glass and reflective surfaces" of Kim & Hilton 2013.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geometry/rigid3d.h"
#include "mmba/io_cloud/point_cloud.h"
#include "mmba/sim/ray_caster.h"
#include "mmba/sim/scenes.h"

namespace mmba::sim {

struct LidarNoiseOptions {
  double range_sigma_m = 0.003;        ///< constant part of the range σ, metres
  double range_sigma_ppm = 20.0;       ///< range-proportional part, parts per million
  double min_range_m = 0.5;
  double max_range_m = 120.0;
  double intensity_sigma = 0.02;
  double min_intensity = 0.01;         ///< weaker returns are lost
  double dropout_probability = 0.01;   ///< at normal incidence
  double grazing_dropout = 0.5;        ///< extra dropout probability at 90° incidence
  double glass_pass_probability = 0.6;
  double ghost_probability = 0.3;      ///< mirror ghost on glass (if not passed) / reflective
  bool Check(std::string* error) const;
};

/// A static panoramic scanner, levelled (scan frame z up), rotating about z.
struct StaticScanOptions {
  double azimuth_step_deg = 0.4;
  double elevation_step_deg = 0.4;
  double elevation_min_deg = -60.0;
  double elevation_max_deg = 85.0;
  LidarNoiseOptions noise;
  bool Check(std::string* error) const;
};

/// A spinning multi-beam head (Velodyne HDL-64E-like: 64 beams from −24.8° to +2°).
struct MobileScanOptions {
  int beams = 64;
  double elevation_min_deg = -24.8;
  double elevation_max_deg = 2.0;
  double azimuth_step_deg = 0.35;  ///< HDL-64E: 0.08° at 10 Hz
  double rotation_hz = 10.0;
  LidarNoiseOptions noise;
  bool Check(std::string* error) const;
};

/// One scan: points in the sensor frame at the time of each firing, the truth labels.
struct LidarScan {
  std::string name;
  Rigid3d world_from_scan;             ///< static scans: the scan frame; mobile: unused
  io::PointCloud cloud;                ///< sensor frame; intensity in [0, 1]
  std::vector<double> time_s;          ///< mobile: firing time of each point
  std::vector<uint8_t> spurious;       ///< 1 = ghost (not on any surface at that place)
  size_t num_rays = 0;
  size_t num_dropouts = 0;
  size_t num_glass_pass = 0;
  size_t num_ghosts = 0;
};

/// A vehicle trajectory: smooth true motion and a GNSS/INS estimate with slowly varying
/// errors (position error up to ~`ins_position_error_m`, attitude up to
/// ~`ins_attitude_error_deg`), both analytic in time. Body frame: x forward, y left, z up.
class Trajectory {
 public:
  /// A path along x at `y_m`, from `x_start_m` to `x_end_m` at `speed_mps` with a gentle
  /// sideways sway; errors drawn from `seed`.
  Trajectory(double x_start_m, double x_end_m, double y_m, double speed_mps,
             double ins_position_error_m, double ins_attitude_error_deg, uint64_t seed);
  double duration_s() const { return duration_s_; }
  Rigid3d WorldFromBodyTrue(double time_s) const;
  Rigid3d WorldFromBodyIns(double time_s) const;

 private:
  double x_start_m_, x_end_m_, y_m_, speed_mps_, duration_s_;
  double position_amp_m_[3], position_period_s_[3], position_phase_[3];
  double attitude_amp_rad_[3], attitude_period_s_[3], attitude_phase_[3];
};

/// Simulates one static scan from `world_from_scan` (its origin is the optical centre).
LidarScan SimulateStaticScan(const RayCaster& caster, const SimScene& scene,
                             const Rigid3d& world_from_scan, const StaticScanOptions& options,
                             const std::string& name, uint64_t seed, int threads);

/// Simulates a mobile scan for `revolutions` turns of the head from time 0, mounted with
/// `body_from_lidar` (lidar frame: x forward, y left, z up, the head spinning about z).
LidarScan SimulateMobileScan(const RayCaster& caster, const SimScene& scene,
                             const Trajectory& trajectory, const Rigid3d& body_from_lidar,
                             const MobileScanOptions& options, int revolutions,
                             const std::string& name, uint64_t seed, int threads);

/// The points of a mobile scan in the world frame, georeferenced with `ins` = true:
/// the GNSS/INS estimate (what a mobile-mapping system delivers) or the true trajectory.
io::PointCloud GeoreferenceMobileScan(const LidarScan& scan, const Trajectory& trajectory,
                                      const Rigid3d& body_from_lidar, bool ins);

}  // namespace mmba::sim
