// Static LiDAR scans adjusted on their own: one scan_from_world block per scan, its
// registration as a prior, scan-to-scan point-to-plane, tie points on each scan's surface.
// A scan without a registration is placed by its surveyed targets or by feature registration.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;

namespace {

void Log(JointState* s, const std::string& text) {
  s->log.push_back(text);
  spdlog::info("adjust: {}", text);
}

/// Every `stride`-th point of a scan (streamed: at most `cap` points are held).
io::PointCloud ReadThinned(const std::string& path, size_t cap) {
  io::PointCloud out;
  size_t stride = 1;
  io::StreamPointCloud(path, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t first, size_t total) {
    stride = std::max<size_t>(1, (total + cap - 1) / cap);
    for (size_t i = 0; i < chunk.points.size(); ++i) {
      if ((first + i) % stride == 0) out.points.push_back(chunk.points[i]);
    }
  });
  return out;
}

/// world_from_scan from surveyed targets measured in the scan: the rigid fit (Umeyama 1991,
/// without scale) of their scan coordinates to their network coordinates.
bool PlaceByTargets(const JointState& s, const std::vector<ScanTarget>& targets, size_t scan, Rigid3d* world_from_scan,
                    std::string* detail) {
  std::vector<Eigen::Vector3d> from, to;
  for (const ScanTarget& t : targets) {
    if (t.scan != scan) continue;
    from.push_back(t.measured);
    to.push_back(WorldFromSurvey(*s.joint, *s.joint->Find(t.point_id)));
  }
  if (from.size() < 3) return false;
  Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
  for (size_t i = 0; i < from.size(); ++i) {
    a.col(i) = from[i];
    b.col(i) = to[i];
  }
  // Targets (nearly) in a line leave the rotation about that line open: the spread across the
  // line must be at least 5 % of the spread along it.
  const Eigen::Vector3d mean = a.rowwise().mean();
  const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(a.colwise() - mean);
  if (svd.singularValues()(1) < 0.05 * svd.singularValues()(0)) return false;
  const Eigen::Matrix4d t = Eigen::umeyama(a, b, false);
  *world_from_scan = Rigid3d::FromMatrix(t.topRows<3>());
  double sum = 0.0;
  for (size_t i = 0; i < from.size(); ++i) sum += (*world_from_scan * from[i] - to[i]).squaredNorm();
  std::ostringstream d;
  d << from.size() << " surveyed targets, RMS " << std::sqrt(sum / from.size()) << " m";
  *detail = d.str();
  return true;
}

}  // namespace

const char* ScanPlacementName(ScanPlacement method) {
  switch (method) {
    case ScanPlacement::kApproximate: return "approximate";
    case ScanPlacement::kGiven: return "given";
    case ScanPlacement::kTargets: return "targets";
    case ScanPlacement::kFeatureRegistration: return "feature registration";
  }
  return "given";
}

