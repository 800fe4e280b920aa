// Project keys of coordinate reference systems: `crs` and `geoid_grid` (docs/project-yaml.md),
// and the origin derived from the control when `crs` is given without `origin`.
#include <filesystem>

#include "mmba/core/error.h"
#include "mmba/io/control_points.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/survey_csv.h"
#include "project_internal.h"

namespace mmba::adjust::project_internal {
namespace {

namespace fs = std::filesystem;

/// The CRS coordinates of the control: the total-station network's points with plane
/// coordinates (given or approximate) (points without a height take the mean height of the others, 0 without any),
/// else the `control` file's points.
std::vector<Eigen::Vector3d> ControlInCrs(const Project& project, std::string* source) {
  std::vector<Eigen::Vector3d> points;
  if (!project.total_stations.empty()) {
    const std::string& file = project.total_stations.front().file;
    const survey::SurveyNetwork net =
        fs::path(file).extension() == ".csv" ? io::ReadSurveyCsv(file) : io::ReadGamaLocal(file);
    if (net.geodetic) {
      throw InputError::Message(project.path + ":" + std::to_string(project.crs_line) + ": field 'crs'",
                                file + " is already georeferenced (an origin record); expected plane coordinates in " +
                                    project.crs->name());
    }
    double height_sum = 0.0;
    int heights = 0;
    for (const survey::SurveyPoint& p : net.points) {
      if (p.has_z) height_sum += p.coords.z(), ++heights;
    }
    for (const survey::SurveyPoint& p : net.points) {
      if (!p.has_xy) continue;
      points.emplace_back(p.coords.x(), p.coords.y(), p.has_z ? p.coords.z() : heights ? height_sum / heights : 0.0);
    }
    *source = file;
  } else if (project.control) {
    const ControlFile& c = *project.control;
    for (const io::ControlPoint& p :
         io::ReadControlPoints(c.file, c.columns, c.sigma_m >= 0 ? std::optional<double>(c.sigma_m) : std::nullopt)) {
      points.push_back(p.xyz_m);
    }
    *source = c.file;
  }
  return points;
}

}  // namespace

void ReadCrs(const io::YamlReader& r, const YAML::Node& crs, const YAML::Node& grid, Project* project) {
  if (!crs && grid) r.Fail(grid, "geoid_grid", "a crs key too (the grid turns the CRS's orthometric heights into ellipsoidal ones)", "no crs");
  if (!crs) return;
  const std::string definition = r.String(crs, "crs");
  const std::string grid_file = grid ? ExistingFile(r, grid, "geoid_grid", project->dir) : std::string();
  project->crs_line = crs.Mark().line + 1;
  const std::string where = r.path() + ":" + std::to_string(project->crs_line) + ": field 'crs'";
  project->crs = std::make_shared<const geodesy::Crs>(definition, where, grid_file);
}

void SetCrsOrigin(const io::YamlReader& r, const YAML::Node& root, bool have_origin, Project* project) {
  if (!project->crs) return;
  if (project->frame == WorldFrame::kCartesian) {
    r.Fail(root["frame"], "frame", "local_tangent_plane (the world is the tangent plane of the crs's datum)", "cartesian");
  }
  if (have_origin) return;
  std::string source;
  const std::vector<Eigen::Vector3d> points = ControlInCrs(*project, &source);
  if (points.empty()) {
    r.Fail(root["crs"], "crs", "an origin key, or control coordinates in the crs (a total_station network or a control file) to place the origin at their mean", "neither");
  }
  project->origin = geodesy::OriginOfCrsPoints(*project->crs, points);
  project->origin_source = "mean of " + std::to_string(points.size()) + " point(s) of " +
                           fs::path(source).filename().string() + " in the crs";
}

}  // namespace mmba::adjust::project_internal
