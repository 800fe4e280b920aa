#include "mmba/io_kitti/kitti.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include <Eigen/LU>

#include "mmba/core/error.h"
#include "mmba/io/colmap_model.h"
#include "mmba/io/pose_json.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

// A row of a calibration file: its values and its line.
struct CalibRow {
  std::vector<double> values;
  int64_t line = 0;
};

Eigen::Matrix<double, 3, 4> Matrix3x4(const CalibRow& row) {
  Eigen::Matrix<double, 3, 4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = row.values[4 * r + c];
  }
  return m;
}

}  // namespace

namespace {

// "KEY: v1 v2 ..." rows of one calibration file by key; the tracking benchmark writes some
// keys without the colon ("R_rect v1 ...", "Tr_velo_cam v1 ..."). The raw recordings'
// "calib_time:" (a date, the only key whose value is text) is skipped.
std::map<std::string, CalibRow> ReadCalibRows(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  LineCursor cursor(text, path);
  std::string_view line_text;
  std::map<std::string, CalibRow> rows;
  while (cursor.Next(&line_text)) {
    TokenLine line(path, cursor.line_number(), line_text);
    if (line.size() == 0) continue;
    std::string key = line.Str(0, "key");
    double number;
    const char* kExpected = "'NAME:' (or NAME) followed by numbers (KITTI calibration format)";
    if (!key.empty() && key.back() == ':') {
      key.pop_back();
    } else if (key.find(':') != std::string::npos || ParseDouble(key, &number)) {
      // Before the first row the file is not known to be a calibration at all: its words are
      // not quoted back.
      line.Fail("key", rows.empty() ? "a first word that is not a key" : key, kExpected);
    }
    if (key == "calib_time") continue;
    if (rows.empty()) {
      for (size_t i = 1; i < line.size(); ++i) {
        if (!ParseDouble(line.Str(i, "value"), &number)) line.Fail("first row", "values that are not numbers", kExpected);
      }
    }
    // A key given twice leaves the file's meaning open (which one did its writer mean?).
    if (const auto earlier = rows.find(key); earlier != rows.end()) {
      line.Fail(key, "a second '" + key + ":' line (the first on line " + std::to_string(earlier->second.line) + ")",
                "each key once");
    }
    CalibRow row;
    row.line = line.line_number();
    for (size_t i = 1; i < line.size(); ++i) {
      row.values.push_back(line.Double(i, key + "[" + std::to_string(i - 1) + "]"));
    }
    rows[key] = std::move(row);
  }
  return rows;
}

constexpr const char* kRawCamToCam = "calib_cam_to_cam.txt";
constexpr const char* kRawVeloToCam = "calib_velo_to_cam.txt";

// The file(s) of a calibration: `path` alone, or a raw recording's cam-to-cam `path` with
// its velo-to-cam `velo_path`.
struct CalibFiles {
  std::string path;
  std::string velo_path;  // "" unless a raw recording
};

// A raw recording's calibration is two files in the date folder: calib_cam_to_cam.txt
// (P_rect_0X, R_rect_00) and calib_velo_to_cam.txt (R, T: velodyne → camera 0). Given the
// folder or either file, both are named.
CalibFiles ResolveCalibFiles(const std::string& path_or_folder) {
  namespace fs = std::filesystem;
  CalibFiles files{path_or_folder, ""};
  std::string& path = files.path;
  std::string& velo_path = files.velo_path;
  const fs::path given(path_or_folder);
  std::error_code ec;
  if (fs::is_directory(given, ec)) {
    path = (given / kRawCamToCam).string();
    velo_path = (given / kRawVeloToCam).string();
    if (!fs::exists(path) || !fs::exists(velo_path)) {
      const std::string missing = !fs::exists(path) && !fs::exists(velo_path)
                                      ? std::string(kRawCamToCam) + " and " + kRawVeloToCam
                                      : (!fs::exists(path) ? kRawCamToCam : kRawVeloToCam);
      throw InputError::Message(path_or_folder, "is a folder without " + missing + " (expected a KITTI calibration file, "
                                                "or a raw recording's calibration folder with " + kRawCamToCam +
                                                " and " + kRawVeloToCam + ")");
    }
  } else if (given.filename() == kRawCamToCam || given.filename() == kRawVeloToCam) {
    path = (given.parent_path() / kRawCamToCam).string();
    velo_path = (given.parent_path() / kRawVeloToCam).string();
    const std::string& other = given.filename() == kRawCamToCam ? velo_path : path;
    if (fs::exists(given) && !fs::exists(other)) {
      throw InputError::Message(other, "file not found: a KITTI raw calibration needs " + std::string(kRawCamToCam) +
                                           " and " + kRawVeloToCam + " side by side (given " + path_or_folder + ")");
    }
  }
  return files;
}

// A raw recording's R (9 numbers) and T (3 numbers) of `velo_path` as one 3×4 row
// "Tr_velo_to_cam", on the line of R.
CalibRow ReadRawVeloToCam(const std::string& velo_path) {
  const std::map<std::string, CalibRow> velo = ReadCalibRows(velo_path);
  const auto r = velo.find("R"), t = velo.find("T");
  if (r == velo.end() || t == velo.end()) {
    throw InputError::Message(velo_path, "missing calibration key " + std::string(r == velo.end() ? "R" : "T") +
                                             " (expected R: 9 numbers and T: 3 numbers, velodyne to camera 0)");
  }
  for (const auto& [key, row] : {std::pair{"R", r->second}, std::pair{"T", t->second}}) {
    const size_t count = std::string(key) == "R" ? 9 : 3;
    if (row.values.size() != count) {
      throw InputError(velo_path, row.line, key, std::to_string(row.values.size()) + " numbers",
                       std::to_string(count) + " numbers");
    }
  }
  CalibRow tr;
  tr.line = r->second.line;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) tr.values.push_back(r->second.values[3 * i + j]);
    tr.values.push_back(t->second.values[i]);
  }
  return tr;
}

