#include "mmba/io_survey/survey_csv.h"

#include <cmath>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io/csv_table.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {

using survey::Cluster;
using survey::CoordStatus;
using survey::ObsKind;
using survey::Observation;

namespace {

// A non-blank record: its line number and its fields (RFC 4180: quoted fields may hold
// commas, line breaks and doubled quotes), unquoted ones trimmed.
struct Row {
  int line;
  std::vector<std::string> f;
};

// The records of the file; '#' starts a comment outside quotes, blank lines are dropped.
std::vector<Row> ReadRows(const std::string& text, const std::string& file) {
  std::vector<Row> rows;
  for (CsvRecord& record : SplitCsvRecords(text, file, '#', /*trailing_comments=*/true)) {
    rows.push_back({record.line, std::move(record.cells)});
  }
  return rows;
}

// Builds the network from the records: parameters and points first, observations second.
class CsvNetworkReader {
 public:
  CsvNetworkReader(const std::string& file, survey::SurveyNetwork* net) : file_(file), net_(*net) {}

  // param, gpoint and point records.
  void ReadParamOrPoint(const Row& r) {
    const std::string& kind = r.f[0];
    if (kind == "param" && r.f.size() == 5 && r.f[1] == "origin") {
      ReadOrigin(r);
    } else if (kind == "param") {
      ReadParam(r);
    } else if (kind == "gpoint") {
      ReadGpoint(r);
    } else if (kind == "point") {
      ReadPoint(r);
    }
  }

  // set and observation records (the others are skipped).
  void ReadObservationRecord(const Row& r) {
    const std::string& kind = r.f[0];
    if (kind == "param" || kind == "point" || kind == "gpoint") return;
    if (kind == "set") {
      ReadSet(r);
      return;
    }
    const Observation o = ReadObservation(r);
    if (o.kind == ObsKind::kDirection) {
      if (set_ < 0 || net_.clusters[set_].station != o.from) {
        Fail(r, "direction", o.from, "a direction after a 'set," + o.from + "' record");
      }
      net_.clusters[set_].observations.push_back(o);
      return;
    }
    Cluster c;
    c.type = o.kind == ObsKind::kHeightDiff ? Cluster::Type::kHeightDifferences
                                            : Cluster::Type::kStandpoint;
    c.station = o.from;
    c.line = r.line;
    c.observations.push_back(o);
    net_.clusters.push_back(c);
  }

 private:
  [[noreturn]] void Fail(const Row& r, const std::string& field, const std::string& found,
                         const std::string& expected) const {
    throw InputError(file_, r.line, field, found, expected);
  }

  double Number(const Row& r, size_t i, const std::string& field) const {
    double v = 0.0;
    if (i >= r.f.size() || !ParseDouble(r.f[i], &v)) {
      Fail(r, field, i < r.f.size() ? r.f[i] : "nothing", "a number");
    }
    return v;
  }

  // A point record must not repeat an id: the second would silently replace the first.
  survey::SurveyPoint& NewPoint(const Row& r) {
    if (const survey::SurveyPoint* first = net_.Find(r.f[1])) {
      Fail(r, r.f[0] + " id", r.f[1],
           "each point once (point " + r.f[1] + " is defined at line " +
               std::to_string(first->line) + ")");
    }
    return net_.GetOrAdd(r.f[1], r.line);
  }

  // A fix or adj code (xy, xyz, z; capitals: constrained) applied to the point's status.
  void ApplyCode(const Row& r, const std::string& code, bool fixed, survey::SurveyPoint* p) const {
    if (code.empty()) return;
    if (code != "xy" && code != "xyz" && code != "z" && code != "XY" && code != "XYZ" &&
        code != "XYz" && code != "xyZ" && code != "Z") {
      Fail(r, fixed ? "fix" : "adj", code, "one of xy, xyz, z, XY, XYZ, XYz, xyZ, Z");
    }
    const bool xy = code.find_first_of("xyXY") != std::string::npos;
    const bool z = code.find_first_of("zZ") != std::string::npos;
    if (xy) p->xy = fixed ? CoordStatus::kFixed : (code[0] == 'X' ? CoordStatus::kConstrained : CoordStatus::kAdjusted);
    if (z) p->z = fixed ? CoordStatus::kFixed : (code.back() == 'Z' ? CoordStatus::kConstrained : CoordStatus::kAdjusted);
  }

