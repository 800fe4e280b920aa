#include "mmba/sensors/camera.h"

#include <algorithm>
#include <limits>
#include <sstream>
#include <type_traits>

namespace mmba::sensors {
namespace {

template <typename Model, typename = void>
struct FixedIdxsOf {
  static std::vector<int> Get() { return {}; }
};
template <typename Model>
struct FixedIdxsOf<Model, std::void_t<decltype(Model::kFixedIdxs)>> {
  static std::vector<int> Get() { return std::vector<int>(Model::kFixedIdxs.begin(), Model::kFixedIdxs.end()); }
};

}  // namespace

std::string CameraModelName(CameraModelId model_id) {
#define MMBA_CASE(Model) \
  if (model_id == Model::kModelId) return Model::kName;
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return "";
}

CameraModelId CameraModelFromName(const std::string& name) {
#define MMBA_CASE(Model) \
  if (name == Model::kName) return Model::kModelId;
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return CameraModelId::kInvalid;
}

CameraModelId CameraModelFromInt(int value) {
#define MMBA_CASE(Model) \
  if (value == static_cast<int>(Model::kModelId)) return Model::kModelId;
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return CameraModelId::kInvalid;
}

std::string KnownCameraModelNames() {
  std::string names;
#define MMBA_CASE(Model)             \
  if (!names.empty()) names += ", "; \
  names += Model::kName;
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return names;
}

int CameraModelNumParams(CameraModelId model_id) {
#define MMBA_CASE(Model) \
  if (model_id == Model::kModelId) return Model::kNumParams;
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return -1;
}

std::string CameraModelParamsInfo(CameraModelId model_id) {
#define MMBA_CASE(Model) \
  if (model_id == Model::kModelId) return Model::kParamsInfo;
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return "";
}

std::vector<int> CameraModelFocalIdxs(CameraModelId model_id) {
#define MMBA_CASE(Model)                                                        \
  if (model_id == Model::kModelId)                                              \
    return std::vector<int>(Model::kFocalIdxs.begin(), Model::kFocalIdxs.end());
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return {};
}

std::vector<int> CameraModelPrincipalIdxs(CameraModelId model_id) {
#define MMBA_CASE(Model)                                                                \
  if (model_id == Model::kModelId)                                                      \
    return std::vector<int>(Model::kPrincipalIdxs.begin(), Model::kPrincipalIdxs.end());
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return {};
}

std::vector<int> CameraModelFixedIdxs(CameraModelId model_id) {
#define MMBA_CASE(Model) \
  if (model_id == Model::kModelId) return FixedIdxsOf<Model>::Get();
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return {};
}

std::vector<int> CameraModelExtraIdxs(CameraModelId model_id) {
  std::vector<int> extra;
  const int num_params = CameraModelNumParams(model_id);
  std::vector<int> taken = CameraModelFocalIdxs(model_id);
  for (const std::vector<int>& more : {CameraModelPrincipalIdxs(model_id), CameraModelFixedIdxs(model_id)}) {
    taken.insert(taken.end(), more.begin(), more.end());
  }
  for (int i = 0; i < num_params; ++i) {
    if (std::find(taken.begin(), taken.end(), i) == taken.end()) extra.push_back(i);
  }
  return extra;
}

std::vector<std::string> CameraModelParamNames(CameraModelId model_id) {
  std::vector<std::string> names;
  std::istringstream info(CameraModelParamsInfo(model_id));
  std::string name;
  while (std::getline(info, name, ',')) {
    name.erase(0, name.find_first_not_of(' '));
    if (!name.empty()) names.push_back(name);
  }
  return names;
}

int CameraModelParamIdx(CameraModelId model_id, const std::string& name) {
  const std::vector<std::string> names = CameraModelParamNames(model_id);
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

double Camera::MeanFocalLength() const {
  if (model_id == CameraModelId::kPhotogrammetric) {
    return params.at(0) * 2.0 / (params.at(10) + params.at(11));
  }
  const std::vector<int> idxs = CameraModelFocalIdxs(model_id);
  double sum = 0.0;
  for (int i : idxs) sum += params.at(i);
  return idxs.empty() ? 0.0 : sum / idxs.size();
}

std::optional<Eigen::Vector2d> Camera::ImgFromCam(const Eigen::Vector3d& point_in_cam) const {
  Eigen::Vector2d xy;
#define MMBA_CASE(Model)                                                          \
  if (model_id == Model::kModelId) {                                              \
    if (!Model::ImgFromCam(params.data(), point_in_cam.data(), xy.data())) {      \
      return std::nullopt;                                                        \
    }                                                                             \
    return xy;                                                                    \
  }
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  return std::nullopt;
}

Eigen::Vector3d Camera::CamFromImg(const Eigen::Vector2d& xy) const {
  Eigen::Vector3d ray = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
#define MMBA_CASE(Model) \
  if (model_id == Model::kModelId) Model::CamFromImg(params.data(), xy.x(), xy.y(), ray.data());
  MMBA_FOR_EACH_CAMERA_MODEL(MMBA_CASE)
#undef MMBA_CASE
  // A perspective model's ray is (u, v, 1): it cannot represent a direction 90° or more from
  // the axis, which a fisheye's corners can see (the simulated rig's 320×400 fisheyes: 8.6 % of
  // their pixels), and there the iterative undistortion returns a ray that does not image back
  // to the pixel. Such a pixel is outside the model's domain: NaN, as for any other.
  if (ray.allFinite() && !IsSpherical()) {
    const std::optional<Eigen::Vector2d> back = ImgFromCam(ray);
    if (!back || !((*back - xy).norm() <= 0.01)) {
      ray.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  return ray;
}

}  // namespace mmba::sensors
