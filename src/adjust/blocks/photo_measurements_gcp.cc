// A photo_measurements sensor's OpenDroneMap gcp_list.txt: its image measurements join the
// block's, its points join the control (docs/project-yaml.md, `gcp_list`).
#include <filesystem>
#include <set>

#include "blocks.h"
#include "photo_measurements.h"
#include "mmba/core/error.h"
#include "mmba/io/odm_gcp_list.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;

namespace {

/// The block's image id of a gcp_list image name: an id or file name of the images list, an
/// image id of the measurement files, or (with neither) a photo next to the gcp_list or in
/// its images/ folder. InputError naming the gcp_list's line otherwise.
std::string ImageIdOf(const io::GcpObservation& o, const std::string& file, const std::map<std::string, std::string>& image_files,
                      const std::set<std::string>& measured) {
  if (image_files.count(o.image) || measured.count(o.image)) return o.image;
  for (const auto& [id, name] : image_files) {
    if (name == o.image || fs::path(name).filename() == o.image) return id;
  }
  const fs::path dir = fs::path(file).parent_path();
  const bool on_disk = fs::exists(dir / o.image) || fs::exists(dir / "images" / o.image);
  if (image_files.empty() && measured.empty() && on_disk) return o.image;
  throw InputError(file, o.line, "image_name", o.image,
                   image_files.empty() && measured.empty()
                       ? "a photo next to the gcp_list or in its images/ folder"
                       : "an image of the sensor's images list or measurement files");
}

}  // namespace

void AppendGcpMeasurements(const PhotoMeasurements& p, const sensors::Camera& camera,
                           const std::map<std::string, std::string>& image_files, std::vector<io::ImageMeasurement>* all) {
  if (p.gcp_list.empty()) return;
  std::set<std::string> measured;
  for (const io::ImageMeasurement& m : *all) measured.insert(m.image_id);
  for (const io::GcpObservation& o : io::ReadOdmGcpList(p.gcp_list).observations) {
    io::ImageMeasurement m;
    m.point_id = o.point_id;
    m.image_id = ImageIdOf(o, p.gcp_list, image_files, measured);
    m.xy_px = o.xy_px;
    m.sigma_px = Eigen::Vector2d::Constant(p.gcp_sigma_px);
    m.file = p.gcp_list;
    m.line = o.line;
    io::CheckInsideImage(m, camera.width, camera.height);
    all->push_back(std::move(m));
  }
}

void AppendGcpControl(const Project& project, std::map<std::string, io::ControlPoint>* control) {
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(project);
  for (const PhotoMeasurements& p : project.photo_measurements) {
    if (p.gcp_list.empty()) continue;
    for (const io::GcpObservation& o : io::ReadOdmGcpList(p.gcp_list).observations) {
      io::ControlPoint c;
      c.id = o.point_id;
      c.xyz_m = crs->WorldFromCrs(o.geo);  // ApplyGcpListCrs made the projection the project's crs
      c.sigma_m = Eigen::Vector3d::Constant(p.gcp_sigma_m);
      c.line = o.line;
      c.file = p.gcp_list;
      const auto [it, inserted] = control->emplace(c.id, c);
      if (!inserted && it->second.file != p.gcp_list) {
        throw InputError(p.gcp_list, o.line, "gcp_name", c.id,
                         "a point not also in the control file " + it->second.file + " (line " + std::to_string(it->second.line) + ")");
      }
    }
  }
}

}  // namespace mmba::adjust::internal
