// GeoJSON of the adjusted points with their 95 % ellipses and of the camera positions
// (geojson_output.h).
#include "geojson_output.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <proj.h>
#include <proj_experimental.h>

#include "blocks/photo_measurements.h"
#include "output_support.h"

namespace mmba::adjust::internal {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

/// sqrt(χ²(2, 0.95)) = sqrt(5.9915): a plan standard ellipse's semi-axes to the 95 % region.
constexpr double k95Ellipse2d = 2.4477;
constexpr int kEllipseVertices = 72;

/// `v` rounded to a multiple of 1 / `per_unit`.
double Round(double v, double per_unit) { return std::round(v * per_unit) / per_unit; }

/// World (tangent plane) → WGS84 longitude, latitude, ellipsoidal height. The plane's
/// geodetic coordinates are on the project crs's datum when there is one; PROJ transforms
/// them to WGS84 (EPSG:4979) by the operation it ranks first for the area.
class Wgs84FromWorld {
 public:
  explicit Wgs84FromWorld(const JointState& s) : plane_(&s.plane) {
    if (!s.project->crs) return;
    ctx_ = proj_context_create();
    proj_log_level(ctx_, PJ_LOG_NONE);
    PJ* crs = proj_create(ctx_, s.project->crs->wkt().c_str());
    PJ* geodetic = crs ? proj_crs_get_geodetic_crs(ctx_, crs) : nullptr;
    PJ* geodetic3d = geodetic ? proj_crs_promote_to_3D(ctx_, nullptr, geodetic) : nullptr;
    PJ* wgs84 = proj_create(ctx_, "EPSG:4979");
    PJ* raw = (geodetic3d && wgs84) ? proj_create_crs_to_crs_from_pj(ctx_, geodetic3d, wgs84, nullptr, nullptr) : nullptr;
    if (raw) op_ = proj_normalize_for_visualization(ctx_, raw);
    for (PJ* p : {crs, geodetic, geodetic3d, wgs84, raw}) {
      if (p) proj_destroy(p);
    }
  }
  ~Wgs84FromWorld() {
    if (op_) proj_destroy(op_);
    if (ctx_) proj_context_destroy(ctx_);
  }
  Wgs84FromWorld(const Wgs84FromWorld&) = delete;
  Wgs84FromWorld& operator=(const Wgs84FromWorld&) = delete;

  /// False when a crs is given and PROJ has no operation to WGS84: the coordinates are then
  /// on the crs's datum.
  bool on_wgs84() const { return ctx_ == nullptr || op_ != nullptr; }

  /// [longitude, latitude, height] (degrees, degrees, m).
  json operator()(const Eigen::Vector3d& point_in_world) const {
    geodesy::Geodetic g = plane_->GeodeticFromEnu(point_in_world);
    if (op_) {
      const PJ_COORD out = proj_trans(op_, PJ_FWD, proj_coord(g.longitude_deg, g.latitude_deg, g.height_m, 0.0));
      if (std::isfinite(out.xyz.x) && std::isfinite(out.xyz.y) && std::abs(out.xyz.x) < 1e300) {
        g.longitude_deg = out.xyz.x;
        g.latitude_deg = out.xyz.y;
        g.height_m = out.xyz.z;
      }
    }
    // 1e-10 deg (10 µm) and 0.1 mm: a sub-millimetre ellipse keeps its shape, and the text
    // holds no more digits than that (RFC 7946 §11.2).
    return json::array({Round(g.longitude_deg, 1e10), Round(g.latitude_deg, 1e10), Round(g.height_m, 1e4)});
  }

