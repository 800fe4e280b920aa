// Initialisation of the spherical stations from their dense clouds (vertical-baseline spherical
// stereo → a dense cloud per pair; feature registration of each pair's cloud to the LiDAR → the
// station's pose), with the pipeline of `mmba register-cloud`.
#include <algorithm>
#include <cmath>
#include <sstream>

#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/registration/cloud/feature_registration.h"
#include "sphere_dense.h"

namespace mmba::adjust::internal {

namespace {

using json = nlohmann::json;

/// The reference cloud's points within `radius` of any of `centres` (streamed: only those are
/// held), per centre, each thinned to at most `cap` points.
std::vector<io::PointCloud> CropAround(const std::string& path, const std::vector<Eigen::Vector3d>& centres, double radius,
                                       size_t cap) {
  std::vector<io::PointCloud> out(centres.size());
  io::StreamPointCloud(path, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
    for (const Eigen::Vector3d& p : chunk.points) {
      for (size_t k = 0; k < centres.size(); ++k) {
        if ((p - centres[k]).squaredNorm() < radius * radius) out[k].points.push_back(p);
      }
    }
  });
  for (io::PointCloud& cloud : out) ThinEvenly(&cloud.points, cap);
  return out;
}

/// A station's registration to the LiDAR ended with `status`: kept with `entry`, whose
/// "status" says so, for report.json.
void SetStationStatus(SphereBlock* sb, const std::string& station, json* entry, StepStatus status,
                      const std::string& reason = "") {
  (*entry)["status"] = StepStatusText(status, reason);
  sb->registration[station] = *entry;
  sb->registration_status[station] = status;
}

/// Registers the dense stereo cloud of one station (in the world at its setup) to the LiDAR
/// around it; an "ok" moves the station's lower-sphere pose. True when it moved.
bool RegisterStation(JointState* s, const std::string& station, const io::PointCloud& target, double radius,
                     const DenseStereoOptions& dense_options) {
  SphereBlock& sb = *s->spheres;
  const ImageId id = sb.lower_image.at(station);
  json entry = {{"station", station}};
  const std::string lower = FindImage(sb.config->images, station + "_lower");
  const std::string upper = FindImage(sb.config->images, station + "_upper");
  if (lower.empty() || upper.empty()) {
    SetStationStatus(&sb, station, &entry, StepStatus::kNotAttempted,
                     "no panoramas " + station + "_lower/_upper in " + sb.config->images);
    return false;
  }
  spdlog::info("adjust: initialisation: dense cloud of spherical station {} registered to the LiDAR", station);
  DenseStereoCloud dense;
  try {
    dense = DenseSphericalStereo(lower, upper, s->scene.Camera(sb.lower_camera), s->scene.Camera(sb.upper_camera),
                                 sb.baseline_prior, dense_options);
  } catch (const std::exception& e) {
    SetStationStatus(&sb, station, &entry, StepStatus::kNotAttempted, e.what());
    return false;
  }
  // The cloud in the world at the setup: the registration's correction is then a world-frame
  // transform near the identity, and the mast's verticality makes it a heading-only search.
  const Rigid3d world_from_setup = s->scene.Image(id).cam_from_world.Inverse();
  io::PointCloud source;
  for (const Eigen::Vector3d& p : dense.cloud.points) source.points.push_back(world_from_setup * p);
  entry["dense_points"] = source.size();
  entry["lidar_points"] = target.size();
  if (source.size() < 100 || target.size() < 100) {
    SetStationStatus(&sb, station, &entry, StepStatus::kFailed,
                     "too few points (" + std::to_string(source.size()) + " stereo, " +
                         std::to_string(target.size()) + " LiDAR within " + std::to_string(radius) + " m)");
    return false;
  }
  registration::CloudRegistrationOptions options;
  options.gravity_aligned = true;
  // A setup is known to a few decimetres and degrees; a repeated bay of a facade farther away
  // is then no alternative.
  options.search_window_m = sb.config->setup_window_m;
  options.search_window_deg = sb.config->setup_window_deg;
  options.source_viewpoints = {world_from_setup.translation};
  const registration::CloudRegistrationResult r = registration::RegisterClouds(source, target, options);
  entry["fitness"] = r.fitness;
  entry["inlier_rmse_m"] = r.inlier_rmse;
  entry["resolution_m"] = std::isfinite(r.resolution_m) ? json(r.resolution_m) : json(nullptr);
  entry["seconds"] = r.total_seconds();
  if (!r.ok()) {
    SetStationStatus(&sb, station, &entry, StepStatus::kFailed, r.reason + " (the setup is kept)");
    Note(s, "spherical station " + station + ": dense cloud not registered to the LiDAR (" + r.reason + "); setup kept");
    return false;
  }
  const Rigid3d correction = Rigid3d::FromMatrix(r.target_from_source.topRows<3>());
  const Rigid3d world_from_lower = correction * world_from_setup;
  const double shift = (world_from_lower.translation - world_from_setup.translation).norm();
  const double turn = world_from_lower.rotation.angularDistance(world_from_setup.rotation) * 180.0 / M_PI;
  entry["shift_from_setup_m"] = shift;
  entry["rotation_from_setup_deg"] = turn;
  SetStationStatus(&sb, station, &entry, StepStatus::kOk);
  s->scene.Image(id).cam_from_world = world_from_lower.Inverse();
  sb.initial_poses[id] = s->scene.Image(id).cam_from_world;
  std::ostringstream m;
  m << "spherical station " << station << ": dense cloud registered to the LiDAR (fitness " << r.fitness << ", "
    << r.descriptor << "): setup moved " << shift << " m, " << turn << "°";
  Note(s, m.str());
  return true;
}

}  // namespace

void RegisterSphereStations(JointState* s) {
  if (!s->spheres || s->project->lidar_static.empty() || !s->spheres->config->register_to_lidar) return;
  SphereBlock& sb = *s->spheres;
  const LidarStatic& lidar = s->project->lidar_static.front();
  // The stereo cloud reaches a few tens of metres at most (range σ ≤ 10 %): the LiDAR around
  // each setup within twice the dense cloud's reach.
  const DenseStereoOptions dense_options;
  const double radius = std::min(2.0 * dense_options.max_range_m, 40.0);
  std::vector<std::string> names;
  std::vector<Eigen::Vector3d> centres;
  for (const auto& [station, id] : sb.lower_image) {
    names.push_back(station);
    centres.push_back(CameraCentre(s->scene.Image(id).cam_from_world));
  }
  spdlog::info("adjust: initialisation: the LiDAR around the {} spherical stations", names.size());
  const std::vector<io::PointCloud> targets = CropAround(lidar.reference_cloud, centres, radius, 1000000);
  size_t moved = 0;
  for (size_t k = 0; k < names.size(); ++k) {
    if (RegisterStation(s, names[k], targets[k], radius, dense_options)) ++moved;
  }
  Note(s, "spherical stations placed by their dense clouds: " + std::to_string(moved) + " of " + std::to_string(names.size()) +
              " (the others start from their setups)");
}

}  // namespace mmba::adjust::internal