void LoadScans(JointState* s, const Eigen::Vector3d& roi_min, const Eigen::Vector3d& roi_max) {
  const LidarStatic& l = s->project->lidar_static.front();
  if (!l.AdjustsScans()) return;
  std::vector<std::string> names;
  for (const LidarScanFile& file : l.scans) names.push_back(fs::path(file.file).stem().string());
  // The surveyed targets first: they tie the scans to the control and can place a scan that
  // has no registration.
  if (!l.targets.empty() && !s->joint) {
    s->warnings.push_back("lidar_static '" + l.id + "': targets " + l.targets + " not used (no total_station network)");
  } else if (!l.targets.empty()) {
    const io::CsvTable table = io::CsvTable::Read(l.targets, {"scan", "point_id", "x_m", "y_m", "z_m", "sigma_m"});
    size_t skipped = 0;
    for (const io::CsvTable::Row& row : table.rows()) {
      const std::string scan_name = table.String(row, "scan");
      const auto scan = std::find(names.begin(), names.end(), scan_name);
      if (scan == names.end()) table.Fail(row, "scan", scan_name, "the name (file stem) of one of the lidar_static scans");
      ScanTarget t;
      t.scan = static_cast<size_t>(scan - names.begin());
      t.point_id = table.String(row, "point_id");
      if (s->joint->Find(t.point_id) == nullptr) {
        table.Fail(row, "point_id", t.point_id, "a point of the total-station network");
      }
      t.measured = Eigen::Vector3d(table.Double(row, "x_m"), table.Double(row, "y_m"), table.Double(row, "z_m"));
      t.sigma = table.Double(row, "sigma_m");
      if (!(t.sigma > 0)) table.Fail(row, "sigma_m", table.String(row, "sigma_m"), "a positive σ in metres");
      t.source = l.targets + ":" + std::to_string(row.line);
      // Only points the network determines (a point without observations has approximate
      // coordinates only); check points stay independent of the LiDAR.
      const bool check = std::count(s->project->check_points.begin(), s->project->check_points.end(), t.point_id) > 0;
      if (!s->surveyed_ids.count(t.point_id) || check) {
        ++skipped;
        continue;
      }
      s->scan_targets.push_back(t);
    }
    Log(s, "LiDAR targets " + l.targets + ": " + std::to_string(s->scan_targets.size()) + " measurements used (" +
               std::to_string(skipped) + " of check points or of points without total-station observations left out)");
  }
  // Initial world_from_scan: the registration given, else the targets, else (below) feature
  // registration to the scans placed so far.
  std::vector<std::optional<Rigid3d>> world_from_scan(l.scans.size());
  std::vector<ScanInitialisation> init(l.scans.size());
  for (size_t k = 0; k < l.scans.size(); ++k) {
    if (l.scans[k].has_pose && l.scans[k].approximate) {
      world_from_scan[k] = l.scans[k].world_from_scan;
      init[k] = {ScanPlacement::kApproximate, "world_from_scan of the project file as an initial value only (no prior)"};
      continue;
    }
    if (l.scans[k].has_pose) {
      world_from_scan[k] = l.scans[k].world_from_scan;
      init[k] = {ScanPlacement::kGiven, "the registration of the project file (prior σ " + std::to_string(l.scan_sigma_m) + " m, " +
                              std::to_string(l.scan_sigma_deg) + "°)"};
      continue;
    }
    Rigid3d pose;
    std::string detail;
    if (s->joint && PlaceByTargets(*s, s->scan_targets, k, &pose, &detail)) {
      world_from_scan[k] = pose;
      init[k] = {ScanPlacement::kTargets, detail};
      Log(s, "static scan " + names[k] + " placed by its targets: " + detail);
    }
  }
  // A scan that cannot be placed fails the run when the project registered some scans; when it
  // registered none (the scans came with targets only), the registered reference cloud is held
  // as the world instead, as without targets.
  const bool any_given = std::any_of(l.scans.begin(), l.scans.end(), [](const LidarScanFile& f) { return f.has_pose; });
  const auto unplaced = [&](const std::string& reason) {
    const std::string message = "lidar_static '" + l.id + "': " + reason;
    if (any_given) throw AdjustFailure(AdjustStatus::kFailed, message);
    s->warnings.push_back(message + "; the scans are not adjusted (the registered reference cloud is used)");
    s->scan_targets.clear();
  };
  for (size_t k = 0; k < l.scans.size(); ++k) {
    if (world_from_scan[k]) continue;
    // Feature registration (register-cloud's pipeline) to the scans placed so far, in the world frame,
    // with the scanners' positions for the visibility test.
    registration::CloudRegistrationOptions options;
    options.gravity_aligned = l.scans_levelled;
    options.source_viewpoints = {Eigen::Vector3d::Zero()};
    io::PointCloud target;
    std::string placed;
    constexpr size_t kScanCap = 1000000;
    for (size_t j = 0; j < l.scans.size(); ++j) {
      if (!world_from_scan[j]) continue;
      const io::PointCloud part = ReadThinned(l.scans[j].file, kScanCap);
      for (const Eigen::Vector3d& p : part.points) target.points.push_back(*world_from_scan[j] * p);
      options.target_viewpoints.push_back(world_from_scan[j]->translation);
      placed += (placed.empty() ? "" : ", ") + names[j];
    }
    if (target.points.empty()) {
      return unplaced("scan " + names[k] + " cannot be placed: no scan has world_from_scan and it has fewer than 3 usable "
                      "surveyed targets (in a line counts as fewer)");
    }
    const io::PointCloud source = ReadThinned(l.scans[k].file, kScanCap);
    if (source.points.empty()) throw InputError::Message(l.scans[k].file, "the scan has no points (sensor '" + l.id + "')");
    Log(s, "static scan " + names[k] + ": feature registration to " + placed + " (" + std::to_string(source.points.size()) +
               " and " + std::to_string(target.points.size()) + " points" + (l.scans_levelled ? ", levelled" : "") + ")");
    const registration::CloudRegistrationResult r = registration::RegisterClouds(source, target, options);
    if (!r.ok()) {
      return unplaced("scan " + names[k] + " could not be registered to " + placed + ": " + r.reason +
                      " — give its world_from_scan (even a rough one) or measure 3 surveyed targets in it");
    }
    world_from_scan[k] = Rigid3d::FromMatrix(r.target_from_source.topRows<3>());
    std::ostringstream d;
    d << r.descriptor << " descriptors, to " << placed << ": fitness " << r.fitness << ", inlier RMSE "
      << r.inlier_rmse << " m, resolved to " << r.resolution_m << " m, confidence " << r.confidence << ", "
      << r.total_seconds() << " s";
    init[k] = {ScanPlacement::kFeatureRegistration, d.str()};
    Log(s, "static scan " + names[k] + ": " + d.str());
  }
  for (size_t k = 0; k < l.scans.size(); ++k) {
    ScanBlock scan;
    scan.file = l.scans[k].file;
    scan.name = names[k];
    scan.surface = std::make_unique<LidarSurface>(scan.file, roi_min, roi_max, 1.0, *world_from_scan[k]);
    if (scan.surface->num_read() == 0) {
      throw InputError::Message(scan.file, "the scan has no points (sensor '" + l.id + "')");
    }
    scan.prior = world_from_scan[k]->Inverse();
    scan.has_prior = l.scans[k].has_pose && !l.scans[k].approximate;
    scan.initialisation = init[k];
    scan.sample = scan.surface->Sample(static_cast<size_t>(l.scan_points));
    Log(s, "static scan " + scan.name + ": " + std::to_string(scan.surface->num_read()) + " points read, " +
               std::to_string(scan.surface->size()) + " near the photo block kept, " +
               std::to_string(scan.sample.size()) + " sampled for scan-to-scan");
    s->scene.AddScan(ScanId(s->scans.size()), scan.prior);
    s->scans.push_back(std::move(scan));
  }
}

