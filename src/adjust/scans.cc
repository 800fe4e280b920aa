// Static LiDAR scans adjusted on their own: one scan_from_world block per scan, its
// registration as a prior, scan-to-scan point-to-plane, tie points on each scan's surface.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;

void LoadScans(JointState* s, const Eigen::Vector3d& roi_min, const Eigen::Vector3d& roi_max) {
  const LidarStatic& l = s->project->lidar_static.front();
  if (!l.AdjustsScans()) return;
  for (const LidarScanFile& file : l.scans) {
    ScanBlock scan;
    scan.file = file.file;
    scan.name = fs::path(file.file).stem().string();
    scan.surface = std::make_unique<LidarSurface>(file.file, roi_min, roi_max, 1.0, file.world_from_scan);
    if (scan.surface->num_read() == 0) {
      throw InputError::Message(file.file, "the scan has no points (sensor '" + l.id + "')");
    }
    scan.prior = file.world_from_scan.Inverse();
    scan.sample = scan.surface->Sample(static_cast<size_t>(l.scan_points));
    s->log.push_back("static scan " + scan.name + ": " + std::to_string(scan.surface->num_read()) + " points read, " +
                     std::to_string(scan.surface->size()) + " near the photo block kept, " +
                     std::to_string(scan.sample.size()) + " sampled for scan-to-scan");
    spdlog::info("adjust: {}", s->log.back());
    s->scan_from_world.push_back(scan.prior);
    s->scans.push_back(std::move(scan));
  }
  if (l.targets.empty()) return;
  if (!s->joint) {
    s->warnings.push_back("lidar_static '" + l.id + "': targets " + l.targets + " not used (no total_station network)");
    return;
  }
  const io::CsvTable table = io::CsvTable::Read(l.targets, {"scan", "point_id", "x_m", "y_m", "z_m", "sigma_m"});
  size_t skipped = 0;
  for (const io::CsvTable::Row& row : table.rows()) {
    const std::string scan_name = table.String(row, "scan");
    const auto scan = std::find_if(s->scans.begin(), s->scans.end(), [&](const ScanBlock& b) { return b.name == scan_name; });
    if (scan == s->scans.end()) table.Fail(row, "scan", scan_name, "the name (file stem) of one of the lidar_static scans");
    ScanTarget t;
    t.scan = static_cast<size_t>(scan - s->scans.begin());
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
  s->log.push_back("LiDAR targets " + l.targets + ": " + std::to_string(s->scan_targets.size()) + " measurements used (" +
                   std::to_string(skipped) + " of check points or of points without total-station observations left out)");
  spdlog::info("adjust: {}", s->log.back());
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
    const Eigen::Vector3d in_scan = s.scan_from_world[k] * world;
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
    const Rigid3d world_from_scan = s->scan_from_world[i].Inverse();
    for (size_t j = 0; j < s->scans.size(); ++j) {
      if (i == j) continue;
      for (const Eigen::Vector3d& p : s->scans[i].sample) {
        const Eigen::Vector3d in_to = s->scan_from_world[j] * (world_from_scan * p);
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
