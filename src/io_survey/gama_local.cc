#include "mmba/io_survey/gama_local.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

#include <Eigen/Cholesky>

#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"
#include "xml_tree.h"

namespace mmba::io {

using survey::Cluster;
using survey::CoordStatus;
using survey::ObsKind;
using survey::Observation;
using survey::SurveyNetwork;
using survey::SurveyPoint;

namespace {

constexpr double kGonToRad = M_PI / 200.0;
constexpr double kCcToRad = M_PI / 2.0e6;          // 1 cc = 1e-4 gon
constexpr double kArcsecToRad = M_PI / 648000.0;   // 1" = 1/3600 deg
constexpr double kDegToRad = M_PI / 180.0;
constexpr double kMmToM = 1e-3;

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

class GamaReader {
 public:
  GamaReader(const std::string& file) : file_(file) { net_.source = file; }

  SurveyNetwork Read(const std::string& text) {
    const std::unique_ptr<xml::Element> root = xml::Parse(text, file_);
    if (root->name != "gama-local") {
      Fail(*root, "root element", root->name, "<gama-local>");
    }
    for (const auto& [key, value] : root->attributes) {
      if (key == "xmlns") {
        if (value != "http://www.gnu.org/software/gama/gama-local") {
          Fail(*root, "gama-local@xmlns", value, "http://www.gnu.org/software/gama/gama-local");
        }
      } else if (key != "version") {
        Fail(*root, "gama-local@" + key, value, "no other attribute than xmlns, version");
      }
    }
    CheckNoText(*root);
    int networks = 0;
    for (const auto& child : root->children) {
      if (child->name != "network") {
        Fail(*child, "element", "<" + child->name + ">", "<network> inside <gama-local>");
      }
      ++networks;
      ReadNetwork(*child);
    }
    if (networks != 1) Fail(*root, "<network>", std::to_string(networks), "exactly one <network>");
    return std::move(net_);
  }

 private:
  [[noreturn]] void Fail(const xml::Element& at, const std::string& field,
                         const std::string& found, const std::string& expected) const {
    throw InputError(file_, at.line, field, found, expected);
  }

  void CheckNoText(const xml::Element& e) const {
    if (!Trim(e.text).empty()) {
      Fail(e, "<" + e.name + ">", "text '" + Trim(e.text).substr(0, 30) + "'", "only elements");
    }
  }

  double Number(const xml::Element& e, const std::string& attribute,
                const std::string& value) const {
    double v = 0.0;
    if (!ParseDouble(Trim(value), &v)) {
      Fail(e, e.name + "@" + attribute, value, "a number");
    }
    return v;
  }

  /// An angle value: gon as a decimal number, or d-m-s. Returns radians; `*dms` tells which.
  double Angle(const xml::Element& e, const std::string& attribute, const std::string& value,
               bool* dms) const {
    double degrees = 0.0;
    if (ParseDms(Trim(value), &degrees)) {
      *dms = true;
      return degrees * kDegToRad;
    }
    *dms = false;
    return Number(e, attribute, value) * kGonToRad;
  }

  void ReadNetwork(const xml::Element& network) {
    for (const auto& [key, value] : network.attributes) {
      if (key == "axes-xy") {
        if (!survey::InputAxes::Parse(value, &net_.axes)) {
          Fail(network, "network@axes-xy", value, "one of ne, sw, es, wn, en, nw, se, ws");
        }
      } else if (key == "angles") {
        if (value == "left-handed") net_.angles_left_handed = true;
        else if (value == "right-handed") net_.angles_left_handed = false;
        else Fail(network, "network@angles", value, "left-handed or right-handed");
      } else if (key == "epoch") {
        Number(network, key, value);
      } else {
        Fail(network, "network@" + key, value, "one of axes-xy, angles, epoch");
      }
    }
    CheckNoText(network);
    for (const auto& child : network.children) {
      if (child->name == "description") {
        net_.description = Trim(child->text);
      } else if (child->name == "parameters") {
        ReadParameters(*child);
      } else if (child->name == "points-observations") {
        ReadPointsObservations(*child);
      } else {
        Fail(*child, "element", "<" + child->name + ">",
             "<description>, <parameters> or <points-observations> inside <network>");
      }
    }
  }