 private:
  const geodesy::LocalTangentPlane* plane_;
  PJ_CONTEXT* ctx_ = nullptr;
  PJ* op_ = nullptr;
};

json PointFeature(const json& coordinates, json properties) {
  return {{"type", "Feature"}, {"geometry", {{"type", "Point"}, {"coordinates", coordinates}}},
          {"properties", std::move(properties)}};
}

/// The point's Feature and its 95 % plan ellipse's Polygon Feature.
void AddPoint(const Wgs84FromWorld& wgs84, const std::string& id, const std::string& role, const Eigen::Vector3d& x,
              const Eigen::Matrix3d& cov, json* features) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(cov.topLeftCorner<2, 2>());
  const Eigen::Vector2d axes = k95Ellipse2d * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();  // minor, major
  const Eigen::Vector2d major = eigen.eigenvectors().col(1), minor = eigen.eigenvectors().col(0);
  double azimuth = std::atan2(major.x(), major.y()) * kDeg;  // from north, east positive
  if (azimuth < 0) azimuth += 180.0;
  if (azimuth >= 180.0) azimuth -= 180.0;
  const Eigen::Vector3d sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
  json properties = {{"id", id}, {"role", role}, {"sigma_east_m", sigma.x()}, {"sigma_north_m", sigma.y()},
                     {"sigma_up_m", sigma.z()}, {"ellipse95_a_m", axes.y()}, {"ellipse95_b_m", axes.x()},
                     {"ellipse95_azimuth_deg", azimuth}};
  features->push_back(PointFeature(wgs84(x), properties));
  // Counter-clockwise seen from above (RFC 7946 §3.1.6's right-hand rule): major → minor axis
  // is east → north turned by the ellipse's orientation when det [major minor] > 0.
  const double turn = major.x() * minor.y() - major.y() * minor.x() > 0 ? 1.0 : -1.0;
  json ring = json::array();
  for (int k = 0; k < kEllipseVertices; ++k) {
    const double t = 2.0 * M_PI * k / kEllipseVertices;
    const Eigen::Vector2d d = axes.y() * std::cos(t) * major + turn * axes.x() * std::sin(t) * minor;
    json position = wgs84(x + Eigen::Vector3d(d.x(), d.y(), 0.0));
    position.erase(2);  // a plan figure: longitude, latitude
    ring.push_back(position);
  }
  ring.push_back(ring.front());  // closed: the last position equals the first
  properties["feature"] = "ellipse95";
  features->push_back({{"type", "Feature"}, {"geometry", {{"type", "Polygon"}, {"coordinates", json::array({ring})}}},
                       {"properties", properties}});
}

/// The points of points.csv (WriteSurveyPoints' selection) and of the photo measurements.
json PointFeatures(const JointState& s, const Wgs84FromWorld& wgs84) {
  const Project& project = *s.project;
  json features = json::array();
  if (s.joint) {
    for (const survey::SurveyPoint& p : s.joint->points) {
      const bool check = std::count(project.check_points.begin(), project.check_points.end(), p.id) > 0;
      if (check && !(s.photos && s.photos->check_ids.count(p.id))) continue;
      const Eigen::Vector3d x = check ? s.scene.Point(s.photos->check_ids.at(p.id)) : WorldFromSurvey(*s.joint, p);
      const Eigen::Matrix3d cov = check ? PointCovariance3(s.statistics, s.scene.Point(s.photos->check_ids.at(p.id)).data())
                                        : SurveyPointCovariance(s.statistics, *s.joint, p);
      const std::string role = check ? "check (photos only)" : (p.xy_free() || p.z_free()) ? "adjusted" : "fixed";
      AddPoint(wgs84, p.id, role, x, cov, &features);
    }
  }
  if (s.measured) {
    const MeasurementBlock& b = *s.measured;
    std::set<Point3DId> weighted;
    for (const ControlCoordinate& c : b.control) weighted.insert(c.point);
    for (const auto& [name, id] : b.point_of) {
      const Eigen::Vector3d& x = s.scene.Point(id);
      const Eigen::Matrix3d cov = b.point_covariance.count(id) ? b.point_covariance.at(id) : PointCovariance3(s.statistics, x.data());
      const char* kind = b.fixed_points.count(id) ? "control (fixed)" : weighted.count(id) ? "control (weighted)"
                         : b.check_reference.count(name) ? "check" : "tie";
      AddPoint(wgs84, name, kind, x, cov, &features);
    }
  }
  return features;
}

