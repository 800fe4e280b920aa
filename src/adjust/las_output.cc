// LAS 1.4 copies of the output clouds in the project's output CRS (las_output.h).
#include "las_output.h"

#include <utility>

#include "mmba/geodesy/crs.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;

LasOutputFrame::LasOutputFrame(const JointState& s) : s_(&s) {
  const Project& project = *s.project;
  if (project.frame == WorldFrame::kCartesian) {
    local_ = true;
    description_ = "the project's local cartesian frame (m), no CRS record";
    return;
  }
  crs_ = ProjectCrsFrame(project);
  if (crs_) {
    const geodesy::Crs& crs = crs_->crs();
    geographic_ = crs.is_geographic();
    wkt_ = crs.wkt1();
    description_ = (crs.identifier().empty() ? std::string("the project's crs") : crs.identifier()) + " (" +
                   crs.name() + "), heights " + geodesy::HeightKindName(crs.height_kind());
    return;
  }
  const geodesy::Utm origin = geodesy::UtmFromGeodetic(project.origin);
  utm_zone_ = origin.zone;
  // EPSG:326zz / 327zz: WGS 84 / UTM zone zz N / S; zone 0: UPS North 32661 / South 32761.
  const int code = origin.zone == 0 ? (origin.northp ? 32661 : 32761) : (origin.northp ? 32600 : 32700) + origin.zone;
  const std::string id = "EPSG:" + std::to_string(code);
  const geodesy::Crs utm(id, "the LAS output's CRS");
  wkt_ = utm.wkt1();
  description_ = id + " (" + utm.name() + "), heights ellipsoidal (WGS84)";
}

Eigen::Vector3d LasOutputFrame::FromWorld(const Eigen::Vector3d& point_in_world) const {
  if (local_) return point_in_world;
  if (crs_) return crs_->CrsFromWorld(point_in_world);
  const geodesy::Geodetic g = s_->plane.GeodeticFromEnu(point_in_world);
  // UtmFromGeodetic's zone argument forces a UTM zone (>= 1); 0 leaves the UPS as chosen.
  const geodesy::Utm u = geodesy::UtmFromGeodetic(g, utm_zone_ == 0 ? -1 : utm_zone_);
  return Eigen::Vector3d(u.easting_m, u.northing_m, g.height_m);
}

io::PointCloud LasOutputFrame::FromWorld(const io::PointCloud& cloud) const {
  io::PointCloud out = cloud;
  for (Eigen::Vector3d& p : out.points) p = FromWorld(p);
  return out;
}

io::LasWriteOptions LasOutputFrame::Options() const {
  io::LasWriteOptions options;
  options.crs_wkt = wkt_;
  // Degrees: 1e-7 deg is 1.1 cm of latitude; the height then spans ±214 m around the offset.
  if (geographic_) options.scale_m = 1e-7;
  return options;
}

fs::path LasBeside(const fs::path& ply_path) {
  fs::path las = ply_path;
  las.replace_extension(".las");
  return las;
}

std::string WriteLasBeside(const JointState& s, const io::PointCloud& cloud_in_world, const fs::path& ply_path,
                           const std::vector<io::LasExtraField>& extra) {
  const LasOutputFrame frame(s);
  const fs::path las = LasBeside(ply_path);
  io::WriteLas(frame.FromWorld(cloud_in_world), las.string(), frame.Options(), extra);
  return las.filename().string();
}

std::string WriteErrorMapLas(const JointState& s, const io::PointCloud& error_map, const fs::path& ply_path,
                             const std::string& description) {
  io::PointCloud points = error_map;
  io::LasExtraField distance;
  distance.name = "distance_m";
  distance.description = description.substr(0, 32);
  distance.values.assign(error_map.intensity.begin(), error_map.intensity.end());
  points.intensity.clear();
  return WriteLasBeside(s, points, ply_path, {distance});
}

nlohmann::json LasFileEntry(const JointState& s, const std::string& ply_name, const std::string& what) {
  return {{"name", LasBeside(ply_name).string()},
          {"description", "LAS 1.4 of " + ply_name + ": " + what + "; coordinates in " + LasOutputFrame(s).Description()}};
}

}  // namespace mmba::adjust::internal