  // param,origin,lat,lon,h: the network is geodetic, in the tangent plane at this origin.
  void ReadOrigin(const Row& r) {
    net_.geodetic = true;
    net_.origin = {Number(r, 2, "origin latitude"), Number(r, 3, "origin longitude"),
                   Number(r, 4, "origin height")};
    if (std::abs(net_.origin.latitude_deg) > 90 || std::abs(net_.origin.longitude_deg) > 180) {
      Fail(r, "origin", r.f[2] + "," + r.f[3], "latitude in [-90, 90], longitude in [-180, 180]");
    }
    if (origin_after_points_) Fail(r, "origin", "after gpoint records", "the origin before any gpoint");
  }

  // param,name,value.
  void ReadParam(const Row& r) {
    if (r.f.size() != 3) Fail(r, "param", std::to_string(r.f.size()) + " fields", "3 fields (origin: 5)");
    const std::string& name = r.f[1];
    const std::string& value = r.f[2];
    if (name == "refraction") {
      net_.refraction_k = Number(r, 2, name);
      if (std::abs(net_.refraction_k) > 1) Fail(r, name, value, "a coefficient in [-1, 1]");
    } else if (name == "sigma-apr") {
      net_.sigma0_apriori = Number(r, 2, name);
      if (!(net_.sigma0_apriori > 0)) Fail(r, name, value, "a number > 0");
    } else if (name == "conf-pr") {
      net_.confidence = Number(r, 2, name);
      if (!(net_.confidence > 0 && net_.confidence < 1)) Fail(r, name, value, "0 < p < 1");
    } else if (name == "sigma-act") {
      if (value != "apriori" && value != "aposteriori") Fail(r, name, value, "apriori or aposteriori");
      net_.sigma_act_apriori = value == "apriori";
    } else if (name == "axes-xy") {
      if (!survey::InputAxes::Parse(value, &net_.axes)) Fail(r, name, value, "ne, sw, es, wn, en, nw, se or ws");
    } else if (name == "angles") {
      if (value != "left-handed" && value != "right-handed") Fail(r, name, value, "left-handed or right-handed");
      net_.angles_left_handed = value == "left-handed";
    } else {
      Fail(r, "param", name, "sigma-apr, conf-pr, sigma-act, axes-xy, angles, refraction or origin");
    }
  }

  // gpoint,id,latitude,longitude,height,fix,adj: geodetic (WGS84) coordinates.
  void ReadGpoint(const Row& r) {
    if (!net_.geodetic) Fail(r, "gpoint", r.f.size() > 1 ? r.f[1] : "", "a 'param,origin,lat,lon,h' record first");
    origin_after_points_ = true;
    if (r.f.size() != 7) Fail(r, "gpoint", std::to_string(r.f.size()) + " fields", "7 fields: gpoint,id,lat,lon,h,fix,adj");
    if (r.f[1].empty()) Fail(r, "gpoint id", "nothing", "a point id");
    const geodesy::LocalTangentPlane plane(net_.origin);
    const geodesy::Geodetic g{Number(r, 2, "latitude"), Number(r, 3, "longitude"), Number(r, 4, "height")};
    survey::SurveyPoint& p = NewPoint(r);
    p.coords = plane.EnuFromGeodetic(g);
    p.has_xy = p.given_xy = p.has_z = p.given_z = true;
    ApplyCode(r, r.f[6], false, &p);
    ApplyCode(r, r.f[5], true, &p);
  }

  // point,id,x,y,z,fix,adj: x and y in the network's axes, either may be empty.
  void ReadPoint(const Row& r) {
    if (r.f.size() != 7) Fail(r, "point", std::to_string(r.f.size()) + " fields", "7 fields: point,id,x,y,z,fix,adj");
    if (r.f[1].empty()) Fail(r, "point id", "nothing", "a point id");
    survey::SurveyPoint& p = NewPoint(r);
    if (r.f[2].empty() != r.f[3].empty()) Fail(r, "point x/y", r.f[2] + "/" + r.f[3], "both x and y or neither");
    if (!r.f[2].empty()) {
      p.coords.head<2>() = net_.axes.EnFromXy(Eigen::Vector2d(Number(r, 2, "x"), Number(r, 3, "y")));
      p.has_xy = p.given_xy = true;
    }
    if (!r.f[4].empty()) {
      p.coords.z() = Number(r, 4, "z");
      p.has_z = p.given_z = true;
    }
    ApplyCode(r, r.f[6], false, &p);
    ApplyCode(r, r.f[5], true, &p);
  }

