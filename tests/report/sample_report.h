#pragma once

// A report JSON (schema mmba-adjust-report-1) with every section filled, shaped like the
// simulated gate survey: whitened residuals drawn from N(0,1) (seeded), a few blunders, 8
// control and 3 check points, 60 panoramas. Shared by the renderer tests.

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mmba::report::testing {

inline nlohmann::json MakeSampleReport() {
  using nlohmann::json;
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  json report = {
      {"schema", "mmba-adjust-report-1"},
      {"project", "gate"},
      {"generated_utc", "2026-11-22T03:10:00Z"},
      {"status", "converged"},
      {"reason", "function tolerance reached"},
      {"origin", {{"latitude_deg", 45.50412345}, {"longitude_deg", -73.57712345}, {"height_m", 35.12}}},
      {"frame", "local ENU at the origin (east, north, up; metres)"},
      {"utm_zone", "18N"},
      {"solver",
       {{"iterations", 12}, {"outer_iterations", 3}, {"initial_cost", 88412.5}, {"final_cost", 18020.75},
        {"seconds", 41.3}}},
      {"sigma0",
       {{"apriori", 1.0}, {"aposteriori", 1.006}, {"dof", 12345}, {"confidence", 0.95},
        {"chi2_lower", 0.9876}, {"chi2_upper", 1.0125}, {"passed", true}}},
  };
  // Groups: components of a 1-D group, norms of a 2-D reprojection group.
  json groups = json::array();
  {
    std::vector<double> w;
    for (int i = 0; i < 400; ++i) w.push_back(normal(rng));
    w.push_back(6.1);
    groups.push_back({{"name", "total station"}, {"unit", "mm / cc"}, {"observations", 401},
                      {"residuals", 401}, {"rms", 1.9}, {"mean", 0.1}, {"max", 12.2}, {"sigma", 2.0},
                      {"loss", "huber 3"}, {"outliers", 1}, {"variance_component", 0.97},
                      {"redundancy", 250.5}, {"whitened", w}, {"whitened_kind", "components"},
                      {"reweighting", "variance components"}, {"sigma_factor", 0.985}});
  }
  {
    std::vector<double> w;
    for (int i = 0; i < 3000; ++i) w.push_back(std::hypot(normal(rng), normal(rng)));
    groups.push_back({{"name", "photos reprojection"}, {"unit", "px"}, {"observations", 3000},
                      {"residuals", 6000}, {"rms", 0.51}, {"mean", 0.6}, {"max", 2.9}, {"sigma", 0.5},
                      {"loss", "huber 3"}, {"outliers", 0}, {"variance_component", 1.02},
                      {"redundancy", 5200.3}, {"whitened", w}});
  }
  {
    std::vector<double> w;
    for (int i = 0; i < 900; ++i) w.push_back(normal(rng) * 1.1);
    groups.push_back({{"name", "lidar point-to-plane"}, {"unit", "m"}, {"observations", 900},
                      {"residuals", 900}, {"rms", 0.0055}, {"mean", 0.0001}, {"max", 0.02},
                      {"sigma", 0.005}, {"loss", "cauchy 2"}, {"outliers", 3},
                      {"variance_component", 1.21}, {"redundancy", 870.0}, {"whitened", w},
                      {"reweighting", "prior: not re-weighted"}});
  }
  report["groups"] = groups;

  // Control and check points on a 60 m × 40 m site.
  json points = json::array();
  const double coords[11][3] = {{0, 0, 10},  {60, 0, 11},  {60, 40, 12}, {0, 40, 10.5},
                                {30, -5, 10}, {65, 20, 11}, {30, 45, 12}, {-5, 20, 10},
                                {20, 15, 15}, {40, 25, 16}, {30, 30, 14}};
  for (int i = 0; i < 11; ++i) {
    const bool check = i >= 8;
    std::vector<double> d = {0.002 * normal(rng), 0.002 * normal(rng), 0.003 * normal(rng)};
    std::vector<double> sigma = {0.002, 0.0025, 0.004};
    if (i == 9) d[2] = 0.016;  // a check point off by 4σ in U
    const std::vector<double> surveyed = {coords[i][0], coords[i][1], coords[i][2]};
    json p = {{"id", (check ? "C" : "T") + std::to_string(i + 1)},
              {"role", check ? "check" : "control"},
              {"surveyed", surveyed},
              {"adjusted", {surveyed[0] + d[0], surveyed[1] + d[1], surveyed[2] + d[2]}},
              {"d", d},
              {"sigma", sigma},
              {"ellipse", {{"a", 0.0026}, {"b", 0.0019}, {"azimuth_deg", 20.0 + 15.0 * i}}}};
    points.push_back(p);
  }
  report["control_points"] = points;
  report["check_summary"] = {{"count", 3},
                             {"rmse", {0.0021, 0.0018, 0.0095}},
                             {"rmse_3d", 0.0099},
                             {"expected_rmse_3d", 0.0052}};
  report["blunders"] = json::array(
      {{{"group", "total station"}, {"observation", "direction M1->T3 (network.xml:45)"},
        {"studentized", 5.2}, {"whitened", 6.1}, {"downweighted", true}},
       {{"group", "gnss"}, {"observation", "antenna position pano_017"}, {"studentized", 4.1},
        {"whitened", 4.6}, {"downweighted", false}}});
  json poses = json::array();
  for (int i = 0; i < 60; ++i) {
    const std::vector<double> d = {0.03 * normal(rng), 0.03 * normal(rng), 0.015 * normal(rng)};
    poses.push_back({{"image", "pano_" + std::to_string(1000 + i).substr(1) + ".jpg"},
                     {"sensor", i < 40 ? "ladybug" : "photos"},
                     {"d", d},
                     {"d_position_m", std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])},
                     {"d_rotation_deg", std::abs(0.2 * normal(rng))}});
  }
  report["pose_corrections"] = poses;
  report["calibrations"] = json::array(
      {{{"name", "photo camera"},
        {"parameters",
         {{{"name", "fx"}, {"initial", 2400.0}, {"adjusted", 2403.1}, {"sigma", 0.8}},
          {{"name", "cx"}, {"initial", 1200.0}, {"adjusted", 1199.2}, {"sigma", 0.5}},
          {{"name", "k1"}, {"initial", 0.0}, {"adjusted", -0.0123}, {"sigma", 0.0004}}}}},
       {{"name", "camera-LiDAR extrinsic"},
        {"parameters",
         {{{"name", "lever arm x [m]"}, {"initial", 0.1}, {"adjusted", 0.104}, {"sigma", 0.002}},
          {{"name", "boresight roll [deg]"}, {"initial", 0.0}, {"adjusted", 0.03}, {"sigma", 0.01}}}}}});
  report["files"] = json::array({{{"name", "colmap/photos"}, {"description", "adjusted COLMAP model"}},
                                 {{"name", "poses_utm.csv"}, {"description", "poses in UTM 18N"}}});
  report["warnings"] = json::array({"check point C10 misses its predicted accuracy (|dU| > 3σ)",
                                    "group lidar point-to-plane: variance component 1.21"});
  return report;
}