  void ReadParameters(const xml::Element& e) {
    for (const auto& [key, value] : e.attributes) {
      const std::string v = Trim(value);
      if (key == "sigma-apr") {
        net_.sigma0_apriori = Number(e, key, v);
        if (!(net_.sigma0_apriori > 0)) Fail(e, "parameters@sigma-apr", v, "a number > 0");
      } else if (key == "conf-pr") {
        net_.confidence = Number(e, key, v);
        if (!(net_.confidence > 0 && net_.confidence < 1)) {
          Fail(e, "parameters@conf-pr", v, "a probability in (0, 1)");
        }
      } else if (key == "tol-abs") {
        net_.tol_abs_mm = Number(e, key, v);
        if (!(net_.tol_abs_mm > 0)) Fail(e, "parameters@tol-abs", v, "a number > 0");
      } else if (key == "sigma-act") {
        if (v == "aposteriori") net_.sigma_act_apriori = false;
        else if (v == "apriori") net_.sigma_act_apriori = true;
        else Fail(e, "parameters@sigma-act", v, "apriori or aposteriori");
      } else if (key == "update-constrained-coordinates") {
        if (v == "yes") net_.update_constrained = true;
        else if (v == "no") net_.update_constrained = false;
        else Fail(e, "parameters@" + key, v, "yes or no");
      } else if (key == "angles") {
        if (v == "400") net_.output_gons = true;
        else if (v == "360") net_.output_gons = false;
        else Fail(e, "parameters@angles", v, "400 or 360");
      } else if (key == "cov-band") {
        int64_t band = 0;
        if (!ParseInt(v, &band)) Fail(e, "parameters@cov-band", v, "an integer");
      } else if (key == "latitude") {
        double degrees = 0.0;
        if (!ParseDms(v, &degrees)) Number(e, key, v);
      } else if (key == "algorithm" || key == "ellipsoid" || key == "language" ||
                 key == "encoding") {
        // Gama's solver choice, ellipsoid name, and the language and encoding of its text
        // output: no observation, and the solution does not depend on them here.
      } else {
        Fail(e, "parameters@" + key, value,
             "one of sigma-apr, conf-pr, tol-abs, sigma-act, update-constrained-coordinates, "
             "angles, algorithm, cov-band, latitude, ellipsoid, language, encoding");
      }
    }
    CheckNoText(e);
    if (!e.children.empty()) Fail(*e.children[0], "element", "<" + e.children[0]->name + ">",
                                  "nothing inside <parameters>");
  }

