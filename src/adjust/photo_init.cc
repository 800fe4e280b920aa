// Initialisation of a photo block that has no control (GNSS/INS → approximate poses; COLMAP →
// photo block): a COLMAP reconstruction comes in a frame and scale of its own.
// When fewer than 3 surveyed targets are measured in it, the block's tie points that the
// georeferenced sensors also observe — the rig frames at their GNSS/INS poses, the spherical
// stations at their setups — are intersected in the world from those sensors' rays alone, and
// the similarity block → world (Umeyama 1991, inside a RANSAC over point triples, Fischler &
// Bolles 1981) moves the whole block there. A block that only a static LiDAR overlaps is
// registered to it at trial scales (registration::RegisterCloudsOverScales: Kim & Hilton's
// rigid pipeline per scale, then a similarity point-to-plane ICP). The joint solve then refines
// everything.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <random>
#include <sstream>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/registration/cloud/feature_registration.h"
#include "mmba/registration/cloud/scale_trial_json.h"

namespace mmba::adjust::internal {

namespace {

using Ray = std::pair<Eigen::Vector3d, Eigen::Vector3d>;  // centre, unit direction (world)

// Least-squares intersection of rays; false when they are nearly parallel (largest angle
// between any two below `min_angle_rad`) or the point lies behind one of them.
bool Intersect(const std::vector<Ray>& rays, double min_angle_rad, Eigen::Vector3d* point) {
  if (rays.size() < 2) return false;
  double widest = 0.0;
  for (size_t i = 0; i < rays.size(); ++i) {
    for (size_t j = i + 1; j < rays.size(); ++j) {
      widest = std::max(widest, std::acos(std::clamp(rays[i].second.dot(rays[j].second), -1.0, 1.0)));
    }
  }
  if (widest < min_angle_rad) return false;
  *point = Triangulate(rays);
  for (const auto& [c, d] : rays) {
    if ((*point - c).dot(d) <= 0) return false;
  }
  return point->allFinite();
}

// RANSAC over triples (Fischler & Bolles 1981), each triple's similarity by Umeyama (1991); the
// largest set of pairs within their tolerance, then the similarity refitted on it.
Sim3d RansacSimilarity(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                       const std::vector<double>& tolerance, std::vector<size_t>* best) {
  best->clear();
  if (from.size() < 3) return Sim3d();
  std::mt19937 rng(7);
  std::uniform_int_distribution<size_t> pick(0, from.size() - 1);
  const int trials = std::min<int>(2000, static_cast<int>(from.size() * from.size()));
  for (int trial = 0; trial < trials; ++trial) {
    const std::vector<size_t> triple = {pick(rng), pick(rng), pick(rng)};
    if (triple[0] == triple[1] || triple[1] == triple[2] || triple[0] == triple[2]) continue;
    // Collinear points fix no rotation about their line.
    if (!(((from[triple[1]] - from[triple[0]]).cross(from[triple[2]] - from[triple[0]])).norm() > 0)) continue;
    const Sim3d candidate = SimilarityFrom(from, to, triple);
    if (!(candidate.scale > 0) || !std::isfinite(candidate.scale)) continue;
    std::vector<size_t> inliers;
    for (size_t i = 0; i < from.size(); ++i) {
      if ((candidate * from[i] - to[i]).norm() < tolerance[i]) inliers.push_back(i);
    }
    if (inliers.size() > best->size()) *best = std::move(inliers);
  }
  return best->size() >= 3 ? SimilarityFrom(from, to, *best) : Sim3d();
}

// [sR | t] as a similarity.
Sim3d SimFromMatrix(const Eigen::Matrix4d& m) {
  const double scale = m.topLeftCorner<3, 3>().col(0).norm();
  return Sim3d(scale, Eigen::Quaterniond(Eigen::Matrix3d(m.topLeftCorner<3, 3>() / scale)).normalized(),
               m.topRightCorner<3, 1>());
}

// Moves the photo block's images and points only (the scene also holds the spherical stations).
void MoveBlock(JointState* s, const Sim3d& world_from_block, const std::string& georeference) {
  PhotoBlock& block = *s->photos;
  for (const auto& [image_id, image] : block.model.images) {
    ImagePose& pose = s->scene.Image(image_id);
    pose.cam_from_world = world_from_block.TransformCamFromSource(pose.cam_from_world);
    block.initial_poses[image_id] = pose.cam_from_world;
  }
  for (const auto& [point_id, point] : block.model.points3D) {
    if (s->scene.HasPoint(point_id)) s->scene.Point(point_id) = world_from_block * s->scene.Point(point_id);
  }
  for (const auto& [name, point_id] : block.check_ids) s->scene.Point(point_id) = world_from_block * s->scene.Point(point_id);
  block.georeference = georeference;
  Note(s, "photo block '" + block.config->id + "': " + georeference);
}

}  // namespace

Sim3d SimilarityFrom(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                     const std::vector<size_t>& use) {
  Eigen::Matrix3Xd a(3, use.size()), b(3, use.size());
  for (size_t k = 0; k < use.size(); ++k) {
    a.col(k) = from[use[k]];
    b.col(k) = to[use[k]];
  }
  return SimFromMatrix(Eigen::umeyama(a, b, true));
}

Eigen::Vector3d Triangulate(const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& rays) {
  // Least-squares intersection of rays (centre, unit direction): Σ (I − ddᵀ)(X − c) = 0.
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& [c, d] : rays) {
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += p;
    b += p * c;
  }
  return a.ldlt().solve(b);
}

