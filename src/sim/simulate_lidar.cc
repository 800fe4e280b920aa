// The LiDAR of mmba::sim::Simulate: static terrestrial scans around the front of the object
// (delivered registered a few millimetres off, merged into clouds/lidar.ply, with the surveyed
// targets each scan measures) and the mobile LiDAR head on the vehicle (georeferenced with the
// GNSS/INS trajectory and a nominal mounting that is off by a typical boresight and lever arm).

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "mmba/io_cloud/point_cloud.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {
namespace {

using Eigen::Vector3d;

// The pose of static scan `s`: on an arc at `distance` around the front, 1.6 ± 0.1 m high,
// turned about the vertical at random.
Rigid3d StaticScanPose(const Context& c, int s, double distance, Rng* rng) {
  const int scans = c.options.static_scans;
  const double t = scans == 1 ? 0.5 : static_cast<double>(s) / (scans - 1);
  const double azimuth = (-50.0 + 100.0 * t) * kDeg + rng->Uniform(-3, 3) * kDeg;
  const Vector3d position(c.framing.centre.x() + distance * std::sin(azimuth),
                          c.framing.front_y - distance * std::cos(azimuth), 1.6 + rng->Uniform(-0.1, 0.1));
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(rng->Uniform(0, 2 * M_PI), Vector3d::UnitZ())), position);
}

// The surveyed targets scan `name` sees (in range, line of sight): their centres in the scan's
// frame as target-fitting software reports them, N(0, 2 mm) per axis, appended to `csv`.
// Returns their number.
size_t MeasureScanTargets(const Context& c, const std::string& name, const Rigid3d& world_from_scan, Rng* noise,
                          std::ostringstream* csv) {
  const LidarNoiseOptions& range = c.options.static_scan.noise;
  size_t count = 0;
  for (const ScenePoint& target : c.scene.targets) {
    if (target.kind != "target") continue;
    const Vector3d in_scan = world_from_scan.Inverse() * target.point_in_world;
    if (in_scan.norm() < range.min_range_m || in_scan.norm() > range.max_range_m) continue;
    if (!SeesPoint(c.caster, world_from_scan.translation, target.point_in_world)) continue;
    const Vector3d measured = in_scan + Vector3d(noise->Normal(0.002), noise->Normal(0.002), noise->Normal(0.002));
    *csv << name << "," << target.id << "," << Fmt(measured.x(), 5) << "," << Fmt(measured.y(), 5) << ","
         << Fmt(measured.z(), 5) << ",0.002\n";
    ++count;
  }
  return count;
}

// The scan's registration as a scanner's software delivers it (target or cloud-to-cloud):
// N(0, 0.015°) and N(0, 4 mm) per axis off the true pose.
Rigid3d DeliveredRegistration(const Rigid3d& world_from_scan, Rng* error) {
  const Vector3d rotation_error(error->Normal(0.015 * kDeg), error->Normal(0.015 * kDeg), error->Normal(0.015 * kDeg));
  const Vector3d position_error(error->Normal(0.004), error->Normal(0.004), error->Normal(0.004));
  const Eigen::Quaterniond rotation_delta =
      rotation_error.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(rotation_error.norm(), rotation_error.normalized()))
                                : Eigen::Quaterniond::Identity();
  return Rigid3d(rotation_delta * world_from_scan.rotation, world_from_scan.translation + position_error);
}

// The static scans' outputs the project and the truth need.
struct StaticScans {
  json scans = json::array();
  std::vector<Rigid3d> registrations;
  std::ostringstream targets_csv;
  size_t num_target_observations = 0;
};

