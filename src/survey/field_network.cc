#include "mmba/survey/field_network.h"

#include <cmath>
#include <map>
#include <optional>

#include "mmba/core/error.h"

namespace mmba::survey {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kCcToRad = kPi / 200.0 * 1e-4;

/// Horizontal distance and height difference (instrument mark to target mark) of `o`.
bool Polar(const ReducedObservation& o, double instrument_height, double* hd, double* dz) {
  if (!o.has_slope) {
    *hd = o.horizontal_m;  // 0 without one
    return false;
  }
  const double zenith = o.has_zenith ? o.zenith_rad : kPi / 2;
  *hd = o.slope_m * std::sin(zenith);
  *dz = o.slope_m * std::cos(zenith) + instrument_height - o.reflector_height_m;
  return o.has_zenith;
}

struct Approximator {
  const FaceReduction& reduction;
  std::map<std::string, Eigen::Vector2d> xy;
  std::map<std::string, double> z;
  std::vector<std::optional<double>> orientation;  // per set: bearing = direction + ω

  explicit Approximator(const FaceReduction& r) : reduction(r), orientation(r.sets.size()) {}

  /// ω of set `k` from its placed targets (station placed); true when set.
  bool Orient(size_t k) {
    const ReducedSet& set = reduction.sets[k];
    double s = 0, c = 0;
    for (const ReducedObservation& o : set.observations) {
      auto it = xy.find(o.target);
      if (!o.has_direction || it == xy.end()) continue;
      const Eigen::Vector2d d = it->second - xy.at(set.station);
      if (d.norm() < 1e-6) continue;
      const double w = std::atan2(d.x(), d.y()) - o.direction_rad;
      s += std::sin(w);
      c += std::cos(w);
    }
    if (s == 0 && c == 0) return false;
    orientation[k] = std::atan2(s, c);
    return true;
  }

  /// Places the station of set `k` from two or more placed targets (2-D Helmert, no scale).
  bool Resect(size_t k) {
    const ReducedSet& set = reduction.sets[k];
    std::vector<Eigen::Vector2d> p, q;
    for (const ReducedObservation& o : set.observations) {
      double hd = 0, dz = 0;
      auto it = xy.find(o.target);
      if (it == xy.end() || !o.has_direction) continue;
      Polar(o, set.instrument_height_m, &hd, &dz);
      if (!(hd > 0)) continue;
      p.emplace_back(hd * std::sin(o.direction_rad), hd * std::cos(o.direction_rad));
      q.push_back(it->second);
    }
    if (p.size() < 2) return false;
    Eigen::Vector2d pc = Eigen::Vector2d::Zero(), qc = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < p.size(); ++i) pc += p[i], qc += q[i];
    pc /= p.size();
    qc /= q.size();
    double cross = 0, dot = 0;
    for (size_t i = 0; i < p.size(); ++i) {
      const Eigen::Vector2d a = p[i] - pc, b = q[i] - qc;
      cross += a.x() * b.y() - a.y() * b.x();
      dot += a.dot(b);
    }
    const double phi = std::atan2(cross, dot);  // counter-clockwise in (E, N)
    const double w = -phi;                       // clockwise bearing offset
    Eigen::Matrix2d m;
    m << std::cos(w), std::sin(w), -std::sin(w), std::cos(w);
    xy[set.station] = qc - m * pc;
    orientation[k] = w;
    return true;
  }

  /// Places unplaced targets of oriented set `k`; heights both ways. True when anything new.
  bool Place(size_t k) {
    const ReducedSet& set = reduction.sets[k];
    bool changed = false;
    for (const ReducedObservation& o : set.observations) {
      double hd = 0, dz = 0;
      const bool has_dz = Polar(o, set.instrument_height_m, &hd, &dz);
      if (orientation[k] && hd > 0 && o.has_direction && !xy.count(o.target)) {
        const double bearing = o.direction_rad + *orientation[k];
        xy[o.target] = xy.at(set.station) + hd * Eigen::Vector2d(std::sin(bearing), std::cos(bearing));
        changed = true;
      }
      if (!has_dz) continue;
      if (z.count(set.station) && !z.count(o.target)) {
        z[o.target] = z.at(set.station) + dz;
        changed = true;
      } else if (!z.count(set.station) && z.count(o.target)) {
        z[set.station] = z.at(o.target) - dz;
        changed = true;
      }
    }
    return changed;
  }

  void Run() {
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t k = 0; k < reduction.sets.size(); ++k) {
        const std::string& station = reduction.sets[k].station;
        if (!xy.count(station) && Resect(k)) changed = true;
        if (xy.count(station) && !orientation[k] && Orient(k)) changed = true;
        if (Place(k)) changed = true;
      }
    }
  }
};

Observation MakeObservation(ObsKind kind, const ReducedSet& set, const ReducedObservation& o,
                            double value, double sigma) {
  Observation obs;
  obs.kind = kind;
  obs.from = set.station;
  obs.to = o.target;
  obs.value = value;
  obs.sigma = sigma;
  obs.from_dh = set.instrument_height_m;
  obs.to_dh = o.reflector_height_m;
  obs.line = o.line;
  return obs;
}

