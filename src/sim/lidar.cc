#include "mmba/sim/lidar.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "mmba/core/parallel_for.h"
#include "mmba/sim/texture.h"
#include "sim/random_internal.h"

namespace mmba::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

// One pulse: the first return along `direction` from `origin`, with the error model of
// lidar.h. Returns false when nothing comes back.
struct PulseResult {
  Eigen::Vector3d point_in_world;
  float intensity = 0.0f;
  bool spurious = false;
  bool glass_pass = false;
};

bool SimulatePulse(const RayCaster& caster, const SimScene& scene, const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& direction, const LidarNoiseOptions& noise,
                   uint64_t seed, internal::Rng* rng, PulseResult* result) {
  const TriangleMesh& mesh = scene.mesh;
  double travelled = 0.0;
  Eigen::Vector3d from = origin;
  result->spurious = false;
  result->glass_pass = false;
  for (int bounce = 0; bounce < 3; ++bounce) {
    const RayHit hit = caster.Intersect(from, direction, bounce == 0 ? noise.min_range_m : 1e-4,
                                        noise.max_range_m - travelled);
    if (!hit.hit) return false;
    const Material& material = mesh.materials[mesh.triangle_material[hit.triangle]];
    const double cos_incidence = std::abs(hit.normal.dot(direction));
    double range = travelled + hit.distance_m;
    double albedo = Albedo(material, hit.point, hit.normal, seed);
    const double u = rng->Uniform();
    if (material.material_class == MaterialClass::kGlass) {
      if (u < noise.glass_pass_probability) {
        travelled = range;
        from = hit.point;
        result->glass_pass = true;
        continue;
      }
    }
    if (material.material_class != MaterialClass::kDiffuse &&
        rng->Uniform() < noise.ghost_probability) {
      // Mirror ghost: the pulse reflects specularly, meets another surface and comes back
      // the same way; the scanner places the return along its own beam at the path length.
      const Eigen::Vector3d reflected =
          direction - 2.0 * direction.dot(hit.normal) * hit.normal;
      const RayHit second = caster.Intersect(hit.point, reflected, 1e-4, noise.max_range_m - range);
      if (!second.hit) return false;
      const Material& m2 = mesh.materials[mesh.triangle_material[second.triangle]];
      range += second.distance_m;
      albedo = 0.5 * Albedo(m2, second.point, second.normal, seed);
      result->spurious = true;
      result->point_in_world = origin + (range + rng->Normal(noise.range_sigma_m)) * direction;
      result->intensity = static_cast<float>(std::clamp(
          albedo * std::abs(second.normal.dot(reflected)) + rng->Normal(noise.intensity_sigma), 0.0, 1.0));
      return range <= noise.max_range_m;
    }
    if (material.material_class == MaterialClass::kGlass) albedo *= 0.3;  // weak pane return
    const double intensity = albedo * cos_incidence + rng->Normal(noise.intensity_sigma);
    const double incidence_deg = std::acos(std::min(1.0, cos_incidence)) / kDeg;
    double p_drop = noise.dropout_probability;
    if (incidence_deg > 60.0) {
      const double t = (incidence_deg - 60.0) / 30.0;
      p_drop += noise.grazing_dropout * t * t;
    }
    if (rng->Uniform() < p_drop || intensity < noise.min_intensity) return false;
    const double sigma = noise.range_sigma_m + noise.range_sigma_ppm * 1e-6 * range;
    // Along the beam from the scanner (through any pane passed).
    result->point_in_world = origin + (range + rng->Normal(sigma)) * direction;
    result->intensity = static_cast<float>(std::clamp(intensity, 0.0, 1.0));
    return true;
  }
  return false;
}

std::string CheckNoise(const LidarNoiseOptions& n) {
  std::ostringstream e;
  if (!(n.range_sigma_m >= 0)) e << "range_sigma_m " << n.range_sigma_m << " must be >= 0";
  else if (!(n.range_sigma_ppm >= 0)) e << "range_sigma_ppm " << n.range_sigma_ppm << " must be >= 0";
  else if (!(n.min_range_m >= 0)) e << "min_range_m " << n.min_range_m << " must be >= 0";
  else if (!(n.max_range_m > n.min_range_m)) e << "max_range_m " << n.max_range_m << " must be > min_range_m";
  else if (!(n.dropout_probability >= 0 && n.dropout_probability < 1)) e << "dropout_probability " << n.dropout_probability << " must be in [0, 1)";
  else if (!(n.glass_pass_probability >= 0 && n.glass_pass_probability <= 1)) e << "glass_pass_probability " << n.glass_pass_probability << " must be in [0, 1]";
  else if (!(n.ghost_probability >= 0 && n.ghost_probability <= 1)) e << "ghost_probability " << n.ghost_probability << " must be in [0, 1]";
  return e.str();
}

bool Report(const std::string& message, std::string* error) {
  if (message.empty()) return true;
  if (error) *error = message;
  return false;
}

}  // namespace

bool LidarNoiseOptions::Check(std::string* error) const { return Report(CheckNoise(*this), error); }

