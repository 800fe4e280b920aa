// The mobile LiDAR on the vehicle: its factor groups (the corrected trajectory, its points on
// the static surface, the camera–LiDAR extrinsic and the MI calibration) and parameters, and
// its outputs (the extrinsic, the trajectory corrections, the corrected and coloured cloud, the
// error map). Loading and association are mobile.cc, the groups' residuals mobile_groups.cc.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "../las_output.h"
#include "../output_support.h"
#include "blocks.h"
#include "mmba/core/atomic_file.h"
#include "mmba/io_cloud/point_cloud.h"

namespace mmba::adjust::internal {

using json = nlohmann::json;

void AddMobileGroups(JointState* s, const GroupWeights& w) {
  MobileBlock& m = *s->mobile;
  const LidarMobile& mc = *m.config;
  std::vector<TrajectoryNode>* nodes = &s->scene.trajectory_nodes();
  Rigid3d* vehicle_from_lidar = &s->scene.Mount(m.mount);
  s->builder->AddGroup(std::make_unique<TrajectoryPriorGroup>(nodes, w.Factor(kTrajectoryPrior) * mc.trajectory_sigma_m,
                                                              w.Factor(kTrajectoryPrior) * mc.trajectory_sigma_deg * M_PI / 180.0,
                                                              mc.trajectory_correlation_s, mc.loss, kTrajectoryPrior))
      .set_role(FactorRole::kPrior);
  if (nodes->size() > 2 && (mc.smoothness_sigma_m > 0 || mc.smoothness_sigma_deg > 0)) {
    s->builder->AddGroup(std::make_unique<TrajectorySmoothnessGroup>(nodes, mc.smoothness_sigma_m,
                                                                     mc.smoothness_sigma_deg * M_PI / 180.0, kSmoothness))
        .set_role(FactorRole::kConstraint);
  }
  if (!m.points.empty()) {
    s->builder->AddGroup(std::make_unique<MobileLidarGroup>(w.Scaled(kMobile, m.points), nodes, vehicle_from_lidar,
                                                            m.body_from_vehicle, mc.loss, kMobile));
  }
  if (m.with_rig && s->rig && !s->rig->mi_mobile.empty()) {
    s->builder->AddGroup(std::make_unique<MobileMiPriorGroup>(
        w.Kept(kRigMiMobile, s->rig->mi_mobile), nodes, vehicle_from_lidar, m.body_from_vehicle,
        m.body_from_lidar_nominal, w.Factor(kRigMiMobile) * w.Factor(kRigMiMobile), s->rig->config->loss, kRigMiMobile))
        .set_role(FactorRole::kPrior);
  }
  if (m.with_rig && !m.mi_extrinsic.empty()) {
    std::vector<MiResult> mi = m.mi_extrinsic;
    for (MiResult& r : mi) r.pose = vehicle_from_lidar;
    s->builder->AddGroup(std::make_unique<MiPriorGroup>(w.Kept(kMiExtrinsic, mi), w.Factor(kMiExtrinsic) * w.Factor(kMiExtrinsic),
                                                        mc.loss, kMiExtrinsic)).set_role(FactorRole::kPrior);
  }
  if (m.with_rig && mc.extrinsic == PoseTreatment::kWeighted) {
    s->builder->AddGroup(std::make_unique<PosePriorGroup>(
        std::vector<Rigid3d*>{vehicle_from_lidar}, std::vector<Rigid3d>{m.vehicle_from_lidar_initial},
        w.Factor(kExtrinsicPrior) * mc.extrinsic_sigma_m, w.Factor(kExtrinsicPrior) * mc.extrinsic_sigma_deg * M_PI / 180.0,
        LossOptions(), kExtrinsicPrior)).set_role(FactorRole::kPrior);
  }
  if (!m.with_rig || mc.extrinsic == PoseTreatment::kFixed) s->builder->parameter_options().constant_mounts.insert(m.mount);
}

std::string DescribeMobileObservation(const JointState& s, const std::string& name, size_t index) {
  if (!s.mobile) return "";
  if (name == kMiExtrinsic) return "MI rig calibration rig_from_lidar (" + s.mobile->mi_extrinsic[index].source + ")";
  if (name == kMobile) {
    const MobilePoint& p = s.mobile->points[index];
    return "mobile LiDAR point " + std::to_string(p.source) + " of " + s.mobile->config->cloud + " (t = " +
           std::to_string(p.time_s) + " s)";
  }
  if (name == kTrajectoryPrior) return "GNSS/INS prior at t = " + std::to_string(s.scene.trajectory_nodes()[index].time_s) + " s";
  return "";
}

std::string MobileOverlapFailure(const JointState& s, size_t on_surface, double gate) {
  // A units mistake in the trajectory and the cloud: the sample, scaled to metres about the
  // world origin, would lie on the static surface.
  const MobileBlock& m = *s.mobile;
  const double sigma = std::hypot(m.config->range_sigma_m, m.config->surface_sigma_m);
  std::string hint;
  size_t best = on_surface;
  for (const auto& [scale, unit] : {std::pair<double, const char*>{0.001, "millimetres"}, {0.01, "centimetres"},
                                    {0.3048, "feet (international or US survey)"}}) {
    size_t on = 0;
    for (size_t i = 0; i < m.sample.size(); ++i) {
      SurfacePlane plane;
      const Eigen::Vector3d delivered = m.sample_ins[i] * (m.body_from_lidar_nominal * m.sample_lidar[i]);
      on += FitSurfacePlane(s, scale * delivered, gate, sigma, &plane) ? 1 : 0;
    }
    if (on >= 100 && on > 10 * best) {
      best = on;
      hint = std::string(" (") + m.config->cloud + " with " + m.config->trajectory + ": its coordinates look like " + unit +
             ": scaled to metres, " + std::to_string(on) + " of the points would lie on the surface)";
    }
  }
  return "lidar_mobile '" + m.config->id + "': only " + std::to_string(on_surface) + " of its points lie within " +
         std::to_string(gate) + " m of the static LiDAR surface: no overlap, or its trajectory/calibration is far off" + hint;
}

namespace {

/// calibration/<id>_camera_lidar.yaml: the extrinsic with σ (and, with a rig, cam_from_lidar of
/// every camera); its calibration table. Returns the extrinsic's change (deg, m).
std::pair<double, double> WriteMobileCalibration(const JointState& s, OutputSink* out) {
  const MobileBlock& m = *s.mobile;
  const Rigid3d& vehicle_from_lidar = s.scene.Mount(m.mount);
  const stats::NetworkStatistics& st = s.statistics;
  const Rigid3d body_from_lidar = m.body_from_vehicle * vehicle_from_lidar;
  // Calibration: the extrinsic with σ (and, with a rig, cam_from_lidar of every camera).
  const Eigen::Matrix<double, 6, 6> cov = ComposedPoseCovariance(st, Rigid3d(), vehicle_from_lidar);
  const auto sigma_text = [](const Eigen::Matrix<double, 6, 6>& c) {
    std::ostringstream o;
    o << std::setprecision(3) << "rotation_sigma_deg: [" << std::sqrt(std::max(0.0, c(0, 0))) * kDeg << ", "
      << std::sqrt(std::max(0.0, c(1, 1))) * kDeg << ", " << std::sqrt(std::max(0.0, c(2, 2))) * kDeg
      << "], tvec_sigma_m: [" << std::sqrt(std::max(0.0, c(3, 3))) << ", " << std::sqrt(std::max(0.0, c(4, 4))) << ", "
      << std::sqrt(std::max(0.0, c(5, 5))) << "]";
    return o.str();
  };
  std::ostringstream yaml;
  yaml << "# mmba adjust: camera-LiDAR calibration of '" << m.config->id << "' (extrinsic "
       << (m.with_rig ? std::string(PoseTreatmentName(m.config->extrinsic)) : std::string("held: no rig on the vehicle"))
       << "); sigma from the adjustment (rotation sigma about the target frame's axes)\n"
       << "body_from_lidar: " << YamlPose(body_from_lidar) << "\n";
  json parameters = json::array();
  const auto [dr, dt] = PoseError(vehicle_from_lidar, m.vehicle_from_lidar_initial);
  if (m.with_rig) {
    yaml << "rig_from_lidar: " << YamlPose(vehicle_from_lidar) << "\nrig_from_lidar_sigma: {" << sigma_text(cov)
         << "}\ncameras:\n";
    for (size_t k = 0; k < s.rig->cameras.size(); ++k) {
      const Rigid3d cam_from_lidar = s.scene.CamFromRig(s.rig->cameras[k]) * vehicle_from_lidar;
      yaml << "  - name: " << s.rig->camera_names[k] << "\n    cam_from_lidar: " << YamlPose(cam_from_lidar)
           << "\n    cam_from_lidar_sigma: {"
           << sigma_text(ComposedPoseCovariance(st, s.scene.CamFromRig(s.rig->cameras[k]), vehicle_from_lidar)) << "}\n";
    }
  }
  parameters.push_back({{"name", "extrinsic rotation change [deg]"}, {"initial", 0.0}, {"adjusted", dr},
                        {"sigma", std::sqrt(std::max(0.0, cov.topLeftCorner<3, 3>().trace())) * kDeg}});
  parameters.push_back({{"name", "extrinsic lever-arm change [m]"}, {"initial", 0.0}, {"adjusted", dt},
                        {"sigma", std::sqrt(std::max(0.0, cov.bottomRightCorner<3, 3>().trace()))}});
  WriteText(out->stage / "calibration" / (m.config->id + "_camera_lidar.yaml"), yaml.str());
  out->calibrations.push_back({{"name", m.config->id + " camera-LiDAR extrinsic"}, {"parameters", parameters}});
  return {dr, dt};
}

/// <id>_trajectory.csv: the trajectory corrections at the nodes with σ and what observes each
/// node. Returns the times of the nodes nothing observes; `worst` = the largest position
/// correction (m).
json WriteMobileTrajectory(const JointState& s, OutputSink* out, double* worst_correction) {
  const MobileBlock& m = *s.mobile;
  const std::vector<TrajectoryNode>& nodes = s.scene.trajectory_nodes();
  const stats::NetworkStatistics& st = s.statistics;
  // The trajectory corrections at the nodes, with σ.
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(*s.project);
  std::ostringstream trajectory;
  trajectory << "time_s,omega_x_deg,omega_y_deg,omega_z_deg,delta_east_m,delta_north_m,delta_up_m,sigma_omega_deg,"
                "sigma_delta_m,east_m,north_m,up_m,points,rig_frames"
             << (crs ? CrsColumns(crs->crs()) : "") << "\n";
  // What observes each node: the mobile points on the static surface and the rig frames whose
  // time falls in the node's two intervals. A node with neither follows the GNSS/INS prior's
  // model alone (extrapolated from its neighbours).
  std::vector<size_t> node_points(nodes.size(), 0), node_frames(nodes.size(), 0);
  const auto touch = [&](const NodeWeight& w, std::vector<size_t>* count) {
    if (w.alpha < 1.0) ++(*count)[w.node];
    if (w.alpha > 0.0 && w.node + 1 < count->size()) ++(*count)[w.node + 1];
  };
  for (const MobilePoint& p : m.points) touch(p.weight, &node_points);
  for (const FrameOnTrajectory& f : m.frames) touch(f.weight, &node_frames);
  json unobserved = json::array();
  double worst = 0.0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const TrajectoryNode& node = nodes[i];
    if (node_points[i] == 0 && node_frames[i] == 0) unobserved.push_back(node.time_s);
    double var_omega = 0.0, var_delta = 0.0;
    for (int k = 0; k < 3; ++k) {
      var_omega += st.Covariance(node.correction, k, node.correction, k);
      var_delta += st.Covariance(node.correction, 3 + k, node.correction, 3 + k);
    }
    const Rigid3d corrected = CorrectedPose(nodes, WeightAt(nodes, node.time_s), InterpolateTrajectory(m.trajectory, node.time_s));
    trajectory << std::setprecision(10) << node.time_s << std::setprecision(6);
    for (int k = 0; k < 3; ++k) trajectory << "," << node.correction[k] * kDeg;
    for (int k = 0; k < 3; ++k) trajectory << "," << node.correction[3 + k];
    trajectory << "," << std::sqrt(std::max(0.0, var_omega)) * kDeg << "," << std::sqrt(std::max(0.0, var_delta))
               << std::setprecision(12) << "," << corrected.translation.x() << "," << corrected.translation.y() << ","
               << corrected.translation.z() << "," << node_points[i] << "," << node_frames[i]
               << (crs ? CrsValues(*crs, corrected.translation) : "") << "\n";
    worst = std::max(worst, Eigen::Vector3d(node.correction[3], node.correction[4], node.correction[5]).norm());
  }
  WriteText(out->stage / (m.config->id + "_trajectory.csv"), trajectory.str());
  *worst_correction = worst;
  return unobserved;
}

/// <id>_corrected.ply and .las: the whole delivered cloud re-georeferenced with the corrected trajectory
/// and extrinsic, coloured from the adjusted rig images and photos where seen (colourise.cc: a
/// first pass builds the images' z-buffers from the cloud, the second colours). Streamed: one
/// chunk in memory at a time.
void WriteCorrectedCloud(const JointState& s, int num_threads, OutputSink* out) {
  const MobileBlock& m = *s.mobile;
  const Rigid3d& vehicle_from_lidar = s.scene.Mount(m.mount);
  const std::vector<TrajectoryNode>& nodes = s.scene.trajectory_nodes();
  const Rigid3d body_from_lidar = m.body_from_vehicle * vehicle_from_lidar;
  const Rigid3d lidar_from_body_nominal = m.body_from_lidar_nominal.Inverse();
  const auto correct = [&](const io::PointCloud& chunk, io::PointCloud* corrected) {
    corrected->points.resize(chunk.size());
    corrected->intensity = chunk.intensity;
    corrected->time = chunk.time;
    for (size_t i = 0; i < chunk.size(); ++i) {
      const Rigid3d ins = InterpolateTrajectory(m.trajectory, chunk.time[i]);
      const Eigen::Vector3d in_lidar = lidar_from_body_nominal * (ins.Inverse() * chunk.points[i]);
      corrected->points[i] = CorrectedPose(nodes, WeightAt(nodes, chunk.time[i]), ins) * (body_from_lidar * in_lidar);
    }
  };
  MobileColouring colouring(s, num_threads);
  if (colouring.active()) {
    io::PointCloud corrected;
    io::StreamPointCloud(m.config->cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t, size_t) {
      correct(chunk, &corrected);
      colouring.AddDepths(corrected);
    });
  }
  // The PLY and the LAS (in the output CRS) from one pass over the delivered cloud.
  const LasOutputFrame las_frame(s);
  WriteFileAtomically(LasBeside(out->stage / (m.config->id + "_corrected.ply")), [&](std::ostream& las) {
    std::optional<io::LasStreamWriter> las_writer;
    WriteFileAtomically(out->stage / (m.config->id + "_corrected.ply"), [&](std::ostream& ply) {
      io::PointCloud corrected;
      io::StreamPointCloud(m.config->cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t first, size_t total) {
        correct(chunk, &corrected);
        colouring.Colour(&corrected);
        if (first == 0) io::WritePlyHeader(ply, total, corrected);
        io::AppendPlyRecords(ply, corrected);
        const io::PointCloud in_crs = las_frame.FromWorld(corrected);
        if (!las_writer) las_writer.emplace(&las, in_crs, las_frame.Options());
        las_writer->Append(in_crs);
      });
    }, /*binary=*/true);
    if (!las_writer) las_writer.emplace(&las, io::PointCloud(), las_frame.Options());
    las_writer->Finish();
  }, /*binary=*/true);
  if (colouring.active()) (*out->report)["mobile_lidar_coloured"] = colouring.Report(m.config->id + "_corrected.ply");
}

}  // namespace