Cluster MakeCluster(const ReducedSet& set, const FaceReductionOptions& options) {
  Cluster cluster;
  cluster.type = Cluster::Type::kStandpoint;
  cluster.station = set.station;
  cluster.line = set.line;
  for (const ReducedObservation& o : set.observations) {
    if (o.has_direction) {
      cluster.observations.push_back(MakeObservation(ObsKind::kDirection, set, o, o.direction_rad,
                                                     options.direction_sigma_cc * kCcToRad));
    }
    if (o.has_slope) {
      const double sigma_mm = options.distance_sigma_mm + options.distance_sigma_ppm * o.slope_m * 1e-3;
      cluster.observations.push_back(
          MakeObservation(ObsKind::kSlopeDistance, set, o, o.slope_m, sigma_mm * 1e-3));
    }
    if (o.has_horizontal) {
      const double sigma_mm = options.distance_sigma_mm + options.distance_sigma_ppm * o.horizontal_m * 1e-3;
      cluster.observations.push_back(
          MakeObservation(ObsKind::kDistance, set, o, o.horizontal_m, sigma_mm * 1e-3));
    }
    if (o.has_zenith) {
      const double angle = options.zenith_sigma_cc * kCcToRad;
      const double heights = o.has_slope ? options.height_sigma_mm * 1e-3 / o.slope_m : 0.0;
      cluster.observations.push_back(MakeObservation(ObsKind::kZenithAngle, set, o, o.zenith_rad,
                                                     std::sqrt(angle * angle + heights * heights)));
    }
  }
  return cluster;
}

/// Fixes the known points of the network; returns (any xy known, any z known).
std::pair<bool, bool> ApplyKnown(const std::vector<KnownPoint>& known, SurveyNetwork* net) {
  bool any_xy = false, any_z = false;
  for (const KnownPoint& k : known) {
    SurveyPoint* p = net->Find(k.id);
    if (p == nullptr) continue;
    if (k.has_xy) {
      p->coords.head<2>() = k.en_h.head<2>();
      p->has_xy = p->given_xy = true;
      p->xy = CoordStatus::kFixed;
      any_xy = true;
    }
    if (k.has_z) {
      p->coords.z() = k.en_h.z();
      p->has_z = p->given_z = true;
      p->z = CoordStatus::kFixed;
      any_z = true;
    }
  }
  if (!known.empty() && !any_xy && !any_z) {
    throw InputError::Message(known.front().file,
                              "none of its " + std::to_string(known.size()) +
                                  " point(s) is a station or target of the field book " + net->source +
                                  " (first: " + known.front().id + "); expected known points of this network");
  }
  return {any_xy, any_z};
}

/// 2-D rotation and translation (no scale) taking `from` onto `to` in the least-squares sense
/// (one pair: translation only). `m`, `t`: to = m · from + t.
void FitRigid2d(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to,
                Eigen::Matrix2d* m, Eigen::Vector2d* t) {
  Eigen::Vector2d fc = Eigen::Vector2d::Zero(), tc = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < from.size(); ++i) fc += from[i], tc += to[i];
  fc /= from.size();
  tc /= to.size();
  double cross = 0, dot = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector2d a = from[i] - fc, b = to[i] - tc;
    cross += a.x() * b.y() - a.y() * b.x();
    dot += a.dot(b);
  }
  const double phi = from.size() > 1 ? std::atan2(cross, dot) : 0.0;
  *m << std::cos(phi), -std::sin(phi), std::sin(phi), std::cos(phi);
  *t = tc - *m * fc;
}

/// Approximate coordinates of the points without given ones: the network placed freely from
/// its first station (0, 0, 0, first round's zero direction north), then moved onto the known
/// points (rotation and translation from their horizontal positions, a shift from their
/// heights).
void ApplyApproximations(const FaceReduction& reduction, SurveyNetwork* net) {
  if (reduction.sets.empty()) return;
  Approximator approx(reduction);
  const std::string& first = reduction.sets.front().station;
  approx.xy[first] = Eigen::Vector2d::Zero();
  approx.orientation[0] = 0.0;
  approx.z[first] = 0.0;
  approx.Run();
  std::vector<Eigen::Vector2d> from, to;
  double dz = 0;
  int nz = 0;
  for (const SurveyPoint& p : net->points) {
    if (p.has_xy && approx.xy.count(p.id)) from.push_back(approx.xy.at(p.id)), to.push_back(p.coords.head<2>());
    if (p.has_z && approx.z.count(p.id)) dz += p.coords.z() - approx.z.at(p.id), ++nz;
  }
  Eigen::Matrix2d m = Eigen::Matrix2d::Identity();
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  if (!from.empty()) FitRigid2d(from, to, &m, &t);
  if (nz > 0) dz /= nz;
  for (SurveyPoint& p : net->points) {
    if (!p.has_xy && approx.xy.count(p.id)) {
      p.coords.head<2>() = m * approx.xy.at(p.id) + t;
      p.has_xy = p.given_xy = true;
    }
    if (!p.has_z && approx.z.count(p.id)) {
      p.coords.z() = approx.z.at(p.id) + dz;
      p.has_z = p.given_z = true;
    }
  }
}

}  // namespace

SurveyNetwork BuildFieldNetwork(const FaceReduction& reduction, const std::vector<KnownPoint>& known,
                                const FaceReductionOptions& options, const std::string& source) {
  SurveyNetwork net;
  net.source = source;
  net.description = "reduced from the field book " + source;
  net.sigma0_apriori = 1.0;
  for (const ReducedSet& set : reduction.sets) {
    net.GetOrAdd(set.station, set.line);
    for (const ReducedObservation& o : set.observations) net.GetOrAdd(o.target, o.line);
    net.clusters.push_back(MakeCluster(set, options));
  }
  const auto [any_xy, any_z] = ApplyKnown(known, &net);
  for (SurveyPoint& p : net.points) {
    if (p.xy != CoordStatus::kFixed) p.xy = any_xy ? CoordStatus::kAdjusted : CoordStatus::kConstrained;
    if (p.z != CoordStatus::kFixed) p.z = any_z ? CoordStatus::kAdjusted : CoordStatus::kConstrained;
  }
  ApplyApproximations(reduction, &net);
  return net;
}

}  // namespace mmba::survey
