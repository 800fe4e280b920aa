// The common report of `mmba adjust` (report.json → report.html, the terminal summary) and the
// files every adjustment writes (poses.csv, points.csv, observations.csv). Each sensor unit
// (blocks/*.cc) adds its own poses, calibration files and report entries.
#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>

#include "blocks/blocks.h"
#include "blocks/photo_measurements.h"
#include "geojson_output.h"
#include "internal.h"
#include "las_output.h"
#include "mmba/core/version.h"
#include "mmba/report/adjust_report.h"
#include "output_support.h"

namespace mmba::adjust::internal {

nlohmann::json EvaluateTruth(const JointState& s);
// report_points.cc: report.json `points`, `points_file` and `relative_precision`; `observations`;
// `settings`.
void PointsReport(const JointState& s, nlohmann::json* report);
nlohmann::json ObservationsReport(const JointState& s);
nlohmann::json SettingsReport(const JointState& s, const AdjustOptions& options);

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

/// How the variance components treated a group (report.json `groups[].reweighting`).
std::string Reweighting(const JointState& s, const FactorGroup& group, double redundancy) {
  const std::string exemption = VarianceComponentExemption(s, group, redundancy);
  return exemption.empty() ? "variance components" : exemption + ": not re-weighted";
}

/// The whitened residuals of a group (its histogram in the report).
json Histogram(const FactorGroup& group) {
  json values = json::array();
  for (const ObservationResidual& o : group.Evaluate().observations) {
    for (double w : o.whitened) values.push_back(Num(w));
  }
  return values;
}

/// report.json's identification, frame, solver figures, photo block and σ0 tests.
void ReportHeader(const JointState& s, const std::string& status, json* report) {
  const Project& project = *s.project;
  const stats::NetworkStatistics& st = s.statistics;
  (*report)["schema"] = "mmba-adjust-report-1";
  RecordBuild(report);
  (*report)["project"] = project.name;
  // Absolute, so that report.html shows the paths of the run relative to the project folder.
  (*report)["project_file"] = fs::absolute(project.path).lexically_normal().string();
  (*report)["project_dir"] = fs::absolute(project.dir.empty() ? "." : project.dir).lexically_normal().string();
  {
    std::time_t now = std::time(nullptr);
    char buffer[32];
    std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    (*report)["generated_utc"] = buffer;
  }
  (*report)["status"] = status;
  (*report)["origin"] = {{"latitude_deg", project.origin.latitude_deg}, {"longitude_deg", project.origin.longitude_deg},
                      {"height_m", project.origin.height_m}};
  (*report)["origin"]["source"] = project.origin_source;
  const geodesy::Utm origin_utm = geodesy::UtmFromGeodetic(project.origin);
  (*report)["frame"] = "local ENU tangent plane at the project origin (metres); WGS84 and UTM in the CSV files";
  if (project.crs) {
    (*report)["crs"] = CrsJson(*project.crs);
    (*report)["origin"]["datum"] = project.crs->name();
    (*report)["frame"] = "local ENU tangent plane at the project origin on the datum of " + project.crs->name() +
                         " (metres); " + project.crs->name() + " coordinates (" + CrsColumns(*project.crs).substr(1) +
                         "), latitude/longitude on its datum and UTM in the CSV files";
  }
  (*report)["utm_zone"] = std::to_string(origin_utm.zone) + (origin_utm.northp ? "N" : "S");
  (*report)["solver"] = {{"iterations", s.total_iterations}, {"outer_iterations", s.outer_iterations},
                      {"initial_cost", s.solve.initial_cost}, {"final_cost", s.solve.final_cost},
                      {"seconds", s.seconds}};
  if (s.photos) {
    (*report)["photo_block"] = {{"id", s.photos->config->id},
                             {"images", s.photos->model.images.size()},
                             {"tie_points", s.photos->model.points3D.size()},
                             {"georeference", s.photos->georeference}};
    if (!s.photos->registration.is_null()) (*report)["photo_block"]["registration_to_lidar"] = s.photos->registration;
  }
  (*report)["sigma0"] = {{"apriori", 1.0}, {"aposteriori", st.sigma0_ratio}, {"dof", st.degrees_of_freedom},
                      {"confidence", st.confidence}, {"chi2_lower", st.chi2_lower}, {"chi2_upper", st.chi2_upper},
                      {"passed", st.chi2_passed}};
  const stats::NetworkStatistics& given = s.given_weights;
  (*report)["sigma0_given_weights"] = {{"aposteriori", given.sigma0_ratio}, {"dof", given.degrees_of_freedom},
                                    {"chi2_lower", given.chi2_lower}, {"chi2_upper", given.chi2_upper},
                                    {"passed", given.chi2_passed}};
}

/// report.json `groups`: per factor group its residuals, σ, variance component, re-weighting.
json GroupsReport(const JointState& s) {
  const stats::NetworkStatistics& st = s.statistics;
  const stats::NetworkStatistics& given = s.given_weights;
  json groups = json::array();
  const auto& builder_groups = s.builder->groups();
  for (size_t g = 0; g < builder_groups.size(); ++g) {
    const FactorGroup& group = *builder_groups[g];
    const GroupEvaluation e = group.Evaluate();
    double max_norm = 0.0, sigma_sum = 0.0;
    for (const ObservationResidual& o : e.observations) max_norm = std::max(max_norm, o.norm_units);
    for (double sigma : group.block_sigmas()) sigma_sum += sigma;
    const stats::GroupStatistic& gs = st.groups.at(g);
    // Angles in mgon, as surveyors read them (the groups work in radians).
    const bool angle = group.unit() == "rad";
    const double k = angle ? 200000.0 / M_PI : 1.0;
    groups.push_back({{"name", group.name()}, {"unit", angle ? "mgon" : group.unit()}, {"observations", e.num_observations},
                      {"residuals", e.num_residuals}, {"rms", Num(k * e.rms_units)}, {"mean", Num(k * e.mean_norm_units)},
                      {"max", Num(k * max_norm)},
                      {"sigma", group.block_sigmas().empty() ? 0.0 : k * sigma_sum / group.block_sigmas().size()},
                      {"whitened_kind", "components"},
                      {"loss", group.loss().ToString()}, {"outliers", e.num_outliers},
                      {"variance_component", Num(gs.variance_component)}, {"redundancy", Num(gs.redundancy)},
                      {"sigma_factor", s.sigma_factor.count(group.name()) ? s.sigma_factor.at(group.name()) : 1.0},
                      {"reweighting", Reweighting(s, group, gs.redundancy)},
                      {"variance_component_given_weights",
                       g < given.groups.size() ? Num(given.groups[g].variance_component) : 0.0},
                      {"whitened", Histogram(group)}});
  }
  return groups;
}

/// report.json `control_points` (control and check points against their surveyed
/// coordinates) and `check_summary`.
void ControlPointsReport(const JointState& s, json* report) {
  const stats::NetworkStatistics& st = s.statistics;
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(*s.project);
  json control = json::array();
  double check_sum[3] = {0, 0, 0}, expected_sum = 0.0;
  size_t check_count = 0;
  if (s.joint) {
    std::set<std::string> measured;
    if (s.photos) {
      for (const TargetMeasurement& m : s.photos->control) measured.insert(m.point_id);
    }
    for (const survey::SurveyPoint& p : s.joint->points) {
      const survey::SurveyPoint* before = s.surveyed->Find(p.id);
      const bool check = s.photos && s.photos->check_ids.count(p.id);
      if ((!check && !measured.count(p.id)) || !s.surveyed_ids.count(p.id)) continue;
      const Eigen::Vector3d surveyed = WorldFromSurvey(*s.surveyed, *before);
      const Eigen::Matrix3d surveyed_cov = SurveyPointCovariance(s.surveyed_adjustment.statistics, *s.surveyed, *before);
      Eigen::Vector3d adjusted;
      Eigen::Matrix3d cov;
      if (check) {
        const double* point = s.scene.Point(s.photos->check_ids.at(p.id)).data();
        adjusted = s.scene.Point(s.photos->check_ids.at(p.id));
        cov = PointCovariance3(st, point) + surveyed_cov;  // the difference of independent estimates
      } else {
        adjusted = WorldFromSurvey(*s.joint, p);
        cov = SurveyPointCovariance(st, *s.joint, p);
      }
      const Eigen::Vector3d d = adjusted - surveyed;
      const Eigen::Vector3d sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
      control.push_back({{"id", p.id}, {"role", check ? "check" : "control"}, {"surveyed", Vec(surveyed)},
                         {"adjusted", Vec(adjusted)}, {"d", Vec(d)}, {"sigma", Vec(sigma)}, {"ellipse", Ellipse(cov)}});
      if (crs) {
        control.back()["surveyed_crs"] = Vec(crs->CrsFromWorld(surveyed));
        control.back()["adjusted_crs"] = Vec(crs->CrsFromWorld(adjusted));
      }
      if (check) {
        for (int a = 0; a < 3; ++a) check_sum[a] += d(a) * d(a);
        expected_sum += cov.trace();
        ++check_count;
      }
    }
  }
  (*report)["control_points"] = control;
  if (check_count > 0) {
    const Eigen::Vector3d rmse(std::sqrt(check_sum[0] / check_count), std::sqrt(check_sum[1] / check_count),
                               std::sqrt(check_sum[2] / check_count));
    (*report)["check_summary"] = {{"count", check_count}, {"rmse", Vec(rmse)}, {"rmse_3d", rmse.norm()},
                               {"expected_rmse_3d", std::sqrt(expected_sum / check_count)}};
  }
}

/// ",a" with a the ENU azimuth `azimuth_deg` (from true north) from the CRS's grid north at the
/// world point x: a − γ, γ the meridian convergence (grid north γ east of true north), in
/// [0, 180) as an ellipse's axis.
std::string GridAzimuth(const geodesy::CrsFrame& crs, const Eigen::Vector3d& x, double azimuth_deg) {
  double a = std::fmod(azimuth_deg - crs.FactorsAtWorld(x).convergence_deg, 180.0);
  if (a < 0) a += 180.0;
  std::ostringstream out;
  out << "," << std::setprecision(6) << a;
  return out.str();
}

/// points.csv: the surveyed points in the world with σ and error ellipses.
void WriteSurveyPoints(const JointState& s, const fs::path& stage) {
  const Project& project = *s.project;
  const stats::NetworkStatistics& st = s.statistics;
  std::ostringstream points;
  points << "id,role,east_m,north_m,up_m,sigma_east_m,sigma_north_m,sigma_up_m,ellipse_a_m,ellipse_b_m,"
            "ellipse_azimuth_deg,latitude_deg,longitude_deg,height_m,utm_zone,utm_easting_m,utm_northing_m"
         << (project.crs ? CrsColumns(*project.crs) + ",ellipse_azimuth_grid_deg" : "") << "\n";
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(project);
  for (const survey::SurveyPoint& p : s.joint->points) {
    const bool check = std::count(project.check_points.begin(), project.check_points.end(), p.id) > 0;
    if (check && !(s.photos && s.photos->check_ids.count(p.id))) continue;
    const Eigen::Vector3d x = check ? s.scene.Point(s.photos->check_ids.at(p.id)) : WorldFromSurvey(*s.joint, p);
    const Eigen::Matrix3d cov = check ? PointCovariance3(st, s.scene.Point(s.photos->check_ids.at(p.id)).data())
                                      : SurveyPointCovariance(st, *s.joint, p);
    const Eigen::Vector3d sigma = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
    const json e = Ellipse(cov);
    const std::string role = check ? "check (photos only)" : (p.xy_free() || p.z_free()) ? "adjusted" : "fixed";
    points << p.id << "," << role << "," << std::setprecision(12) << x.x() << "," << x.y() << "," << x.z() << ","
           << std::setprecision(6) << sigma.x() << "," << sigma.y() << "," << sigma.z() << ","
           << e["a"].get<double>() << "," << e["b"].get<double>() << "," << e["azimuth_deg"].get<double>() << ","
           << Geo(s.plane, x)
           << (crs ? CrsValues(*crs, x) + GridAzimuth(*crs, x, e["azimuth_deg"].get<double>()) : "") << "\n";
  }
  WriteText(stage / "points.csv", points.str());
}

/// observations.csv: every residual row with its redundancy and studentized residual.
void WriteObservations(const JointState& s, const fs::path& stage) {
  const stats::NetworkStatistics& st = s.statistics;
  const auto& builder_groups = s.builder->groups();
  std::ostringstream obs;
  obs << "group,block,row,residual,whitened,sigma,redundancy,studentized,critical\n";
  for (const stats::RowStatistic& r : st.rows) {
    obs << '"' << builder_groups[r.group]->name() << "\"," << r.block << "," << r.row << "," << std::setprecision(6)
        << r.residual << "," << r.whitened << "," << r.sigma << "," << r.redundancy << "," << r.studentized << ","
        << (r.critical ? 1 : 0) << "\n";
  }
  WriteText(stage / "observations.csv", obs.str());
}

/// report.json `files`: the files every adjustment writes, then each sensor's.
json ListFiles(const JointState& s) {
  json files = json::array({json{{"name", "report.html"}, {"description", "this report"}},
                            json{{"name", "report.json"}, {"description", "the report's data"}},
                            json{{"name", "poses.csv"},
                                 {"description", "camera poses: the camera centre in the world (local ENU at the project "
                                                 "origin), WGS84 and UTM, q = cam_from_world (w, x, y, z), sigma of the "
                                                 "centre from the adjustment (scaled by sigma0), the corrections"}},
                            json{{"name", "observations.csv"},
                                 {"description", "every residual row: residual = adjusted - observed in the group's unit, "
                                                 "whitened, sigma, redundancy number, studentized residual w, critical = 1 "
                                                 "where |w| exceeds the data-snooping limit"}}});
  if (s.rig) {
    files.push_back({{"name", "calibration/" + s.rig->config->id + "_rig.yaml"},
                     {"description", "rig calibration (cam_from_rig, intrinsics) with sigma"}});
  }
  if (s.spheres) {
    files.push_back({{"name", "calibration/" + s.spheres->config->id + "_spherical.yaml"},
                     {"description", "line-scan calibration of the spherical pair with sigma"}});
  }
  if (s.mobile) {
    const std::string id = s.mobile->config->id;
    files.push_back({{"name", "calibration/" + id + "_camera_lidar.yaml"}, {"description", "camera-LiDAR extrinsic with sigma"}});
    files.push_back({{"name", id + "_trajectory.csv"}, {"description", "corrections of the GNSS/INS trajectory at the nodes (linear in between): world_from_body = (Exp(omega) R_ins, p_ins + delta), with sigma, the corrected position in the world and what observes each node"}});
    files.push_back({{"name", id + "_corrected.ply"}, {"description", "the mobile cloud re-georeferenced (corrected trajectory and extrinsic), coloured from the adjusted rig images and photos where seen (grey: not seen)"}});
    files.push_back({{"name", "error_map_" + id + ".ply"}, {"description", "mobile points used, intensity = signed distance to the static surface (m)"}});
    files.push_back(LasFileEntry(s, id + "_corrected.ply", "the corrected mobile cloud"));
    files.push_back(LasFileEntry(s, "error_map_" + id + ".ply", "mobile points used, extra field distance_m = signed distance to the static surface (m)"));
  }
  if (s.joint) {
    files.push_back({{"name", "points.csv"},
                     {"description", "surveyed points in the world (local ENU at the project origin), WGS84 and UTM, "
                                     "sigma and the 1-sigma error ellipse (azimuth from north) from the joint adjustment"}});
  }
  if (s.measured) {
    const std::string id = s.measured->config->id;
    files.push_back({{"name", id + "_images.csv"},
                     {"description", "exterior orientation of the photo measurements' images: centre in the world, "
                                     "q = cam_from_world (w, x, y, z), sigma (scaled by sigma0), observations and rms_px "
                                     "per coordinate"}});
    files.push_back({{"name", id + "_points.csv"},
                     {"description", "points of the photo measurements in the world: sigma (scaled by sigma0; 0 when "
                                     "held), a95 >= b95 >= c95 the semi-axes of the 95 % confidence ellipsoid, rays"}});
    files.push_back({{"name", "calibration/" + id + "_camera.yaml"}, {"description", "camera calibration with sigma"}});
  }
  if (!s.scans.empty()) {
    files.push_back({{"name", "scans.csv"},
                     {"description", "static scans, world_from_scan: scanner position in the world (local ENU), "
                                     "q = scan_from_world (w, x, y, z), sigma, the correction of the registration given "
                                     "in the project"}});
  }
  if (s.photos) {
    files.push_back({{"name", "colmap/" + s.photos->config->id}, {"description", "adjusted COLMAP model (text)"}});
    files.push_back({{"name", "calibration/" + s.photos->config->id + "_camera.yaml"}, {"description", "camera calibration with sigma"}});
    files.push_back({{"name", "tie_points.ply"}, {"description", "georeferenced tie points, coloured from the images"}});
    files.push_back(LasFileEntry(s, "tie_points.ply", "the tie points"));
    if (!s.planes.empty()) files.push_back({{"name", "error_map_lidar.ply"}, {"description", "tie points, intensity = signed distance to the LiDAR surface (m)"}});
    if (!s.planes.empty()) files.push_back(LasFileEntry(s, "error_map_lidar.ply", "tie points, extra field distance_m = signed distance to the LiDAR surface (m)"));
  }
  return files;
}

/// report.json `mi_registration`: the MI registrations the adjustment ran, with where the
/// adjustment ended against them (the MI paper's camera-pose corrections, Fig. 13); their
/// register-mi result files in mi/.
void MiRegistrationReport(const JointState& s, const fs::path& stage, json* files, json* report) {
  // The MI registrations the adjustment ran, and where the adjustment ended against them
  // (the MI paper's camera-pose corrections, Fig. 13).
  json registration = json::array();
  for (size_t i = 0; i < s.mi_registration.size(); ++i) {
    json e = s.mi_registration[i];
    if (e.value("prior", false)) {
      // The MI rig calibration found rig_from_lidar: against the adjusted extrinsic.
      const Rigid3d adjusted = e.value("extrinsic", false) ? s.scene.Mount(s.mobile->mount)
                               : e.contains("frame")       ? s.scene.RigFrame(FrameId(e["frame"].get<size_t>()))
                                                           : s.scene.Image(ImageId(e["image_id"].get<uint64_t>())).cam_from_world;
      const Rigid3d& registered = s.mi_registered[i];
      e["adjusted_minus_registered_m"] = (CameraCentre(adjusted) - CameraCentre(registered)).norm();
      e["adjusted_minus_registered_deg"] = adjusted.rotation.angularDistance(registered.rotation) * kDeg;
    }
    e.erase("frame");
    e.erase("image_id");
    e.erase("extrinsic");
    registration.push_back(e);
  }
  (*report)["mi_registration"] = registration;
  fs::create_directories(stage / "mi");
  for (const auto& [name, result] : s.mi_files) WriteText(stage / "mi" / (name + ".json"), result.dump(2) + "\n");
  if (!s.mi_files.empty()) {
    files->push_back({{"name", "mi/"}, {"description", "the MI registrations run by the adjustment (mi_register), one register-mi result per image"}});
  }
}

/// report.json `spherical_registration`: each station's dense-cloud registration, with where
/// the adjustment ended against it; a warning for a registration the adjustment contradicts.
void SphereRegistrationReport(JointState& s, json* report) {
  json registration = json::array();
  for (const auto& [station, entry] : s.spheres->registration) {
    json e = entry;
    if (s.spheres->registration_status.at(station) == StepStatus::kOk) {
      // Where the adjustment ended against where the registration put the station.
      const ImageId id = s.spheres->lower_image.at(station);
      const Rigid3d& adjusted = s.scene.Image(id).cam_from_world;
      const Rigid3d& registered = s.spheres->initial_poses.at(id);
      const double dp = (CameraCentre(adjusted) - CameraCentre(registered)).norm();
      const double dr = adjusted.rotation.angularDistance(registered.rotation) * kDeg;
      e["adjusted_minus_registered_m"] = dp;
      e["adjusted_minus_registered_deg"] = dr;
      // The registration is an initial value only; the adjustment (tie points, control) is
      // the judge. A registration that ended far from it was wrong although it passed.
      const double resolution = e["resolution_m"].is_number() ? e["resolution_m"].get<double>() : 0.0;
      if (dp > std::max(0.05, 3 * resolution) || dr > 0.5) {
        std::ostringstream w;
        w << "spherical station " << station << ": its dense cloud's registration to the LiDAR (the initial pose) is "
          << dp << " m, " << dr << " deg from the adjusted pose: that registration was wrong";
        s.warnings.push_back(w.str());
        e["disagrees_with_adjustment"] = true;
      }
    }
    registration.push_back(e);
  }
  (*report)["spherical_registration"] = registration;
}

/// The terminal summary's lines about the spherical stations (registration, dense clouds).
void SummariseSpheres(const JointState& s, const json& report, const std::vector<StepStatus>& dense_status,
                      std::ostringstream& sum) {
  if (report.contains("spherical_registration")) {
    for (const json& d : report["spherical_registration"]) {
      sum << "  station " << d["station"].get<std::string>() << " initialised by its dense cloud on the LiDAR: "
          << d["status"].get<std::string>();
      if (s.spheres->registration_status.at(d["station"].get<std::string>()) == StepStatus::kOk) {
        sum << " (setup moved " << std::setprecision(3) << d["shift_from_setup_m"].get<double>() << " m, "
            << d["rotation_from_setup_deg"].get<double>() << " deg)";
      }
      sum << "\n";
    }
  }
  if (report.contains("spherical_dense")) {
    for (size_t k = 0; k < dense_status.size(); ++k) {
      const json& d = report["spherical_dense"][k];
      if (dense_status[k] != StepStatus::kOk) {
        sum << "  dense cloud of station " << d["station"].get<std::string>() << ": " << d["status"].get<std::string>()
            << "\n";
        continue;
      }
      sum << "  dense cloud of station " << d["station"].get<std::string>() << ": " << d["points"].get<size_t>()
          << " points, median range " << std::setprecision(3) << d["median_range_m"].get<double>() << " m (sigma "
          << d["median_range_sigma_m"].get<double>() << " m)";
      if (d.contains("median_abs_distance_to_lidar_m")) {
        sum << ", " << d["lidar_compared"].get<size_t>() << " on the LiDAR surface: median |distance| "
            << d["median_abs_distance_to_lidar_m"].get<double>() << " m";
      }
      sum << "\n";
    }
  }
}

/// The terminal summary: σ0 and its tests, the groups, check points, blunders, the spherical
/// stations, the warnings.
std::string Summary(const JointState& s, const json& report, const std::vector<StepStatus>& dense_status,
                    const fs::path& out_dir) {
  const Project& project = *s.project;
  const stats::NetworkStatistics& st = s.statistics;
  const stats::NetworkStatistics& given = s.given_weights;
  std::ostringstream sum;
  sum << "adjust " << project.name << ": converged, " << s.total_iterations << " iterations (" << s.outer_iterations
      << " outer), " << std::fixed << std::setprecision(1) << s.seconds << " s\n"
      << "  sigma0 " << std::setprecision(3) << st.sigma0_ratio << ", chi2 test at " << st.confidence << ": ["
      << st.chi2_lower << ", " << st.chi2_upper << "] -> " << (st.chi2_passed ? "passed" : "FAILED") << ", dof "
      << st.degrees_of_freedom << "\n"
      << "  with the project's sigma: sigma0 " << given.sigma0_ratio << " -> "
      << (given.chi2_passed ? "passed" : "FAILED") << (s.sigma_factor.empty() ? "" : "; groups re-weighted by variance components")
      << "\n";
  const auto& groups = s.builder->groups();
  for (size_t k = 0; k < groups.size(); ++k) {
    const json& g = report["groups"][k];
    sum << "  " << std::left << std::setw(44) << g["name"].get<std::string>() << std::right << std::setw(7)
        << g["observations"].get<size_t>() << " obs  RMS " << std::setprecision(4) << g["rms"].get<double>() << " "
        << g["unit"].get<std::string>() << "  variance component " << std::setprecision(3)
        << g["variance_component_given_weights"].get<double>();
    if (VarianceComponentExemption(s, *groups[k], st.groups.at(k).redundancy).empty()) {
      sum << " (sigma x " << g["sigma_factor"].get<double>() << ")\n";
    } else {
      sum << " (" << g["reweighting"].get<std::string>() << ")\n";
    }
  }
  if (report.contains("check_summary")) {
    const json& c = report["check_summary"];
    sum << "  check points: " << c["count"].get<size_t>() << ", RMSE 3D " << std::setprecision(4)
        << c["rmse_3d"].get<double>() << " m (expected " << c["expected_rmse_3d"].get<double>() << " m)\n";
  }
  sum << "  blunders flagged and excluded: " << s.blunders.size() << "\n";
  SummariseSpheres(s, report, dense_status, sum);
  for (const std::string& w : s.warnings) sum << "  warning: " << w << "\n";
  sum << "  report: " << (out_dir / "report.html").string();
  return sum.str();
}


/// poses.csv `text` (the header, rows whose columns 3–5 are the centre in the world)
/// with the project CRS's columns appended (output_support.h CrsColumns); unchanged without a CRS.
std::string WithCrsColumns(const Project& project, const std::string& text) {
  const std::optional<geodesy::CrsFrame> crs = ProjectCrsFrame(project);
  if (!crs) return text;
  std::istringstream in(text);
  std::ostringstream out;
  std::string line;
  for (int n = 0; std::getline(in, line); ++n) {
    if (n == 0) {
      out << line << CrsColumns(crs->crs()) << "\n";
      continue;
    }
    std::istringstream row(line);
    std::string cell;
    Eigen::Vector3d centre;
    for (int c = 0; c < 5 && std::getline(row, cell, ','); ++c) {
      if (c >= 2) centre(c - 2) = std::stod(cell);
    }
    out << line << CrsValues(*crs, centre) << "\n";
  }
  return out.str();
}

/// The sensor units' outputs in poses.csv's order (photos, spheres, rig), then the mobile LiDAR
/// and the static scans; poses.csv, pose corrections and calibrations into the report.
void WriteSensorOutputs(JointState& s, const AdjustOptions& options, const fs::path& stage, json* report) {
  std::ostringstream poses;
  poses << "image,sensor,east_m,north_m,up_m,qw,qx,qy,qz,latitude_deg,longitude_deg,height_m,utm_zone,utm_easting_m,"
           "utm_northing_m,sigma_east_m,sigma_north_m,sigma_up_m,d_position_m,d_rotation_deg\n";
  OutputSink sink;
  sink.stage = stage;
  sink.poses = &poses;
  sink.report = report;
  if (s.photos) WritePhotoOutputs(s, &sink);
  if (s.measured) WritePhotoMeasurementOutputs(s, &sink);
  if (s.spheres) WriteSphereOutputs(s, &sink);
  if (s.rig) WriteRigOutputs(s, &sink);
  if (s.mobile) WriteMobileOutputs(s, options.num_threads, &sink);
  if (!s.scans.empty()) WriteScanOutputs(s, &sink);
  WriteText(stage / "poses.csv", WithCrsColumns(*s.project, poses.str()));
  (*report)["pose_corrections"] = sink.corrections;
  (*report)["calibrations"] = sink.calibrations;
}

}  // namespace

