// The projection of OpenDroneMap gcp_list.txt files named by photo_measurements sensors: the
// project's crs (docs/project-yaml.md, `gcp_list`).
#include <filesystem>
#include <memory>

#include "mmba/core/error.h"
#include "mmba/io/odm_gcp_list.h"
#include "project_internal.h"

namespace mmba::adjust::project_internal {

namespace fs = std::filesystem;

bool ApplyGcpListCrs(const io::YamlReader& r, const YAML::Node& root, bool have_origin, Project* project) {
  bool origin_set = false;
  for (const PhotoMeasurements& p : project->photo_measurements) {
    if (p.gcp_list.empty()) continue;
    if (project->frame == WorldFrame::kCartesian) {
      r.Fail(root["frame"], "frame", "local_tangent_plane (a gcp_list gives coordinates in a projection)", "cartesian");
    }
    const io::GcpList list = io::ReadOdmGcpList(p.gcp_list);
    const std::string where = p.gcp_list + ":" + std::to_string(list.crs_line) + ": field 'projection'";
    auto crs = std::make_shared<const geodesy::Crs>(list.crs, where);
    if (!project->crs) {
      project->crs = crs;
      project->crs_line = p.gcp_list_line;
    } else {
      const bool same = project->crs->definition() == crs->definition() ||
                        (!crs->identifier().empty() && crs->identifier() == project->crs->identifier());
      if (!same) {
        const std::string project_crs = project->crs->identifier().empty() ? project->crs->definition() : project->crs->identifier();
        throw InputError(p.gcp_list, list.crs_line, "projection", list.crs,
                         "the project's crs " + project_crs + " (convert the GCP coordinates or the project's crs)");
      }
    }
    // The origin from the GCPs only where SetCrsOrigin has no control of its own to take it from.
    if (have_origin || origin_set || !project->total_stations.empty() || project->control) continue;
    std::vector<Eigen::Vector3d> points;
    for (const io::GcpObservation& o : list.observations) points.push_back(o.geo);
    project->origin = geodesy::OriginOfCrsPoints(*project->crs, points);
    project->origin_source = "mean of the " + std::to_string(points.size()) + " GCP measurement(s) of " +
                             fs::path(p.gcp_list).filename().string() + " in the crs";
    origin_set = true;
  }
  return origin_set;
}

}  // namespace mmba::adjust::project_internal