// The rows of a calibration with the file each came from.
class CalibTable {
 public:
  explicit CalibTable(const CalibFiles& files) : path_(files.path), rows_(ReadCalibRows(files.path)) {
    if (!files.velo_path.empty()) {
      rows_["Tr_velo_to_cam"] = ReadRawVeloToCam(files.velo_path);
      row_file_["Tr_velo_to_cam"] = files.velo_path;
    }
  }

  bool Has(const std::string& key) const { return rows_.count(key) != 0; }

  std::string FileOf(const std::string& key) const {
    const auto it = row_file_.find(key);
    return it == row_file_.end() ? path_ : it->second;
  }

  // The first of `names` present, which must hold `count` numbers; nullptr if none is and
  // !required, else InputError naming the keys and `why`.
  const CalibRow* Find(std::initializer_list<const char*> names, size_t count, bool required,
                       const std::string& why = "") const {
    for (const char* name : names) {
      auto it = rows_.find(name);
      if (it == rows_.end()) continue;
      if (it->second.values.size() != count) {
        throw InputError(FileOf(name), it->second.line, name,
                         std::to_string(it->second.values.size()) + " numbers",
                         std::to_string(count) + " numbers");
      }
      return &it->second;
    }
    if (required) {
      std::string list;
      for (const char* name : names) list += (list.empty() ? "" : " or ") + std::string(name);
      throw InputError::Message(path_, "missing calibration key " + list + why +
                                           " (expected a KITTI object/odometry calib file, or a raw "
                                           "recording's calib_cam_to_cam.txt + calib_velo_to_cam.txt)");
    }
    return nullptr;
  }

 private:
  std::string path_;
  std::map<std::string, CalibRow> rows_;
  std::map<std::string, std::string> row_file_;
};

}  // namespace

