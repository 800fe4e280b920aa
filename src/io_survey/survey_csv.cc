#include "mmba/io/survey_csv.h"

#include <cmath>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/io/gama_local.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {

using survey::Cluster;
using survey::CoordStatus;
using survey::ObsKind;
using survey::Observation;

namespace {

std::vector<std::string> SplitCsv(std::string_view line) {
  std::vector<std::string> out;
  std::string field;
  for (char c : line) {
    if (c == ',') {
      out.push_back(field);
      field.clear();
    } else {
      field += c;
    }
  }
  out.push_back(field);
  for (std::string& f : out) {
    size_t b = 0, e = f.size();
    while (b < e && std::isspace(static_cast<unsigned char>(f[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(f[e - 1]))) --e;
    f = f.substr(b, e - b);
  }
  return out;
}

}  // namespace

survey::SurveyNetwork ParseSurveyCsv(const std::string& text, const std::string& file) {
  survey::SurveyNetwork net;
  net.source = file;
  struct Row {
    int line;
    std::vector<std::string> f;
  };
  std::vector<Row> rows;
  LineCursor cursor(text, file);
  std::string_view line;
  while (cursor.Next(&line)) {
    const size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    bool blank = true;
    for (char c : line) blank = blank && std::isspace(static_cast<unsigned char>(c));
    if (blank) continue;
    rows.push_back({static_cast<int>(cursor.line_number()), SplitCsv(line)});
  }
  auto fail = [&](const Row& r, const std::string& field, const std::string& found,
                  const std::string& expected) {
    throw InputError(file, r.line, field, found, expected);
  };
  if (rows.empty()) {
    throw InputError(file, 0, "records", "none (the file is empty or only comments)",
                     "point records and observations");
  }
  // A point record must not repeat an id: the second would silently replace the first.
  auto new_point = [&](const Row& r) -> survey::SurveyPoint& {
    if (const survey::SurveyPoint* first = net.Find(r.f[1])) {
      fail(r, r.f[0] + " id", r.f[1],
           "each point once (point " + r.f[1] + " is defined at line " +
               std::to_string(first->line) + ")");
    }
    return net.GetOrAdd(r.f[1], r.line);
  };
  auto number = [&](const Row& r, size_t i, const std::string& field) {
    double v = 0.0;
    if (i >= r.f.size() || !ParseDouble(r.f[i], &v)) {
      fail(r, field, i < r.f.size() ? r.f[i] : "nothing", "a number");
    }
    return v;
  };
  // Pass 1: parameters and points.
  bool origin_after_points = false;
  for (const Row& r : rows) {
    const std::string& kind = r.f[0];
    if (kind == "param" && r.f.size() == 5 && r.f[1] == "origin") {
      net.geodetic = true;
      net.origin = {number(r, 2, "origin latitude"), number(r, 3, "origin longitude"),
                    number(r, 4, "origin height")};
      if (std::abs(net.origin.latitude_deg) > 90 || std::abs(net.origin.longitude_deg) > 180) {
        fail(r, "origin", r.f[2] + "," + r.f[3], "latitude in [-90, 90], longitude in [-180, 180]");
      }
      if (origin_after_points) fail(r, "origin", "after gpoint records", "the origin before any gpoint");
    } else if (kind == "param") {
      if (r.f.size() != 3) fail(r, "param", std::to_string(r.f.size()) + " fields", "3 fields (origin: 5)");
      const std::string& name = r.f[1];
      const std::string& value = r.f[2];
      if (name == "refraction") {
        net.refraction_k = number(r, 2, name);
        if (std::abs(net.refraction_k) > 1) fail(r, name, value, "a coefficient in [-1, 1]");
      } else if (name == "sigma-apr") {
        net.sigma0_apriori = number(r, 2, name);
        if (!(net.sigma0_apriori > 0)) fail(r, name, value, "a number > 0");
      } else if (name == "conf-pr") {
        net.confidence = number(r, 2, name);
        if (!(net.confidence > 0 && net.confidence < 1)) fail(r, name, value, "0 < p < 1");
      } else if (name == "sigma-act") {
        if (value != "apriori" && value != "aposteriori") fail(r, name, value, "apriori or aposteriori");
        net.sigma_act_apriori = value == "apriori";
      } else if (name == "axes-xy") {
        if (!survey::InputAxes::Parse(value, &net.axes)) fail(r, name, value, "ne, sw, es, wn, en, nw, se or ws");
      } else if (name == "angles") {
        if (value != "left-handed" && value != "right-handed") fail(r, name, value, "left-handed or right-handed");
        net.angles_left_handed = value == "left-handed";
      } else {
        fail(r, "param", name, "sigma-apr, conf-pr, sigma-act, axes-xy, angles, refraction or origin");
      }
    } else if (kind == "gpoint") {
      // gpoint,id,latitude,longitude,height,fix,adj: geodetic (WGS84) coordinates.
      if (!net.geodetic) fail(r, "gpoint", r.f.size() > 1 ? r.f[1] : "", "a 'param,origin,lat,lon,h' record first");
      origin_after_points = true;
      if (r.f.size() != 7) fail(r, "gpoint", std::to_string(r.f.size()) + " fields", "7 fields: gpoint,id,lat,lon,h,fix,adj");
      if (r.f[1].empty()) fail(r, "gpoint id", "nothing", "a point id");
      const geodesy::LocalTangentPlane plane(net.origin);
      const geodesy::Geodetic g{number(r, 2, "latitude"), number(r, 3, "longitude"), number(r, 4, "height")};
      survey::SurveyPoint& p = new_point(r);
      p.coords = plane.EnuFromGeodetic(g);
      p.has_xy = p.given_xy = p.has_z = p.given_z = true;
      auto apply = [&](const std::string& code, bool fixed) {
        if (code.empty()) return;
        if (code != "xy" && code != "xyz" && code != "z" && code != "XY" && code != "XYZ" &&
            code != "XYz" && code != "xyZ" && code != "Z") {
          fail(r, fixed ? "fix" : "adj", code, "one of xy, xyz, z, XY, XYZ, XYz, xyZ, Z");
        }
        const bool xy = code.find_first_of("xyXY") != std::string::npos;
        const bool z = code.find_first_of("zZ") != std::string::npos;
        if (xy) p.xy = fixed ? CoordStatus::kFixed : (code[0] == 'X' ? CoordStatus::kConstrained : CoordStatus::kAdjusted);
        if (z) p.z = fixed ? CoordStatus::kFixed : (code.back() == 'Z' ? CoordStatus::kConstrained : CoordStatus::kAdjusted);
      };
      apply(r.f[6], false);
      apply(r.f[5], true);
    } else if (kind == "point") {
      if (r.f.size() != 7) fail(r, "point", std::to_string(r.f.size()) + " fields", "7 fields: point,id,x,y,z,fix,adj");
      if (r.f[1].empty()) fail(r, "point id", "nothing", "a point id");
      survey::SurveyPoint& p = new_point(r);
      if (r.f[2].empty() != r.f[3].empty()) fail(r, "point x/y", r.f[2] + "/" + r.f[3], "both x and y or neither");
      if (!r.f[2].empty()) {
        p.coords.head<2>() = net.axes.EnFromXy(Eigen::Vector2d(number(r, 2, "x"), number(r, 3, "y")));
        p.has_xy = p.given_xy = true;
      }
      if (!r.f[4].empty()) {
        p.coords.z() = number(r, 4, "z");
        p.has_z = p.given_z = true;
      }
      auto apply = [&](const std::string& code, bool fixed) {
        if (code.empty()) return;
        const bool xy = code.find_first_of("xyXY") != std::string::npos;
        const bool z = code.find_first_of("zZ") != std::string::npos;
        if (code != "xy" && code != "xyz" && code != "z" && code != "XY" && code != "XYZ" &&
            code != "XYz" && code != "xyZ" && code != "Z") {
          fail(r, fixed ? "fix" : "adj", code, "one of xy, xyz, z, XY, XYZ, XYz, xyZ, Z");
        }
        if (xy) p.xy = fixed ? CoordStatus::kFixed : (code[0] == 'X' ? CoordStatus::kConstrained : CoordStatus::kAdjusted);
        if (z) p.z = fixed ? CoordStatus::kFixed : (code.back() == 'Z' ? CoordStatus::kConstrained : CoordStatus::kAdjusted);
      };
      apply(r.f[6], false);
      apply(r.f[5], true);
    }
  }
  // Pass 2: observations.
  long set = -1;  // index of the current direction set
  for (const Row& r : rows) {
    const std::string& kind = r.f[0];
    if (kind == "param" || kind == "point" || kind == "gpoint") continue;
    if (kind == "set") {
      if (r.f.size() != 2 || net.Find(r.f[1]) == nullptr) {
        fail(r, "set station", r.f.size() > 1 ? r.f[1] : "nothing", "the id of a defined point");
      }
      Cluster c;
      c.type = Cluster::Type::kStandpoint;
      c.station = r.f[1];
      c.line = r.line;
      net.clusters.push_back(c);
      set = static_cast<long>(net.clusters.size()) - 1;
      continue;
    }
    Observation o;
    o.line = r.line;
    bool angle = true;
    if (kind == "direction") o.kind = ObsKind::kDirection;
    else if (kind == "angle") o.kind = ObsKind::kAngle;
    else if (kind == "z-angle") o.kind = ObsKind::kZenithAngle;
    else if (kind == "azimuth") o.kind = ObsKind::kAzimuth;
    else {
      angle = false;
      if (kind == "distance") o.kind = ObsKind::kDistance;
      else if (kind == "s-distance") o.kind = ObsKind::kSlopeDistance;
      else if (kind == "dh") o.kind = ObsKind::kHeightDiff;
      else fail(r, "record", kind, "param, point, set, direction, angle, z-angle, azimuth, distance, s-distance or dh");
    }
    if (r.f.size() != 5 && r.f.size() != 7) {
      fail(r, kind, std::to_string(r.f.size()) + " fields", "5 or 7 fields: kind,from,to,value,sigma[,from_dh,to_dh]");
    }
    o.from = r.f[1];
    o.to = r.f[2];
    if (o.kind == ObsKind::kAngle) {
      const size_t slash = o.to.find('/');
      if (slash == std::string::npos) fail(r, "angle targets", o.to, "bs/fs");
      o.fs = o.to.substr(slash + 1);
      o.to = o.to.substr(0, slash);
    }
    for (const std::string* id : {&o.from, &o.to, &o.fs}) {
      if (id == &o.fs && o.fs.empty()) continue;
      if (net.Find(*id) == nullptr) fail(r, "point id", *id, "the id of a point defined by a point record");
    }
    if (o.from == o.to || o.from == o.fs) fail(r, "to", o.to, "a target different from the station " + o.from);
    bool dms = false;
    double degrees = 0.0;
    if (angle && ParseDms(r.f[3], &degrees)) {
      dms = true;
      o.value = degrees * M_PI / 180.0;
    } else {
      o.value = number(r, 3, "value");
      if (angle) o.value *= M_PI / 200.0;
    }
    if (angle && !net.angles_left_handed) o.value = -o.value;
    const double sigma = number(r, 4, "sigma");
    if (!(sigma > 0)) fail(r, "sigma", r.f[4], "a standard deviation > 0");
    o.sigma = sigma * (angle ? (dms ? M_PI / 648000.0 : M_PI / 2.0e6) : 1e-3);
    if (r.f.size() == 7) {
      o.from_dh = number(r, 5, "from_dh");
      o.to_dh = number(r, 6, "to_dh");
    }
    if (o.kind == ObsKind::kDirection) {
      if (set < 0 || net.clusters[set].station != o.from) {
        fail(r, "direction", o.from, "a direction after a 'set," + o.from + "' record");
      }
      net.clusters[set].observations.push_back(o);
      continue;
    }
    Cluster c;
    c.type = o.kind == ObsKind::kHeightDiff ? Cluster::Type::kHeightDifferences
                                            : Cluster::Type::kStandpoint;
    c.station = o.from;
    c.line = r.line;
    c.observations.push_back(o);
    net.clusters.push_back(c);
  }
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