bool StaticScanOptions::Check(std::string* error) const {
  std::ostringstream e;
  if (!(azimuth_step_deg > 0.001 && azimuth_step_deg <= 45)) e << "lidar azimuth_step_deg " << azimuth_step_deg << " must be in (0.001, 45]";
  else if (!(elevation_step_deg > 0.001 && elevation_step_deg <= 45)) e << "lidar elevation_step_deg " << elevation_step_deg << " must be in (0.001, 45]";
  else if (!(elevation_min_deg >= -90 && elevation_max_deg <= 90 && elevation_min_deg < elevation_max_deg)) e << "lidar elevation range [" << elevation_min_deg << ", " << elevation_max_deg << "] must be increasing within [-90, 90]";
  else e << CheckNoise(noise);
  return Report(e.str(), error);
}

bool MobileScanOptions::Check(std::string* error) const {
  std::ostringstream e;
  if (beams < 1 || beams > 512) e << "mobile lidar beams " << beams << " must be in [1, 512]";
  else if (!(azimuth_step_deg > 0.001 && azimuth_step_deg <= 45)) e << "mobile lidar azimuth_step_deg " << azimuth_step_deg << " must be in (0.001, 45]";
  else if (!(elevation_min_deg >= -90 && elevation_max_deg <= 90 && elevation_min_deg < elevation_max_deg)) e << "mobile lidar elevation range must be increasing within [-90, 90]";
  else if (!(rotation_hz > 0)) e << "mobile lidar rotation_hz " << rotation_hz << " must be > 0";
  else e << CheckNoise(noise);
  return Report(e.str(), error);
}

Trajectory::Trajectory(double x_start_m, double x_end_m, double y_m, double speed_mps,
                       double ins_position_error_m, double ins_attitude_error_deg, uint64_t seed)
    : x_start_m_(x_start_m), x_end_m_(x_end_m), y_m_(y_m), speed_mps_(speed_mps) {
  duration_s_ = std::abs(x_end_m - x_start_m) / speed_mps;
  internal::Rng rng(seed, 0x7A11);
  // Slowly varying errors (periods 15–60 s): the low-frequency drift of a GNSS/INS solution.
  for (int k = 0; k < 3; ++k) {
    position_amp_m_[k] = ins_position_error_m / std::sqrt(3.0) * rng.Uniform(0.5, 1.0);
    position_period_s_[k] = rng.Uniform(15.0, 60.0);
    position_phase_[k] = rng.Uniform(0.0, 2.0 * M_PI);
    // Heading is the worst-determined angle of an INS; roll and pitch a third of it.
    attitude_amp_rad_[k] = ins_attitude_error_deg * kDeg * (k == 2 ? 1.0 : 0.33) * rng.Uniform(0.5, 1.0);
    attitude_period_s_[k] = rng.Uniform(15.0, 60.0);
    attitude_phase_[k] = rng.Uniform(0.0, 2.0 * M_PI);
  }
}

Rigid3d Trajectory::WorldFromBodyTrue(double time_s) const {
  const double direction = x_end_m_ >= x_start_m_ ? 1.0 : -1.0;
  const double x = x_start_m_ + direction * speed_mps_ * time_s;
  const double sway = 0.3 * std::sin(0.4 * time_s);
  const double dsway = 0.3 * 0.4 * std::cos(0.4 * time_s);
  const double heading = std::atan2(dsway, direction * speed_mps_);
  const double yaw = (direction > 0 ? 0.0 : M_PI) + heading;
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                 Eigen::Vector3d(x, y_m_ + sway, 0.0));
}

Rigid3d Trajectory::WorldFromBodyIns(double time_s) const {
  const Rigid3d truth = WorldFromBodyTrue(time_s);
  Eigen::Vector3d dp, da;
  for (int k = 0; k < 3; ++k) {
    dp[k] = position_amp_m_[k] * std::sin(2 * M_PI * time_s / position_period_s_[k] + position_phase_[k]);
    da[k] = attitude_amp_rad_[k] * std::sin(2 * M_PI * time_s / attitude_period_s_[k] + attitude_phase_[k]);
  }
  const Eigen::Quaterniond error = Eigen::AngleAxisd(da[2], Eigen::Vector3d::UnitZ()) *
                                   Eigen::AngleAxisd(da[1], Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(da[0], Eigen::Vector3d::UnitX());
  return Rigid3d(truth.rotation * error, truth.translation + dp);
}

namespace {

// Runs the pulses of a scan in parallel; `ray(i, &origin_w, &dir_w, &sensor_from_world,
// &time)` describes pulse i. Points kept in pulse order.
template <typename RayFn>
LidarScan RunPulses(const RayCaster& caster, const SimScene& scene, size_t num_rays,
                    const LidarNoiseOptions& noise, uint64_t seed, uint64_t stream, int threads,
                    const RayFn& ray) {
  struct Slot {
    bool valid = false;
    PulseResult result;
    Eigen::Vector3d point_in_sensor;
    double time_s = 0;
  };
  std::vector<Slot> slots(num_rays);
  ParallelChunks(num_rays, threads, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      Eigen::Vector3d origin, direction;
      Rigid3d sensor_from_world;
      double time_s = 0;
      ray(i, &origin, &direction, &sensor_from_world, &time_s);
      internal::Rng rng(seed, stream, i);
      Slot& slot = slots[i];
      slot.valid = SimulatePulse(caster, scene, origin, direction, noise, seed, &rng, &slot.result);
      if (slot.valid) {
        slot.point_in_sensor = sensor_from_world * slot.result.point_in_world;
        slot.time_s = time_s;
      }
    }
  });
  LidarScan scan;
  scan.num_rays = num_rays;
  for (const Slot& slot : slots) {
    if (slot.result.glass_pass) ++scan.num_glass_pass;
    if (!slot.valid) {
      ++scan.num_dropouts;
      continue;
    }
    scan.cloud.points.push_back(slot.point_in_sensor);
    scan.cloud.intensity.push_back(slot.result.intensity);
    scan.spurious.push_back(slot.result.spurious ? 1 : 0);
    scan.time_s.push_back(slot.time_s);
    if (slot.result.spurious) ++scan.num_ghosts;
  }
  return scan;
}

}  // namespace