bool FitSurfacePlane(const JointState& s, const Eigen::Vector3d& world, double gate, double sigma, SurfacePlane* plane) {
  Eigen::Vector3d n, c;
  double roughness = 0.0;
  if (s.scans.empty()) {
    if (!s.surface->FitPlane(world, gate, 12, &n, &c, &roughness)) return false;
    plane->normal = n;
    plane->point = c;
    plane->sigma_m = std::hypot(sigma, roughness);
    plane->scan = -1;
    return true;
  }
  // The scan whose scanner is nearest (the smallest footprint and range noise) among those
  // with a plane there.
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < s.scans.size(); ++k) {
    const Eigen::Vector3d in_scan = s.scene.Scan(ScanId(k)) * world;
    if (in_scan.norm() >= best || !s.scans[k].surface->FitPlane(in_scan, gate, 12, &n, &c, &roughness)) continue;
    best = in_scan.norm();
    plane->normal = n;
    plane->point = c;
    plane->sigma_m = std::hypot(sigma, roughness);
    plane->scan = static_cast<int>(k);
  }
  return std::isfinite(best);
}

size_t AssociateScans(JointState* s, double gate) {
  s->scan_pairs.clear();
  const LidarStatic& l = s->project->lidar_static.front();
  // Both points carry range noise: σ = √2·σ_range, plus the target patch's roughness.
  const double sigma = std::sqrt(2.0) * l.range_sigma_m;
  for (size_t i = 0; i < s->scans.size(); ++i) {
    const Rigid3d world_from_scan = s->scene.Scan(ScanId(i)).Inverse();
    for (size_t j = 0; j < s->scans.size(); ++j) {
      if (i == j) continue;
      for (const Eigen::Vector3d& p : s->scans[i].sample) {
        const Eigen::Vector3d in_to = s->scene.Scan(ScanId(j)) * (world_from_scan * p);
        Eigen::Vector3d n, c;
        double roughness = 0.0;
        if (!s->scans[j].surface->FitPlane(in_to, gate, 12, &n, &c, &roughness)) continue;
        ScanPairPoint pair;
        pair.from = i;
        pair.to = j;
        pair.point = p;
        pair.normal = n;
        pair.plane_point = c;
        pair.sigma_m = std::hypot(sigma, roughness);
        s->scan_pairs.push_back(pair);
      }
    }
  }
  return s->scan_pairs.size();
}

}  // namespace mmba::adjust::internal
