// The mobile LiDAR of `mmba adjust`: reading the delivered cloud, un-georeferencing a sample
// of its points into the LiDAR frame, placing the trajectory-correction nodes, and tying the
// points to the static LiDAR surface. The factor groups are in mobile_groups.cc.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include <spdlog/spdlog.h>

#include "internal.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/io/camera_yaml.h"

namespace mmba::adjust::internal {

namespace {

/// One streamed pass over the cloud (memory: one chunk and the sample, whatever the cloud's
/// size): checks every point's time against the trajectory, and keeps `points` of them evenly
/// spaced in file order (= time order for a scanner's file), un-georeferenced into the LiDAR
/// frame with the GNSS/INS pose at their time. [*lo, *hi]: the points' time span [s].
void SampleMobileCloud(const LidarMobile& config, double max_range, MobileBlock* m_ptr, double* lo_ptr, double* hi_ptr) {
  MobileBlock& m = *m_ptr;
  double& lo = *lo_ptr;
  double& hi = *hi_ptr;
  const double t0 = m.trajectory.front().first, t1 = m.trajectory.back().first;
  const Rigid3d lidar_from_body = m.body_from_lidar_nominal.Inverse();
  size_t wanted = 0, next = 0;  // next sample: the point index floor(next · total / wanted)
  io::ReadStats stats;
  io::StreamPointCloud(config.cloud, kMobileChunkPoints, [&](const io::PointCloud& chunk, size_t first, size_t total) {
    if (first == 0) wanted = std::min<size_t>(config.points, total);
    if (!chunk.has_time()) {
      throw InputError::Message(config.cloud, "no time per point (PLY property time / gps_time / timestamp, or LAS GPS time); "
                                              "a mobile cloud cannot be re-georeferenced without it");
    }
    for (size_t j = 0; j < chunk.size(); ++j) {
      const size_t i = first + j;
      const double time = chunk.time[j];
      if (time < t0 - 1e-6 || time > t1 + 1e-6) {
        throw InputError::Message(config.cloud, "point " + std::to_string(i) + " has time " + std::to_string(time) +
                                                    " s, outside the trajectory " + config.trajectory + " [" +
                                                    std::to_string(t0) + ", " + std::to_string(t1) + "] s");
      }
      lo = std::min(lo, time);
      hi = std::max(hi, time);
      if (next < wanted && i >= next * total / wanted) {
        // The pick, or the first point after it within max_range_m; picks passed over while
        // looking are skipped (the sample stays evenly spread).
        const Rigid3d ins = InterpolateTrajectory(m.trajectory, time);
        const Eigen::Vector3d in_lidar = lidar_from_body * (ins.Inverse() * chunk.points[j]);
        if (max_range > 0 && in_lidar.norm() > max_range) continue;
        m.sample.push_back(i);
        m.sample_time.push_back(time);
        m.sample_ins.push_back(ins);
        m.sample_lidar.push_back(in_lidar);
        while (next < wanted && next * total / wanted <= i) ++next;
      }
    }
    m.num_points = first + chunk.size();
    if (m.num_points % (20 * kMobileChunkPoints) == 0) {
      spdlog::info("adjust: mobile LiDAR '{}': {} of {} points read", config.id, m.num_points, total);
    }
  }, io::ReadOptions{}, &stats);
  if (m.num_points == 0) throw InputError::Message(config.cloud, "the mobile LiDAR cloud has no points (sensor '" + config.id + "')");
  m.format = stats.format;
}

/// Trajectory-correction nodes every node_spacing_s over [lo, hi] (the sample's and the rig
/// frames' times); each sample point's and rig frame's place between them.
void PlaceTrajectoryNodes(JointState* s, const LidarMobile& config, double lo, double hi, MobileBlock* m_ptr) {
  MobileBlock& m = *m_ptr;
  const int intervals = std::max(1, static_cast<int>(std::ceil((hi - lo) / config.node_spacing_s - 1e-9)));
  std::vector<TrajectoryNode> nodes;
  for (int k = 0; k <= intervals; ++k) {
    TrajectoryNode node;
    node.time_s = lo + (hi - lo) * k / intervals;
    nodes.push_back(node);
  }
  if (hi <= lo) nodes.back().time_s = lo + config.node_spacing_s;
  for (double time : m.sample_time) m.sample_weight.push_back(WeightAt(nodes, time));
  if (m.with_rig) {
    for (size_t f = 0; f < s->rig->frame_times.size(); ++f) {
      const double t = s->rig->frame_times[f];
      m.frames.push_back({f, WeightAt(nodes, t), InterpolateTrajectory(m.trajectory, t)});
    }
  }
  s->scene.SetTrajectoryNodes(std::move(nodes));
}

}  // namespace

void LoadMobile(JointState* s) {
  if (s->project->lidar_mobile.empty()) return;
  const LidarMobile& config = s->project->lidar_mobile.front();
  MobileBlock m;
  m.config = &config;
  // Calibration: the mounting the delivered cloud was georeferenced with.
  m.body_from_lidar_nominal = io::ReadLidarMountYaml(config.calibration);
  m.trajectory = ReadTrajectory(config.trajectory);
  const double max_range = MobileMaxRange(config);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  SampleMobileCloud(config, max_range, &m, &lo, &hi);
  // The vehicle frame: the rig's frame when the rig rides on the same vehicle.
  m.with_rig = !config.rig.empty() && s->rig && s->rig->config->id == config.rig;
  m.body_from_vehicle = m.with_rig ? s->rig->body_from_rig : Rigid3d();
  m.vehicle_from_lidar_initial = m.body_from_vehicle.Inverse() * m.body_from_lidar_nominal;
  s->scene.AddMount(m.mount, m.vehicle_from_lidar_initial);
  if (m.with_rig) {
    for (double t : s->rig->frame_times) {
      lo = std::min(lo, t);
      hi = std::max(hi, t);
    }
  }
  PlaceTrajectoryNodes(s, config, lo, hi, &m);
  s->log.push_back("mobile LiDAR '" + config.id + "': " + std::to_string(m.num_points) + " points (" + m.format + ", streamed" +
                   "), " + std::to_string(m.sample.size()) + " used (" +
                   (max_range > 0 ? fmt::format("within {:.1f} m of the scanner", max_range) +
                                        (config.max_range_m < 0 ? ": first gate / tan(attitude σ)" : "")
                                  : "no range limit") +
                   "); trajectory corrected at " + std::to_string(s->scene.trajectory_nodes().size()) +
                   " nodes over " + std::to_string(hi - lo) + " s" +
                   (m.with_rig ? "; rig '" + config.rig + "' on the same vehicle, camera-LiDAR extrinsic " + PoseTreatmentName(config.extrinsic)
                               : "; no rig on the vehicle: body_from_lidar held at the calibration"));
  spdlog::info("adjust: {}", s->log.back());
  if (!config.rig.empty() && !m.with_rig) {
    s->warnings.push_back("lidar_mobile '" + config.id + "': rig '" + config.rig + "' has no frames loaded; extrinsic held");
  }
  s->mobile = std::move(m);
}

size_t AssociateMobile(JointState* s, double gate) {
  MobileBlock& m = *s->mobile;
  const double sigma = std::hypot(m.config->range_sigma_m, m.config->surface_sigma_m);
  m.points.clear();
  const Rigid3d body_from_lidar = m.body_from_vehicle * s->scene.Mount(m.mount);
  for (size_t k = 0; k < m.sample.size(); ++k) {
    const Rigid3d world_from_body = CorrectedPose(s->scene.trajectory_nodes(), m.sample_weight[k], m.sample_ins[k]);
    const Eigen::Vector3d world = world_from_body * (body_from_lidar * m.sample_lidar[k]);
    SurfacePlane plane;
    if (!FitSurfacePlane(*s, world, gate, sigma, &plane)) continue;
    MobilePoint p;
    p.scan = plane.scan;  // an adjusted scan's plane stays in its frame; its pose is a block
    p.point_lidar = m.sample_lidar[k];
    p.weight = m.sample_weight[k];
    p.ins = m.sample_ins[k];
    p.normal = plane.normal;
    p.plane_point = plane.point;
    p.sigma_m = plane.sigma_m;
    p.source = m.sample[k];
    p.time_s = m.sample_time[k];
    m.points.push_back(p);
  }
  return m.points.size();
}

}  // namespace mmba::adjust::internal