  void ReadPointsObservations(const xml::Element& e) {
    distance_a_ = 0.0;
    distance_b_ = 0.0;
    distance_c_ = 1.0;
    direction_sigma_ = angle_sigma_ = zenith_sigma_ = azimuth_sigma_ = 0.0;
    for (const auto& [key, value] : e.attributes) {
      if (key == "distance-stdev") {
        std::istringstream in(value);
        std::vector<std::string> tokens;
        std::string token;
        while (in >> token) tokens.push_back(token);
        if (tokens.empty() || tokens.size() > 3) {
          Fail(e, "points-observations@distance-stdev", value, "'a [b [c]]' (a + b·D[km]^c mm)");
        }
        distance_a_ = Number(e, key, tokens[0]);
        if (tokens.size() > 1) distance_b_ = Number(e, key, tokens[1]);
        if (tokens.size() > 2) distance_c_ = Number(e, key, tokens[2]);
      } else if (key == "direction-stdev") {
        direction_sigma_ = Number(e, key, value);
      } else if (key == "angle-stdev") {
        angle_sigma_ = Number(e, key, value);
      } else if (key == "zenith-angle-stdev") {
        zenith_sigma_ = Number(e, key, value);
      } else if (key == "azimuth-stdev") {
        azimuth_sigma_ = Number(e, key, value);
      } else {
        Fail(e, "points-observations@" + key, value,
             "one of distance-stdev, direction-stdev, angle-stdev, zenith-angle-stdev, "
             "azimuth-stdev");
      }
    }
    CheckNoText(e);
    // Points first (Gama collects them regardless of order), then observations.
    for (const auto& child : e.children) {
      if (child->name == "point") ReadPoint(*child, /*in_coordinates=*/false);
    }
    for (const auto& child : e.children) {
      if (child->name == "point") continue;
      if (child->name == "obs") ReadObs(*child);
      else if (child->name == "height-differences") ReadHeightDifferences(*child);
      else if (child->name == "coordinates") ReadCoordinates(*child);
      else if (child->name == "vectors") ReadVectors(*child);
      else {
        Fail(*child, "element", "<" + child->name + ">",
             "<point>, <obs>, <coordinates>, <height-differences> or <vectors> inside "
             "<points-observations>");
      }
    }
  }

  /// Returns the point and whether xy / z were given.
  SurveyPoint& ReadPoint(const xml::Element& e, bool in_coordinates, bool* xy_given = nullptr,
                         bool* z_given = nullptr) {
    std::string id, sx, sy, sz, fix, adj;
    bool has_x = false, has_y = false, has_z = false;
    for (const auto& [key, value] : e.attributes) {
      if (key == "id") id = Trim(value);
      else if (key == "x") { sx = value; has_x = true; }
      else if (key == "y") { sy = value; has_y = true; }
      else if (key == "z") { sz = value; has_z = true; }
      else if (key == "fix" && !in_coordinates) fix = Trim(value);
      else if (key == "adj" && !in_coordinates) adj = Trim(value);
      else Fail(e, "point@" + key, value, in_coordinates ? "one of id, x, y, z"
                                                         : "one of id, x, y, z, fix, adj");
    }
    CheckNoText(e);
    if (!e.children.empty()) Fail(e, "point", "<" + e.children[0]->name + ">", "an empty <point/>");
    if (id.empty()) Fail(e, "point@id", "", "a point id");
    if (has_x != has_y) Fail(e, has_x ? "point@y" : "point@x", "", "both x and y, or neither");
    if (!in_coordinates) {
      if (const SurveyPoint* first = net_.Find(id)) {
        Fail(e, "point@id", id,
             "each point once (point " + id + " is defined at line " +
                 std::to_string(first->line) + ")");
      }
    }
    SurveyPoint& p = net_.GetOrAdd(id, e.line);
    if (has_x) {
      const Eigen::Vector2d xy(Number(e, "x", sx), Number(e, "y", sy));
      p.coords.head<2>() = net_.axes.EnFromXy(xy);
      p.has_xy = p.given_xy = true;
    }
    if (has_z) {
      p.coords.z() = Number(e, "z", sz);
      p.has_z = p.given_z = true;
    }
    if (xy_given) *xy_given = has_x;
    if (z_given) *z_given = has_z;
    auto apply = [&](const std::string& code, bool fixed, const char* attribute) {
      if (code.empty()) return;
      bool xy = false, z = false, cxy = false, cz = false;
      if (code == "xy") xy = true;
      else if (code == "xyz") xy = z = true;
      else if (code == "z") z = true;
      else if (code == "XY") xy = cxy = true;
      else if (code == "XYZ") xy = z = cxy = cz = true;
      else if (code == "XYz") xy = z = cxy = true;
      else if (code == "xyZ") xy = z = cz = true;
      else if (code == "Z") z = cz = true;
      else Fail(e, std::string("point@") + attribute, code, "one of xy, xyz, z, XY, XYZ, XYz, xyZ, Z");
      if (fixed) {
        if (xy) p.xy = CoordStatus::kFixed;
        if (z) p.z = CoordStatus::kFixed;
      } else {
        if (xy) p.xy = cxy ? CoordStatus::kConstrained : CoordStatus::kAdjusted;
        if (z) p.z = cz ? CoordStatus::kConstrained : CoordStatus::kAdjusted;
      }
    };
    apply(adj, false, "adj");  // Gama applies adj first, then fix
    apply(fix, true, "fix");
    return p;
  }