// Simulates every static scan into clouds/scans/, and the merged reference cloud
// clouds/lidar.ply built with the delivered registrations (the truth keeps the true poses).
void SimulateStaticScans(Context* c, StaticScans* out) {
  const SimulateOptions& o = c->options;
  io::PointCloud merged;
  Rng rng(o.seed, 0x5CA);
  Rng registration_error(o.seed, 0x5CB);
  Rng target_noise(o.seed, 0x5CC);
  out->targets_csv << "# mmba simulate: surveyed targets measured in the static scans (scan frame)\n"
                      "scan,point_id,x_m,y_m,z_m,sigma_m\n";
  const double distance = std::max(5.0, 0.7 * c->framing.width);
  for (int s = 0; s < o.static_scans; ++s) {
    const Rigid3d world_from_scan = StaticScanPose(*c, s, distance, &rng);
    const std::string name = "scan_" + std::to_string(s + 1);
    const LidarScan scan = SimulateStaticScan(c->caster, c->scene, world_from_scan, o.static_scan, name, o.seed, o.threads);
    io::WritePly(scan.cloud, (c->out / "clouds" / "scans" / (name + ".ply")).string());
    out->num_target_observations += MeasureScanTargets(*c, name, world_from_scan, &target_noise, &out->targets_csv);
    const Rigid3d registered = DeliveredRegistration(world_from_scan, &registration_error);
    out->registrations.push_back(registered);
    for (size_t i = 0; i < scan.cloud.size(); ++i) {
      merged.points.push_back(registered * scan.cloud.points[i]);
      merged.intensity.push_back(scan.cloud.intensity[i]);
    }
    c->result.static_points += scan.cloud.size();
    c->result.ghost_points += scan.num_ghosts;
    out->scans.push_back({{"name", name}, {"file", "clouds/scans/" + name + ".ply"},
                          {"world_from_scan", PoseJson(world_from_scan)}, {"world_from_scan_registered", PoseJson(registered)},
                          {"points", scan.cloud.size()},
                          {"rays", scan.num_rays}, {"dropouts", scan.num_dropouts},
                          {"glass_pass", scan.num_glass_pass}, {"ghosts", scan.num_ghosts}});
  }
  if (!merged.empty()) {
    io::WritePly(merged, (c->out / "clouds" / "lidar.ply").string());
    c->registration_truth["world_from_lidar"] = MatrixJson(Rigid3d());
    std::vector<Vector3d> stations_registered;  // the model's own placement of each station
    for (const Rigid3d& r : out->registrations) stations_registered.push_back(r.translation);
    WriteViewpoints(c, "lidar", Rigid3d(), stations_registered);
  }
}

// The mounting the delivered mobile cloud is georeferenced with: the true one off by a typical
// residual boresight (0.15°, −0.2°, 0.3°) and lever-arm (2, −1.5, 1 cm) error.
Rigid3d NominalMount(const Rigid3d& body_from_lidar) {
  return Rigid3d(body_from_lidar.rotation * Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * kDeg, Vector3d::UnitZ()) *
                                                               Eigen::AngleAxisd(-0.2 * kDeg, Vector3d::UnitY()) *
                                                               Eigen::AngleAxisd(0.15 * kDeg, Vector3d::UnitX())),
                 body_from_lidar.translation + Vector3d(0.02, -0.015, 0.01));
}

// The mobile scan, georeferenced as a mobile-mapping system would (clouds/mobile_lidar.ply,
// each point keeping its time) and with the true trajectory and mounting
// (truth/mobile_lidar_true.ply), with each cloud's scanner sidecar. Returns its truth entry.
json SimulateMobile(Context* c, const Trajectory& trajectory, const Rigid3d& body_from_lidar,
                    const Rigid3d& body_from_lidar_nominal) {
  const SimulateOptions& o = c->options;
  const LidarScan scan = SimulateMobileScan(c->caster, c->scene, trajectory, body_from_lidar, o.mobile_scan,
                                            o.mobile_revolutions, "mobile", o.seed, o.threads);
  io::WritePly(GeoreferenceMobileScan(scan, trajectory, body_from_lidar_nominal, true),
               (c->out / "clouds" / "mobile_lidar.ply").string());
  io::WritePly(GeoreferenceMobileScan(scan, trajectory, body_from_lidar, false),
               (c->out / "truth" / "mobile_lidar_true.ply").string());
  // Each cloud's sidecar (io::ReadScannerSidecar): the trajectory and mounting it was
  // georeferenced with, which place the scanner of each point (register-mi's incidence
  // correction finds them without options).
  WriteText(c->out / "clouds" / "mobile_lidar.scanner.yaml",
            "# The scanner of each point of mobile_lidar.ply: the pose at the point's time on the GNSS/INS\n"
            "# trajectory and the nominal mounting it was georeferenced with (paths relative to this file).\n"
            "trajectory: ../trajectory_ins.csv\nlidar_mount: ../calib/mobile_lidar.yaml\n");
  WriteText(c->out / "truth" / "mobile_lidar_mount_true.yaml",
            "# The true mounting of the mobile LiDAR head on the vehicle (body: x forward, y left, z up).\n"
            "body_from_lidar: " + YamlPose(body_from_lidar) + "\n");
  WriteText(c->out / "truth" / "mobile_lidar_true.scanner.yaml",
            "# The scanner of each point of mobile_lidar_true.ply: the pose at the point's time on the true\n"
            "# trajectory and the true mounting (paths relative to this file).\n"
            "trajectory: trajectory_true.csv\nlidar_mount: mobile_lidar_mount_true.yaml\n");
  c->result.mobile_points = scan.cloud.size();
  c->result.ghost_points += scan.num_ghosts;
  return {{"file", "clouds/mobile_lidar.ply"}, {"true_file", "truth/mobile_lidar_true.ply"},
          {"body_from_lidar", PoseJson(body_from_lidar)}, {"body_from_lidar_nominal", PoseJson(body_from_lidar_nominal)},
          {"points", scan.cloud.size()},
          {"revolutions", o.mobile_revolutions}, {"ghosts", scan.num_ghosts}};
}

