// OpenCalib's calib.txt and intrinsic/extrinsic JSON (include/mmba/io_kitti/opencalib.h).

#include "mmba/io_kitti/opencalib.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/core/number_text.h"
#include "mmba/io/pose_json.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

using json = nlohmann::json;

// The counts of numbers each key of calib.txt accepts.
const std::map<std::string, std::vector<size_t>> kTxtCounts = {{"K", {9, 12}}, {"D", {4, 5, 8}}, {"T", {12, 16}}};

struct TxtRow {
  std::vector<double> values;
  int64_t line = 0;
};

std::string CountsText(const std::vector<size_t>& counts) {
  std::string out;
  for (size_t i = 0; i < counts.size(); ++i) {
    out += (i == 0 ? "" : (i + 1 == counts.size() ? " or " : ", ")) + std::to_string(counts[i]);
  }
  return out;
}

// The K, D and T rows of calib.txt, each checked for its count.
std::map<std::string, TxtRow> ReadTxtRows(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  LineCursor cursor(text, path);
  std::string_view line_text;
  std::map<std::string, TxtRow> rows;
  while (cursor.Next(&line_text)) {
    TokenLine line(path, cursor.line_number(), line_text);
    if (line.size() == 0 || line.Str(0, "key")[0] == '#') continue;
    std::string key = line.Str(0, "key");
    if (key.size() > 1 && key.back() == ':') key.pop_back();
    const auto counts = kTxtCounts.find(key);
    if (counts == kTxtCounts.end()) {
      const bool kitti = key.rfind("P", 0) == 0 || key.rfind("Tr", 0) == 0 || key.rfind("R0", 0) == 0 ||
                         key.rfind("R_rect", 0) == 0 || key == "calib_time";
      line.Fail("key", key,
                std::string("K:, D: or T: followed by numbers (OpenCalib calib.txt)") +
                    (kitti ? "; this looks like a KITTI calibration: give it as --kitti-calib" : ""));
    }
    if (const auto earlier = rows.find(key); earlier != rows.end()) {
      line.Fail(key, "a second '" + key + ":' line (the first on line " + std::to_string(earlier->second.line) + ")",
                "each key once");
    }
    const size_t n = line.size() - 1;
    if (std::find(counts->second.begin(), counts->second.end(), n) == counts->second.end()) {
      line.Fail(key, std::to_string(n) + " numbers", CountsText(counts->second) + " numbers");
    }
    TxtRow row;
    row.line = line.line_number();
    for (size_t i = 1; i < line.size(); ++i) row.values.push_back(line.Double(i, key + "[" + std::to_string(i - 1) + "]"));
    rows[key] = std::move(row);
  }
  for (const char* key : {"K", "D", "T"}) {
    if (rows.count(key) == 0) {
      throw InputError(path, 0, key, "(missing)",
                       std::string("a line '") + key + ": " +
                           (key[0] == 'K'   ? "fx 0 cx 0 fy cy 0 0 1"
                            : key[0] == 'D' ? "k1 k2 p1 p2 [k3]"
                                            : "3x4 row-major LiDAR-to-camera") +
                           "' (OpenCalib calib.txt)");
    }
  }
  return rows;
}

// InputError unless `k` is [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 (mmba's models have no skew).
void CheckK(const Eigen::Matrix3d& k, const std::string& path, int64_t line, const std::string& field) {
  if (!(k(0, 0) > 0) || !(k(1, 1) > 0) || std::abs(k(0, 1)) > 1e-9 * k(0, 0) || k(1, 0) != 0.0 || k(2, 0) != 0.0 ||
      k(2, 1) != 0.0 || k(2, 2) != 1.0) {
    std::ostringstream found;
    found << "[" << k.format(Eigen::IOFormat(Eigen::FullPrecision, Eigen::DontAlignCols, " ", "; ")) << "]";
    throw InputError(path, line, field, found.str(), "[fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 and no skew");
  }
}

// A JSON object's member, or InputError naming the field path.
const json& Member(const json& object, const std::string& key, const std::string& path, const std::string& field) {
  if (!object.is_object() || !object.contains(key)) {
    throw InputError(path, 0, field + "." + key, "(missing)", "the field of an OpenCalib calibration JSON");
  }
  return object[key];
}

json ParseJson(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError::AtByte(path, e.byte, "json", e.what(), "valid JSON");
  } catch (const json::exception& e) {
    throw InputError::Message(path, std::string("invalid JSON: ") + e.what());
  }
}

// The one top-level object of an OpenCalib JSON and its name.
const json& Root(const json& document, const std::string& path, std::string* name) {
  if (!document.is_object() || document.size() != 1 || !document.begin().value().is_object()) {
    throw InputError(path, 0, "top level", document.is_object() ? std::to_string(document.size()) + " members" : "not an object",
                     "one object named after the sensor (OpenCalib calibration JSON)");
  }
  *name = document.begin().key();
  return document.begin().value();
}

// `rows` × `cols` numbers of an OpenCalib matrix's "data" (a list of rows).
std::vector<double> MatrixData(const json& data, size_t rows, size_t cols, const std::string& path,
                               const std::string& field) {
  std::vector<double> out;
  const auto fail = [&](const std::string& found) {
    throw InputError(path, 0, field, found, std::to_string(rows) + " rows of " + std::to_string(cols) + " numbers");
  };
  if (!data.is_array() || data.size() != rows) fail(data.is_array() ? std::to_string(data.size()) + " rows" : data.dump());
  for (size_t r = 0; r < rows; ++r) {
    if (!data[r].is_array() || data[r].size() != cols) {
      fail("row " + std::to_string(r) + " = " + data[r].dump());
    }
    for (size_t c = 0; c < cols; ++c) {
      if (!data[r][c].is_number() || !std::isfinite(data[r][c].get<double>())) {
        fail("element [" + std::to_string(r) + "][" + std::to_string(c) + "] = " + data[r][c].dump());
      }
      out.push_back(data[r][c].get<double>());
    }
  }
  return out;
}

}  // namespace