  double Sigma(const xml::Element& e, const std::string* attribute, double implicit) const {
    if (attribute == nullptr) return implicit;
    return Number(e, "stdev", *attribute);
  }

  std::string Id(const xml::Element& e, const char* attribute, bool required,
                 const std::string& fallback = std::string()) const {
    const std::string* value = e.Attribute(attribute);
    const std::string id = value ? Trim(*value) : fallback;
    if (required && id.empty()) Fail(e, e.name + "@" + attribute, "", "a point id");
    if (!id.empty() && net_.Find(id) == nullptr) {
      Fail(e, e.name + "@" + attribute, id, "the id of a point defined by <point>");
    }
    return id;
  }

  void CheckAttributes(const xml::Element& e, std::initializer_list<const char*> allowed) const {
    for (const auto& [key, value] : e.attributes) {
      bool ok = false;
      std::string list;
      for (const char* a : allowed) {
        ok = ok || key == a;
        list += (list.empty() ? "" : ", ") + std::string(a);
      }
      if (!ok) Fail(e, e.name + "@" + key, value, "one of " + list);
    }
    CheckNoText(e);
    if (!e.children.empty()) Fail(e, e.name, "<" + e.children[0]->name + ">", "an empty element");
  }

  double Height(const xml::Element& e, const char* attribute, double fallback) const {
    const std::string* v = e.Attribute(attribute);
    return v ? Number(e, attribute, *v) : fallback;
  }

  const std::string& Required(const xml::Element& e, const char* attribute) const {
    const std::string* v = e.Attribute(attribute);
    if (v == nullptr || Trim(*v).empty()) Fail(e, e.name + "@" + attribute, "nothing", "a value");
    return *v;
  }

  /// A cluster of `type` at element `e`, which takes no attributes but Gama's `extern` (a
  /// label for other programs, no observation) and no text.
  Cluster ClusterWithoutAttributes(const xml::Element& e, Cluster::Type type) const {
    Cluster cluster;
    cluster.type = type;
    cluster.line = e.line;
    for (const auto& [key, value] : e.attributes) {
      if (key != "extern") Fail(e, e.name + "@" + key, value, "no attribute other than extern");
    }
    CheckNoText(e);
    return cluster;
  }

  /// Calls on_observation(child) for each child of a cluster element up to its <cov-mat>,
  /// which must come last; returns the <cov-mat> (nullptr if there is none).
  template <typename OnObservation>
  const xml::Element* ForEachObservation(const xml::Element& cluster,
                                         OnObservation on_observation) const {
    const xml::Element* cov = nullptr;
    for (const auto& child_ptr : cluster.children) {
      const xml::Element& e = *child_ptr;
      if (cov != nullptr) Fail(e, "element", "<" + e.name + ">", "no observation after <cov-mat>");
      if (e.name == "cov-mat") {
        cov = &e;
        continue;
      }
      on_observation(e);
    }
    return cov;
  }

  /// A standpoint cluster from the attributes of <obs> (from, orientation) and its default
  /// from_dh.
  Cluster ReadObsAttributes(const xml::Element& obs, double* default_from_dh) const {
    Cluster cluster;
    cluster.type = Cluster::Type::kStandpoint;
    cluster.line = obs.line;
    for (const auto& [key, value] : obs.attributes) {
      if (key == "from") {
        cluster.station = Trim(value);
      } else if (key == "orientation") {
        cluster.orientation = Number(obs, key, value) * kGonToRad;
        cluster.orientation_known = true;
      } else if (key == "from_dh") {
        *default_from_dh = Number(obs, key, value);
      } else {
        Fail(obs, "obs@" + key, value, "one of from, orientation, from_dh");
      }
    }
    if (!cluster.station.empty()) Id(obs, "from", false);
    CheckNoText(obs);
    return cluster;
  }