bool PlacePhotoBlockByTiePoints(JointState* s) {
  if (!s->photos) return false;
  PhotoBlock& block = *s->photos;
  const std::string& id = block.config->id;
  // Rays of the georeferenced sensors per photo tie point, in the world.
  std::map<Point3DId, std::vector<Ray>> rays;
  std::set<std::string> sensors;
  if (s->rig && s->rig->config->tie_block == id) {
    const RigBlock& rig = *s->rig;
    for (const RigObservation& o : rig.observations) {
      const Rigid3d world_from_cam =
          (s->scene.CamFromRig(rig.cameras[o.camera]) * s->scene.RigFrame(FrameId(o.frame))).Inverse();
      const Eigen::Vector3d d = world_from_cam.rotation * s->scene.Camera(rig.cameras[o.camera]).CamFromImg(o.xy);
      if (d.allFinite() && d.norm() > 0) rays[o.point3D_id].emplace_back(world_from_cam.translation, d.normalized());
    }
    sensors.insert("rig '" + rig.config->id + "' at its GNSS/INS poses");
  }
  if (s->spheres && s->spheres->config->tie_block == id) {
    const SphereBlock& sb = *s->spheres;
    for (const ReprojectionObservation& o : sb.lower) {
      const Rigid3d world_from_cam = s->scene.Image(o.image_id).cam_from_world.Inverse();
      const Eigen::Vector3d d = world_from_cam.rotation * s->scene.Camera(sb.lower_camera).CamFromImg(o.xy);
      if (d.allFinite() && d.norm() > 0) rays[o.point3D_id].emplace_back(world_from_cam.translation, d.normalized());
    }
    for (const UpperSphereObservation& o : sb.upper) {
      const Rigid3d world_from_lower = s->scene.Image(o.lower_image_id).cam_from_world.Inverse();
      const Eigen::Vector3d centre = world_from_lower * sb.baseline;
      const Eigen::Vector3d d = world_from_lower.rotation * s->scene.Camera(sb.upper_camera).CamFromImg(o.xy);
      if (d.allFinite() && d.norm() > 0) rays[o.point3D_id].emplace_back(centre, d.normalized());
    }
    sensors.insert("spherical stations '" + sb.config->id + "' at their setups");
  }
  if (sensors.empty()) return false;
  // Intersections: at least two rays crossing at ≥ 2° (a GNSS/INS pose is good to ~1°).
  std::vector<Eigen::Vector3d> from, to;
  std::vector<double> tolerance;
  for (const auto& [point_id, point_rays] : rays) {
    if (!s->scene.HasPoint(point_id)) continue;
    Eigen::Vector3d world;
    if (!Intersect(point_rays, 2.0 * M_PI / 180.0, &world)) continue;
    double range = std::numeric_limits<double>::infinity();
    for (const Ray& ray : point_rays) range = std::min(range, (world - ray.first).norm());
    from.push_back(s->scene.Point(point_id));
    to.push_back(world);
    tolerance.push_back(std::max(0.5, 0.05 * range));
  }
  std::string sensor_list;
  for (const std::string& name : sensors) sensor_list += (sensor_list.empty() ? "" : ", ") + name;
  if (from.size() < 3) {
    Note(s, "photo block '" + id + "': " + std::to_string(from.size()) + " tie points intersected by " + sensor_list +
                " (3 needed): not placed by them");
    return false;
  }
  // An intersection counts when it lies within max(0.5 m, 5 % of its range from the nearest
  // sensor) of the transformed block point: the sensors' poses are approximate, so far points
  // carry proportionally larger errors.
  std::vector<size_t> best;
  const Sim3d world_from_block = RansacSimilarity(from, to, tolerance, &best);
  if (best.size() < 3 || best.size() < 0.5 * from.size()) {
    std::ostringstream m;
    m << "photo block '" << id << "': the " << from.size() << " tie points intersected by " << sensor_list
      << " agree on no similarity (largest consistent set " << best.size() << "): not placed by them";
    Note(s, m.str());
    return false;
  }
  double sum = 0.0;
  for (size_t i : best) sum += (world_from_block * from[i] - to[i]).squaredNorm();
  std::ostringstream g;
  g << "similarity from " << best.size() << " of " << from.size() << " tie points intersected by " << sensor_list
    << ": scale " << world_from_block.scale << ", RMS " << std::sqrt(sum / best.size()) << " m";
  MoveBlock(s, world_from_block, g.str());
  return true;
}

