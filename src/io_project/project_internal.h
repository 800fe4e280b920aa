// The project reader's parts in their own units (private to mmba_io_project): the keys of
// photogrammetric networks from image measurements (photo_measurements.cc).
#pragma once

#include <string>

#include "mmba/io/yaml_reader.h"
#include "mmba/io_project/project.h"

namespace mmba::adjust::project_internal {

/// `path` (relative to `dir` or absolute) as given in `n`; InputError unless it is an existing
/// file.
std::string ExistingFile(const io::YamlReader& r, const YAML::Node& n, const std::string& field, const std::string& dir);

/// `frame`: `cartesian` or `local_tangent_plane`.
WorldFrame ReadFrame(const io::YamlReader& r, const YAML::Node& n, const std::string& field);
/// `control: {file, columns, sigma_m}`.
ControlFile ReadControl(const io::YamlReader& r, const YAML::Node& n, const std::string& field, const std::string& dir);
/// `scale_bars: [{from, to, distance_m, sigma_m}]`.
std::vector<ScaleBar> ReadScaleBars(const io::YamlReader& r, const YAML::Node& n, const std::string& field);
/// A sensor `type: photo_measurements` (its camera YAML read to resolve `refine`).
PhotoMeasurements ReadPhotoMeasurements(const io::YamlReader& r, const YAML::Node& n, const std::string& field,
                                        const std::string& id, const std::string& dir);
/// The cross-checks of these keys: frame without origin only with `cartesian`; GNSS needs the
/// geodetic frame; check points need a total station or a control file; scale bars and control
/// need a photo_measurements sensor.
void CheckPhotogrammetricKeys(const Project& project, const io::YamlReader& r, const YAML::Node& root,
                              bool have_origin);

/// `crs` and `geoid_grid` (nodes undefined when absent): the CRS parsed by PROJ; an unknown
/// CRS is an InputError naming the file, the line and the value.
void ReadCrs(const io::YamlReader& r, const YAML::Node& crs, const YAML::Node& grid, Project* project);
/// With `crs`: `frame: cartesian` refused; without `origin`, the origin at the mean of the
/// control's CRS coordinates (the total-station network's points, else the control file's).
void SetCrsOrigin(const io::YamlReader& r, const YAML::Node& root, bool have_origin, Project* project);
/// The projection of each photo_measurements sensor's gcp_list is the project's crs: taken
/// as the crs when the project names none, else an InputError unless it is the same CRS.
/// Without `origin`, a total-station network or a control file, the origin is the mean of
/// the GCPs (returns true then).
bool ApplyGcpListCrs(const io::YamlReader& r, const YAML::Node& root, bool have_origin, Project* project);

}  // namespace mmba::adjust::project_internal
