// The static LiDAR: its reference cloud around the photo block (the surface the tie points and
// the mobile LiDAR are tied to) and the scans adjusted on their own, their factor groups and
// outputs. Loading and associating the scans is scans.cc, the surface lidar_surface.cc.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "../output_support.h"
#include "blocks.h"
#include "mmba/core/error.h"

namespace mmba::adjust::internal {

using json = nlohmann::json;

void LoadLidar(JointState* s) {
  if (s->project->lidar_static.empty() || !s->photos) return;
  const LidarStatic& l = s->project->lidar_static.front();
  if (s->project->lidar_static.size() > 1) {
    s->warnings.push_back("only the first lidar_static sensor's reference cloud ties the photos in this version");
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& [id, p] : s->scene.points()) {
    if (id.value >= kCheckPointIdBase) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  s->surface = std::make_unique<LidarSurface>(l.reference_cloud, lo, hi, 1.0);
  if (s->surface->num_read() == 0) {
    throw InputError::Message(l.reference_cloud, "the reference cloud has no points (sensor '" + l.id + "')");
  }
  Note(s, "LiDAR reference " + l.reference_cloud + ": " + std::to_string(s->surface->num_read()) +
                   " points read, " + std::to_string(s->surface->size()) + " near the photo block kept");
  if (s->surface->size() < 100) {
    const std::string hint = CoordinateHint(s->surface->read_min(), s->surface->read_max(), lo, hi);
    throw AdjustFailure(AdjustStatus::kFailed, "lidar_static '" + l.id + "': the reference cloud " + l.reference_cloud +
                                      " does not overlap the photo block (" + std::to_string(s->surface->size()) +
                                      " points within 1 m of its tie points)" + (hint.empty() ? "" : ": " + hint));
  }
  if (l.AdjustsScans()) {
    LoadScans(s, lo, hi);
  } else if (!l.scans.empty()) {
    s->warnings.push_back("lidar_static '" + l.id + "': the " + std::to_string(l.scans.size()) +
                          " scans carry no world_from_scan and no targets are given: not adjusted (the registered "
                          "reference cloud is used)");
  }
}

size_t AssociateTiePoints(JointState* s, double gate) {
  const LidarStatic& l = s->project->lidar_static.front();
  const double sigma = std::sqrt(l.surface_sigma_m * l.surface_sigma_m + l.range_sigma_m * l.range_sigma_m);
  s->planes.clear();
  for (const auto& [id, p] : s->scene.points()) {
    if (id.value >= kCheckPointIdBase) continue;
    SurfacePlane plane;
    plane.point3D_id = id;
    if (FitSurfacePlane(*s, p, gate, sigma, &plane)) s->planes.push_back(plane);
  }
  std::sort(s->planes.begin(), s->planes.end(),
            [](const SurfacePlane& a, const SurfacePlane& b) { return a.point3D_id < b.point3D_id; });
  return s->planes.size();
}

void AddStaticLidarGroups(JointState* s, const GroupWeights& w) {
  const LidarStatic& l = s->project->lidar_static.front();
  if (!s->planes.empty()) {
    s->builder->AddGroup(std::make_unique<LidarSurfaceGroup>(w.Scaled(kLidar, s->planes), l.loss, kLidar));
  }
  if (s->scans.empty()) return;
  if (!s->scan_pairs.empty()) {
    s->builder->AddGroup(std::make_unique<ScanToScanGroup>(w.Scaled(kScanToScan, s->scan_pairs), l.loss, kScanToScan));
  }
  if (!s->scan_targets.empty()) {
    s->builder->AddGroup(std::make_unique<ScanTargetGroup>(&*s->joint, w.Scaled(kScanTargets, s->scan_targets), l.loss,
                                                           kScanTargets));
  }
  std::vector<Rigid3d*> poses;
  std::vector<Rigid3d> priors;
  for (size_t k = 0; k < s->scans.size(); ++k) {
    if (!s->scans[k].has_prior) continue;  // placed by targets or feature registration: no observation
    poses.push_back(&s->scene.Scan(ScanId(k)));
    priors.push_back(s->scans[k].prior);
  }
  if (!poses.empty()) {
    s->builder->AddGroup(std::make_unique<PosePriorGroup>(poses, priors, w.Factor(kScanPrior) * l.scan_sigma_m,
                                                          w.Factor(kScanPrior) * l.scan_sigma_deg * M_PI / 180.0, l.loss,
                                                          kScanPrior)).set_role(FactorRole::kPrior);
  }
}

std::string DescribeStaticLidarObservation(const JointState& s, const std::string& name, size_t index) {
  if (name == kLidar) return "tie point " + std::to_string(s.planes[index].point3D_id.value) + " to the LiDAR surface";
  if (name == kScanToScan) {
    const ScanPairPoint& p = s.scan_pairs[index];
    return "a point of scan " + s.scans[p.from].name + " on scan " + s.scans[p.to].name;
  }
  if (name == kScanPrior) return "registration of scan " + s.scans[index].name;
  if (name == kScanTargets) return "target " + s.scan_targets[index].point_id + " in scan " + s.scans[s.scan_targets[index].scan].name;
  return "";
}

void WriteScanOutputs(const JointState& s, OutputSink* out) {
  const stats::NetworkStatistics& st = s.statistics;
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(*s.project);
  std::ostringstream csv;
  csv << std::setprecision(12)
      << "scan,east_m,north_m,up_m,qw,qx,qy,qz,sigma_east_m,sigma_north_m,sigma_up_m,sigma_rotation_deg,"
         "d_position_m,d_rotation_deg"
      << (crs ? CrsColumns(crs->crs()) : "") << "\n";
  json scans = json::array();
  for (size_t k = 0; k < s.scans.size(); ++k) {
    const Rigid3d& pose = s.scene.Scan(ScanId(k));
    const Eigen::Vector3d centre = CameraCentre(pose);
    const Eigen::Vector3d sigma = CentreCovariance(st, pose).diagonal().cwiseMax(0.0).cwiseSqrt();
    const double* q = pose.rotation.coeffs().data();
    double rotation_variance = 0.0;
    if (st.IsFree(q)) {
      for (int a = 0; a < 3; ++a) rotation_variance += st.Covariance(q, a, q, a);
    }
    const double sigma_rotation = kRotationPerTangent * std::sqrt(std::max(0.0, rotation_variance)) * kDeg;  // of the rotation vector
    const double dp = (centre - CameraCentre(s.scans[k].prior)).norm();
    const double dr = pose.rotation.angularDistance(s.scans[k].prior.rotation) * kDeg;
    csv << s.scans[k].name << "," << centre.x() << "," << centre.y() << "," << centre.z() << "," << pose.rotation.w()
        << "," << pose.rotation.x() << "," << pose.rotation.y() << "," << pose.rotation.z() << "," << sigma.x() << ","
        << sigma.y() << "," << sigma.z() << "," << sigma_rotation << "," << dp << "," << dr
        << (crs ? CrsValues(*crs, centre) : "") << "\n";
    // In the report's calibration tables: the scanner position and the rotation change.
    const Eigen::Vector3d registered = CameraCentre(s.scans[k].prior);
    json parameters = json::array();
    const char* axes[3] = {"scanner east [m]", "scanner north [m]", "scanner up [m]"};
    for (int a = 0; a < 3; ++a) {
      parameters.push_back({{"name", axes[a]}, {"initial", registered[a]}, {"adjusted", centre[a]}, {"sigma", sigma[a]}});
    }
    parameters.push_back({{"name", "rotation change [deg]"}, {"initial", 0.0}, {"adjusted", dr}, {"sigma", sigma_rotation}});
    const ScanInitialisation& init = s.scans[k].initialisation;
    out->calibrations.push_back({{"name", "static scan " + s.scans[k].name + " (world_from_scan; initial = " +
                                         (init.method == ScanPlacement::kGiven ? std::string("the registration") : ScanPlacementName(init.method)) + ")"},
                            {"parameters", parameters}});
    scans.push_back({{"name", s.scans[k].name}, {"file", s.scans[k].file}, {"position_m", Vec(centre)},
                     {"sigma_position_m", Vec(sigma)}, {"sigma_rotation_deg", sigma_rotation},
                     {"position_correction_m", dp}, {"rotation_correction_deg", dr},
                     {"initialisation", ScanPlacementName(init.method)}, {"initialisation_detail", init.detail},
                     {"registration_prior", s.scans[k].has_prior}});
  }
  WriteText(out->stage / "scans.csv", csv.str());
  (*out->report)["static_scans"] = {{"scans", scans}, {"scan_to_scan_pairs", s.scan_pairs.size()}};
}

}  // namespace mmba::adjust::internal