bool PlacePhotoBlockByGnss(JointState* s) {
  if (!s->photos || s->photos->gnss.size() < 3) return false;
  const PhotoBlock& block = *s->photos;
  std::vector<Eigen::Vector3d> from, to;
  std::vector<double> tolerance;
  for (const GnssCamera& c : block.gnss) {
    from.push_back(CameraCentre(s->scene.Image(c.image_id).cam_from_world));
    to.push_back(c.enu);
    // The antenna is off the camera centre by the lever arm (turned by the unknown rotation).
    tolerance.push_back(std::max(0.5, 3 * c.sigma.norm() + c.lever_arm.norm()));
  }
  std::vector<size_t> best;
  const Sim3d world_from_block = RansacSimilarity(from, to, tolerance, &best);
  if (best.size() < 3 || best.size() < 0.5 * from.size()) {
    Note(s, "photo block '" + block.config->id + "': the GNSS positions of " + std::to_string(from.size()) +
                " photos agree on no similarity (largest consistent set " + std::to_string(best.size()) +
                "): not placed by them");
    return false;
  }
  double sum = 0.0;
  for (size_t i : best) sum += (world_from_block * from[i] - to[i]).squaredNorm();
  std::ostringstream g;
  g << "similarity from the GNSS positions of " << best.size() << " of " << from.size() << " photos: scale "
    << world_from_block.scale << ", RMS " << std::sqrt(sum / best.size()) << " m";
  MoveBlock(s, world_from_block, g.str());
  return true;
}

namespace {

// The photo block's tie points and camera centres at their current coordinates.
void TiePointCloud(const JointState& s, io::PointCloud* points, std::vector<Eigen::Vector3d>* centres) {
  const PhotoBlock& block = *s.photos;
  for (const auto& [point_id, point] : block.model.points3D) {
    if (s.scene.HasPoint(point_id)) points->points.push_back(s.scene.Point(point_id));
  }
  for (const auto& [image_id, image] : block.model.images) centres->push_back(CameraCentre(s.scene.Image(image_id).cam_from_world));
}

/// The block's registration to the LiDAR ended with `status`; report.json's "status" says so.
void SetRegistrationStatus(PhotoBlock* block, StepStatus status, const std::string& reason = "") {
  block->registration_status = status;
  block->registration["status"] = StepStatusText(status, reason);
}

}  // namespace