OpenCalibTxt ReadOpenCalibTxt(const std::string& path) {
  const std::map<std::string, TxtRow> rows = ReadTxtRows(path);
  const TxtRow& k_row = rows.at("K");
  const TxtRow& t_row = rows.at("T");
  OpenCalibTxt out;
  out.intrinsics.path = path;
  const size_t k_cols = k_row.values.size() / 3;  // 3 (K) or 4 (P = [K | p])
  Eigen::Matrix<double, 3, 4> p = Eigen::Matrix<double, 3, 4>::Zero();
  for (size_t r = 0; r < 3; ++r) {
    for (size_t c = 0; c < k_cols; ++c) p(r, c) = k_row.values[k_cols * r + c];
  }
  out.intrinsics.k = p.leftCols<3>();
  CheckK(out.intrinsics.k, path, k_row.line, k_cols == 3 ? "K" : "K (left 3x3 of the 3x4)");
  out.intrinsics.distortion = rows.at("D").values;
  double t[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  std::copy(t_row.values.begin(), t_row.values.end(), t);
  const Rigid3d t_pose = RigidFromRowMajor4x4(t, path + ":" + std::to_string(t_row.line), "T");
  // K·T·X with a 3×4 K = [K₃ | p]: K₃·([I | K₃⁻¹·p]·T·X), the same shift as KITTI's P_i.
  Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
  shift.block<3, 1>(0, 3) = out.intrinsics.k.inverse() * p.col(3);
  out.cam_from_lidar = k_cols == 3 ? t_pose : Rigid3d::FromMatrix((shift * t_pose.ToMatrix4()).topRows<3>());
  return out;
}

OpenCalibIntrinsics ReadOpenCalibIntrinsicJson(const std::string& path) {
  const json document = ParseJson(path);
  std::string name;
  const json& root = Root(document, path, &name);
  const json& param = Member(root, "param", path, name);
  const std::string param_field = name + ".param";
  OpenCalibIntrinsics out;
  out.path = path;
  const std::vector<double> k =
      MatrixData(Member(Member(param, "cam_K", path, param_field), "data", path, param_field + ".cam_K"), 3, 3, path,
                 param_field + ".cam_K.data");
  out.k = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(k.data());
  CheckK(out.k, path, 0, param_field + ".cam_K.data");
  const json& dist = Member(Member(param, "cam_dist", path, param_field), "data", path, param_field + ".cam_dist");
  const std::string dist_field = param_field + ".cam_dist.data";
  const size_t n = dist.is_array() && dist.size() == 1 && dist[0].is_array() ? dist[0].size() : 0;
  if (n != 4 && n != 5 && n != 8) {
    throw InputError(path, 0, dist_field, dist.dump(), "one row of 4, 5 or 8 numbers: k1 k2 p1 p2 [k3 [k4 k5 k6]]");
  }
  out.distortion = MatrixData(dist, 1, n, path, dist_field);
  for (const char* key : {"img_dist_w", "img_dist_h"}) {
    if (!param.contains(key)) continue;
    const json& v = param[key];
    if (!v.is_number_integer() || v.get<int64_t>() <= 0) {
      throw InputError(path, 0, param_field + "." + key, v.dump(), "a positive integer (pixels)");
    }
    (key[9] == 'w' ? out.width : out.height) = v.get<uint64_t>();
  }
  return out;
}

Rigid3d ReadOpenCalibExtrinsicJson(const std::string& path) {
  const json document = ParseJson(path);
  std::string name;
  const json& root = Root(document, path, &name);
  const std::string field = name + ".param.sensor_calib";
  const json& calib = Member(Member(root, "param", path, name), "sensor_calib", path, name + ".param");
  const std::vector<double> v = MatrixData(Member(calib, "data", path, field), 4, 4, path, field + ".data");
  return RigidFromRowMajor4x4(v.data(), path, field + ".data");
}

sensors::Camera CameraFromOpenCalib(const OpenCalibIntrinsics& intrinsics, uint64_t width, uint64_t height) {
  sensors::Camera camera;
  camera.width = width;
  camera.height = height;
  const Eigen::Matrix3d& k = intrinsics.k;
  // OpenCV's pixel centres are at integers, COLMAP's (mmba's) at integers + 0.5.
  camera.params = {k(0, 0), k(1, 1), k(0, 2) + 0.5, k(1, 2) + 0.5};
  std::vector<double> d = intrinsics.distortion;
  d.resize(8, 0.0);
  const bool rational = d[4] != 0.0 || d[5] != 0.0 || d[6] != 0.0 || d[7] != 0.0;
  camera.model_id = rational ? sensors::CameraModelId::kFullOpenCV : sensors::CameraModelId::kOpenCV;
  camera.params.insert(camera.params.end(), d.begin(), d.begin() + (rational ? 8 : 4));
  return camera;
}

std::string OpenCalibJsonKind(const std::string& path) {
  const json document = ParseJson(path);
  if (!document.is_object() || document.size() != 1) return "";
  const json& root = document.begin().value();
  if (!root.is_object() || !root.contains("param") || !root["param"].is_object()) return "";
  if (root["param"].contains("cam_K")) return "intrinsic";
  if (root["param"].contains("sensor_calib")) return "extrinsic";
  return "";
}

}  // namespace mmba::io
