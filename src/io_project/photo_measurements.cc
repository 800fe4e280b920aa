// Project keys of photogrammetric networks from image measurements: frame, control,
// scale_bars and the sensor `type: photo_measurements` (docs/project-yaml.md).
#include <algorithm>
#include <filesystem>
#include <set>

#include "mmba/io/camera_yaml.h"
#include "mmba/io/column_text.h"
#include "mmba/io/control_points.h"
#include "mmba/io/image_measurements.h"
#include "project_internal.h"

namespace mmba::adjust::project_internal {
namespace {

namespace fs = std::filesystem;
using Node = const YAML::Node&;
using Field = const std::string&;

/// The comma-separated names of a model's parameters ("fx, fy, cx, cy, k1, …") as a list.
std::vector<std::string> ParamNames(sensors::CameraModelId model) {
  std::vector<std::string> names;
  const std::string info = sensors::CameraModelParamsInfo(model);
  size_t start = 0;
  while (start < info.size()) {
    size_t end = info.find(',', start);
    if (end == std::string::npos) end = info.size();
    std::string name = info.substr(start, end - start);
    while (!name.empty() && name.front() == ' ') name.erase(name.begin());
    names.push_back(name);
    start = end + 1;
  }
  return names;
}

/// `refine`: focal, principal_point, distortion or the model's own parameter names → indices.
std::vector<int> FreeIntrinsics(const io::YamlReader& r, Node n, Field f, const sensors::Camera& camera,
                                std::vector<std::string>* names) {
  *names = r.StringList(n, f);
  const std::vector<std::string> params = ParamNames(camera.model_id);
  std::set<int> free;
  for (size_t i = 0; i < names->size(); ++i) {
    const std::string& name = (*names)[i];
    std::vector<int> idx;
    if (name == "focal") idx = sensors::CameraModelFocalIdxs(camera.model_id);
    else if (name == "principal_point") idx = sensors::CameraModelPrincipalIdxs(camera.model_id);
    else if (name == "distortion") idx = sensors::CameraModelExtraIdxs(camera.model_id);
    for (size_t k = 0; k < params.size(); ++k) {
      if (params[k] == name) idx.push_back(static_cast<int>(k));
    }
    if (idx.empty()) {
      std::string allowed = "focal, principal_point, distortion";
      for (const std::string& p : params) allowed += ", " + p;
      r.Fail(n[i], f + "[" + std::to_string(i) + "]", "one of " + allowed + " (camera model " + camera.ModelName() + ")", name);
    }
    free.insert(idx.begin(), idx.end());
  }
  for (int k : sensors::CameraModelFixedIdxs(camera.model_id)) free.erase(k);  // the sensor's pixel pitch
  return {free.begin(), free.end()};
}

io::MeasurementFile MeasurementEntry(const io::YamlReader& r, Node n, Field f, const std::string& dir) {
  io::MeasurementFile m;
  bool have_sigma = false;
  r.Map(n, f, {{"file", [&](Node v, Field g) { m.file = ExistingFile(r, v, g, dir); }},
               {"columns", [&](Node v, Field g) {
                  m.columns = r.StringList(v, g);
                  io::CheckMeasurementColumns(m.columns, r.path(), v.Mark().line + 1, g);
                }},
               {"sigma_px", [&](Node v, Field g) {
                  m.sigma_px = r.Positive(v, g, 50.0, "px");
                  have_sigma = true;
                }}});
  r.Require(n, f, {"file", "columns"});
  const bool file_sigma = io::ColumnIndex(m.columns, "sxy") >= 0 ||
                          (io::ColumnIndex(m.columns, "sx") >= 0 && io::ColumnIndex(m.columns, "sy") >= 0);
  if (!have_sigma && !file_sigma) r.Fail(n, f + ".sigma_px", "σ of the measurements in pixels (or sx, sy columns)", "nothing");
  return m;
}

}  // namespace

std::string ExistingFile(const io::YamlReader& r, Node n, Field f, const std::string& dir) {
  const fs::path given = r.String(n, f);
  const fs::path full = given.is_absolute() ? given : fs::path(dir) / given;
  if (!fs::exists(full)) r.Fail(n, f, "an existing file", given.string() + " (not found)");
  if (fs::is_directory(full)) r.Fail(n, f, "a file", given.string() + " (a folder)");
  return full.string();
}

WorldFrame ReadFrame(const io::YamlReader& r, Node n, Field f) {
  const std::string value = r.String(n, f);
  if (value == "cartesian") return WorldFrame::kCartesian;
  if (value == "local_tangent_plane") return WorldFrame::kLocalTangentPlane;
  r.Fail(n, f, "cartesian (the control's local metric frame) or local_tangent_plane (ENU at origin)", value);
}

ControlFile ReadControl(const io::YamlReader& r, Node n, Field f, const std::string& dir) {
  ControlFile c;
  c.line = n.Mark().line + 1;
  r.Map(n, f, {{"file", [&](Node v, Field g) { c.file = ExistingFile(r, v, g, dir); }},
               {"columns", [&](Node v, Field g) {
                  c.columns = r.StringList(v, g);
                  io::CheckControlColumns(c.columns, r.path(), v.Mark().line + 1, g);
                }},
               {"sigma_m", [&](Node v, Field g) {
                  c.sigma_m = r.Number(v, g);
                  if (!(c.sigma_m >= 0 && c.sigma_m <= 100)) r.Fail(v, g, "a σ in metres in [0, 100] (0 = fixed)", r.Text(v));
                }}});
  r.Require(n, f, {"file", "columns"});
  if (!io::ControlColumnsHaveSigma(c.columns) && c.sigma_m < 0) {
    r.Fail(n, f + ".sigma_m", "σ of the control in metres (0 = fixed): the columns name no sx, sy, sz or sxyz", "nothing");
  }
  return c;
}

std::vector<ScaleBar> ReadScaleBars(const io::YamlReader& r, Node n, Field f) {
  if (!n.IsSequence()) r.Fail(n, f, "a list of {from, to, distance_m, sigma_m}", io::YamlReader::Kind(n));
  std::vector<ScaleBar> bars;
  for (size_t i = 0; i < n.size(); ++i) {
    const std::string g = f + "[" + std::to_string(i) + "]";
    ScaleBar b;
    b.line = n[i].Mark().line + 1;
    r.Map(n[i], g, {{"from", [&](Node v, Field h) { b.from = r.String(v, h); }},
                    {"to", [&](Node v, Field h) { b.to = r.String(v, h); }},
                    {"distance_m", [&](Node v, Field h) { b.distance_m = r.Positive(v, h, 1e4, "m"); }},
                    {"sigma_m", [&](Node v, Field h) { b.sigma_m = r.Positive(v, h, 1.0, "m (metres)"); }}});
    r.Require(n[i], g, {"from", "to", "distance_m", "sigma_m"});
    if (b.from == b.to) r.Fail(n[i]["to"], g + ".to", "a point other than 'from'", b.to);
    bars.push_back(b);
  }
  return bars;
}

PhotoMeasurements ReadPhotoMeasurements(const io::YamlReader& r, Node n, Field f, const std::string& id,
                                        const std::string& dir) {
  PhotoMeasurements p;
  p.id = id;
  p.line = n.Mark().line + 1;
  YAML::Node refine;
  bool have_refine = false;
  r.Map(n, f, {{"id", [](Node, Field) {}}, {"type", [](Node, Field) {}},
               {"camera", [&](Node v, Field g) { p.camera = ExistingFile(r, v, g, dir); }},
               {"images", [&](Node v, Field g) { p.images = ExistingFile(r, v, g, dir); }},
               {"measurements", [&](Node v, Field g) {
                  if (!v.IsSequence() || v.size() == 0) r.Fail(v, g, "a non-empty list of {file, columns, sigma_px}", io::YamlReader::Kind(v));
                  for (size_t i = 0; i < v.size(); ++i) {
                    p.measurements.push_back(MeasurementEntry(r, v[i], g + "[" + std::to_string(i) + "]", dir));
                    p.measurement_lines.push_back(v[i].Mark().line + 1);
                  }
                }},
               {"refine", [&](Node v, Field) {
                  refine = v;
                  have_refine = true;
                }},
               {"prior_eo", [&](Node v, Field g) {
                  r.Map(v, g, {{"file", [&](Node w, Field h) { p.prior_eo = ExistingFile(r, w, h, dir); }},
                               {"columns", [&](Node w, Field h) {
                                  p.prior_eo_columns = r.StringList(w, h);
                                  io::CheckColumnNames(p.prior_eo_columns, {"image", "x", "y", "z", "omega", "phi", "kappa"},
                                                       {"image", "x", "y", "z", "omega", "phi", "kappa"}, r.path(),
                                                       w.Mark().line + 1, h);
                                }}});
                  r.Require(v, g, {"file", "columns"});
                }},
               {"gcp_list", [&](Node v, Field g) {
                  p.gcp_list_line = v.Mark().line + 1;
                  r.Map(v, g, {{"file", [&](Node w, Field h) { p.gcp_list = ExistingFile(r, w, h, dir); }},
                               {"sigma_px", [&](Node w, Field h) { p.gcp_sigma_px = r.Positive(w, h, 50.0, "px"); }},
                               {"sigma_m", [&](Node w, Field h) {
                                  p.gcp_sigma_m = r.Number(w, h);
                                  if (!(p.gcp_sigma_m >= 0 && p.gcp_sigma_m <= 100)) {
                                    r.Fail(w, h, "a σ in metres in [0, 100] (0 = fixed)", io::YamlReader::Text(w));
                                  }
                                }}});
                  r.Require(v, g, {"file", "sigma_px", "sigma_m"});
                }},
               {"loss", [&](Node v, Field g) {
                  if (!v.IsScalar()) r.Fail(v, g, "none, huber, cauchy or soft_l1", io::YamlReader::Kind(v));
                  const std::string name = r.String(v, g);
                  if (!ParseLossType(name, &p.loss.type)) r.Fail(v, g, "none, huber, cauchy or soft_l1", name);
                }}});
  r.Require(n, f, {"camera"});
  if (p.measurements.empty() && p.gcp_list.empty()) r.Require(n, f, {"measurements"});
  const sensors::Camera camera = io::ReadCameraFile(p.camera).camera;
  if (have_refine) {
    p.free_intrinsics = FreeIntrinsics(r, refine, f + ".refine", camera, &p.refine);
  } else {  // default: self-calibration of every parameter
    p.refine = {"focal", "principal_point", "distortion"};
    const std::vector<int> fixed = sensors::CameraModelFixedIdxs(camera.model_id);
    for (int k = 0; k < static_cast<int>(camera.params.size()); ++k) {
      if (std::find(fixed.begin(), fixed.end(), k) == fixed.end()) p.free_intrinsics.push_back(k);
    }
  }
  return p;
}

void CheckPhotogrammetricKeys(const Project& project, const io::YamlReader& r, Node root, bool have_origin) {
  if (project.frame == WorldFrame::kLocalTangentPlane && !have_origin) {
    r.Fail(root, "origin", "the key to be present (or frame: cartesian for a local control frame)", "nothing");
  }
  if (project.frame == WorldFrame::kCartesian && have_origin) {
    r.Fail(root["origin"], "origin", "no origin with frame: cartesian (the world is the control's own frame)", "an origin");
  }
  if (project.frame == WorldFrame::kCartesian && !project.gnss.empty()) {
    r.Fail(root["frame"], "frame", "local_tangent_plane with an origin: a gnss sensor gives WGS84 positions", "cartesian");
  }
  if ((project.control || !project.scale_bars.empty()) && project.photo_measurements.empty()) {
    r.Fail(root[project.control ? "control" : "scale_bars"], project.control ? "control" : "scale_bars",
           "a photo_measurements sensor whose points it holds", "none");
  }
}

}  // namespace mmba::adjust::project_internal