bool PlacePhotoBlockByLidar(JointState* s, std::string* reason) {
  PhotoBlock& block = *s->photos;
  const PhotoCollection& p = *block.config;
  const LidarStatic& lidar = s->project->lidar_static.front();
  io::PointCloud source, target;
  std::vector<Eigen::Vector3d> centres;
  TiePointCloud(*s, &source, &centres);
  nlohmann::json& entry = block.registration;
  entry = {{"method", "scale search"}, {"tie_points", source.size()}};
  if (source.size() < 100) {
    *reason = std::to_string(source.size()) + " tie points, 100 needed to register the block to the LiDAR";
    SetRegistrationStatus(&block, StepStatus::kFailed, *reason);
    return false;
  }
  io::StreamPointCloud(lidar.reference_cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
    target.points.insert(target.points.end(), chunk.points.begin(), chunk.points.end());
  });
  ThinEvenly(&target.points, 2000000);
  entry["lidar_points"] = target.size();
  // Already in place (a model georeferenced before it came here): kept as given.
  const double tau = registration::ScaleSearchTolerance(target);
  const std::vector<double> distances = registration::DistancesToTarget(source, target, Eigen::Matrix4d::Identity());
  const double given = static_cast<double>(std::count_if(distances.begin(), distances.end(), [tau](double d) { return d < tau; })) /
                       static_cast<double>(distances.size());
  entry["fitness_as_given"] = given;
  if (given >= 0.5) {
    SetRegistrationStatus(&block, StepStatus::kAsGiven);
    block.georeference += "; " + std::to_string(static_cast<int>(100 * given)) + " % of its tie points lie on the LiDAR";
    Note(s, "photo block '" + p.id + "': in place on the LiDAR as given (" + block.georeference + ")");
    return true;
  }
  // Trial scales over lidar_scale_range, or 1/8 … 1.5 × the ratio of the clouds' extents.
  const double ratio = registration::RobustExtent(target.points) / std::max(1e-12, registration::RobustExtent(source.points));
  if (!(ratio > 0) || !std::isfinite(ratio)) {
    *reason = "the extent of its tie points or of the LiDAR is zero: no scale can be searched";
    SetRegistrationStatus(&block, StepStatus::kFailed, *reason);
    return false;
  }
  const double lo = p.lidar_scale_min > 0 ? p.lidar_scale_min : ratio / 8.0;
  const double hi = p.lidar_scale_max > 0 ? p.lidar_scale_max : 1.5 * ratio;
  registration::CloudRegistrationOptions options;
  options.source_viewpoints = centres;
  // The scanner positions, where the scans' registrations are given: the free-space test then
  // refuses poses that put tie points where the LiDAR saw through.
  for (const LidarScanFile& scan : lidar.scans) {
    if (scan.has_pose) options.target_viewpoints.push_back(scan.world_from_scan.translation);
  }
  spdlog::info("adjust: initialisation: photo block {} has no scale: its {} tie points registered to the LiDAR ({} points) "
               "at trial scales {:.4g} … {:.4g}", p.id, source.size(), target.size(), lo, hi);
  const registration::ScaleSearchResult r = registration::RegisterCloudsOverScales(
      source, target, options, lo, hi, 1.05, tau, [](size_t done, size_t total, const registration::ScaleTrial& t) {
        spdlog::info("adjust: scale {} of {} ({:.4g}): {}", done, total, t.scale, t.status.substr(0, 160));
      });
  nlohmann::json trials = nlohmann::json::array();
  for (const registration::ScaleTrial& t : r.trials) trials.push_back(nlohmann::json(registration::ScaleTrialJson(t)));
  entry["trials"] = trials;
  entry["scale_range"] = {lo, hi};
  entry["seconds"] = r.seconds;
  if (!r.ok()) {
    *reason = r.reason + " (set lidar_scale_range if the scale lies outside, or add control, GNSS positions of the photos or a sensor that sees its tie points)";
    SetRegistrationStatus(&block, StepStatus::kFailed, *reason);
    return false;
  }
  const Sim3d world_from_block = SimFromMatrix(r.target_from_source);
  SetRegistrationStatus(&block, StepStatus::kOk);
  entry["scale"] = world_from_block.scale;
  entry["fitness"] = r.fitness;
  entry["inlier_rmse_m"] = r.inlier_rmse;
  size_t registered = 0;
  for (const registration::ScaleTrial& t : r.trials) registered += t.refined ? 1 : 0;
  std::ostringstream g;
  g << "similarity from registering its " << source.size() << " tie points to the LiDAR over trial scales (" << registered
    << " of " << r.trials.size() << " registered): scale " << world_from_block.scale << ", " << 100 * r.fitness
    << " % within " << tau << " m, RMS " << r.inlier_rmse << " m";
  MoveBlock(s, world_from_block, g.str());
  return true;
}

