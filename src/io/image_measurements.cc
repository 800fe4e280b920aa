#include "mmba/io/image_measurements.h"

#include <set>
#include <utility>

#include "mmba/core/error.h"
#include "mmba/io/column_text.h"

namespace mmba::io {

const std::vector<std::string>& MeasurementColumnNames() {
  static const std::vector<std::string> names{"id", "image", "x", "y", "sx", "sy", "sxy"};
  return names;
}

void CheckMeasurementColumns(const std::vector<std::string>& columns, const std::string& file, int64_t line,
                             const std::string& field) {
  CheckColumnNames(columns, MeasurementColumnNames(), {"id", "image", "x", "y"}, file, line, field);
}

std::vector<ImageMeasurement> ReadImageMeasurements(const MeasurementFile& spec) {
  const std::vector<std::string>& c = spec.columns;
  const int id = ColumnIndex(c, "id"), image = ColumnIndex(c, "image");
  const int x = ColumnIndex(c, "x"), y = ColumnIndex(c, "y");
  const int sx = ColumnIndex(c, "sx"), sy = ColumnIndex(c, "sy"), sxy = ColumnIndex(c, "sxy");
  std::vector<ImageMeasurement> out;
  std::map<std::pair<std::string, std::string>, int64_t> seen;  // (image, point) → line
  ForEachColumnLine(spec.file, [&](int64_t line, const std::vector<std::string>& fields) {
    const ColumnRow row(spec.file, line, &fields, &c);
    if (fields.size() < c.size()) row.Text(fields.size());  // names the first missing column
    if (fields.size() > c.size()) {
      throw InputError(spec.file, line, "line", std::to_string(fields.size()) + " fields",
                       std::to_string(c.size()) + " fields, one per name of `columns` (name extra ones _)");
    }
    ImageMeasurement m;
    m.file = spec.file;
    m.line = line;
    m.point_id = row.Text(id);
    m.image_id = row.Text(image);
    if (m.point_id.empty()) row.Fail(id, "an empty field", "a point id");
    if (m.image_id.empty()) row.Fail(image, "an empty field", "an image id");
    m.xy_px = {row.Number(x), row.Number(y)};
    m.sigma_px.setConstant(spec.sigma_px);
    for (int k : {sxy, sx, sy}) {
      if (k < 0) continue;
      const double sigma = row.Number(k);
      if (!(sigma > 0)) row.Fail(k, fields[k], "a σ > 0 in pixels");
      if (k != sy) m.sigma_px[0] = sigma;
      if (k != sx) m.sigma_px[1] = sigma;
    }
    const auto [it, inserted] = seen.emplace(std::make_pair(m.image_id, m.point_id), line);
    if (!inserted) {
      row.Fail(id, m.point_id + " (image " + m.image_id + ", also on line " + std::to_string(it->second) + ")",
               "each point measured once per image");
    }
    out.push_back(std::move(m));
  });
  return out;
}

void CheckInsideImage(const ImageMeasurement& m, uint64_t width, uint64_t height) {
  const double w = static_cast<double>(width), h = static_cast<double>(height);
  for (int k = 0; k < 2; ++k) {
    const double v = m.xy_px[k], limit = k == 0 ? w : h;
    if (v < 0 || v > limit) {
      throw InputError(m.file, m.line, k == 0 ? "x" : "y",
                       std::to_string(v) + " (point " + m.point_id + ", image " + m.image_id + ")",
                       "a pixel coordinate in [0, " + std::to_string(static_cast<uint64_t>(limit)) +
                           "] (the camera's image " + std::to_string(width) + " x " + std::to_string(height) +
                           " px; origin at the upper-left corner)");
    }
  }
}

std::map<std::string, std::string> ReadImageList(const std::string& path) {
  std::map<std::string, std::string> images;
  std::map<std::string, int64_t> lines;
  ForEachColumnLine(path, [&](int64_t line, const std::vector<std::string>& fields) {
    if (fields.size() != 2) {
      throw InputError(path, line, "image list line", std::to_string(fields.size()) + " fields",
                       "2 fields: image id, file name");
    }
    if (!images.emplace(fields[0], fields[1]).second) {
      throw InputError(path, line, "image id", fields[0] + " (also on line " + std::to_string(lines[fields[0]]) + ")",
                       "each image listed once");
    }
    lines[fields[0]] = line;
  });
  return images;
}

}  // namespace mmba::io
