#include "mmba/io/pose_json.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/LU>

#include "mmba/core/error.h"
#include "mmba/core/number_text.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {

using json = nlohmann::json;

namespace {

// The JSON object of a file; InputError with the line (and the key read last, which names the
// field of a number out of range such as 1e400: nlohmann reports those without a position).
json ParseJsonFile(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  std::string last_key = "json";
  const json::parser_callback_t track_key = [&last_key](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::key && parsed.is_string()) last_key = parsed.get<std::string>();
    return true;
  };
  try {
    return json::parse(text, track_key);
  } catch (const json::parse_error& e) {
    throw InputError::AtByte(path, e.byte, "json", e.what(), "valid JSON");
  } catch (const json::exception& e) {
    // e.g. "[json.exception.out_of_range.406] number overflow parsing '1e400'"
    std::string found = e.what();
    const size_t quote = found.find('\'');
    if (quote != std::string::npos) found = found.substr(quote + 1, found.rfind('\'') - quote - 1);
    int64_t line = 0;
    if (const size_t at = text.find(found); quote != std::string::npos && at != std::string::npos) {
      line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
    }
    throw InputError(path, line, last_key, found, "a finite number (a double)");
  }
}

// {qvec_wxyz: [w, x, y, z], tvec: [x, y, z]} with a unit quaternion (within 1e-3).
Rigid3d QvecTvecFromJson(const json& value, const std::string& file, const std::string& field) {
  const json& q = value["qvec_wxyz"];
  const json& t = value.contains("tvec") ? value["tvec"] : json();
  auto numbers = [](const json& v, size_t n) {
    return v.is_array() && v.size() == n &&
           std::all_of(v.begin(), v.end(), [](const json& x) { return x.is_number(); });
  };
  if (!numbers(q, 4) || !numbers(t, 3)) {
    throw InputError(file, 0, field, value.dump().substr(0, 80),
                     "{\"qvec_wxyz\": [4 numbers], \"tvec\": [3 numbers]}");
  }
  const Eigen::Quaterniond rotation(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>());
  if (!(std::abs(rotation.norm() - 1.0) <= 1e-3)) {
    throw InputError(file, 0, field + ".qvec_wxyz", "a quaternion of norm " + ExactNumber(rotation.norm()),
                     "a unit quaternion (norm 1 within 1e-3)");
  }
  return Rigid3d(rotation.normalized(), Eigen::Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>()));
}

}  // namespace

json PoseToJson(const Rigid3d& pose) {
  const Eigen::Matrix4d m = pose.ToMatrix4();
  json rows = json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

bool Matrix4FromJson(const json& value, double row_major[16], std::string* problem) {
  auto number = [&](const json& v, const std::string& where, double* out) {
    if (!v.is_number()) {
      *problem = where + " is " + v.dump().substr(0, 40) + ", not a number";
      return false;
    }
    *out = v.get<double>();
    return true;
  };
  if (value.is_array() && value.size() == 16) {
    for (int i = 0; i < 16; ++i) {
      if (!number(value[i], "value " + std::to_string(i), &row_major[i])) return false;
    }
    return true;
  }
  if (value.is_array() && value.size() == 4) {
    for (int r = 0; r < 4; ++r) {
      if (!value[r].is_array() || value[r].size() != 4) {
        *problem = "row " + std::to_string(r) + " is " + value[r].dump().substr(0, 40) + ", not 4 numbers";
        return false;
      }
      for (int c = 0; c < 4; ++c) {
        const std::string where = "[" + std::to_string(r) + "][" + std::to_string(c) + "]";
        if (!number(value[r][c], where, &row_major[4 * r + c])) return false;
      }
    }
    return true;
  }
  *problem = value.is_array() ? "a list of " + std::to_string(value.size()) + " values" : value.dump().substr(0, 40);
  return false;
}

Rigid3d PoseFromJson(const json& value, const std::string& file, const std::string& field) {
  if (value.is_object() && value.contains("qvec_wxyz")) return QvecTvecFromJson(value, file, field);
  double v[16];
  std::string problem;
  if (!Matrix4FromJson(value, v, &problem)) {
    throw InputError(file, 0, field, problem,
                     "16 numbers (4x4 row-major), 4 rows of 4 numbers, or {qvec_wxyz, tvec}");
  }
  return RigidFromRowMajor4x4(v, file, field);
}

Rigid3d ReadPoseJson(const std::string& path, const std::string& key) {
  const json root = ParseJsonFile(path);
  if (!root.is_object() || !root.contains(key)) {
    throw InputError(path, 0, key, "(missing)", "an object with \"" + key + "\": 16 numbers (4x4 row-major) or 4 rows of 4");
  }
  double v[16];
  std::string problem;
  if (!Matrix4FromJson(root[key], v, &problem)) {
    throw InputError(path, 0, key, problem, "16 numbers (4x4 row-major) or 4 rows of 4 numbers");
  }
  return RigidFromRowMajor4x4(v, path, key);
}

void CheckRotation(const Eigen::Matrix3d& rotation, const std::string& file, int64_t line, const std::string& field,
                   double tolerance) {
  const double orthonormality = (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = rotation.determinant();
  if (!(orthonormality <= tolerance) || !(std::abs(det - 1.0) <= tolerance)) {
    throw InputError(file, line, field, "rotation with |R·Rᵀ − I| = " + ExactNumber(orthonormality) + ", det = " + ExactNumber(det),
                     "an orthonormal rotation (det +1) within " + ExactNumber(tolerance));
  }
}

Rigid3d RigidFromRowMajor4x4(const double* v, const std::string& where, const std::string& field, double tolerance) {
  for (int i = 0; i < 16; ++i) {
    if (!std::isfinite(v[i])) {
      throw InputError::Message(where, "field '" + field + "': element " + std::to_string(i) +
                                           " is not finite, expected a number");
    }
  }
  if (std::abs(v[12]) > tolerance || std::abs(v[13]) > tolerance || std::abs(v[14]) > tolerance ||
      std::abs(v[15] - 1.0) > tolerance) {
    throw InputError::Message(where, "field '" + field + "': last row is (" + ExactNumber(v[12]) + " " + ExactNumber(v[13]) + " " +
                                         ExactNumber(v[14]) + " " + ExactNumber(v[15]) + "), expected (0 0 0 1)");
  }
  Eigen::Matrix<double, 3, 4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = v[4 * r + c];
  }
  CheckRotation(m.leftCols<3>(), where, 0, field, tolerance);
  return Rigid3d::FromMatrix(m);
}

}  // namespace mmba::io
