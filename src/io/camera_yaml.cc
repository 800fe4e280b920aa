#include "mmba/io/camera_yaml.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/core/number_text.h"
#include "mmba/io/colmap_model.h"
#include "mmba/io/dbat_camera.h"
#include "mmba/io/pose_json.h"

namespace mmba::io {

Rigid3d ReadLidarMountYaml(const std::string& path) {
  const YamlReader r(path);
  const YAML::Node root = r.Load("mobile LiDAR calibration");
  std::optional<Rigid3d> mounting;
  const auto ignore = [](const YAML::Node&, const std::string&) {};
  r.Map(root, "", {{"body_from_lidar", [&](const YAML::Node& n, const std::string& f) { mounting = ReadYamlPose(r, n, f); }},
                   {"beams", ignore}, {"elevation_deg", ignore}, {"rotation_hz", ignore}});
  if (!mounting) r.Fail(root, "body_from_lidar", "the key to be present", "nothing");
  return *mounting;
}

Rigid3d ReadYamlPose(const YamlReader& r, const YAML::Node& n, const std::string& f) {
  std::vector<double> q, t;
  r.Map(n, f, {{"qvec_wxyz", [&](const YAML::Node& v, const std::string& g) { q = r.NumberList(v, g); }},
               {"tvec", [&](const YAML::Node& v, const std::string& g) { t = r.NumberList(v, g); }}});
  if (q.size() != 4 || t.size() != 3) {
    r.Fail(n, f, "{qvec_wxyz: [4 numbers], tvec: [3 numbers]}",
           std::to_string(q.size()) + " and " + std::to_string(t.size()) + " numbers");
  }
  const Eigen::Quaterniond rotation(q[0], q[1], q[2], q[3]);
  if (std::abs(rotation.norm() - 1.0) > 1e-3) {
    r.Fail(n, f + ".qvec_wxyz", "a unit quaternion", "norm " + ExactNumber(rotation.norm()));
  }
  return Rigid3d(rotation.normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
}

namespace {

/// 16 numbers row-major, or 4 rows of 4 numbers.
Rigid3d Matrix4Pose(const YamlReader& r, const YAML::Node& n, const std::string& f) {
  std::vector<double> v;
  if (n.IsSequence() && n.size() == 4) {
    for (size_t i = 0; i < 4; ++i) {
      const std::vector<double> row = r.NumberList(n[i], f + "[" + std::to_string(i) + "]");
      if (row.size() != 4) r.Fail(n[i], f + "[" + std::to_string(i) + "]", "a row of 4 numbers", std::to_string(row.size()) + " numbers");
      v.insert(v.end(), row.begin(), row.end());
    }
  } else {
    v = r.NumberList(n, f);
    if (v.size() != 16) r.Fail(n, f, "16 numbers (4x4 row-major) or 4 rows of 4 numbers", std::to_string(v.size()) + " numbers");
  }
  return RigidFromRowMajor4x4(v.data(), r.path() + ":" + std::to_string(n.Mark().line + 1), f);
}

}  // namespace

namespace {

/// `params: [...]` in the model's order, with positive focal lengths.
std::vector<double> ReadParamsList(const YamlReader& r, const YAML::Node& params, sensors::CameraModelId model_id) {
  const int expected = sensors::CameraModelNumParams(model_id);
  if (!params.IsSequence() || static_cast<int>(params.size()) != expected) {
    r.Fail(params, "params",
           "a list of " + std::to_string(expected) + " values (" + sensors::CameraModelParamsInfo(model_id) + ")",
           params.IsSequence() ? std::to_string(params.size()) + " values" : "a " + YamlReader::Kind(params));
  }
  std::vector<double> values = r.NumberList(params, "params");
  for (int i : sensors::CameraModelFocalIdxs(model_id)) {
    if (!(values[i] > 0)) {
      r.Fail(params[i], "params[" + std::to_string(i) + "]", "a positive focal length", ExactNumber(values[i]));
    }
  }
  return values;
}

}  // namespace

namespace {

/// PHOTOGRAMMETRIC's named fields and their parameter index; the pitch (10, 11) comes from
/// format_width_mm / width and format_height_mm / height.
struct PhotoField {
  const char* key;
  int index;
  bool required;
};
constexpr PhotoField kPhotoFields[] = {
    {"c_mm", 0, true}, {"xp_mm", 1, true}, {"yp_mm", 2, true}, {"K1", 3, false}, {"K2", 4, false},
    {"K3", 5, false},  {"P1", 6, false},   {"P2", 7, false},   {"b1", 8, false}, {"b2", 9, false}};
constexpr const char* kPhotoFormatKeys[] = {"format_width_mm", "format_height_mm"};

bool IsPhotoKey(const std::string& key) {
  for (const PhotoField& f : kPhotoFields) {
    if (key == f.key) return true;
  }
  return key == kPhotoFormatKeys[0] || key == kPhotoFormatKeys[1];
}

/// The parameters of a PHOTOGRAMMETRIC camera from its named fields (calib/README.md).
std::vector<double> ReadPhotoParams(const YamlReader& r, const YAML::Node& root, const sensors::Camera& camera) {
  std::vector<std::string> required = {"format_width_mm", "format_height_mm"};
  for (const PhotoField& f : kPhotoFields) {
    if (f.required) required.push_back(f.key);
  }
  r.Require(root, "", required);
  std::vector<double> params(sensors::PhotogrammetricModel::kNumParams, 0.0);
  for (const PhotoField& f : kPhotoFields) {
    if (root[f.key]) params[f.index] = r.Number(root[f.key], f.key);
  }
  if (!(params[0] > 0)) r.Fail(root["c_mm"], "c_mm", "a positive camera constant (mm)", YamlReader::Text(root["c_mm"]));
  const uint64_t size[2] = {camera.width, camera.height};
  for (int i = 0; i < 2; ++i) {
    const YAML::Node node = root[kPhotoFormatKeys[i]];
    const double format_mm = r.Number(node, kPhotoFormatKeys[i]);
    if (!(format_mm > 0)) r.Fail(node, kPhotoFormatKeys[i], "a positive format size (mm)", YamlReader::Text(node));
    params[10 + i] = format_mm / static_cast<double>(size[i]);
  }
  return params;
}

}  // namespace

CameraYaml ReadCameraYaml(const std::string& path) {
  const YamlReader r(path);
  const YAML::Node root = r.Load("camera calibration");
  // The keys in any order: the parameter count depends on the model.
  std::optional<YAML::Node> model, width, height, params, pose;
  std::vector<std::string> photo_keys;
  const auto keep = [](std::optional<YAML::Node>* slot) {
    return [slot](const YAML::Node& n, const std::string&) { slot->emplace(n); };
  };
  std::map<std::string, YamlReader::Handler> handlers = {
      {"model", keep(&model)}, {"width", keep(&width)}, {"height", keep(&height)},
      {"params", keep(&params)}, {"cam_from_lidar", keep(&pose)}};
  for (const PhotoField& f : kPhotoFields) {
    handlers[f.key] = [&photo_keys](const YAML::Node&, const std::string& g) { photo_keys.push_back(g); };
  }
  for (const char* key : kPhotoFormatKeys) {
    handlers[key] = [&photo_keys](const YAML::Node&, const std::string& g) { photo_keys.push_back(g); };
  }
  r.Map(root, "", handlers);
  r.Require(root, "", {"model", "width", "height"});
  CameraYaml result;
  const std::string model_name = r.String(*model, "model");
  result.camera.model_id = sensors::CameraModelFromName(model_name);
  if (result.camera.model_id == sensors::CameraModelId::kInvalid) {
    r.Fail(*model, "model", "one of " + sensors::KnownCameraModelNames(), model_name);
  }
  const auto size = [&](const YAML::Node& n, const std::string& field) {
    const double value = r.Number(n, field);
    if (!(value >= 1 && value <= static_cast<double>(kMaxImageSidePx)) || value != std::floor(value)) {
      r.Fail(n, field, "a whole number of pixels in 1.." + std::to_string(kMaxImageSidePx), YamlReader::Text(n));
    }
    return static_cast<uint64_t>(value);
  };
  result.camera.width = size(*width, "width");
  result.camera.height = size(*height, "height");
  if (result.camera.model_id == sensors::CameraModelId::kPhotogrammetric) {
    if (params) {
      r.Fail(*params, "params", "the named fields of PHOTOGRAMMETRIC (c_mm, xp_mm, yp_mm, format_width_mm, format_height_mm, K1, K2, K3, P1, P2, b1, b2)", "params");
    }
    result.camera.params = ReadPhotoParams(r, root, result.camera);
  } else {
    if (!photo_keys.empty()) {
      r.Fail(root[photo_keys.front()], photo_keys.front(), "params: [...] for a " + model_name + " camera (named fields are for PHOTOGRAMMETRIC)", photo_keys.front());
    }
    r.Require(root, "", {"params"});
    result.camera.params = ReadParamsList(r, *params, result.camera.model_id);
  }
  if (pose) result.cam_from_lidar = Matrix4Pose(r, *pose, "cam_from_lidar");
  return result;
}

CameraYaml ReadCameraFile(const std::string& path) {
  std::string extension = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  if (extension != ".xml") return ReadCameraYaml(path);
  CameraYaml result;
  result.camera = ReadDbatCamera(path);
  return result;
}

RigYaml ReadRigYaml(const std::string& path) {
  const YamlReader r(path);
  const YAML::Node root = r.Load("rig calibration");
  RigYaml rig;
  r.Map(root, "",
        {{"body_from_rig", [&](const YAML::Node& v, const std::string& g) { rig.body_from_rig = ReadYamlPose(r, v, g); }},
         {"rig_from_lidar", [&](const YAML::Node& v, const std::string& g) { rig.rig_from_lidar = Matrix4Pose(r, v, g); }},
         {"cameras", [&](const YAML::Node& n, const std::string& f) {
            if (!n.IsSequence() || n.size() == 0) r.Fail(n, f, "a list of cameras", YamlReader::Kind(n));
            for (size_t i = 0; i < n.size(); ++i) {
              const std::string fi = f + "[" + std::to_string(i) + "]";
              sensors::Camera camera;
              std::string name, model;
              Rigid3d cam_from_rig;
              r.Map(n[i], fi,
                    {{"name", [&](const YAML::Node& v, const std::string& g) { name = r.String(v, g); }},
                     {"model", [&](const YAML::Node& v, const std::string& g) {
                        model = r.String(v, g);
                        camera.model_id = sensors::CameraModelFromName(model);
                        if (camera.model_id == sensors::CameraModelId::kInvalid) {
                          r.Fail(v, g, "one of " + sensors::KnownCameraModelNames(), model);
                        }
                      }},
                     {"width", [&](const YAML::Node& v, const std::string& g) {
                        const int size = r.Integer(v, g);
                        if (size < 1 || static_cast<uint64_t>(size) > kMaxImageSidePx) {
                          r.Fail(v, g, "a number of pixels in 1.." + std::to_string(kMaxImageSidePx), std::to_string(size));
                        }
                        camera.width = static_cast<uint64_t>(size);
                      }},
                     {"height", [&](const YAML::Node& v, const std::string& g) {
                        const int size = r.Integer(v, g);
                        if (size < 1 || static_cast<uint64_t>(size) > kMaxImageSidePx) {
                          r.Fail(v, g, "a number of pixels in 1.." + std::to_string(kMaxImageSidePx), std::to_string(size));
                        }
                        camera.height = static_cast<uint64_t>(size);
                      }},
                     {"params", [&](const YAML::Node& v, const std::string& g) { camera.params = r.NumberList(v, g); }},
                     {"cam_from_rig", [&](const YAML::Node& v, const std::string& g) { cam_from_rig = ReadYamlPose(r, v, g); }},
                     {"sigma", [](const YAML::Node&, const std::string&) {}},
                     {"cam_from_rig_tvec_sigma", [](const YAML::Node&, const std::string&) {}}});
              r.Require(n[i], fi, {"name", "model", "width", "height", "params", "cam_from_rig"});
              const int expected = sensors::CameraModelNumParams(camera.model_id);
              if (static_cast<int>(camera.params.size()) != expected) {
                r.Fail(n[i]["params"], fi + ".params", std::to_string(expected) + " numbers for " + model,
                       std::to_string(camera.params.size()) + " numbers");
              }
              for (int k : sensors::CameraModelFocalIdxs(camera.model_id)) {
                if (!(camera.params[k] > 0)) r.Fail(n[i]["params"], fi + ".params", "a positive focal length", ExactNumber(camera.params[k]));
              }
              if (std::find(rig.names.begin(), rig.names.end(), name) != rig.names.end()) {
                r.Fail(n[i]["name"], fi + ".name", "a name no other camera has", name);
              }
              camera.camera_id = CameraId(static_cast<uint32_t>(i + 1));
              rig.names.push_back(name);
              rig.cameras.push_back(camera);
              rig.cam_from_rig.push_back(cam_from_rig);
            }
          }},
         {"beams", [](const YAML::Node&, const std::string&) {}}});
  r.Require(root, "", {"cameras"});
  return rig;
}

void WriteCameraYaml(const CameraYaml& camera_yaml, const std::string& path) {
  WriteFileAtomically(path, [&](std::ostream& out) {
    out.precision(17);
    out << "# mmba camera (schema: calib/README.md)\n";
    const sensors::Camera& camera = camera_yaml.camera;
    out << "model: " << camera.ModelName() << "\n";
    out << "width: " << camera.width << "\n";
    out << "height: " << camera.height << "\n";
    if (camera.model_id == sensors::CameraModelId::kPhotogrammetric) {
      out << "format_width_mm: " << camera.params.at(10) * static_cast<double>(camera.width) << "\n";
      out << "format_height_mm: " << camera.params.at(11) * static_cast<double>(camera.height) << "\n";
      for (const PhotoField& f : kPhotoFields) out << f.key << ": " << camera.params.at(f.index) << "\n";
    } else {
      out << "params: [";
      for (size_t i = 0; i < camera.params.size(); ++i) out << (i ? ", " : "") << camera.params[i];
      out << "]\n";
    }
    if (camera_yaml.cam_from_lidar) {
      const Eigen::Matrix4d m = camera_yaml.cam_from_lidar->ToMatrix4();
      out << "cam_from_lidar: [";
      for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) out << ((r || c) ? ", " : "") << m(r, c);
      }
      out << "]\n";
    }
  });
}

}  // namespace mmba::io
