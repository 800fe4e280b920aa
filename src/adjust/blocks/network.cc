// The total-station network and GNSS: the network adjusted alone (the control) and the joint
// network with check points withheld, the GNSS control marks and photo antenna positions, their
// factor groups. The survey groups themselves are mmba_survey's (survey_group.h).
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <Eigen/Geometry>

#include "blocks.h"
#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/io/exif_gps.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io_survey/survey_csv.h"
#include "mmba/survey/result_json.h"
#include "mmba/survey/survey_group.h"

namespace mmba::adjust::internal {

namespace fs = std::filesystem;

Eigen::Vector3d WorldFromSurvey(const survey::SurveyNetwork&, const survey::SurveyPoint& p) { return p.coords; }

Eigen::Matrix3d SurveyPointCovariance(const stats::NetworkStatistics& st, const survey::SurveyNetwork&,
                                      const survey::SurveyPoint& p) {
  double* xy = const_cast<double*>(p.coords.data());
  const std::pair<double*, int> scalars[3] = {{xy, 0}, {xy, 1}, {xy + 2, 0}};
  Eigen::Matrix3d enu = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      enu(a, b) = st.Covariance(scalars[a].first, scalars[a].second, scalars[b].first, scalars[b].second);
    }
  }
  return enu;
}

void LoadNetwork(JointState* s) {
  const Project& project = *s->project;
  if (project.total_stations.empty()) return;
  const TotalStation& ts = project.total_stations.front();
  const std::string ext = fs::path(ts.file).extension().string();
  survey::SurveyNetwork network = ext == ".csv" ? io::ReadSurveyCsv(ts.file) : io::ReadGamaLocal(ts.file);
  if (const auto crs = ProjectCrsFrame(project)) {  // coordinates in the project's crs → world
    survey::NetworkFromCrs(*crs, project.path + ":" + std::to_string(project.crs_line) + ": crs", &network);
  }
  for (size_t i = 0; i < project.check_points.size(); ++i) {
    if (!network.Find(project.check_points[i])) {
      throw InputError::Message(project.path, "check_points[" + std::to_string(i) + "]: found " +
                                                  project.check_points[i] + ", expected a point of " + ts.file);
    }
  }
  for (const survey::SurveyPoint& p : network.points) {
    if (p.xy == survey::CoordStatus::kFixed && p.z == survey::CoordStatus::kFixed) s->surveyed_ids.insert(p.id);
  }
  for (const survey::Cluster& cluster : network.clusters) {
    for (const survey::Observation& o : cluster.observations) {
      if (!o.active) continue;
      for (const std::string* id : {&o.from, &o.to, &o.fs}) {
        if (!id->empty()) s->surveyed_ids.insert(*id);
      }
    }
  }
  for (const survey::SurveyPoint& p : network.points) {
    if (!s->surveyed_ids.count(p.id)) {
      s->warnings.push_back("point " + p.id + " of " + ts.file +
                            " has no total-station observation: not control, not a check point (its coordinates are approximate)");
    }
  }
  // Initialisation step 1: the network alone gives the control coordinates (and, for check
  // points, the surveyed coordinates they are compared with).
  s->surveyed = network;
  survey::SurveyAdjustOptions options;
  options.confidence = project.settings.confidence;
  s->surveyed_adjustment = survey::AdjustNetwork(&*s->surveyed, options);
  if (!s->surveyed_adjustment.converged) {
    throw AdjustFailure(AdjustStatus::kFailed, "total station network " + ts.file + " alone does not adjust: " +
                                      s->surveyed_adjustment.reason);
  }
  Note(s, "total station network alone: " + std::to_string(s->surveyed_adjustment.statistics.num_equations) +
                   " observations, sigma0 ratio " + std::to_string(s->surveyed_adjustment.statistics.sigma0_ratio));
  // The joint network starts from the adjusted coordinates; check points are withheld: their
  // coordinates leave the network and every observation of them is set passive.
  s->joint = *s->surveyed;
  const std::set<std::string> check(project.check_points.begin(), project.check_points.end());
  for (survey::SurveyPoint& p : s->joint->points) {
    if (check.count(p.id)) p.xy = p.z = survey::CoordStatus::kUnused;
  }
  for (survey::Cluster& cluster : s->joint->clusters) {
    for (survey::Observation& o : cluster.observations) {
      if (check.count(o.from) || check.count(o.to) || check.count(o.fs)) {
        o.active = false;
        o.passive_reason = "check point withheld";
      }
    }
  }
}


