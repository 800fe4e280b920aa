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

#include "mmba/core/atomic_file.h"
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

std::string Seconds(double s) {
  std::ostringstream out;
  out << std::setprecision(2) << s << " s";
  return out.str();
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

SceneEvaluation EvaluateScene(const std::string& dir, const SceneEvalOptions& options) {
  SceneEvaluation eval;
  eval.dir = dir;
  const std::string gt_path = (fs::path(dir) / "ground_truth.json").string();
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
  for (const auto& [name, m] : world_from) {
    if (name == "lidar" || (name.size() > 5 && name.substr(name.size() - 5) == "_part")) continue;
    if (fs::exists(fs::path(dir) / "clouds" / (name + ".ply"))) eval.modalities.push_back(name);
  }
  if (eval.modalities.empty()) {
    throw InputError::Message(dir, "no modality: ground_truth.json names no world_from_<m> "
                                   "with a clouds/<m>.ply besides lidar");
  }
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
  std::map<std::string, io::PointCloud> clouds;
  auto cloud = [&](const std::string& name) -> const io::PointCloud& {
    auto it = clouds.find(name);
    if (it == clouds.end()) {
      it = clouds.emplace(name, io::ReadPointCloud((fs::path(dir) / "clouds" / (name + ".ply")).string()))
               .first;
    }
    return it->second;
  };
  const io::PointCloud& lidar = cloud("lidar");
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

  auto viewpoints = [&](const std::string& name) -> std::vector<Eigen::Vector3d> {
    if (!options.use_viewpoints) return {};
    fs::path file = fs::path(dir) / "clouds" / (name + ".viewpoints.txt");
    if (!fs::exists(file) && name.size() > 5 && name.substr(name.size() - 5) == "_part") {
      file = fs::path(dir) / "clouds" / (name.substr(0, name.size() - 5) + ".viewpoints.txt");
    }
    return fs::exists(file) ? ReadViewpoints(file.string()) : std::vector<Eigen::Vector3d>{};
  };
  std::vector<bool> cell_seen(options.cells.size(), false);
  auto selected = [&](const std::string& source, const std::string& target) {
    if (options.cells.empty()) return true;
    bool any = false;
    for (size_t i = 0; i < options.cells.size(); ++i) {
      if (options.cells[i] == source + ":" + target) any = cell_seen[i] = true;
    }
    return any;
  };
  auto run = [&](const std::string& experiment, const std::string& source,
                 const std::string& target) {
    if (!selected(source, target)) return;
    const Eigen::Matrix4d truth = Inverse(world_from.at(target)) * world_from.at(source);
    for (const std::string& method : options.methods) {
      CloudRegistrationOptions o = options.base;
      // The reference: the source moved to its true pose first (points, normals and sensor
      // positions), searched only around it; its result composed with that move.
      const bool from_truth = method == kFromTruth;
      io::PointCloud placed;
      if (method == "mmba" || method == "mmba-g" || from_truth) {
        o.descriptor = Descriptor::kAuto;
        o.paper_only = false;
        if (method == "mmba-g") o.gravity_aligned = true;
        o.source_viewpoints = viewpoints(source);
        o.target_viewpoints = viewpoints(target);
      } else {
        ParseDescriptor(method, &o.descriptor);
        o.paper_only = true;
      }
      if (from_truth) {
        placed = PlacedAtTruth(cloud(source), truth, &o.source_viewpoints);
        o.search_window_m = options.truth_window_m;
        o.search_window_deg = options.truth_window_deg;
      }
      CloudRegistrationResult r =
          RegisterClouds(from_truth ? placed : cloud(source), cloud(target), o);
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
                      : TransformRmsOnCloud(cloud(source), r.target_from_source, truth);
      row.runtime_s = r.total_seconds();
      row.fitness = r.fitness;
      row.confidence = r.confidence;
      row.resolution_m = r.resolution_m;
      row.sigma_rms_m = r.sigma_rms_m;
      row.violation = r.violation;
      row.visibility = r.visibility_tested;
      row.intensity_correlation = r.intensity_tested ? r.intensity_correlation : -1.0;
      row.success = row.rms_m < eval.success_threshold_m;
      row.accurate = row.rms_m < options.accurate_m;
      spdlog::info("{} {} → {} [{}]: {} RMS {:.4g} m, {:.2f} s", experiment, source, target,
                   method, r.status, row.rms_m, row.runtime_s);
      eval.rows.push_back(row);
    }
  };
  for (const std::string& m : eval.modalities) run("to-lidar", m, "lidar");
  if (options.cross_modal) {
    std::vector<std::string> models = eval.modalities;
    models.push_back("lidar");
    for (const std::string& m : eval.modalities) {
      const std::string part = m + "_part";
      if (!world_from.count(part) || !fs::exists(fs::path(dir) / "clouds" / (part + ".ply"))) {
        continue;
      }
      for (const std::string& target : models) {
        if (target != m) run("cross-modal", part, target);
      }
    }
  }
  for (size_t i = 0; i < options.cells.size(); ++i) {
    if (!cell_seen[i]) {
      throw InputError::Message("cells", "'" + options.cells[i] +
                                             "' is no cell of " + dir +
                                             " (expected SOURCE:TARGET, e.g. multi_view:lidar or "
                                             "spherical_stereo_part:plane_proxy)");
    }
  }
  return eval;
}

void WriteSceneEvaluation(const SceneEvaluation& eval, const std::string& out_dir) {
  AtomicFileSet files;
  files.Add(fs::path(out_dir) / "results.csv", [&](std::ostream& out) {
    out << "experiment,source,target,method,status,rms_m,success,accurate,runtime_s,fitness,"
           "confidence,resolution_m,sigma_rms_m,visibility,violation,intensity_correlation,reason\n";
    out << std::setprecision(6);
    for (const EvalRow& r : eval.rows) {
      std::string reason = r.reason;
      std::replace(reason.begin(), reason.end(), '"', '\'');
      out << r.experiment << ',' << r.source << ',' << r.target << ',' << r.method << ','
          << r.status << ',' << r.rms_m << ',' << (r.success ? 1 : 0) << ','
          << (r.accurate ? 1 : 0) << ',' << r.runtime_s << ',' << r.fitness << ','
          << r.confidence << ',' << r.resolution_m << ',' << r.sigma_rms_m << ','
          << (r.visibility ? 1 : 0) << ','
          << r.violation << ',';
      // empty when the intensity test did not run
      if (r.intensity_correlation >= 0) out << r.intensity_correlation;
      out << ",\"" << reason << "\"\n";
    }
  });
  files.Add(fs::path(out_dir) / "tables.md", [&](std::ostream& out) {
    std::vector<std::string> methods;
    for (const EvalRow& r : eval.rows) {
      if (std::find(methods.begin(), methods.end(), r.method) == methods.end()) {
        methods.push_back(r.method);
      }
    }
    out << std::setprecision(3);
    out << "Scene `" << eval.dir << "`: extent " << eval.extent_m
        << " m; success = RMS to ground truth < " << eval.success_threshold_m
        << " m (Kim & Hilton: 3 m on the 30 m Cathedral, scaled); accurate = RMS < "
        << eval.accurate_m << " m. Cell: RMS m, ✓ success / ✗ failure, "
        << "(status failed = the method itself reported failure; ok: the pose resolution it "
           "states), runtime s.\n\n";
    auto cell = [](const EvalRow& r) {
      std::ostringstream s;
      if (std::isnan(r.rms_m)) return "no pose (" + r.status + "), " + Seconds(r.runtime_s);
      s << std::setprecision(3) << r.rms_m << (r.success ? " ✓" : " ✗")
        << (r.status == "ok" ? "" : " (" + r.status + ")");
      if (r.status == "ok") s << " (ok, resolved to " << r.resolution_m << " m)";
      s << ", " << Seconds(r.runtime_s);
      return s.str();
    };
    // Table I.
    out << "Table I — each modality registered to the LiDAR model\n\n| modality |";
    for (const auto& m : methods) out << ' ' << m << " |";
    out << "\n|---|";
    for (size_t i = 0; i < methods.size(); ++i) out << "---|";
    out << '\n';
    for (const std::string& mod : eval.modalities) {
      out << "| " << mod << " |";
      for (const auto& method : methods) {
        std::string c = "–";
        for (const EvalRow& r : eval.rows) {
          if (r.experiment == "to-lidar" && r.source == mod && r.method == method) c = cell(r);
        }
        out << ' ' << c << " |";
      }
      out << '\n';
    }
    // Table II.
    std::vector<std::string> parts, targets;
    for (const EvalRow& r : eval.rows) {
      if (r.experiment != "cross-modal") continue;
      if (std::find(parts.begin(), parts.end(), r.source) == parts.end()) parts.push_back(r.source);
      if (std::find(targets.begin(), targets.end(), r.target) == targets.end()) {
        targets.push_back(r.target);
      }
    }
    if (!parts.empty()) {
      out << "\nTable II — cross-modal matrix: each part (rows) registered to each other full "
             "model (columns)\n";
      for (const auto& method : methods) {
        int ok = 0, total = 0, accurate = 0, refused = 0;
        std::ostringstream table;
        table << "\n" << method << "\n\n| part \\ model |";
        for (const auto& t : targets) table << ' ' << t << " |";
        table << "\n|---|";
        for (size_t i = 0; i < targets.size(); ++i) table << "---|";
        table << '\n';
        for (const auto& p : parts) {
          table << "| " << p << " |";
          for (const auto& t : targets) {
            std::string c = "–";
            for (const EvalRow& r : eval.rows) {
              if (r.experiment == "cross-modal" && r.source == p && r.target == t &&
                  r.method == method) {
                c = cell(r);
                ++total;
                // A success is a pose the method gave (ok, or the paper's unverified best)
                // within the threshold; a pose it refused is counted apart.
                const bool given = r.status != "failed";
                ok += given && r.success ? 1 : 0;
                accurate += given && r.accurate ? 1 : 0;
                refused += !given && r.success ? 1 : 0;
              }
            }
            table << ' ' << c << " |";
          }
          table << '\n';
        }
        out << table.str() << "\n" << method << ": " << ok << " of " << total
            << " succeeded, " << accurate << " of " << total << " accurate (poses the method gave; "
            << refused << " more refused by the method at a pose within the success threshold).\n";
      }
    }
    // The best method per cell (the "registered ... with the best method"): of the
    // methods that reported ok, the one closest to the ground truth. A cell counts as
    // registered when that one is accurate; a method that reported ok beyond the success
    // threshold is a wrong ok, counted on its own. Choosing by the truth is an evaluation's
    // privilege; a user has only the results' own words, so the table also gives the ok a
    // user would take — the one with the smallest stated uncertainty (sigma_rms_m) — and
    // whether it is accurate.
    struct Cell {
      const EvalRow* first = nullptr;
      const EvalRow* best = nullptr;
      const EvalRow* chosen = nullptr;
      const EvalRow* reference = nullptr;  // the "from-truth" row, when run
      const EvalRow* closest = nullptr;    // any status: the method row nearest the truth
    };
    std::vector<Cell> cells;
    int wrong_ok = 0;
    for (const EvalRow& r : eval.rows) {
      auto it = std::find_if(cells.begin(), cells.end(), [&](const Cell& c) {
        return c.first->experiment == r.experiment && c.first->source == r.source &&
               c.first->target == r.target;
      });
      if (it == cells.end()) it = cells.insert(cells.end(), Cell{&r});
      if (r.method == kFromTruth) {
        it->reference = &r;
        continue;
      }
      if (std::isfinite(r.rms_m) && (it->closest == nullptr || r.rms_m < it->closest->rms_m)) {
        it->closest = &r;
      }
      if (r.status != "ok") continue;
      wrong_ok += r.success ? 0 : 1;
      if (it->best == nullptr || r.rms_m < it->best->rms_m) it->best = &r;
      if (it->chosen == nullptr || r.sigma_rms_m < it->chosen->sigma_rms_m) it->chosen = &r;
    }
    if (cells.empty()) return;
    const bool with_reference = std::any_of(cells.begin(), cells.end(), [](const Cell& c) {
      return c.reference != nullptr;
    });
    int registered = 0, refused = 0, chosen_registered = 0;
    int allowed = 0, allowed_registered = 0, allowed_refused_right = 0;
    std::ostringstream off, limited, missed;
    off << std::setprecision(3);
    limited << std::setprecision(3);
    missed << std::setprecision(3);
    out << "\nBest method per cell — of the methods that reported ok, the one closest to the "
           "ground truth; and the one chosen without it, by the smallest stated sigma_rms_m"
        << (with_reference ? "; and the reference started at the truth (from-truth: RMS m, "
                             "status; no method a user has)"
                           : "")
        << "\n\n| experiment | source → target | best | RMS m | chosen by σ | its σ m | its RMS m |"
        << (with_reference ? " from the truth |" : "") << "\n|---|---|---|---|---|---|---|"
        << (with_reference ? "---|" : "") << "\n";
    for (const Cell& c : cells) {
      out << "| " << c.first->experiment << " | " << c.first->source << " → " << c.first->target
          << " | ";
      if (c.best == nullptr) {
        out << "– (every method failed) | – | – | – | – |";
        ++refused;
      } else {
        out << c.best->method << " | " << c.best->rms_m << " | " << c.chosen->method << " | "
            << c.chosen->sigma_rms_m << " | " << c.chosen->rms_m << " |";
        chosen_registered += c.chosen->accurate ? 1 : 0;
        if (c.best->accurate) {
          ++registered;
        } else {
          off << (off.tellp() > 0 ? "; " : "") << c.first->source << " → " << c.first->target
              << " " << c.best->rms_m << " m";
        }
      }
      if (with_reference) {
        const EvalRow* ref = c.reference;
        if (ref == nullptr) {
          out << " – |";
        } else {
          if (std::isnan(ref->rms_m)) {
            out << " no pose, " << ref->status << " |";
          } else {
            out << ' ' << ref->rms_m << ", " << ref->status << " |";
          }
          if (ref->status == "ok" && ref->accurate) {
            ++allowed;
            if (c.best != nullptr && c.best->accurate) {
              ++allowed_registered;
            } else {
              // Search- or check-limited: the method row nearest the truth, and the first
              // words of its reason ("ambiguous", "pose not determined", ...).
              missed << (missed.tellp() > 0 ? "; " : "") << c.first->source << " → "
                     << c.first->target;
              if (c.closest == nullptr) {
                missed << " (no method row with a pose)";
              } else {
                const EvalRow& n = *c.closest;
                missed << " (closest: " << n.method << " " << n.rms_m << " m " << n.status;
                if (!n.reason.empty()) missed << ", " << n.reason.substr(0, n.reason.find(':'));
                missed << ")";
                allowed_refused_right += n.accurate ? 1 : 0;  // (an accurate ok is the best)
              }
            }
          } else {
            limited << (limited.tellp() > 0 ? "; " : "") << c.first->source << " → "
                    << c.first->target << " ";
            if (std::isnan(ref->rms_m)) {
              limited << "no pose";
            } else {
              limited << ref->rms_m << " m " << ref->status;
            }
          }
        }
      }
      out << "\n";
    }
    out << "\nRegistered with the best method (ok and RMS < " << eval.accurate_m
        << " m): " << registered << " of " << cells.size() << " cells; every method failed: "
        << refused << "; best ok but RMS ≥ " << eval.accurate_m << " m: "
        << cells.size() - registered - refused << (off.tellp() > 0 ? " (" + off.str() + ")" : "")
        << "; wrong ok (any method, RMS ≥ " << eval.success_threshold_m << " m): " << wrong_ok
        << ".\nRegistered with the method chosen by its stated σ (ok and RMS < " << eval.accurate_m
        << " m): " << chosen_registered << " of " << cells.size() << " cells.\n";
    if (with_reference) {
      out << "From the truth (the reference, searched within " << eval.truth_window_m << " m / "
          << eval.truth_window_deg << "° of it): ok and RMS < " << eval.accurate_m << " m in "
          << allowed << " of " << cells.size()
          << " cells — what the data and the checks allow; of those, registered with the best "
             "method: "
          << allowed_registered;
      if (missed.tellp() > 0) {
        out << "; not registered by any method (search- or check-limited; "
            << allowed_refused_right << " of them refused at a pose within " << eval.accurate_m
            << " m): " << missed.str();
      }
      out << ". Not registered even from the truth (data- or check-limited): "
          << (limited.tellp() > 0 ? limited.str() : std::string("none")) << ".\n";
    }
  });
  files.Commit();
}

}  // namespace mmba::registration
