// The survey of mmba::sim::Simulate: the total-station network (survey/network.xml and its
// truth), GNSS control marks measured by RTK, and the vehicle's GNSS/INS trajectory with its
// true twin.

#include <cmath>
#include <iomanip>
#include <sstream>

#include "mmba/sim/survey.h"
#include "sim/simulate_internal.h"

namespace mmba::sim::internal {
namespace {

using Eigen::Vector3d;

// The network's points, setups and observations as truth.json's "survey".
json NetworkTruth(const SurveyNetwork& network) {
  json points = json::array();
  for (const SurveyPoint& p : network.points) {
    points.push_back({{"id", p.id}, {"kind", p.kind}, {"fixed", p.fixed}, {"point_in_world", VecJson(p.point_in_world)}});
  }
  json setups = json::array();
  for (const TotalStationSetup& s : network.setups) {
    setups.push_back({{"point", s.point_id}, {"instrument_height_m", s.instrument_height_m},
                      {"orientation_gon", s.orientation_gon}});
  }
  json observations = json::array();
  for (const TsObservation& ob : network.observations) {
    observations.push_back({{"from", ob.from}, {"to", ob.to},
                            {"kind", ob.kind == TsObservationKind::kDirection ? "direction"
                                     : ob.kind == TsObservationKind::kZenithAngle ? "z-angle" : "s-distance"},
                            {"value", ob.value}, {"true_value", ob.true_value}, {"sigma", ob.sigma},
                            {"target_height_m", ob.target_height_m}});
  }
  return {{"points", points}, {"setups", setups}, {"observations", observations}};
}

// gnss.csv (control marks: N(0, σ) per axis; trajectory rows at the INS positions),
// trajectory_ins.csv and truth/trajectory_true.csv. Returns the rows of gnss.csv.
size_t WriteGnss(const Context& c, const SurveyNetwork& network, const Trajectory& trajectory) {
  const SimulateOptions& o = c.options;
  Rng rng(o.seed, 0x6755);
  std::ostringstream csv;
  csv << "# mmba simulate GNSS: WGS84 latitude/longitude (deg), ellipsoidal height (m), 1-sigma (m)\n";
  csv << "id,kind,time_s,latitude_deg,longitude_deg,height_m,sigma_east_m,sigma_north_m,sigma_up_m\n";
  csv << std::setprecision(10);
  size_t rows = 0;
  for (const SurveyPoint& p : network.points) {
    if (!p.fixed) continue;
    const Vector3d measured = p.point_in_world + Vector3d(rng.Normal(o.gnss.control_sigma_horizontal_m),
                                                          rng.Normal(o.gnss.control_sigma_horizontal_m),
                                                          rng.Normal(o.gnss.control_sigma_vertical_m));
    const geodesy::Geodetic g = c.plane.GeodeticFromEnu(measured);
    csv << p.id << ",control,," << g.latitude_deg << "," << g.longitude_deg << "," << g.height_m << ","
        << o.gnss.control_sigma_horizontal_m << "," << o.gnss.control_sigma_horizontal_m << ","
        << o.gnss.control_sigma_vertical_m << "\n";
    ++rows;
  }
  std::ostringstream ins, true_csv;
  ins << "# GNSS/INS trajectory of the vehicle body (x forward, y left, z up) in the world ENU frame\n"
         "time_s,x_east_m,y_north_m,z_up_m,qw,qx,qy,qz\n" << std::setprecision(10);
  true_csv << ins.str();
  // Rows up to (at least) the end of the drive: every LiDAR point time lies within them.
  const int samples = static_cast<int>(std::ceil(trajectory.duration_s() * o.gnss.trajectory_rate_hz - 1e-9)) + 1;
  for (int i = 0; i < samples; ++i) {
    const double t = i / o.gnss.trajectory_rate_hz;
    const Rigid3d est = trajectory.WorldFromBodyIns(t);
    const Rigid3d tru = trajectory.WorldFromBodyTrue(t);
    const geodesy::Geodetic g = c.plane.GeodeticFromEnu(est.translation);
    csv << "T" << i << ",trajectory," << t << "," << g.latitude_deg << "," << g.longitude_deg << ","
        << g.height_m << ",0.05,0.05,0.08\n";
    ++rows;
    for (auto [stream, pose] : {std::pair<std::ostringstream*, Rigid3d>{&ins, est}, {&true_csv, tru}}) {
      *stream << t << "," << pose.translation.x() << "," << pose.translation.y() << "," << pose.translation.z()
              << "," << pose.rotation.w() << "," << pose.rotation.x() << "," << pose.rotation.y() << ","
              << pose.rotation.z() << "\n";
    }
  }
  WriteText(c.out / "gnss.csv", csv.str());
  WriteText(c.out / "trajectory_ins.csv", ins.str());
  WriteText(c.out / "truth" / "trajectory_true.csv", true_csv.str());
  return rows;
}

}  // namespace

void SimulateSurvey(Context* c, const Trajectory& trajectory) {
  const SimulateOptions& o = c->options;
  const SurveyNetwork network = SimulateTotalStation(c->caster, c->scene, c->plane, o.total_station, o.seed);
  WriteGamaLocalXml(network,
                    "mmba simulate: scene " + c->scene.name + ", seed " + std::to_string(o.seed) +
                        ". x = north, y = east, z = up of the local tangent plane at the project origin "
                        "(project.yaml); adj points carry approximate coordinates.",
                    (c->out / "survey" / "network.xml").string());
  c->result.ts_setups = network.setups.size();
  c->result.ts_observations = network.observations.size();
  c->truth["survey"] = NetworkTruth(network);
  c->result.gnss_rows = WriteGnss(*c, network, trajectory);
  c->project_sensors << "  - id: total_station\n    type: total_station\n    file: survey/network.xml\n"
                        "  - id: gnss\n    type: gnss\n    file: gnss.csv\n";
}

}  // namespace mmba::sim::internal
