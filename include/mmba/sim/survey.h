#pragma once

// Simulated total-station network and GNSS control, and the writer of GNU Gama's
// gama-local XML (x = north, y = east, z = up; directions and zenith angles in gon,
// clockwise; angle σ in cc = 1e-4 gon, distance σ in mm) — the conversion from the world
// ENU frame happens here, at the io boundary.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/geodesy/geodesy.h"
#include "mmba/sim/ray_caster.h"
#include "mmba/sim/scenes.h"

namespace mmba::sim {

struct SurveyPoint {
  std::string id;
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();       ///< true
  Eigen::Vector3d approximate_in_world = Eigen::Vector3d::Zero(); ///< written for adj points
  bool fixed = false;        ///< control (coordinates given, fix="xyz")
  std::string kind;          ///< mark | target
};

struct TotalStationSetup {
  std::string point_id;            ///< the mark the instrument stands over
  double instrument_height_m = 0;  ///< above the mark, along the station's plumb line
  double orientation_gon = 0;      ///< azimuth of the horizontal circle's zero (true)
};

enum class TsObservationKind { kDirection, kZenithAngle, kSlopeDistance };

struct TsObservation {
  TsObservationKind kind;
  std::string from, to;
  double value = 0;              ///< gon (angles) or metres (distance)
  double sigma = 0;              ///< cc (angles) or mm (distance)
  double target_height_m = 0;    ///< above `to` along its plumb line
  double true_value = 0;         ///< without noise
};

struct SurveyNetwork {
  std::vector<SurveyPoint> points;
  std::vector<TotalStationSetup> setups;
  std::vector<TsObservation> observations;
  const SurveyPoint* Find(const std::string& id) const;
};

struct TotalStationOptions;

/// Exact direction (gon, clockwise from the orientation zero), zenith angle (gon) and slope
/// distance (m) from the instrument at `mark + h_i·up` to `target + h_t·up`, with the
/// plumb lines (up) and the horizontal plane of the station's own local vertical (Eq. of
/// a local-level frame: the ENU of the ellipsoid normal at the station).
void ComputeTsObservation(const geodesy::LocalTangentPlane& plane,
                          const Eigen::Vector3d& mark_in_world, double instrument_height_m,
                          double orientation_gon, const Eigen::Vector3d& target_in_world,
                          double target_height_m, double* direction_gon, double* zenith_gon,
                          double* slope_distance_m);

/// Sets up the total station on the first marks and observes every visible mark (on a pole)
/// and surface target; the marks not occupied are GNSS control (fixed).
SurveyNetwork SimulateTotalStation(const RayCaster& caster, const SimScene& scene,
                                   const geodesy::LocalTangentPlane& plane,
                                   const TotalStationOptions& options, uint64_t seed);

/// Writes a gama-local input document (atomically).
void WriteGamaLocalXml(const SurveyNetwork& network, const std::string& description,
                       const std::string& path);

}  // namespace mmba::sim