// The project's static LiDAR sensor (scans with their delivered registrations, targets).
void RecordStaticScans(Context* c, const StaticScans& tls) {
  const SimulateOptions& o = c->options;
  c->project_sensors << "  - id: tls\n    type: lidar_static\n    reference_cloud: clouds/lidar.ply\n    scans:\n";
  for (size_t k = 0; k < tls.scans.size(); ++k) {
    c->project_sensors << "      - {file: " << tls.scans[k]["file"].get<std::string>()
                       << ", world_from_scan: " << YamlPose(tls.registrations[k]) << "}  # registration as delivered\n";
  }
  c->project_sensors << "    range_sigma_m: " << o.static_scan.noise.range_sigma_m << "\n"
                     << "    scan_sigma_m: 0.004  # the registrations' accuracy\n    scan_sigma_deg: 0.015\n";
  if (tls.num_target_observations > 0) {
    fs::create_directories(c->out / "observations");
    WriteText(c->out / "observations" / "scan_targets.csv", tls.targets_csv.str());
    c->project_sensors << "    targets: observations/scan_targets.csv  # " << tls.num_target_observations
                       << " surveyed targets measured in the scans\n";
  }
}

// The project's mobile LiDAR sensor and its nominal calibration file.
void RecordMobile(Context* c, const Rigid3d& body_from_lidar_nominal) {
  const SimulateOptions& o = c->options;
  c->project_sensors << "  - id: mls\n    type: lidar_mobile\n    cloud: clouds/mobile_lidar.ply\n"
                        "    trajectory: trajectory_ins.csv\n    calibration: calib/mobile_lidar.yaml\n"
                        "    range_sigma_m: " << o.mobile_scan.noise.range_sigma_m << "\n";
  if (c->truth.contains("rig") && !c->tie_points.empty()) {
    c->project_sensors << "    rig: ladybug  # on the same vehicle: camera-LiDAR extrinsic estimated\n";
  }
  WriteText(c->out / "calib" / "mobile_lidar.yaml",
            "# Mounting of the mobile LiDAR head on the vehicle (body: x forward, y left, z up).\n"
            "body_from_lidar: " + YamlPose(body_from_lidar_nominal) + "\nbeams: " + std::to_string(o.mobile_scan.beams) +
                "\nelevation_deg: [" + Fmt(o.mobile_scan.elevation_min_deg, 2) + ", " +
                Fmt(o.mobile_scan.elevation_max_deg, 2) + "]\nrotation_hz: " + Fmt(o.mobile_scan.rotation_hz, 2) + "\n");
}

}  // namespace

// clouds/<name>.viewpoints.txt: the sensor positions of a cloud in its own frame, as its
// provider knows them (a scanner's stations in its registered model, a reconstruction's camera
// centres or stereo stations) — what register-eval's visibility (free-space) test reads
// (docs/commands/register-cloud.md). Not written for a model without a sensor.
void WriteViewpoints(Context* c, const std::string& name, const Rigid3d& cloud_from_world,
                     const std::vector<Vector3d>& sensors_in_world) {
  if (sensors_in_world.empty()) return;
  std::ostringstream text;
  text << "# sensor positions of clouds/" << name << ".ply in its own frame (x y z, m)\n"
       << std::setprecision(10);
  for (const Vector3d& v : sensors_in_world) {
    const Vector3d p = cloud_from_world * v;
    text << p.x() << " " << p.y() << " " << p.z() << "\n";
  }
  WriteText(c->out / "clouds" / (name + ".viewpoints.txt"), text.str());
}

void SimulateLidar(Context* c, const Trajectory& trajectory, const Rigid3d& body_from_lidar) {
  StaticScans tls;
  SimulateStaticScans(c, &tls);
  const Rigid3d body_from_lidar_nominal = NominalMount(body_from_lidar);
  json mobile;
  if (c->options.mobile_revolutions > 0) mobile = SimulateMobile(c, trajectory, body_from_lidar, body_from_lidar_nominal);
  c->truth["lidar"] = {{"static_scans", tls.scans}, {"mobile", mobile}};
  RecordStaticScans(c, tls);
  if (c->options.mobile_revolutions > 0) RecordMobile(c, body_from_lidar_nominal);
}

}  // namespace mmba::sim::internal