/// The sample report with the sections a client report adds: the χ² test with the project's
/// σ (failed) next to the one after variance components (passed), every adjusted point, the
/// relative precision of neighbours, the observation table (more rows than the page shows),
/// a photo block's images and check points, the CRS, the settings and a project folder whose
/// absolute path appears in a warning, a reason and an image file.
inline nlohmann::json MakeClientReport() {
  using nlohmann::json;
  json report = MakeSampleReport();
  report["project_dir"] = "/home/surveyor/jobs/gate";
  report["project_file"] = "/home/surveyor/jobs/gate/project.yaml";
  report["mmba"] = {{"version", "0.9.0"}, {"commit", "abc1234"}};
  report["sigma0_given_weights"] = {{"aposteriori", 1.84}, {"dof", 12345}, {"chi2_lower", 0.9876},
                                    {"chi2_upper", 1.0125}, {"passed", false}};
  report["crs"] = {{"name", "ETRS89 / UTM zone 33N"}, {"code", "EPSG:25833"}, {"heights", "ellipsoidal (GRS80)"}};
  report["settings"] = {{"confidence", 0.95}, {"variance_components", true},
                        {"loss", {{"photos", "huber 3"}, {"lidar", "cauchy 2"}}}};
  report["warnings"].push_back("control file /home/surveyor/jobs/gate/control/points.csv line 7: point T9 unused");
  json points = json::array();
  for (int i = 0; i < 70; ++i) {
    points.push_back({{"id", "P" + std::to_string(i + 1)}, {"role", i < 8 ? "control" : "new"},
                      {"adjusted", {1.5 * i, 0.5 * i, 10.0}}, {"sigma", {0.002, 0.003, 0.005}},
                      {"ellipse", {{"a", 0.003}, {"b", 0.002}, {"azimuth_deg", 10.0}}}});
  }
  report["points"] = points;
  report["relative_precision"] = json::array(
      {{{"from", "T1"}, {"to", "T5"}, {"distance_m", 30.414}, {"sigma_distance_m", 0.0012},
        {"sigma", {0.0011, 0.0013, 0.002}}, {"ellipse", {{"a", 0.0014}, {"b", 0.0010}, {"azimuth_deg", 80.0}}}}});
  json rows = json::array();
  for (int i = 0; i < 320; ++i) {
    const double w = i == 17 ? 5.2 : 0.01 * (i % 200) - 1.0;
    rows.push_back({{"group", "total station"}, {"observation", "direction S1->P" + std::to_string(i)},
                    {"residual", 0.3 * w}, {"unit", "mgon"}, {"sigma", 0.3}, {"redundancy", 0.62},
                    {"studentized", w}, {"critical", std::abs(w) > 3.29}});
  }
  report["observations"] = {{"file", "observations.csv"}, {"total", 401}, {"critical_value", 3.29}, {"rows", rows}};
  json images = json::array();
  for (int i = 0; i < 5; ++i) {
    images.push_back({{"image", "IMG_" + std::to_string(100 + i)},
                      {"file", "/home/surveyor/jobs/gate/images/IMG_" + std::to_string(100 + i) + ".JPG"},
                      {"centre_m", {1.0 * i, 2.0, 30.0}}, {"sigma_centre_m", {0.004, 0.004, 0.006}},
                      {"sigma_rotation_deg", {0.002, 0.002, 0.001}}, {"observations", i == 4 ? 4 : 60},
                      {"rms_px", i == 3 ? 0.9 : 0.3}});
  }
  report["photo_measurements"] = {
      {"id", "drone"}, {"images", images},
      {"check_points", {{"count", 2}, {"points", {{{"point", "CP1"}, {"d_m", {0.004, -0.003, 0.010}}, {"sigma_m", {0.003, 0.003, 0.005}}},
                                                  {{"point", "CP2"}, {"d_m", {-0.002, 0.001, -0.006}}, {"sigma_m", {0.003, 0.003, 0.005}}}}}}}};
  return report;
}

}  // namespace mmba::report::testing