KittiCalibration ReadKittiCalibration(const std::string& path_or_folder, int camera) {
  const CalibFiles files = ResolveCalibFiles(path_or_folder);
  const std::string& path = files.path;
  const CalibTable rows(files);
  if (camera < -1 || camera > 3) {
    throw InputError::Message(path, "KITTI camera index " + std::to_string(camera) + " out of range 0..3");
  }
  KittiCalibration calibration;
  calibration.path = path;
  // Only the projection of the camera used is required (a file with P2 alone serves camera 2).
  for (int i = 0; i < 4; ++i) {
    const std::string a = "P" + std::to_string(i);
    const std::string b = "P_rect_0" + std::to_string(i);
    const bool required = camera == -1 || camera == i;
    if (const CalibRow* row = rows.Find({a.c_str(), b.c_str()}, 12, required, " (KITTI camera " + std::to_string(i) + ")")) {
      calibration.p[i] = Matrix3x4(*row);
      calibration.has_p[i] = true;
    }
  }
  // The odometry format's "Tr" maps velodyne to the (rectified) camera 0 directly; it has no
  // R0_rect and the identity is right for it. With the object format's Tr_velo_to_cam (the
  // tracking format's Tr_velo_cam, a raw recording's R, T) the rectifying rotation is part of
  // the projection (KITTI devkit: P2 · R0_rect · Tr_velo_to_cam), and a file without it is
  // refused rather than read with the identity (a 1-2 px error on KITTI).
  const CalibRow* tr = rows.Find({"Tr_velo_to_cam", "Tr_velo_cam", "Tr"}, 12, true);
  const bool odometry = !rows.Has("Tr_velo_to_cam") && !rows.Has("Tr_velo_cam");
  if (const CalibRow* r0 = rows.Find({"R0_rect", "R_rect_00", "R_rect"}, 9, !odometry,
                                     " (the rectifying rotation, which goes with Tr_velo_to_cam)")) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) calibration.r0_rect(r, c) = r0->values[3 * r + c];
    }
    CheckRotation(calibration.r0_rect, path, r0->line, "R0_rect", 1e-4);
  }
  calibration.tr_velo_to_cam = Matrix3x4(*tr);
  CheckRotation(calibration.tr_velo_to_cam.leftCols<3>(), rows.FileOf("Tr_velo_to_cam"), tr->line,
                files.velo_path.empty() ? "Tr_velo_to_cam" : "R", 1e-4);
  return calibration;
}

KittiCameraPose KittiCamera(const KittiCalibration& calibration, int index, uint64_t width,
                            uint64_t height, const std::string& source) {
  if (index < 0 || index > 3) {
    throw InputError::Message(source, "KITTI camera index " + std::to_string(index) +
                                          " out of range 0..3");
  }
  if (!calibration.has_p[index]) {
    throw InputError::Message(calibration.path.empty() ? source : calibration.path,
                              "missing calibration key P" + std::to_string(index) + " or P_rect_0" +
                                  std::to_string(index) + " (KITTI camera " + std::to_string(index) +
                                  ", the camera asked for)");
  }
  const Eigen::Matrix<double, 3, 4>& p = calibration.p[index];
  const Eigen::Matrix3d k = p.leftCols<3>();
  const std::string field = "P" + std::to_string(index);
  if (!(k(0, 0) > 0) || !(k(1, 1) > 0) || std::abs(k(0, 1)) > 1e-9 * k(0, 0) ||
      std::abs(k(1, 0)) > 1e-12 || std::abs(k(2, 0)) > 1e-12 || std::abs(k(2, 1)) > 1e-12 ||
      std::abs(k(2, 2) - 1.0) > 1e-9) {
    std::ostringstream found;
    found << k.format(Eigen::IOFormat(Eigen::FullPrecision, 0, " ", "; "));
    throw InputError::Message(source, "field '" + field + "': left 3x3 is [" + found.str() +
                                          "], expected K = [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  KittiCameraPose result;
  result.camera.model_id = sensors::CameraModelId::kPinhole;
  result.camera.width = width;
  result.camera.height = height;
  result.camera.params = {k(0, 0), k(1, 1), k(0, 2), k(1, 2)};
  // cam_from_lidar = [I | K⁻¹·P[:,3]] · R0_rect · Tr_velo_to_cam.
  Eigen::Matrix4d rect = Eigen::Matrix4d::Identity();
  rect.topLeftCorner<3, 3>() = calibration.r0_rect;
  Eigen::Matrix4d velo = Eigen::Matrix4d::Identity();
  velo.topRows<3>() = calibration.tr_velo_to_cam;
  Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
  shift.block<3, 1>(0, 3) = k.inverse() * p.col(3);
  const Eigen::Matrix4d cam_from_lidar = shift * rect * velo;
  result.cam_from_lidar = Rigid3d::FromMatrix(cam_from_lidar.topRows<3>());
  return result;
}

}  // namespace mmba::io