std::string FindImage(const std::string& folder, const std::string& stem) {
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file() && entry.path().stem() == stem) return entry.path().string();
  }
  return "";
}

std::vector<NamedPath> ProjectInputs(const Project& project) {
  std::vector<NamedPath> inputs = {{"the project file", project.path}, {"the project folder", project.dir}};
  const auto add = [&inputs](const std::string& id, const std::string& key, const std::string& path) {
    if (!path.empty()) inputs.push_back({"'" + key + "' of sensor '" + id + "'", path});
  };
  for (const PhotoCollection& p : project.photos) {
    for (const auto& [key, path] : {std::pair<const char*, const std::string&>{"images", p.images},
                                    {"calibration", p.calibration}, {"colmap_model", p.colmap_model},
                                    {"control_measurements", p.control_measurements}, {"mi_results", p.mi_results}}) {
      add(p.id, key, path);
    }
  }
  for (const TotalStation& t : project.total_stations) add(t.id, "file", t.file);
  for (const PhotoMeasurements& p : project.photo_measurements) {
    add(p.id, "camera", p.camera);
    add(p.id, "images", p.images);
    add(p.id, "prior_eo", p.prior_eo);
    for (const io::MeasurementFile& m : p.measurements) add(p.id, "measurements", m.file);
  }
  if (project.control) inputs.push_back({"'control'", project.control->file});
  for (const Gnss& g : project.gnss) {
    add(g.id, "file", g.file);
    add(g.id, "photos", g.photos);
  }
  for (const LidarStatic& l : project.lidar_static) {
    add(l.id, "reference_cloud", l.reference_cloud);
    add(l.id, "targets", l.targets);
    for (const LidarScanFile& scan : l.scans) add(l.id, "scans", scan.file);
  }
  for (const SphericalStereo& p : project.spherical) {
    for (const auto& [key, path] : {std::pair<const char*, const std::string&>{"images", p.images},
                                    {"calibration", p.calibration}, {"stations_file", p.stations_file},
                                    {"observations", p.observations}}) {
      add(p.id, key, path);
    }
  }
  for (const CameraRig& r : project.rigs) {
    for (const auto& [key, path] : {std::pair<const char*, const std::string&>{"images", r.images},
                                    {"panoramas", r.panoramas}, {"mi_results", r.mi_results},
                                    {"calibration", r.calibration}, {"trajectory", r.trajectory},
                                    {"frames_file", r.frames_file}, {"observations", r.observations}}) {
      add(r.id, key, path);
    }
  }
  for (const LidarMobile& m : project.lidar_mobile) {
    add(m.id, "cloud", m.cloud);
    add(m.id, "trajectory", m.trajectory);
    add(m.id, "calibration", m.calibration);
  }
  if (!project.truth.empty()) inputs.push_back({"'truth' of the project", project.truth});
  return inputs;
}

