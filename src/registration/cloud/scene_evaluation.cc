#include "mmba/registration/cloud/scene_evaluation.h"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <map>
#include <cmath>
#include <sstream>

#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "mmba/core/error.h"
#include "mmba/core/logging.h"
#include "mmba/io/text_reader.h"

namespace mmba::registration {
namespace {

namespace fs = std::filesystem;

Eigen::Matrix4d ReadMatrix(const nlohmann::json& j, const std::string& file,
                           const std::string& key) {
  Eigen::Matrix4d m;
  if (!j.is_array() || j.size() != 4) {
    throw InputError(file, 0, key, j.dump().substr(0, 60), "a 4×4 matrix as 4 rows of 4 numbers");
  }
  for (int r = 0; r < 4; ++r) {
    if (!j[r].is_array() || j[r].size() != 4) {
      throw InputError(file, 0, key, j[r].dump().substr(0, 60), "a row of 4 numbers");
    }
    for (int c = 0; c < 4; ++c) {
      if (!j[r][c].is_number()) throw InputError(file, 0, key, j[r][c].dump(), "a number");
      m(r, c) = j[r][c].get<double>();
    }
  }
  const Eigen::Matrix3d rot = m.topLeftCorner<3, 3>();
  if ((rot.transpose() * rot - Eigen::Matrix3d::Identity()).norm() > 1e-5 ||
      std::abs(rot.determinant() - 1.0) > 1e-5 || m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    throw InputError(file, 0, key, "a non-rigid matrix", "a rigid transform [R t; 0 0 0 1]");
  }
  return m;
}

Eigen::Matrix4d Inverse(const Eigen::Matrix4d& m) {
  Eigen::Matrix4d out = Eigen::Matrix4d::Identity();
  out.topLeftCorner<3, 3>() = m.topLeftCorner<3, 3>().transpose();
  out.topRightCorner<3, 1>() = -out.topLeftCorner<3, 3>() * m.topRightCorner<3, 1>();
  return out;
}

Eigen::Vector3d Apply(const Eigen::Matrix4d& m, const Eigen::Vector3d& p) {
  return m.topLeftCorner<3, 3>() * p + m.topRightCorner<3, 1>();
}

}  // namespace

io::PointCloud PlacedAtTruth(const io::PointCloud& source,
                             const Eigen::Matrix4d& target_from_source,
                             std::vector<Eigen::Vector3d>* viewpoints) {
  io::PointCloud placed = source;
  for (auto& p : placed.points) p = Apply(target_from_source, p);
  for (auto& n : placed.normals) n = target_from_source.topLeftCorner<3, 3>() * n;
  for (auto& v : *viewpoints) v = Apply(target_from_source, v);
  return placed;
}

std::vector<Eigen::Vector3d> ReadViewpoints(const std::string& path) {
  std::istringstream in(io::ReadWholeFile(path));
  std::vector<Eigen::Vector3d> out;
  std::string line;
  int64_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string t; fields >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    if (tokens.size() != 3) {
      throw InputError(path, number, "viewpoint", std::to_string(tokens.size()) + " fields",
                       "3 numbers x y z");
    }
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) {
      const char* names[] = {"x", "y", "z"};
      size_t used = 0;
      double value = std::nan("");
      try {
        value = std::stod(tokens[k], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != tokens[k].size() || !std::isfinite(value)) {
        throw InputError(path, number, names[k], tokens[k], "a finite number");
      }
      v[k] = value;
    }
    out.push_back(v);
  }
  return out;
}

