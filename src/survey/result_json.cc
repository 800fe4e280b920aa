// adjusted.json of a survey adjustment (result_json.h).
#include "mmba/survey/result_json.h"

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/geodesy/geodesy.h"
#include "survey/output_units_internal.h"

namespace mmba::survey {
namespace {

using internal::AngleUnit;

// The coordinates removed from the adjustment (undetermined), with the warning's text.
nlohmann::json RemovedPointsJson(const SurveyAdjustment& adj) {
  nlohmann::json removed = nlohmann::json::array();
  for (const RemovedCoordinate& r : adj.removed_points) {
    removed.push_back({{"id", r.point}, {"line", r.line}, {"coordinates", r.coordinates},
                       {"reason", r.reason}});
  }
  return removed;
}

// The network's header entries: input, frame, σ0, dimensions, χ² test.
nlohmann::json NetworkJson(const std::string& input, const SurveyNetwork& net,
                           const SurveyAdjustment& adj, const AngleUnit& unit,
                           const geodesy::CrsFrame* crs) {
  const stats::NetworkStatistics& st = adj.statistics;
  const double m0_apr = net.sigma0_apriori;
  nlohmann::json json = {
      {"input", input},
      {"description", net.description},
      {"axes_xy", net.axes.code},
      {"angles", net.angles_left_handed ? "left-handed" : "right-handed"},
      {"angle_unit", unit.name()},
      {"sigma0_apriori", m0_apr},
      {"sigma0_aposteriori", m0_apr * st.sigma0_ratio},
      {"sigma0_ratio", st.sigma0_ratio},
      {"sigma0_used", net.sigma_act_apriori ? "apriori" : "aposteriori"},
      {"degrees_of_freedom", st.degrees_of_freedom},
      {"equations", st.num_equations},
      {"unknowns", st.num_unknowns},
      {"defect", st.defect},
      {"datum", adj.datum},
      {"confidence", st.confidence},
      {"chi2_lower", st.chi2_lower},
      {"chi2_upper", st.chi2_upper},
      {"chi2_test_passed", st.chi2_passed},
      {"critical_value", st.critical_value},
      {"iterations", adj.iterations},
      {"removed_observations", adj.removed},
      {"removed_points", RemovedPointsJson(adj)},
  };
  if (net.geodetic) {
    json["origin"] = {{"latitude_deg", net.origin.latitude_deg},
                      {"longitude_deg", net.origin.longitude_deg},
                      {"height_m", net.origin.height_m}};
    json["frame"] = "local tangent plane (ENU) at the origin, station verticals";
    if (crs) {
      json["crs"] = CrsToJson(crs->crs());
      json["frame"] = "coordinates in " + crs->crs().name() + "; adjusted in the local tangent plane (ENU) at the origin on its datum, station verticals";
    }
  } else {
    json["frame"] = "input plane (gama-local)";
  }
  return json;
}

// WGS84 geodetic and UTM coordinates of an adjusted point of a georeferenced network.
void AddGeoreferencedCoordinates(const SurveyNetwork& net, const SurveyPoint& p,
                                 nlohmann::json* jp) {
  const geodesy::LocalTangentPlane plane(net.origin);
  const Eigen::Vector3d enu(p.coords.x(), p.coords.y(), p.has_z ? p.coords.z() : 0.0);
  const geodesy::Geodetic g = plane.GeodeticFromEnu(enu);
  (*jp)["latitude_deg"] = g.latitude_deg;
  (*jp)["longitude_deg"] = g.longitude_deg;
  if (p.has_z) (*jp)["ellipsoidal_height_m"] = g.height_m;
  const geodesy::Utm utm = geodesy::UtmFromGeodetic(g);
  (*jp)["utm"] = {{"zone", utm.zone}, {"north", utm.northp}, {"easting", utm.easting_m},
                  {"northing", utm.northing_m}};
}

// A point of a network given in a CRS: x, y, z replaced by the CRS's coordinates (in the input
// axes), the tangent-plane coordinates kept as `local`, geodetic coordinates on the CRS's datum
// and the grid factors there.
void AddCrsCoordinates(const SurveyNetwork& net, const geodesy::CrsFrame& crs,
                       const SurveyPoint& p, nlohmann::json* jp) {
  const Eigen::Vector3d xyz = crs.CrsFromWorld(p.coords);
  const Eigen::Vector2d xy = net.axes.XyFromEn(xyz.head<2>());
  (*jp)["local"] = {{"east_m", p.coords.x()}, {"north_m", p.coords.y()}};
  if (p.xy != CoordStatus::kUnused) {
    (*jp)["x"] = xy.x();
    (*jp)["y"] = xy.y();
  }
  if (p.has_z) {
    (*jp)["local"]["up_m"] = p.coords.z();
    if (p.z != CoordStatus::kUnused) (*jp)["z"] = xyz.z();
  }
  const geodesy::Geodetic g = crs.GeodeticFromWorld(p.coords);
  (*jp)["latitude_deg"] = g.latitude_deg;
  (*jp)["longitude_deg"] = g.longitude_deg;
  if (p.has_z) (*jp)["ellipsoidal_height_m"] = g.height_m;
  const geodesy::PointFactors f = geodesy::FactorsAt(crs.crs(), g);
  (*jp)["grid"] = {{"point_scale", f.point_scale}, {"elevation_factor", f.elevation_factor},
                   {"combined_scale", f.combined_scale}, {"convergence_deg", f.convergence_deg}};
}

// One adjusted point: coordinates in the input axes, status, σ, standard and confidence
// ellipses (major axis angle from +x towards +y, Gama's convention, input unit), geodetic
// coordinates when georeferenced, and the standard ellipsoid's axes.
nlohmann::json PointJson(const SurveyNetwork& net, const SurveyAdjustment& adj,
                         const SurveyPoint& p, const AngleUnit& unit,
                         const geodesy::CrsFrame* crs) {
  nlohmann::json jp;
  jp["id"] = p.id;
  const Eigen::Vector2d xy = net.axes.XyFromEn(p.coords.head<2>());
  const Eigen::Matrix3d cov = PointCovariance(adj, net, p);
  if (p.xy == CoordStatus::kRemoved) jp["status_x"] = jp["status_y"] = CoordStatusName(p.xy);
  if (p.z == CoordStatus::kRemoved) jp["status_z"] = CoordStatusName(p.z);
  if (p.xy != CoordStatus::kUnused && p.has_xy) {
    jp["x"] = xy.x();
    jp["y"] = xy.y();
    jp["status_x"] = jp["status_y"] = CoordStatusName(p.xy);
    if (p.xy_free()) {
      jp["sigma_x"] = std::sqrt(cov(0, 0));
      jp["sigma_y"] = std::sqrt(cov(1, 1));
      const stats::ErrorEllipse e = stats::StandardEllipse(cov.topLeftCorner<2, 2>());
      jp["ellipse_a"] = e.a;
      jp["ellipse_b"] = e.b;
      jp["ellipse_azimuth"] = unit.FromRad(e.angle_rad);
      const double k = std::sqrt(stats::ChiSquareQuantile(adj.statistics.confidence, 2));
      jp["confidence_ellipse_a"] = k * e.a;
      jp["confidence_ellipse_b"] = k * e.b;
    }
  }
  if (p.z != CoordStatus::kUnused && p.has_z) {
    jp["z"] = p.coords.z();
    jp["status_z"] = CoordStatusName(p.z);
    if (p.z_free()) jp["sigma_z"] = std::sqrt(cov(2, 2));
  }
  if (crs && p.has_xy) {
    AddCrsCoordinates(net, *crs, p, &jp);
  } else if (net.geodetic && p.has_xy) {
    AddGeoreferencedCoordinates(net, p, &jp);
  }
  if (p.xy_free() && p.z_free()) {
    Eigen::Vector3d axes_m;
    Eigen::Matrix3d dirs;
    stats::StandardEllipsoid(cov, &axes_m, &dirs);
    jp["ellipsoid_axes"] = {axes_m(0), axes_m(1), axes_m(2)};
  }
  return jp;
}

}  // namespace

nlohmann::json ResultToJson(const std::string& input, const SurveyNetwork& net,
                            const SurveyAdjustment& adj, const geodesy::CrsFrame* crs) {
  const AngleUnit unit{net.output_gons};
  nlohmann::json json = NetworkJson(input, net, adj, unit, crs);
  nlohmann::json points = nlohmann::json::array();
  for (const SurveyPoint& p : net.points) {
    if (p.xy == CoordStatus::kUnused && p.z == CoordStatus::kUnused) continue;
    points.push_back(PointJson(net, adj, p, unit, crs));
  }
  json["points"] = points;
  nlohmann::json orientations = nlohmann::json::array();
  for (const Cluster& c : net.clusters) {
    if (c.type != Cluster::Type::kStandpoint || !c.has_orientation) continue;
    const double o = net.angles_left_handed ? c.orientation : -c.orientation;
    orientations.push_back({{"station", c.station}, {"line", c.line},
                            {"orientation", internal::Full(unit.FromRad(o), unit.FullTurn())}});
  }
  json["orientations"] = orientations;
  nlohmann::json groups = nlohmann::json::array();
  for (const stats::GroupStatistic& g : adj.statistics.groups) {
    groups.push_back({{"name", g.name}, {"observations", g.rows},
                      {"redundancy", g.redundancy},
                      {"variance_component", g.variance_component},
                      {"sigma0_ratio", std::sqrt(g.variance_component)}});
  }
  json["variance_components"] = groups;
  return json;
}

nlohmann::json CrsToJson(const geodesy::Crs& crs) {
  const std::string& id = crs.identifier();
  nlohmann::json epsg = nullptr;
  if (id.rfind("EPSG:", 0) == 0 && id.find('+') == std::string::npos) epsg = std::stoi(id.substr(5));
  return {{"definition", crs.definition()},
          {"identifier", id},
          {"epsg", epsg},
          {"name", crs.name()},
          {"wkt", crs.wkt()},
          {"axes", crs.is_geographic() ? "longitude_deg, latitude_deg, height_m" : "easting_m, northing_m, height_m"},
          {"height_kind", geodesy::HeightKindName(crs.height_kind())},
          {"geoid_grid", crs.geoid_grid().empty() ? nlohmann::json(nullptr)
                                                  : nlohmann::json(std::filesystem::path(crs.geoid_grid()).filename().string())}};
}

std::string CrsPointsMarkdown(const SurveyNetwork& net, const geodesy::CrsFrame& frame) {
  const geodesy::Crs& crs = frame.crs();
  std::ostringstream md;
  md << std::fixed << "\n## Coordinates in " << crs.name()
     << (crs.identifier().empty() ? "" : " (" + crs.identifier() + ")") << "\n\n"
     << "Heights: " << geodesy::HeightKindName(crs.height_kind())
     << (crs.height_kind() == geodesy::HeightKind::kAsGiven ? " (a 2-D CRS: taken as ellipsoidal heights)" : "")
     << ". The network was adjusted in the local "
     << "tangent plane at latitude " << std::setprecision(9) << frame.origin().latitude_deg << "°, longitude "
     << frame.origin().longitude_deg << "°, h " << std::setprecision(3) << frame.origin().height_m
     << " m (the mean of its points, on the CRS's datum): the table above is in that plane (x, y in the input's "
     << "axes); observed distances are ground distances, and a horizontal ground distance times the combined "
     << "scale is the grid distance.\n\n"
     << "| point | x [m] | y [m] | z [m] | latitude [°] | longitude [°] | h [m] | combined scale |\n"
     << "|---|---|---|---|---|---|---|---|\n";
  for (const SurveyPoint& p : net.points) {
    if (!p.has_xy || (p.xy == CoordStatus::kUnused && p.z == CoordStatus::kUnused)) continue;
    const Eigen::Vector3d xyz = frame.CrsFromWorld(p.coords);
    const Eigen::Vector2d xy = net.axes.XyFromEn(xyz.head<2>());
    const geodesy::Geodetic g = frame.GeodeticFromWorld(p.coords);
    md << "| `" << p.id << "` | " << internal::Fixed(xy.x(), 4) << " | " << internal::Fixed(xy.y(), 4) << " | "
       << (p.has_z ? internal::Fixed(xyz.z(), 4) : "") << " | " << internal::Fixed(g.latitude_deg, 9) << " | "
       << internal::Fixed(g.longitude_deg, 9) << " | " << (p.has_z ? internal::Fixed(g.height_m, 4) : "") << " | "
       << internal::Fixed(geodesy::FactorsAt(crs, g).combined_scale, 8) << " |\n";
  }
  return md.str();
}

void NetworkFromCrs(const geodesy::CrsFrame& frame, const std::string& where, SurveyNetwork* net) {
  if (net->geodetic) {
    throw InputError::Message(where, net->source + " is already georeferenced (an origin record); " +
                                         "expected plane coordinates in " + frame.crs().name());
  }
  for (const Cluster& c : net->clusters) {
    if (c.type == Cluster::Type::kCoordinates || c.type == Cluster::Type::kVectors) {
      throw InputError(net->source, c.line, c.type == Cluster::Type::kVectors ? "vectors" : "coordinates",
                       "an observed coordinate or vector set",
                       "directions, angles, distances, zenith angles, azimuths and height differences only with " + where);
    }
  }
  double height_sum = 0.0;
  int heights = 0;
  for (const SurveyPoint& p : net->points) {
    if (p.has_z) height_sum += p.coords.z(), ++heights;
  }
  const double default_height = heights ? height_sum / heights : 0.0;
  const Eigen::Vector3d origin_in_crs = frame.CrsFromWorld(Eigen::Vector3d::Zero());
  for (SurveyPoint& p : net->points) {
    if (p.has_xy) {
      const Eigen::Vector3d xyz(p.coords.x(), p.coords.y(), p.has_z ? p.coords.z() : default_height);
      p.coords = frame.WorldFromCrs(xyz);
    } else if (p.has_z) {  // a height alone: its up coordinate above the origin's plumb line
      p.coords.z() = frame.WorldFromCrs({origin_in_crs.x(), origin_in_crs.y(), p.coords.z()}).z();
    }
  }
  net->geodetic = true;
  net->origin = frame.origin();
}

}  // namespace mmba::survey

