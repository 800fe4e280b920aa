#include "mmba/io/trajectory.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <Eigen/Geometry>

#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"
#include "mmba/io/yaml_reader.h"

namespace mmba::io {

std::vector<std::pair<double, Rigid3d>> ReadTrajectory(const std::string& path) {
  std::vector<std::pair<double, Rigid3d>> trajectory;
  const CsvTable ins = CsvTable::Read(path, {"time_s", "x_east_m", "y_north_m", "z_up_m", "qw", "qx", "qy", "qz"});
  for (const CsvTable::Row& row : ins.rows()) {
    const Eigen::Quaterniond q(ins.Double(row, "qw"), ins.Double(row, "qx"), ins.Double(row, "qy"), ins.Double(row, "qz"));
    if (std::abs(q.norm() - 1.0) > 1e-3) ins.Fail(row, "qw", std::to_string(q.norm()), "a unit quaternion (norm 1)");
    const double time = ins.Double(row, "time_s");
    if (!trajectory.empty() && !(time > trajectory.back().first)) ins.Fail(row, "time_s", ins.String(row, "time_s"), "increasing times");
    trajectory.emplace_back(time, Rigid3d(q.normalized(), Eigen::Vector3d(ins.Double(row, "x_east_m"), ins.Double(row, "y_north_m"),
                                                                          ins.Double(row, "z_up_m"))));
  }
  if (trajectory.size() < 2) throw InputError::Message(path, "fewer than 2 trajectory rows");
  return trajectory;
}

Rigid3d InterpolateTrajectory(const std::vector<std::pair<double, Rigid3d>>& rows, double time) {
  auto it = std::lower_bound(rows.begin(), rows.end(), time,
                             [](const std::pair<double, Rigid3d>& row, double t) { return row.first < t; });
  if (it == rows.begin()) return it->second;
  if (it == rows.end()) return rows.back().second;
  const auto& [t1, b] = *it;
  const auto& [t0, a] = *(it - 1);
  const double u = (time - t0) / (t1 - t0);
  return Rigid3d(a.rotation.slerp(u, b.rotation), (1 - u) * a.translation + u * b.translation);
}

std::string ScannerSidecarPath(const std::string& cloud_path) {
  std::filesystem::path p(cloud_path);
  p.replace_extension(".scanner.yaml");
  return p.string();
}

std::optional<ScannerSidecar> ReadScannerSidecar(const std::string& cloud_path) {
  namespace fs = std::filesystem;
  ScannerSidecar sidecar;
  sidecar.path = ScannerSidecarPath(cloud_path);
  if (!fs::exists(sidecar.path)) return std::nullopt;
  const YamlReader r(sidecar.path);
  const YAML::Node root = r.Load("scanner positions of " + cloud_path);
  const fs::path folder = fs::path(sidecar.path).parent_path();
  // A named file, resolved against the sidecar's folder; it must exist.
  auto file = [&](const YAML::Node& n, const std::string& field) {
    const std::string name = r.String(n, field);
    const fs::path resolved = fs::path(name).is_absolute() ? fs::path(name) : folder / name;
    if (!fs::is_regular_file(resolved)) r.Fail(n, field, "an existing file (relative to the sidecar's folder)", name);
    return resolved.string();
  };
  r.Map(root, "",
        {{"scanner_origin",
          [&](const YAML::Node& n, const std::string& field) {
            const std::vector<double> v = r.NumberList(n, field);
            if (v.size() != 3) r.Fail(n, field, "[x, y, z]", std::to_string(v.size()) + " numbers");
            sidecar.origin = Eigen::Vector3d(v[0], v[1], v[2]);
          }},
         {"trajectory", [&](const YAML::Node& n, const std::string& field) { sidecar.trajectory = file(n, field); }},
         {"lidar_mount", [&](const YAML::Node& n, const std::string& field) { sidecar.lidar_mount = file(n, field); }}});
  if (sidecar.trajectory.empty() != sidecar.lidar_mount.empty()) {
    r.Fail(root, sidecar.trajectory.empty() ? "trajectory" : "lidar_mount",
           "trajectory and lidar_mount together (the scanner at a point's time is world_from_body(t) * body_from_lidar)",
           "only one of them");
  }
  if (sidecar.origin && !sidecar.trajectory.empty()) {
    r.Fail(root, "scanner_origin", "either scanner_origin or trajectory, not both", "both");
  }
  if (!sidecar.origin && sidecar.trajectory.empty()) {
    r.Fail(root, "scanner_origin", "scanner_origin, or trajectory and lidar_mount", "none of them");
  }
  return sidecar;
}

}  // namespace mmba::io