  // set,station: opens a direction set at a defined point.
  void ReadSet(const Row& r) {
    if (r.f.size() != 2 || net_.Find(r.f[1]) == nullptr) {
      Fail(r, "set station", r.f.size() > 1 ? r.f[1] : "nothing", "the id of a defined point");
    }
    Cluster c;
    c.type = Cluster::Type::kStandpoint;
    c.station = r.f[1];
    c.line = r.line;
    net_.clusters.push_back(c);
    set_ = static_cast<long>(net_.clusters.size()) - 1;
  }

  // The kind of an observation record; true in *angle for angles (value in gon or d-m-s).
  ObsKind KindOf(const Row& r, bool* angle) const {
    const std::string& kind = r.f[0];
    *angle = true;
    if (kind == "direction") return ObsKind::kDirection;
    if (kind == "angle") return ObsKind::kAngle;
    if (kind == "z-angle") return ObsKind::kZenithAngle;
    if (kind == "azimuth") return ObsKind::kAzimuth;
    *angle = false;
    if (kind == "distance") return ObsKind::kDistance;
    if (kind == "s-distance") return ObsKind::kSlopeDistance;
    if (kind == "dh") return ObsKind::kHeightDiff;
    Fail(r, "record", kind, "param, point, set, direction, angle, z-angle, azimuth, distance, s-distance or dh");
  }

  // kind,from,to,value,sigma[,from_dh,to_dh]: angles in gon (σ in cc) or d-m-s (σ in arc
  // seconds), lengths in m (σ in mm); an angle's targets are bs/fs.
  Observation ReadObservation(const Row& r) {
    const std::string& kind = r.f[0];
    Observation o;
    o.line = r.line;
    bool angle = true;
    o.kind = KindOf(r, &angle);
    if (r.f.size() != 5 && r.f.size() != 7) {
      Fail(r, kind, std::to_string(r.f.size()) + " fields", "5 or 7 fields: kind,from,to,value,sigma[,from_dh,to_dh]");
    }
    o.from = r.f[1];
    o.to = r.f[2];
    if (o.kind == ObsKind::kAngle) {
      const size_t slash = o.to.find('/');
      if (slash == std::string::npos) Fail(r, "angle targets", o.to, "bs/fs");
      o.fs = o.to.substr(slash + 1);
      o.to = o.to.substr(0, slash);
    }
    for (const std::string* id : {&o.from, &o.to, &o.fs}) {
      if (id == &o.fs && o.fs.empty()) continue;
      if (net_.Find(*id) == nullptr) Fail(r, "point id", *id, "the id of a point defined by a point record");
    }
    if (o.from == o.to || o.from == o.fs) Fail(r, "to", o.to, "a target different from the station " + o.from);
    bool dms = false;
    double degrees = 0.0;
    if (angle && ParseDms(r.f[3], &degrees)) {
      dms = true;
      o.value = degrees * M_PI / 180.0;
    } else {
      o.value = Number(r, 3, "value");
      if (angle) o.value *= M_PI / 200.0;
    }
    if (angle && !net_.angles_left_handed) o.value = -o.value;
    const double sigma = Number(r, 4, "sigma");
    if (!(sigma > 0)) Fail(r, "sigma", r.f[4], "a standard deviation > 0");
    o.sigma = sigma * (angle ? (dms ? M_PI / 648000.0 : M_PI / 2.0e6) : 1e-3);
    if (r.f.size() == 7) {
      o.from_dh = Number(r, 5, "from_dh");
      o.to_dh = Number(r, 6, "to_dh");
    }
    return o;
  }

  const std::string& file_;
  survey::SurveyNetwork& net_;
  bool origin_after_points_ = false;
  long set_ = -1;  // index of the current direction set
};

}  // namespace

survey::SurveyNetwork ParseSurveyCsv(const std::string& text, const std::string& file) {
  survey::SurveyNetwork net;
  net.source = file;
  const std::vector<Row> rows = ReadRows(text, file);
  if (rows.empty()) {
    throw InputError(file, 0, "records", "none (the file is empty or only comments)",
                     "point records and observations");
  }
  CsvNetworkReader reader(file, &net);
  for (const Row& r : rows) reader.ReadParamOrPoint(r);
  for (const Row& r : rows) reader.ReadObservationRecord(r);
  size_t num_observations = 0;
  for (const Cluster& c : net.clusters) num_observations += c.observations.size();
  if (num_observations == 0) {
    throw InputError(file, 0, "records", "no observation",
                     "at least one observation record (direction, distance, ...)");
  }
  return net;  // uncorrelated clusters: the σ's are the covariance
}

survey::SurveyNetwork ReadSurveyCsv(const std::string& path) {
  return ParseSurveyCsv(ReadWholeFile(path), path);
}

}  // namespace mmba::io