LidarScan SimulateStaticScan(const RayCaster& caster, const SimScene& scene,
                             const Rigid3d& world_from_scan, const StaticScanOptions& options,
                             const std::string& name, uint64_t seed, int threads) {
  const int num_az = static_cast<int>(std::round(360.0 / options.azimuth_step_deg));
  const int num_el = static_cast<int>(
      std::floor((options.elevation_max_deg - options.elevation_min_deg) / options.elevation_step_deg)) + 1;
  const Rigid3d scan_from_world = world_from_scan.Inverse();
  const Eigen::Vector3d origin = world_from_scan.translation;
  uint64_t stream = 0x5CA17;
  for (char c : name) stream = stream * 131 + static_cast<unsigned char>(c);
  LidarScan scan = RunPulses(
      caster, scene, static_cast<size_t>(num_az) * num_el, options.noise, seed, stream, threads,
      [&](size_t i, Eigen::Vector3d* o, Eigen::Vector3d* d, Rigid3d* sensor_from_world, double* t) {
        const double az = (static_cast<double>(i / num_el) * options.azimuth_step_deg) * kDeg;
        const double el = (options.elevation_min_deg + static_cast<double>(i % num_el) *
                                                           options.elevation_step_deg) * kDeg;
        const Eigen::Vector3d dir_in_scan(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                          std::sin(el));
        *o = origin;
        *d = world_from_scan.rotation * dir_in_scan;
        *sensor_from_world = scan_from_world;
        *t = 0.0;
      });
  scan.time_s.clear();
  scan.name = name;
  scan.world_from_scan = world_from_scan;
  return scan;
}

LidarScan SimulateMobileScan(const RayCaster& caster, const SimScene& scene,
                             const Trajectory& trajectory, const Rigid3d& body_from_lidar,
                             const MobileScanOptions& options, int revolutions,
                             const std::string& name, uint64_t seed, int threads) {
  const int per_rev = static_cast<int>(std::round(360.0 / options.azimuth_step_deg));
  const size_t columns = static_cast<size_t>(per_rev) * std::max(1, revolutions);
  const double column_dt = 1.0 / (options.rotation_hz * per_rev);
  const int beams = options.beams;
  LidarScan scan = RunPulses(
      caster, scene, columns * beams, options.noise, seed, 0x30B11E, threads,
      [&](size_t i, Eigen::Vector3d* o, Eigen::Vector3d* d, Rigid3d* sensor_from_world, double* t) {
        const size_t column = i / beams;
        const int beam = static_cast<int>(i % beams);
        *t = std::min(column * column_dt, trajectory.duration_s());
        const Rigid3d world_from_lidar = trajectory.WorldFromBodyTrue(*t) * body_from_lidar;
        const double az = 2.0 * M_PI * static_cast<double>(column % per_rev) / per_rev;
        const double el = (beams == 1 ? options.elevation_min_deg
                                      : options.elevation_min_deg +
                                            (options.elevation_max_deg - options.elevation_min_deg) *
                                                beam / (beams - 1)) * kDeg;
        const Eigen::Vector3d dir_in_lidar(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                           std::sin(el));
        *o = world_from_lidar.translation;
        *d = world_from_lidar.rotation * dir_in_lidar;
        *sensor_from_world = world_from_lidar.Inverse();
      });
  scan.name = name;
  return scan;
}

io::PointCloud GeoreferenceMobileScan(const LidarScan& scan, const Trajectory& trajectory,
                                      const Rigid3d& body_from_lidar, bool ins) {
  io::PointCloud cloud;
  cloud.points.reserve(scan.cloud.size());
  for (size_t i = 0; i < scan.cloud.size(); ++i) {
    const double t = scan.time_s[i];
    const Rigid3d world_from_body = ins ? trajectory.WorldFromBodyIns(t) : trajectory.WorldFromBodyTrue(t);
    cloud.points.push_back(world_from_body * (body_from_lidar * scan.cloud.points[i]));
  }
  cloud.intensity = scan.cloud.intensity;
  cloud.time = scan.time_s;
  return cloud;
}

}  // namespace mmba::sim
