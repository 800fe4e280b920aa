// Control points of a photogrammetric network in a file whose columns the project names
// (`columns: [id, label, x, y, z, sx, sy, sz]`), coordinates and σ in metres in the project's
// world frame. docs/formats.md, "Image measurements and control".
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace mmba::io {

/// Column names of a control file: id, x, y, z (metres), σ as sx, sy, sz or one sxyz (metres;
/// 0 = the coordinate is fixed); label, skip and _ are ignored. A line has one field per name.
const std::vector<std::string>& ControlColumnNames();
/// CheckColumnNames for a control file's `columns` (id, x, y, z required; σ columns all three,
/// sxyz, or none — then the project's sigma_m applies).
void CheckControlColumns(const std::vector<std::string>& columns, const std::string& file, int64_t line,
                         const std::string& field);
/// Whether the columns carry σ (sx, sy, sz or sxyz).
bool ControlColumnsHaveSigma(const std::vector<std::string>& columns);

struct ControlPoint {
  std::string id;
  std::string label;                                 ///< the `label` column, "" without
  Eigen::Vector3d xyz_m = Eigen::Vector3d::Zero();   ///< world frame
  Eigen::Vector3d sigma_m = Eigen::Vector3d::Zero(); ///< 0 = fixed coordinate
  int64_t line = 0;
  std::string file;  ///< where it was read
  bool Fixed() const { return sigma_m.isZero(); }
};

/// Reads a control file. `sigma_m` is the σ of every coordinate when the columns carry none
/// (required then: a control file without σ is an InputError naming the file). InputError
/// (file:line, column, value, expectation) for a line with a missing or extra field, a value
/// that is not a number, a σ < 0, or a point listed twice.
std::vector<ControlPoint> ReadControlPoints(const std::string& path, const std::vector<std::string>& columns,
                                            std::optional<double> sigma_m);

}  // namespace mmba::io