  /// Kind, points and value of observation `e` inside <obs> (station `station`); `dms` is
  /// set when an angle was given in DMS; returns the implicit σ (input unit) of its kind.
  double ReadObsKind(const xml::Element& obs, const xml::Element& e, const std::string& station,
                     Observation* o, bool* dms) const {
    if (e.name == "direction") {
      CheckAttributes(e, {"to", "val", "stdev", "from_dh", "to_dh", "extern"});
      o->kind = ObsKind::kDirection;
      o->from = station;
      if (o->from.empty()) Fail(obs, "obs@from", "", "a station id for <direction>");
      o->to = Id(e, "to", true);
      o->value = Angle(e, "val", Required(e, "val"), dms);
      return direction_sigma_;
    }
    if (e.name == "distance" || e.name == "s-distance") {
      CheckAttributes(e, {"from", "to", "val", "stdev", "from_dh", "to_dh", "extern"});
      o->kind = e.name == "distance" ? ObsKind::kDistance : ObsKind::kSlopeDistance;
      o->from = Id(e, "from", true, station);
      o->to = Id(e, "to", true);
      o->value = Number(e, "val", Required(e, "val"));
      if (!(o->value > 0)) Fail(e, e.name + "@val", Required(e, "val"), "a length > 0");
      return distance_a_ + distance_b_ * std::pow(o->value / 1000.0, distance_c_);
    }
    if (e.name == "angle") {
      CheckAttributes(e, {"from", "bs", "fs", "to", "rs", "val", "stdev", "from_dh", "bs_dh",
                          "fs_dh", "extern"});
      o->kind = ObsKind::kAngle;
      o->from = Id(e, "from", true, station);
      o->to = e.Attribute("bs") ? Id(e, "bs", true) : Id(e, "to", true);
      const std::string fs_attribute = e.Attribute("fs") ? "fs" : "rs";
      o->fs = Id(e, fs_attribute.c_str(), true);
      o->value = Angle(e, "val", Required(e, "val"), dms);
      o->to_dh = Height(e, "bs_dh", 0.0);
      o->fs_dh = Height(e, "fs_dh", 0.0);
      return angle_sigma_;
    }
    if (e.name == "z-angle" || e.name == "azimuth") {
      CheckAttributes(e, {"from", "to", "val", "stdev", "from_dh", "to_dh", "extern"});
      o->kind = e.name == "z-angle" ? ObsKind::kZenithAngle : ObsKind::kAzimuth;
      o->from = Id(e, "from", true, station);
      o->to = Id(e, "to", true);
      o->value = Angle(e, "val", Required(e, "val"), dms);
      return e.name == "z-angle" ? zenith_sigma_ : azimuth_sigma_;
    }
    Fail(e, "element", "<" + e.name + ">",
         "<direction>, <distance>, <angle>, <s-distance>, <z-angle>, <azimuth> or "
         "<cov-mat> inside <obs>");
    return 0.0;
  }

