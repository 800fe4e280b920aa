#include "mmba/io_survey/gama_local_writer.h"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "mmba/core/xml_escape.h"

namespace mmba::io {
namespace {

using survey::CoordStatus;
using survey::ObsKind;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadToGon = 200.0 / kPi;

std::string Num(const char* format, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, v);
  return buffer;
}

/// The gama-local element of a standpoint observation.
const char* ElementName(ObsKind kind) {
  switch (kind) {
    case ObsKind::kDirection: return "direction";
    case ObsKind::kAngle: return "angle";
    case ObsKind::kDistance: return "distance";
    case ObsKind::kSlopeDistance: return "s-distance";
    case ObsKind::kZenithAngle: return "z-angle";
    case ObsKind::kAzimuth: return "azimuth";
    default: throw std::invalid_argument("GamaLocalText: not an observation of <obs>");
  }
}

std::string Codes(const survey::SurveyPoint& p) {
  std::string fix, adj;
  if (p.xy == CoordStatus::kFixed) fix += "xy";
  if (p.z == CoordStatus::kFixed) fix += "z";
  if (p.xy == CoordStatus::kAdjusted) adj += "xy";
  if (p.xy == CoordStatus::kConstrained) adj += "XY";
  if (p.z == CoordStatus::kAdjusted) adj += "z";
  if (p.z == CoordStatus::kConstrained) adj += "Z";
  std::string out;
  if (!fix.empty()) out += " fix=\"" + fix + "\"";
  if (!adj.empty()) out += " adj=\"" + adj + "\"";
  return out;
}

void WritePoint(const survey::SurveyNetwork& net, const survey::SurveyPoint& p, std::ostream& out) {
  out << "<point id=\"" << XmlEscape(p.id) << "\"";
  if (p.has_xy) {
    const Eigen::Vector2d xy = net.axes.XyFromEn(p.coords.head<2>());
    out << " x=\"" << Num("%.6f", xy.x()) << "\" y=\"" << Num("%.6f", xy.y()) << "\"";
  }
  if (p.has_z) out << " z=\"" << Num("%.6f", p.coords.z()) << "\"";
  out << Codes(p) << "/>\n";
}

void WriteObservation(const survey::SurveyNetwork& net, const survey::Observation& o,
                      double default_from_dh, std::ostream& out) {
  const bool angle = survey::ObsKindIsAngle(o.kind);
  const double sign = net.angles_left_handed ? 1.0 : -1.0;
  out << "  <" << ElementName(o.kind);
  if (o.kind == ObsKind::kAngle) {
    out << " bs=\"" << XmlEscape(o.to) << "\" fs=\"" << XmlEscape(o.fs) << "\"";
  } else {
    out << " to=\"" << XmlEscape(o.to) << "\"";
  }
  if (angle) {
    double gon = sign * o.value * kRadToGon;
    if (o.kind != ObsKind::kZenithAngle) gon = std::fmod(std::fmod(gon, 400.0) + 400.0, 400.0);
    out << " val=\"" << Num("%.9f", gon) << "\" stdev=\"" << Num("%.6g", o.sigma * kRadToGon * 1e4)
        << "\"";
  } else {
    out << " val=\"" << Num("%.6f", o.value) << "\" stdev=\"" << Num("%.6g", o.sigma * 1e3) << "\"";
  }
  if (o.kind == ObsKind::kAngle) {
    if (o.to_dh != 0) out << " bs_dh=\"" << Num("%.6f", o.to_dh) << "\"";
    if (o.fs_dh != 0) out << " fs_dh=\"" << Num("%.6f", o.fs_dh) << "\"";
  } else if (o.to_dh != 0) {
    out << " to_dh=\"" << Num("%.6f", o.to_dh) << "\"";
  }
  if (o.from_dh != default_from_dh) out << " from_dh=\"" << Num("%.6f", o.from_dh) << "\"";
  out << "/>\n";
}

}  // namespace

std::string GamaLocalText(const survey::SurveyNetwork& net) {
  std::ostringstream out;
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<gama-local xmlns=\"http://www.gnu.org/software/gama/gama-local\">\n"
      << "<network axes-xy=\"" << net.axes.code << "\""
      << (net.angles_left_handed ? "" : " angles=\"right-handed\"") << ">\n"
      << "<description>" << XmlEscape(net.description) << "</description>\n"
      << "<parameters sigma-apr=\"" << Num("%.6g", net.sigma0_apriori) << "\" conf-pr=\""
      << Num("%.6g", net.confidence) << "\" tol-abs=\"" << Num("%.6g", net.tol_abs_mm) << "\""
      << (net.sigma_act_apriori ? " sigma-act=\"apriori\"" : "")
      << (net.output_gons ? "" : " angles=\"360\"") << "/>\n"
      << "<points-observations>\n";
  for (const survey::SurveyPoint& p : net.points) WritePoint(net, p, out);
  for (const survey::Cluster& c : net.clusters) {
    if (c.type != survey::Cluster::Type::kStandpoint || c.correlated) {
      throw std::invalid_argument("GamaLocalText: only uncorrelated standpoint clusters are written");
    }
    const double from_dh = c.observations.empty() ? 0.0 : c.observations.front().from_dh;
    out << "<obs from=\"" << XmlEscape(c.station) << "\"";
    if (from_dh != 0) out << " from_dh=\"" << Num("%.6f", from_dh) << "\"";
    out << ">\n";
    for (const survey::Observation& o : c.observations) WriteObservation(net, o, from_dh, out);
    out << "</obs>\n";
  }
  out << "</points-observations>\n</network>\n</gama-local>\n";
  return out.str();
}

}  // namespace mmba::io
