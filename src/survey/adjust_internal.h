#pragma once

// Small geometric helpers of the survey adjustment shared by its units (approximations,
// revision of observations, the solve). Private to mmba_survey.

#include <cmath>
#include <string>
#include <vector>

#include "mmba/survey/network.h"

namespace mmba::survey::internal {

inline bool NeedsXy(ObsKind kind) {
  return kind != ObsKind::kHeightDiff && kind != ObsKind::kCoordZ && kind != ObsKind::kVectorZ;
}
inline bool NeedsZ(ObsKind kind) {
  return kind == ObsKind::kSlopeDistance || kind == ObsKind::kZenithAngle ||
         kind == ObsKind::kHeightDiff || kind == ObsKind::kCoordZ || kind == ObsKind::kVectorZ;
}

inline std::vector<std::string> PointsOf(const Observation& o) {
  std::vector<std::string> ids = {o.from};
  if (!o.to.empty()) ids.push_back(o.to);
  if (!o.fs.empty()) ids.push_back(o.fs);
  return ids;
}

inline double Bearing(const SurveyPoint& a, const SurveyPoint& b) {
  return std::atan2(b.coords.x() - a.coords.x(), b.coords.y() - a.coords.y());
}

inline double Wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

/// Circular mean of bearing − direction over the set's directions to known points.
inline bool EstimateOrientation(SurveyNetwork* net, Cluster* cluster) {
  if (cluster->type != Cluster::Type::kStandpoint) return false;
  const SurveyPoint* station = net->Find(cluster->station);
  if (station == nullptr || !station->has_xy) return false;
  double s = 0.0, c = 0.0;
  int count = 0;
  for (const Observation& o : cluster->observations) {
    if (o.kind != ObsKind::kDirection || !o.active) continue;
    const SurveyPoint* target = net->Find(o.to);
    if (!target->has_xy) continue;
    const double w = Bearing(*station, *target) - o.value;
    s += std::sin(w);
    c += std::cos(w);
    ++count;
  }
  if (count == 0) return false;
  cluster->orientation = std::atan2(s, c);
  return true;
}

}  // namespace mmba::survey::internal
