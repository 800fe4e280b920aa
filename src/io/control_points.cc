#include "mmba/io/control_points.h"

#include <map>
#include <utility>

#include "mmba/core/error.h"
#include "mmba/io/column_text.h"

namespace mmba::io {

const std::vector<std::string>& ControlColumnNames() {
  static const std::vector<std::string> names{"id", "x", "y", "z", "sx", "sy", "sz", "sxyz"};
  return names;
}

bool ControlColumnsHaveSigma(const std::vector<std::string>& columns) {
  for (const char* name : {"sx", "sy", "sz", "sxyz"}) {
    if (ColumnIndex(columns, name) >= 0) return true;
  }
  return false;
}

void CheckControlColumns(const std::vector<std::string>& columns, const std::string& file, int64_t line,
                         const std::string& field) {
  CheckColumnNames(columns, ControlColumnNames(), {"id", "x", "y", "z"}, file, line, field);
  const int axes = (ColumnIndex(columns, "sx") >= 0) + (ColumnIndex(columns, "sy") >= 0) + (ColumnIndex(columns, "sz") >= 0);
  const bool sxyz = ColumnIndex(columns, "sxyz") >= 0;
  if ((axes != 0 && axes != 3) || (axes == 3 && sxyz)) {
    throw InputError(file, line, field, std::to_string(axes) + " of sx, sy, sz" + (sxyz ? " and sxyz" : ""),
                     "σ columns sx, sy, sz (all three), or sxyz, or none");
  }
}

std::vector<ControlPoint> ReadControlPoints(const std::string& path, const std::vector<std::string>& c,
                                            std::optional<double> sigma_m) {
  const bool have_sigma = ControlColumnsHaveSigma(c);
  if (!have_sigma && !sigma_m) {
    throw InputError(path, 0, "columns", "no σ column (sx, sy, sz or sxyz)",
                     "σ in the file, or the project's control sigma_m (0 = fixed)");
  }
  const int id = ColumnIndex(c, "id"), label = ColumnIndex(c, "label");
  const int axis[3] = {ColumnIndex(c, "x"), ColumnIndex(c, "y"), ColumnIndex(c, "z")};
  const int sigma[3] = {ColumnIndex(c, "sx"), ColumnIndex(c, "sy"), ColumnIndex(c, "sz")};
  const int sxyz = ColumnIndex(c, "sxyz");
  std::vector<ControlPoint> out;
  std::map<std::string, int64_t> seen;
  ForEachColumnLine(path, [&](int64_t line, const std::vector<std::string>& fields) {
    const ColumnRow row(path, line, &fields, &c);
    if (fields.size() < c.size()) row.Text(fields.size());  // names the first missing column (a missing σ too)
    if (fields.size() > c.size()) {
      throw InputError(path, line, "line", std::to_string(fields.size()) + " fields",
                       std::to_string(c.size()) + " fields, one per name of `columns` (name extra ones _)");
    }
    ControlPoint p;
    p.line = line;
    p.file = path;
    p.id = row.Text(id);
    if (p.id.empty()) row.Fail(id, "an empty field", "a point id");
    if (label >= 0) p.label = row.Text(label);
    for (int k = 0; k < 3; ++k) {
      p.xyz_m[k] = row.Number(axis[k]);
      const int s = sxyz >= 0 ? sxyz : sigma[k];
      p.sigma_m[k] = s >= 0 ? row.Number(s) : *sigma_m;
      if (s >= 0 && !(p.sigma_m[k] >= 0 && p.sigma_m[k] <= 100)) {
        row.Fail(s, fields[s], "a σ in metres in [0, 100] (0 = fixed)");
      }
    }
    const auto [it, inserted] = seen.emplace(p.id, line);
    if (!inserted) row.Fail(id, p.id + " (also on line " + std::to_string(it->second) + ")", "each control point once");
    out.push_back(std::move(p));
  });
  if (out.empty()) throw InputError::Message(path, "no control point (every line blank or a comment)");
  return out;
}

}  // namespace mmba::io