/// The camera rows of a gnss sensor's `photos`: each image's EXIF GPS position with the
/// sensor's σ, height = EXIF altitude + geoid undulation. An image without a GPS position or
/// altitude is a warning naming it.
void LoadExifCameras(JointState* s, const Gnss& g) {
  std::vector<fs::path> images;
  for (const auto& entry : fs::directory_iterator(g.photos)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    const bool photo = ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff" || ext == ".png";
    if (entry.is_regular_file() && photo) images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  int without = 0;
  for (const fs::path& image : images) {
    const std::optional<io::ExifGps> gps = io::ReadExifGps(image.string());
    if (!gps || !gps->altitude_m) {
      s->warnings.push_back("GNSS " + g.id + ": " + image.string() + " has no EXIF GPS " + (gps ? "altitude" : "position") + ": no camera prior");
      ++without;
      continue;
    }
    const geodesy::Geodetic geo{gps->latitude_deg, gps->longitude_deg, *gps->altitude_m + g.photos_geoid_undulation_m};
    GnssCamera c;
    c.image = image.filename().string();
    c.enu = s->plane.EnuFromGeodetic(geo);
    if (c.enu.norm() > 50000) {
      throw InputError::Message(image.string(), "EXIF GPS position " + std::to_string(geo.latitude_deg) + ", " + std::to_string(geo.longitude_deg) +
                                                    " is more than 50 km from the project origin (expected a photo of the site)");
    }
    c.sigma = {g.photos_sigma_horizontal_m, g.photos_sigma_horizontal_m, g.photos_sigma_vertical_m};
    c.source = image.string() + " (EXIF)";
    s->gnss_camera_rows.push_back(c);
  }
  if (images.empty() || without == static_cast<int>(images.size())) {
    throw InputError::Message(g.photos, "no JPEG, TIFF or PNG photo with an EXIF GPS position and altitude (gnss " + g.id + " photos)");
  }
}

namespace {

/// A GNSS file's coordinate columns: easting_m, northing_m (the project's crs; height_m its
/// height) or latitude_deg, longitude_deg (WGS84, or the crs's datum; height_m ellipsoidal).
bool GnssInCrs(const Project& project, const io::CsvTable& table, const std::string& file) {
  if (table.Has("easting_m") || table.Has("northing_m")) {
    if (!table.Has("easting_m") || !table.Has("northing_m")) {
      throw InputError(file, 1, "(header)", table.Has("easting_m") ? "easting_m without northing_m" : "northing_m without easting_m",
                       "both columns (coordinates in the project's crs)");
    }
    if (!project.crs) {
      throw InputError(file, 1, "(header)", "easting_m, northing_m", "latitude_deg, longitude_deg, or a crs key in " + project.path);
    }
    return true;
  }
  if (!table.Has("latitude_deg") || !table.Has("longitude_deg")) {
    throw InputError(file, 1, "(header)", "no latitude_deg/longitude_deg columns",
                     "latitude_deg, longitude_deg (or easting_m, northing_m with the project's crs)");
  }
  return false;
}

/// A row's latitude, longitude and height, checked.
geodesy::Geodetic GnssGeodetic(const io::CsvTable& table, const io::CsvTable::Row& row) {
  geodesy::Geodetic geo{table.Double(row, "latitude_deg"), table.Double(row, "longitude_deg"), table.Double(row, "height_m")};
  if (std::abs(geo.latitude_deg) > 90) table.Fail(row, "latitude_deg", table.String(row, "latitude_deg"), "[-90, 90] degrees");
  if (std::abs(geo.longitude_deg) > 180) table.Fail(row, "longitude_deg", table.String(row, "longitude_deg"), "[-180, 180] degrees");
  return geo;
}

}  // namespace

void LoadGnss(JointState* s) {
  // Each control mark and each photo's antenna position once over all GNSS files: a second
  // row would silently stand beside (or replace) the first.
  std::map<std::pair<std::string, std::string>, std::string> first_row;  // (kind, id) -> file:line
  for (const Gnss& g : s->project->gnss) {
    if (!g.photos.empty()) {
      LoadExifCameras(s, g);
      continue;
    }
    const io::CsvTable table = io::CsvTable::Read(
        g.file, {"id", "kind", "height_m", "sigma_east_m", "sigma_north_m", "sigma_up_m"});
    const bool in_crs = GnssInCrs(*s->project, table, g.file);
    for (const io::CsvTable::Row& row : table.rows()) {
      const std::string& kind = table.String(row, "kind");
      if (kind == "trajectory") {
        ++s->gnss_trajectory_rows;
        continue;
      }
      if (kind != "control" && kind != "camera") table.Fail(row, "kind", kind, "control, camera or trajectory");
      const auto [first, inserted] =
          first_row.emplace(std::make_pair(kind, table.String(row, "id")), g.file + ":" + std::to_string(row.line));
      if (!inserted) {
        table.Fail(row, "id", table.String(row, "id"), "each " + kind + " id once (also at " + first->second + ")");
      }
      GnssPoint p;
      p.point_id = table.String(row, "id");
      p.enu = in_crs ? ProjectCrsFrame(*s->project)->WorldFromCrs({table.Double(row, "easting_m"),
                                                                   table.Double(row, "northing_m"), table.Double(row, "height_m")})
                     : s->plane.EnuFromGeodetic(GnssGeodetic(table, row));
      if (p.enu.norm() > 50000) {
        const std::string first_column = in_crs ? "easting_m" : "latitude_deg";
        const std::string second_column = in_crs ? "northing_m" : "longitude_deg";
        table.Fail(row, first_column, table.String(row, first_column) + ", " + table.String(row, second_column),
                   "a point within 50 km of the project origin (inconsistent origin or units?)");
      }
      const char* sigma_columns[3] = {"sigma_east_m", "sigma_north_m", "sigma_up_m"};
      for (int a = 0; a < 3; ++a) {
        p.sigma(a) = table.Double(row, sigma_columns[a]);
        if (!(p.sigma(a) > 0 && p.sigma(a) <= 10)) {
          table.Fail(row, sigma_columns[a], table.String(row, sigma_columns[a]), "a σ in (0, 10] m");
        }
      }
      p.source = g.file + ":" + std::to_string(row.line);
      if (kind == "camera") {  // the antenna position of a photo (id = image name)
        GnssCamera c;
        c.image = p.point_id;
        c.enu = p.enu;
        c.sigma = p.sigma;
        c.source = p.source;
        s->gnss_camera_rows.push_back(c);
        continue;
      }
      if (!s->joint || !s->joint->Find(p.point_id)) {
        s->warnings.push_back("GNSS point " + p.point_id + " (" + p.source + ") is not a point of the survey network: not used");
        continue;
      }
      if (std::count(s->project->check_points.begin(), s->project->check_points.end(), p.point_id)) {
        continue;  // withheld with the check point
      }
      s->gnss_points.push_back(p);
    }
  }
  if (s->gnss_trajectory_rows > 0) {
    s->warnings.push_back(std::to_string(s->gnss_trajectory_rows) +
                          " GNSS trajectory rows of the GNSS file not used (the rig and the mobile LiDAR take "
                          "their GNSS/INS poses from their trajectory files)");
  }
}

void AddNetworkGroups(JointState* s, const GroupWeights& w) {
  if (s->joint) {
    for (auto& group : survey::MakeSurveyGroups(&*s->joint, s->project->total_stations.front().loss)) {
      s->builder->AddGroup(std::move(group));
    }
  }
  if (!s->gnss_points.empty()) {
    s->builder->AddGroup(std::make_unique<GnssPointGroup>(&*s->joint, w.Scaled(kGnss, s->gnss_points),
                                                          s->project->gnss.front().loss, kGnss));
  }
}

std::string DescribeNetworkObservation(const JointState& s, const FactorGroup& group, size_t block) {
  const size_t index = group.block_observation_index()[block];
  if (group.name() == kGnss) {
    const GnssPoint& p = s.gnss_points[index / 3];
    return "GNSS " + std::string(index % 3 == 0 ? "east" : index % 3 == 1 ? "north" : "up") + " of " + p.point_id +
           " (" + p.source + ")";
  }
  if (const auto* sg = dynamic_cast<const survey::SurveyGroup*>(&group)) {
    const survey::BlockSpec& spec = sg->added_specs()[block];
    const survey::Cluster& c = s.joint->clusters[spec.cluster];
    const survey::Observation& o = c.observations[spec.observations.front()];
    return std::string(survey::ObsKindName(o.kind)) + " " + o.from + " -> " + o.to + " (" + s.joint->source + ":" +
           std::to_string(o.line) + ")";
  }
  return "";
}

}  // namespace mmba::adjust::internal