json CameraFeature(const Wgs84FromWorld& wgs84, const std::string& id, const std::string& sensor, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& sigma) {
  return PointFeature(wgs84(c), {{"id", id}, {"sensor", sensor}, {"sigma_east_m", sigma.x()},
                                 {"sigma_north_m", sigma.y()}, {"sigma_up_m", sigma.z()}});
}

/// The camera centres of poses.csv (photos, spherical stations, rig cameras) and of the photo
/// measurements' images, σ of the centre as there.
json CameraFeatures(const JointState& s, const Wgs84FromWorld& wgs84) {
  json features = json::array();
  const auto sigma_of = [&s](const Rigid3d& pose) {
    return Eigen::Vector3d(CentreCovariance(s.statistics, pose).diagonal().cwiseMax(0.0).cwiseSqrt());
  };
  if (s.photos) {
    for (const auto& [id, image] : s.photos->model.images) {
      const Rigid3d& pose = s.scene.Image(id).cam_from_world;
      features.push_back(CameraFeature(wgs84, image.name, s.photos->config->id, CameraCentre(pose), sigma_of(pose)));
    }
  }
  if (s.measured) {
    const MeasurementBlock& b = *s.measured;
    for (const std::string& name : b.image_names) {
      const Rigid3d& pose = s.scene.Image(b.image_of.at(name)).cam_from_world;
      features.push_back(CameraFeature(wgs84, name, b.config->id, CameraCentre(pose), sigma_of(pose)));
    }
  }
  if (s.spheres) {
    const SphereBlock& sb = *s.spheres;
    for (const auto& [station, id] : sb.lower_image) {
      const Rigid3d& pose = s.scene.Image(id).cam_from_world;
      const Eigen::Vector3d lower = CameraCentre(pose);
      const Eigen::Vector3d upper = CameraCentre(Rigid3d(Eigen::Quaterniond::Identity(), -sb.baseline) * pose);
      features.push_back(CameraFeature(wgs84, station + "_lower", sb.config->id, lower, sigma_of(pose)));
      features.push_back(CameraFeature(wgs84, station + "_upper", sb.config->id, upper, sigma_of(pose)));
    }
  }
  if (s.rig) {
    const RigBlock& rig = *s.rig;
    for (size_t f = 0; f < rig.frame_names.size(); ++f) {
      const Rigid3d& pose = s.scene.RigFrame(FrameId(f));
      for (size_t k = 0; k < rig.cameras.size(); ++k) {
        const Rigid3d cam_from_world = s.scene.CamFromRig(rig.cameras[k]) * pose;
        features.push_back(CameraFeature(wgs84, rig.frame_names[f] + "_" + rig.camera_names[k], rig.config->id,
                                         CameraCentre(cam_from_world), sigma_of(pose)));
      }
    }
  }
  return features;
}

json Collection(const std::string& name, json features) {
  return {{"type", "FeatureCollection"}, {"name", name}, {"features", std::move(features)}};
}

}  // namespace

void WriteGeoJson(const JointState& s, const fs::path& stage, json* files) {
  if (s.project->frame == WorldFrame::kCartesian) return;
  const Wgs84FromWorld wgs84(s);
  const std::string datum =
      wgs84.on_wgs84() ? "WGS84 longitude, latitude, ellipsoidal height"
                       : "longitude, latitude, ellipsoidal height on the datum of " + s.project->crs->name() +
                             " (PROJ has no transformation to WGS84)";
  WriteText(stage / "points.geojson", Collection("points", PointFeatures(s, wgs84)).dump(1) + "\n");
  WriteText(stage / "cameras.geojson", Collection("cameras", CameraFeatures(s, wgs84)).dump(1) + "\n");
  files->push_back({{"name", "points.geojson"},
                    {"description", "adjusted points with sigma and their 95 % plan confidence ellipses as polygons (GeoJSON, " +
                                        datum + ")"}});
  files->push_back({{"name", "cameras.geojson"},
                    {"description", "camera positions with sigma (GeoJSON, " + datum + ")"}});
}

}  // namespace mmba::adjust::internal