  /// One observation of <obs>: σ in SI, the value clockwise for angles; `unit` is the
  /// factor input σ unit -> SI.
  Observation ReadObservation(const xml::Element& obs, const xml::Element& e,
                              const std::string& station, double default_from_dh,
                              double* unit) const {
    Observation o;
    o.line = e.line;
    bool dms = false;
    const std::string* stdev = e.Attribute("stdev");
    o.from_dh = Height(e, "from_dh", default_from_dh);
    const double implicit = ReadObsKind(obs, e, station, &o, &dms);
    if (o.kind != ObsKind::kAngle) o.to_dh = Height(e, "to_dh", 0.0);
    if (o.from == o.to || (!o.fs.empty() && (o.fs == o.from || o.fs == o.to))) {
      Fail(e, e.name + "@to", o.to, "a target different from the station " + o.from);
    }
    const double sigma_input = stdev ? Number(e, "stdev", *stdev) : implicit;
    *unit = kMmToM;
    if (survey::ObsKindIsAngle(o.kind)) {
      *unit = dms ? kArcsecToRad : kCcToRad;
      if (!net_.angles_left_handed) o.value = -o.value;  // to clockwise
    }
    if (!(sigma_input > 0) && !HasCovMat(obs)) {
      Fail(e, e.name + "@stdev", stdev ? *stdev : std::string("none (no default)"),
           "a standard deviation > 0 (attribute stdev or a default in <points-observations>)");
    }
    o.sigma = sigma_input * *unit;
    return o;
  }

  /// <obs>: one standpoint cluster of directions, distances, angles, zenith angles and
  /// azimuths, with an optional <cov-mat> last.
  void ReadObs(const xml::Element& obs) {
    double default_from_dh = 0.0;
    Cluster cluster = ReadObsAttributes(obs, &default_from_dh);
    std::vector<double> sigma_unit;  // input σ unit -> SI per observation
    const xml::Element* cov = ForEachObservation(obs, [&](const xml::Element& e) {
      double unit = kMmToM;
      cluster.observations.push_back(
          ReadObservation(obs, e, cluster.station, default_from_dh, &unit));
      sigma_unit.push_back(unit);
    });
    FinishCluster(&cluster, cov, sigma_unit);
    net_.clusters.push_back(std::move(cluster));
  }

  static bool HasCovMat(const xml::Element& e) {
    for (const auto& c : e.children) {
      if (c->name == "cov-mat") return true;
    }
    return false;
  }

  /// Sets the SI covariance from <cov-mat> (input units, upper band by rows), or keeps the
  /// σ's when there is none. A band of 0 gives the σ's too; a wider band the full matrix.
  void FinishCluster(Cluster* cluster, const xml::Element* cov,
                     const std::vector<double>& unit) {
    if (cov == nullptr) return;
    const int n = static_cast<int>(cluster->observations.size());
    int dim = 0, band = 0;
    for (const auto& [key, value] : cov->attributes) {
      int64_t v = 0;
      if (!ParseInt(Trim(value), &v)) Fail(*cov, "cov-mat@" + key, value, "an integer");
      if (key == "dim") dim = static_cast<int>(std::clamp<int64_t>(v, -1, INT32_MAX));
      else if (key == "band") band = static_cast<int>(std::clamp<int64_t>(v, -1, INT32_MAX));
      else Fail(*cov, "cov-mat@" + key, value, "dim or band");
    }
    if (cov->Attribute("dim") == nullptr || cov->Attribute("band") == nullptr) {
      Fail(*cov, "cov-mat", "missing dim or band", "both dim and band attributes");
    }
    if (dim != n) {
      Fail(*cov, "cov-mat@dim", std::to_string(dim),
           std::to_string(n) + " (the number of observations of the cluster)");
    }
    if (band < 0 || band >= dim) {
      Fail(*cov, "cov-mat@band", std::to_string(band), "0 <= band < dim");
    }
    cluster->correlated = band > 0;
    if (cluster->correlated) cluster->covariance = Eigen::MatrixXd::Zero(n, n);
    std::vector<double> variance(n, 0.0);
    std::istringstream in(cov->text);
    std::string token;
    int row = 0, col = 0;
    int64_t count = 0;
    const int64_t expected = int64_t{dim} * (band + 1) - int64_t{band} * (band + 1) / 2;
    while (in >> token) {
      double v = 0.0;
      if (!ParseDouble(token, &v)) Fail(*cov, "cov-mat element", token, "a number");
      if (count == expected) {
        Fail(*cov, "cov-mat", "more than " + std::to_string(expected) + " elements",
             std::to_string(expected) + " elements (upper band by rows)");
      }
      const double si = v * unit[row] * unit[col];
      if (row == col) variance[row] = si;
      if (cluster->correlated) cluster->covariance(row, col) = cluster->covariance(col, row) = si;
      ++count;
      ++col;
      if (col > row + band || col >= dim) {
        ++row;
        col = row;
      }
    }
    if (count != expected) {
      Fail(*cov, "cov-mat", std::to_string(count) + " elements",
           std::to_string(expected) + " elements (upper band by rows)");
    }
    const bool positive_definite =
        cluster->correlated ? cluster->covariance.llt().info() == Eigen::Success
                            : std::all_of(variance.begin(), variance.end(), [](double v) { return v > 0; });
    if (!positive_definite) {
      Fail(*cov, "cov-mat", "a matrix that is not positive definite",
           "a positive definite covariance matrix");
    }
    for (int i = 0; i < n; ++i) cluster->observations[i].sigma = std::sqrt(variance[i]);
  }