namespace {

// ground_truth.json's world_from_<name> matrices by name (world_from_lidar required).
std::map<std::string, Eigen::Matrix4d> ReadGroundTruth(const std::string& gt_path) {
  const std::string text = io::ReadWholeFile(gt_path);
  nlohmann::json gt;
  try {
    gt = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError::AtByte(gt_path, e.byte, "JSON", "a syntax error", "valid JSON");
  }
  if (!gt.is_object() || !gt.contains("world_from_lidar")) {
    throw InputError(gt_path, 0, "world_from_lidar", "missing", "a 4×4 matrix for clouds/lidar.ply");
  }
  std::map<std::string, Eigen::Matrix4d> world_from;
  for (auto it = gt.begin(); it != gt.end(); ++it) {
    const std::string key = it.key();
    if (key.rfind("world_from_", 0) != 0) continue;
    world_from[key.substr(11)] = ReadMatrix(it.value(), gt_path, key);
  }
  return world_from;
}

// The options' methods and truth window, checked.
void CheckSceneEvalOptions(const SceneEvalOptions& options) {
  for (const std::string& method : options.methods) {
    Descriptor d;
    if (method != "mmba" && method != "mmba-g" && method != kFromTruth &&
        !ParseDescriptor(method, &d)) {
      throw InputError::Message("methods", "unknown method '" + method +
                                               "', expected fpfh, shot, si, sc3d, mmba, mmba-g "
                                               "or from-truth");
    }
  }
  if (!(options.truth_window_m > 0.0) ||
      !(options.truth_window_deg > 0.0 && options.truth_window_deg <= 180.0)) {
    throw InputError::Message("truth window", "expected > 0 m and (0, 180] degrees");
  }
}

// Runs the methods on the cells of one scene folder: its clouds read once each, its viewpoint
// files, the cells the options select.
class SceneRunner {
 public:
  SceneRunner(const std::string& dir, const SceneEvalOptions& options,
              const std::map<std::string, Eigen::Matrix4d>& world_from, SceneEvaluation* eval)
      : dir_(dir), options_(options), world_from_(world_from), eval_(*eval),
        cell_seen_(options.cells.size(), false) {}

  const io::PointCloud& Cloud(const std::string& name) {
    auto it = clouds_.find(name);
    if (it == clouds_.end()) {
      it = clouds_.emplace(name, io::ReadPointCloud((fs::path(dir_) / "clouds" / (name + ".ply")).string()))
               .first;
    }
    return it->second;
  }

  // Every method on source → target, when the options select that cell.
  void Run(const std::string& experiment, const std::string& source, const std::string& target) {
    if (!Selected(source, target)) return;
    const Eigen::Matrix4d truth = Inverse(world_from_.at(target)) * world_from_.at(source);
    for (const std::string& method : options_.methods) {
      eval_.rows.push_back(RunMethod(experiment, source, target, method, truth));
    }
  }

  // Refuses a selected cell that is no cell of the scene.
  void CheckCellsSeen() const {
    for (size_t i = 0; i < options_.cells.size(); ++i) {
      if (!cell_seen_[i]) {
        throw InputError::Message("cells", "'" + options_.cells[i] +
                                               "' is no cell of " + dir_ +
                                               " (expected SOURCE:TARGET, e.g. multi_view:lidar or "
                                               "spherical_stereo_part:plane_proxy)");
      }
    }
  }

 private:
  // clouds/<name>.viewpoints.txt (a part falls back to its whole model's), when used.
  std::vector<Eigen::Vector3d> Viewpoints(const std::string& name) const {
    if (!options_.use_viewpoints) return {};
    fs::path file = fs::path(dir_) / "clouds" / (name + ".viewpoints.txt");
    if (!fs::exists(file) && name.size() > 5 && name.substr(name.size() - 5) == "_part") {
      file = fs::path(dir_) / "clouds" / (name.substr(0, name.size() - 5) + ".viewpoints.txt");
    }
    return fs::exists(file) ? ReadViewpoints(file.string()) : std::vector<Eigen::Vector3d>{};
  }

  bool Selected(const std::string& source, const std::string& target) {
    if (options_.cells.empty()) return true;
    bool any = false;
    for (size_t i = 0; i < options_.cells.size(); ++i) {
      if (options_.cells[i] == source + ":" + target) any = cell_seen_[i] = true;
    }
    return any;
  }