void WriteOutputs(JointState& s, const AdjustOptions& options, const fs::path& stage, AdjustOutcome* outcome) {
  const Project& project = *s.project;
  fs::create_directories(stage / "calibration");
  json report;
  ReportHeader(s, outcome->status, &report);
  report["groups"] = GroupsReport(s);
  ControlPointsReport(s, &report);
  json blunders = json::array();
  for (const Blunder& b : s.blunders) {
    blunders.push_back({{"group", b.group}, {"observation", b.observation}, {"studentized", b.studentized},
                        {"whitened", b.whitened}, {"downweighted", true}});
  }
  report["blunders"] = blunders;
  WriteSensorOutputs(s, options, stage, &report);
  if (s.joint) WriteSurveyPoints(s, stage);
  WriteObservations(s, stage);
  PointsReport(s, &report);
  report["observations"] = ObservationsReport(s);
  report["settings"] = SettingsReport(s, options);
  if (!project.truth.empty()) report["truth_evaluation"] = EvaluateTruth(s);
  json files = ListFiles(s);
  WriteGeoJson(s, stage, &files);
  std::vector<StepStatus> dense_status;  // per entry of report["spherical_dense"]
  if (s.spheres && s.spheres->config->dense_cloud) {
    report["spherical_dense"] = WriteSphereDense(s, stage, &files, &dense_status);
  }
  if (s.surface) {
    const json coloured = WriteColouredLidar(s, stage, &files);
    if (!coloured.empty()) report["lidar_coloured"] = coloured;
  }
  if (!s.mi_registration.empty()) MiRegistrationReport(s, stage, &files, &report);
  if (s.spheres && !s.spheres->registration.empty()) SphereRegistrationReport(s, &report);
  report["files"] = files;
  json warnings = json::array();
  for (const std::string& w : s.warnings) warnings.push_back(w);
  report["warnings"] = warnings;
  json log = json::array();
  for (const std::string& l : s.log) log.push_back(l);
  report["log"] = log;
  WriteText(stage / "report.json", report.dump(1));
  WriteText(stage / "report.html", report::RenderAdjustReportHtml(report));
  outcome->report = report;
  outcome->summary = Summary(s, report, dense_status, options.output_dir);
}

}  // namespace mmba::adjust::internal