  void ReadHeightDifferences(const xml::Element& hd) {
    Cluster cluster = ClusterWithoutAttributes(hd, Cluster::Type::kHeightDifferences);
    std::vector<double> unit;
    const xml::Element* cov = ForEachObservation(hd, [&](const xml::Element& e) {
      if (e.name != "dh") Fail(e, "element", "<" + e.name + ">", "<dh> or <cov-mat>");
      CheckAttributes(e, {"from", "to", "val", "stdev", "dist", "extern"});
      Observation o;
      o.kind = ObsKind::kHeightDiff;
      o.line = e.line;
      o.from = Id(e, "from", true);
      o.to = Id(e, "to", true);
      if (o.from == o.to) Fail(e, "dh@to", o.to, "a point different from " + o.from);
      o.value = Number(e, "val", Required(e, "val"));
      if (const std::string* d = e.Attribute("dist")) {
        o.dist_km = Number(e, "dist", *d);
        if (o.dist_km < 0) Fail(e, "dh@dist", *d, "a length >= 0 [km]");
      }
      const std::string* stdev = e.Attribute("stdev");
      const double sigma_mm =
          stdev ? Number(e, "stdev", *stdev) : net_.sigma0_apriori * std::sqrt(o.dist_km);
      if (!(sigma_mm > 0) && !HasCovMat(hd)) {
        Fail(e, "dh@stdev", stdev ? *stdev : std::string("none (and no dist)"),
             "a standard deviation > 0 [mm], or dist [km] > 0");
      }
      o.sigma = sigma_mm * kMmToM;
      unit.push_back(kMmToM);
      cluster.observations.push_back(o);
    });
    FinishCluster(&cluster, cov, unit);
    net_.clusters.push_back(std::move(cluster));
  }

  void ReadCoordinates(const xml::Element& c) {
    Cluster cluster = ClusterWithoutAttributes(c, Cluster::Type::kCoordinates);
    std::vector<double> unit;
    const xml::Element* cov = ForEachObservation(c, [&](const xml::Element& e) {
      if (e.name != "point") Fail(e, "element", "<" + e.name + ">", "<point> or <cov-mat>");
      bool xy = false, z = false;
      const std::string* id = e.Attribute("id");
      if (id != nullptr && net_.Find(Trim(*id)) == nullptr) {
        Fail(e, "point@id", *id, "the id of a point defined by <point>");
      }
      SurveyPoint& p = ReadPoint(e, /*in_coordinates=*/true, &xy, &z);
      if (!xy && !z) Fail(e, "point", "no coordinates", "x and y and/or z");
      // The observed coordinates, in the input axes (kept so that the cluster's covariance
      // applies as given).
      const Eigen::Vector2d input_xy = net_.axes.XyFromEn(p.coords.head<2>());
      auto add = [&](ObsKind kind, double value) {
        Observation o;
        o.kind = kind;
        o.line = e.line;
        o.from = p.id;
        o.value = value;
        unit.push_back(kMmToM);
        cluster.observations.push_back(o);
      };
      if (xy) {
        add(ObsKind::kCoordX, input_xy.x());
        add(ObsKind::kCoordY, input_xy.y());
      }
      if (z) add(ObsKind::kCoordZ, p.coords.z());
    });
    if (cov == nullptr) Fail(c, "coordinates", "no <cov-mat>", "a <cov-mat> after the points");
    FinishCluster(&cluster, cov, unit);
    net_.clusters.push_back(std::move(cluster));
  }