void WriteMobileOutputs(JointState& s, int num_threads, OutputSink* out) {
  const MobileBlock& m = *s.mobile;
  const Rigid3d& vehicle_from_lidar = s.scene.Mount(m.mount);
  const std::vector<TrajectoryNode>& nodes = s.scene.trajectory_nodes();
  const Rigid3d body_from_lidar = m.body_from_vehicle * vehicle_from_lidar;
  const auto [dr, dt] = WriteMobileCalibration(s, out);
  double worst = 0.0;
  const json unobserved = WriteMobileTrajectory(s, out, &worst);
  WriteCorrectedCloud(s, num_threads, out);
  // The error map of the points used (intensity = signed distance to the static surface).
  io::PointCloud error_map;
  for (const MobilePoint& p : m.points) {
    const Eigen::Vector3d world = CorrectedPose(nodes, p.weight, p.ins) * (body_from_lidar * p.point_lidar);
    error_map.points.push_back(world);
    const Eigen::Vector3d on_plane = p.scan < 0 ? world : s.scene.Scan(ScanId(p.scan)) * world;
    error_map.intensity.push_back(static_cast<float>(p.normal.dot(on_plane - p.plane_point)));
  }
  io::WritePly(error_map, (out->stage / ("error_map_" + m.config->id + ".ply")).string());
  WriteErrorMapLas(s, error_map, out->stage / ("error_map_" + m.config->id + ".ply"), "signed distance to static LiDAR");
  (*out->report)["mobile_lidar"] = {{"sensor", m.config->id}, {"points", m.num_points}, {"used", m.sample.size()},
                                    {"on_surface", m.points.size()}, {"nodes", nodes.size()},
                                    {"max_position_correction_m", worst},
                                    {"extrinsic", m.with_rig ? PoseTreatmentName(m.config->extrinsic) : "held"},
                                    {"extrinsic_rotation_change_deg", dr}, {"extrinsic_translation_change_m", dt},
                                    {"unobserved_node_times_s", unobserved}};
  if (!unobserved.empty()) {
    s.warnings.push_back("lidar_mobile '" + m.config->id + "': " + std::to_string(unobserved.size()) + " of " +
                         std::to_string(nodes.size()) + " trajectory nodes (t = " + unobserved.front().dump() + " to " +
                         unobserved.back().dump() + " s) have no mobile point on the static surface and no rig frame: "
                         "their corrections are the GNSS/INS prior's extrapolation, see the points and rig_frames "
                         "columns of " + m.config->id + "_trajectory.csv");
  }
}

}  // namespace mmba::adjust::internal
