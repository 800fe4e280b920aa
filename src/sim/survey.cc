#include "mmba/sim/survey.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "mmba/core/atomic_file.h"
#include "mmba/core/xml_escape.h"
#include "mmba/sim/simulate.h"
#include "sim/random_internal.h"

namespace mmba::sim {
namespace {

constexpr double kGonPerRad = 200.0 / M_PI;

double Wrap400(double gon) {
  double g = std::fmod(gon, 400.0);
  if (g < 0) g += 400.0;
  return g;
}

}  // namespace

const SurveyPoint* SurveyNetwork::Find(const std::string& id) const {
  for (const auto& p : points) {
    if (p.id == id) return &p;
  }
  return nullptr;
}

void ComputeTsObservation(const geodesy::LocalTangentPlane& plane,
                          const Eigen::Vector3d& mark_in_world, double instrument_height_m,
                          double orientation_gon, const Eigen::Vector3d& target_in_world,
                          double target_height_m, double* direction_gon, double* zenith_gon,
                          double* slope_distance_m) {
  const Eigen::Matrix3d station_from_world = plane.StationEnuFromWorld(mark_in_world);
  const Eigen::Matrix3d target_from_world = plane.StationEnuFromWorld(target_in_world);
  // Plumb lines: the local up of each point, expressed in the world frame.
  const Eigen::Vector3d up_station = station_from_world.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_target = target_from_world.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d instrument = mark_in_world + instrument_height_m * up_station;
  const Eigen::Vector3d target = target_in_world + target_height_m * up_target;
  const Eigen::Vector3d d = station_from_world * (target - instrument);  // station ENU
  const double azimuth_gon = std::atan2(d.x(), d.y()) * kGonPerRad;    // clockwise from north
  *direction_gon = Wrap400(azimuth_gon - orientation_gon);
  *zenith_gon = std::atan2(std::hypot(d.x(), d.y()), d.z()) * kGonPerRad;
  *slope_distance_m = d.norm();
}

SurveyNetwork SimulateTotalStation(const RayCaster& caster, const SimScene& scene,
                                   const geodesy::LocalTangentPlane& plane,
                                   const TotalStationOptions& options, uint64_t seed) {
  SurveyNetwork network;
  internal::Rng rng(seed, 0x7077A1);
  const int setups = std::min<int>(options.setups, static_cast<int>(scene.marks.size()));
  for (size_t i = 0; i < scene.marks.size(); ++i) {
    SurveyPoint p;
    p.id = scene.marks[i].id;
    p.point_in_world = scene.marks[i].point_in_world;
    p.fixed = static_cast<int>(i) >= setups;
    p.kind = "mark";
    network.points.push_back(p);
  }
  for (const ScenePoint& t : scene.targets) {
    SurveyPoint p;
    p.id = t.id;
    p.point_in_world = t.point_in_world;
    p.kind = "target";
    network.points.push_back(p);
  }
  for (auto& p : network.points) {
    p.approximate_in_world = p.point_in_world;
    if (!p.fixed) {
      for (int k = 0; k < 3; ++k) p.approximate_in_world[k] += rng.Normal(options.approximate_sigma_m);
    }
  }
  for (int s = 0; s < setups; ++s) {
    TotalStationSetup setup;
    setup.point_id = scene.marks[s].id;
    setup.instrument_height_m = options.instrument_height_m + rng.Uniform(-0.1, 0.1);
    setup.orientation_gon = rng.Uniform(0.0, 400.0);
    network.setups.push_back(setup);
    const Eigen::Vector3d mark = scene.marks[s].point_in_world;
    const Eigen::Vector3d instrument = mark + setup.instrument_height_m * Eigen::Vector3d::UnitZ();
    for (const SurveyPoint& p : network.points) {
      if (p.id == setup.point_id) continue;
      const double target_height = p.kind == "mark" ? options.pole_height_m : 0.0;
      const Eigen::Vector3d aim = p.point_in_world + target_height * Eigen::Vector3d::UnitZ();
      // Line of sight: nothing between the instrument and the target (surface targets
      // end on their surface, hence the margin).
      if (!caster.Visible(instrument, aim, 0.01)) continue;
      double direction, zenith, distance;
      ComputeTsObservation(plane, mark, setup.instrument_height_m, setup.orientation_gon,
                           p.point_in_world, target_height, &direction, &zenith, &distance);
      const double distance_sigma_mm =
          options.distance_sigma_mm + options.distance_sigma_ppm * 1e-3 * distance;
      TsObservation o;
      o.from = setup.point_id;
      o.to = p.id;
      o.target_height_m = target_height;
      o.kind = TsObservationKind::kDirection;
      o.true_value = direction;
      o.sigma = options.direction_sigma_cc;
      o.value = Wrap400(direction + rng.Normal(o.sigma * 1e-4));
      network.observations.push_back(o);
      o.kind = TsObservationKind::kZenithAngle;
      o.true_value = zenith;
      o.sigma = options.zenith_sigma_cc;
      o.value = zenith + rng.Normal(o.sigma * 1e-4);
      network.observations.push_back(o);
      o.kind = TsObservationKind::kSlopeDistance;
      o.true_value = distance;
      o.sigma = distance_sigma_mm;
      o.value = distance + rng.Normal(distance_sigma_mm * 1e-3);
      network.observations.push_back(o);
    }
  }
  return network;
}

void WriteGamaLocalXml(const SurveyNetwork& network, const std::string& description,
                       const std::string& path) {
  WriteFileAtomically(path, [&](std::ostream& out) {
    out << "<?xml version=\"1.0\" ?>\n";
    out << "<gama-local xmlns=\"http://www.gnu.org/software/gama/gama-local\">\n";
    out << "<network axes-xy=\"ne\" angles=\"left-handed\">\n\n";
    out << "<description>\n" << XmlEscape(description) << "\n</description>\n\n";
    out << "<parameters sigma-apr=\"10\" conf-pr=\"0.95\" tol-abs=\"1000\" "
           "sigma-act=\"aposteriori\" />\n\n";
    out << "<points-observations>\n\n";
    out << std::fixed;
    for (const SurveyPoint& p : network.points) {
      // x = north, y = east, z = up (world ENU), metres.
      const Eigen::Vector3d& c = p.fixed ? p.point_in_world : p.approximate_in_world;
      out << "<point id=\"" << XmlEscape(p.id) << "\" x=\"" << std::setprecision(4) << c.y()
          << "\" y=\"" << c.x() << "\" z=\"" << c.z() << "\" "
          << (p.fixed ? "fix=\"xyz\"" : "adj=\"xyz\"") << " />\n";
    }
    for (const TotalStationSetup& setup : network.setups) {
      out << "\n<obs from=\"" << XmlEscape(setup.point_id) << "\" from_dh=\""
          << std::setprecision(4) << setup.instrument_height_m << "\">\n";
      for (const TsObservation& o : network.observations) {
        if (o.from != setup.point_id) continue;
        const char* tag = o.kind == TsObservationKind::kDirection     ? "direction"
                          : o.kind == TsObservationKind::kZenithAngle ? "z-angle"
                                                                      : "s-distance";
        out << "   <" << tag << " to=\"" << XmlEscape(o.to) << "\" val=\""
            << std::setprecision(o.kind == TsObservationKind::kSlopeDistance ? 5 : 6) << o.value
            << "\" stdev=\"" << std::setprecision(2) << o.sigma << "\" to_dh=\""
            << std::setprecision(4) << o.target_height_m << "\" />\n";
      }
      out << "</obs>\n";
    }
    out << "\n</points-observations>\n</network>\n</gama-local>\n";
  });
}

}  // namespace mmba::sim