  void ReadVectors(const xml::Element& v) {
    Cluster cluster = ClusterWithoutAttributes(v, Cluster::Type::kVectors);
    std::vector<double> unit;
    const xml::Element* cov = ForEachObservation(v, [&](const xml::Element& e) {
      if (e.name != "vec") Fail(e, "element", "<" + e.name + ">", "<vec> or <cov-mat>");
      CheckAttributes(e, {"from", "to", "dx", "dy", "dz", "from_dh", "to_dh", "extern"});
      Observation o;
      o.line = e.line;
      o.from = Id(e, "from", true);
      o.to = Id(e, "to", true);
      if (o.from == o.to) Fail(e, "vec@to", o.to, "a point different from " + o.from);
      o.from_dh = Height(e, "from_dh", 0.0);
      o.to_dh = Height(e, "to_dh", 0.0);
      const ObsKind kinds[3] = {ObsKind::kVectorX, ObsKind::kVectorY, ObsKind::kVectorZ};
      const char* names[3] = {"dx", "dy", "dz"};
      for (int k = 0; k < 3; ++k) {
        o.kind = kinds[k];
        o.value = Number(e, names[k], Required(e, names[k]));
        unit.push_back(kMmToM);
        cluster.observations.push_back(o);
      }
    });
    if (cov == nullptr) Fail(v, "vectors", "no <cov-mat>", "a <cov-mat> after the vectors");
    FinishCluster(&cluster, cov, unit);
    net_.clusters.push_back(std::move(cluster));
  }

  std::string file_;
  SurveyNetwork net_;
  double distance_a_ = 0.0, distance_b_ = 0.0, distance_c_ = 1.0;
  double direction_sigma_ = 0.0, angle_sigma_ = 0.0, zenith_sigma_ = 0.0, azimuth_sigma_ = 0.0;
};

}  // namespace

bool ParseDms(const std::string& text, double* degrees) {
  // [-]d-m-s with integer d and m, decimal s (Gama's deg2gon).
  std::string s = text;
  bool negative = false;
  if (!s.empty() && (s[0] == '-' || s[0] == '+')) {
    negative = s[0] == '-';
    s = s.substr(1);
  }
  const size_t a = s.find('-');
  if (a == std::string::npos) return false;
  const size_t b = s.find('-', a + 1);
  if (b == std::string::npos) return false;
  int64_t d = 0, m = 0;
  double sec = 0.0;
  if (!ParseInt(s.substr(0, a), &d) || !ParseInt(s.substr(a + 1, b - a - 1), &m) ||
      !ParseDouble(s.substr(b + 1), &sec)) {
    return false;
  }
  if (d < 0 || m < 0 || m >= 60 || sec < 0 || sec > 60) return false;  // Gama accepts 60 s
  const double value = static_cast<double>(d) + static_cast<double>(m) / 60.0 + sec / 3600.0;
  *degrees = negative ? -value : value;
  return true;
}

survey::SurveyNetwork ParseGamaLocal(const std::string& text, const std::string& file) {
  return GamaReader(file).Read(text);
}

survey::SurveyNetwork ReadGamaLocal(const std::string& path) {
  return ParseGamaLocal(ReadWholeFile(path), path);
}

}  // namespace mmba::io