  // One method on one cell. The reference (from-truth): the source moved to its true pose
  // first (points, normals and sensor positions), searched only around it; its result
  // composed with that move.
  EvalRow RunMethod(const std::string& experiment, const std::string& source, const std::string& target,
                    const std::string& method, const Eigen::Matrix4d& truth) {
    CloudRegistrationOptions o = options_.base;
    const bool from_truth = method == kFromTruth;
    io::PointCloud placed;
    if (method == "mmba" || method == "mmba-g" || from_truth) {
      o.descriptor = Descriptor::kAuto;
      o.paper_only = false;
      if (method == "mmba-g") o.gravity_aligned = true;
      o.source_viewpoints = Viewpoints(source);
      o.target_viewpoints = Viewpoints(target);
    } else {
      ParseDescriptor(method, &o.descriptor);
      o.paper_only = true;
    }
    if (from_truth) {
      placed = PlacedAtTruth(Cloud(source), truth, &o.source_viewpoints);
      o.search_window_m = options_.truth_window_m;
      o.search_window_deg = options_.truth_window_deg;
    }
    CloudRegistrationResult r = RegisterClouds(from_truth ? placed : Cloud(source), Cloud(target), o);
    if (from_truth) r.target_from_source = r.target_from_source * truth;
    EvalRow row;
    row.experiment = experiment;
    row.source = source;
    row.target = target;
    row.method = method;
    row.status = r.status;
    row.reason = r.reason;
    // A reference that failed before it had any pose (the truth's neighbourhood drifted
    // out of the window in the coarse ICP) has no RMS: not the truth's 0.
    row.rms_m = from_truth && !r.ok() && r.hypotheses.empty()
                    ? std::numeric_limits<double>::quiet_NaN()
                    : TransformRmsOnCloud(Cloud(source), r.target_from_source, truth);
    row.runtime_s = r.total_seconds();
    row.fitness = r.fitness;
    row.confidence = r.confidence;
    row.resolution_m = r.resolution_m;
    row.sigma_rms_m = r.sigma_rms_m;
    row.violation = r.violation;
    row.visibility = r.visibility_tested;
    row.intensity_correlation = r.intensity_tested ? r.intensity_correlation : -1.0;
    row.success = row.rms_m < eval_.success_threshold_m;
    row.accurate = row.rms_m < options_.accurate_m;
    spdlog::info("{} {} → {} [{}]: {} RMS {:.4g} m, {:.2f} s", experiment, source, target,
                 method, r.status, row.rms_m, row.runtime_s);
    return row;
  }

  const std::string& dir_;
  const SceneEvalOptions& options_;
  const std::map<std::string, Eigen::Matrix4d>& world_from_;
  SceneEvaluation& eval_;
  std::map<std::string, io::PointCloud> clouds_;
  std::vector<bool> cell_seen_;
};

}  // namespace

SceneEvaluation EvaluateScene(const std::string& dir, const SceneEvalOptions& options) {
  SceneEvaluation eval;
  eval.dir = dir;
  const std::map<std::string, Eigen::Matrix4d> world_from =
      ReadGroundTruth((fs::path(dir) / "ground_truth.json").string());
  for (const auto& [name, m] : world_from) {
    if (name == "lidar" || (name.size() > 5 && name.substr(name.size() - 5) == "_part")) continue;
    if (fs::exists(fs::path(dir) / "clouds" / (name + ".ply"))) eval.modalities.push_back(name);
  }
  if (eval.modalities.empty()) {
    throw InputError::Message(dir, "no modality: ground_truth.json names no world_from_<m> "
                                   "with a clouds/<m>.ply besides lidar");
  }
  CheckSceneEvalOptions(options);
  SceneRunner runner(dir, options, world_from, &eval);
  const io::PointCloud& lidar = runner.Cloud("lidar");
  if (lidar.empty()) throw InputError::Message(dir + "/clouds/lidar.ply", "empty cloud");
  Eigen::Vector3d lo = lidar.points[0], hi = lidar.points[0];
  for (const auto& p : lidar.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  eval.extent_m = (hi - lo).maxCoeff();
  eval.success_threshold_m = options.success_fraction * eval.extent_m;
  eval.accurate_m = options.accurate_m;
  eval.truth_window_m = options.truth_window_m;
  eval.truth_window_deg = options.truth_window_deg;

  for (const std::string& m : eval.modalities) runner.Run("to-lidar", m, "lidar");
  if (options.cross_modal) {
    std::vector<std::string> models = eval.modalities;
    models.push_back("lidar");
    for (const std::string& m : eval.modalities) {
      const std::string part = m + "_part";
      if (!world_from.count(part) || !fs::exists(fs::path(dir) / "clouds" / (part + ".ply"))) {
        continue;
      }
      for (const std::string& target : models) {
        if (target != m) runner.Run("cross-modal", part, target);
      }
    }
  }
  runner.CheckCellsSeen();
  return eval;
}

}  // namespace mmba::registration