void RegisterPhotoBlockToLidar(JointState* s) {
  if (!s->photos || !s->photos->config->register_to_lidar || s->project->lidar_static.empty()) return;
  PhotoBlock& block = *s->photos;
  if (block.registration_status == StepStatus::kOk) return;  // placed on the LiDAR already (scale search)
  const PhotoCollection& p = *block.config;
  const LidarStatic& lidar = s->project->lidar_static.front();
  io::PointCloud source;
  std::vector<Eigen::Vector3d> centres;
  TiePointCloud(*s, &source, &centres);
  nlohmann::json& entry = block.registration;
  entry = {{"tie_points", source.size()}};
  if (source.size() < 100) {
    SetRegistrationStatus(&block, StepStatus::kFailed,
                          std::to_string(source.size()) + " tie points (100 needed); the block is kept as placed");
    Note(s, "photo block '" + p.id + "': not registered to the LiDAR (" + std::to_string(source.size()) + " tie points)");
    return;
  }
  // The reference cloud around the tie points (their box grown by the window), streamed.
  Eigen::Vector3d lo = source.points.front(), hi = lo;
  for (const Eigen::Vector3d& x : source.points) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  const double margin = p.registration_window_m + 1.0;
  lo.array() -= margin;
  hi.array() += margin;
  io::PointCloud target;
  io::StreamPointCloud(lidar.reference_cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
    for (const Eigen::Vector3d& x : chunk.points) {
      if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) target.points.push_back(x);
    }
  });
  ThinEvenly(&target.points, 2000000);
  entry["lidar_points"] = target.size();
  if (target.size() < 100) {
    SetRegistrationStatus(&block, StepStatus::kFailed,
                          std::to_string(target.size()) + " LiDAR points around the block; the block is kept as placed");
    Note(s, "photo block '" + p.id + "': not registered to the LiDAR (no LiDAR around it)");
    return;
  }
  registration::CloudRegistrationOptions options;
  options.gravity_aligned = true;  // the block is in the world (ENU) already: turn about up only, ICP free
  options.search_window_m = p.registration_window_m;
  options.search_window_deg = p.registration_window_deg;
  options.source_viewpoints = centres;
  spdlog::info("adjust: initialisation: the tie points of photo block {} ({}) registered to the LiDAR ({} points)", p.id,
               source.size(), target.size());
  const registration::CloudRegistrationResult r = registration::RegisterClouds(source, target, options);
  entry["fitness"] = r.fitness;
  entry["inlier_rmse_m"] = r.inlier_rmse;
  entry["resolution_m"] = std::isfinite(r.resolution_m) ? nlohmann::json(r.resolution_m) : nlohmann::json(nullptr);
  entry["seconds"] = r.total_seconds();
  if (!r.ok()) {
    SetRegistrationStatus(&block, StepStatus::kFailed, r.reason + " (the block is kept as placed)");
    Note(s, "photo block '" + p.id + "': tie points not registered to the LiDAR (" + r.reason + "); kept as placed");
    return;
  }
  const Rigid3d correction = Rigid3d::FromMatrix(r.target_from_source.topRows<3>());
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& x : source.points) centroid += x;
  centroid /= static_cast<double>(source.size());
  const double shift = (correction * centroid - centroid).norm();
  const double turn = correction.rotation.angularDistance(Eigen::Quaterniond::Identity()) * 180.0 / M_PI;
  SetRegistrationStatus(&block, StepStatus::kOk);
  entry["shift_m"] = shift;
  entry["rotation_deg"] = turn;
  std::ostringstream g;
  g << block.georeference << "; tie points registered to the LiDAR by features (fitness " << r.fitness << ", "
    << r.descriptor << "): moved " << shift << " m, " << turn << "°";
  MoveBlock(s, Sim3d(correction), g.str());
}

}  // namespace mmba::adjust::internal
