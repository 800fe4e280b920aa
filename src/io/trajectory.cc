#include "mmba/io/trajectory.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "mmba/core/error.h"
#include "mmba/io/csv_table.h"

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

}  // namespace mmba::io
