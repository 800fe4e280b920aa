#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mmba/core/ids.h"
#include "mmba/sensors/camera_models.h"

namespace mmba::sensors {

/// Name of a model ("PINHOLE"), or "" for an unknown id.
std::string CameraModelName(CameraModelId model_id);
/// Model id of a name; kInvalid when unknown.
CameraModelId CameraModelFromName(const std::string& name);
/// Model id of a COLMAP integer id; kInvalid when unknown.
CameraModelId CameraModelFromInt(int value);
/// Comma-separated list of every known model name (for error messages).
std::string KnownCameraModelNames();
/// Number of parameters; -1 for an unknown model.
int CameraModelNumParams(CameraModelId model_id);
/// "fx, fy, cx, cy, ..." for an unknown model "".
std::string CameraModelParamsInfo(CameraModelId model_id);
/// Each parameter's name in the model's order ("fx", "fy", ...; PHOTOGRAMMETRIC: "c", "xp",
/// ..., "K1", ...); empty for an unknown model.
std::vector<std::string> CameraModelParamNames(CameraModelId model_id);
/// Index of a parameter by its name (CameraModelParamNames); -1 when the model has none.
int CameraModelParamIdx(CameraModelId model_id, const std::string& name);
/// Indices of the focal length(s), principal point, the parameters that describe the sensor
/// and are never estimated (PHOTOGRAMMETRIC's pixel pitch), and the remaining (extra:
/// distortion) parameters. An adjustment holds the fixed ones whatever it refines.
std::vector<int> CameraModelFocalIdxs(CameraModelId model_id);
std::vector<int> CameraModelPrincipalIdxs(CameraModelId model_id);
std::vector<int> CameraModelFixedIdxs(CameraModelId model_id);
std::vector<int> CameraModelExtraIdxs(CameraModelId model_id);

/// A camera's intrinsics (COLMAP "camera"): model, image size in pixels, parameters in the
/// model's order.
struct Camera {
  CameraId camera_id;
  CameraModelId model_id = CameraModelId::kInvalid;
  uint64_t width = 0;
  uint64_t height = 0;
  std::vector<double> params;

  std::string ModelName() const { return CameraModelName(model_id); }
  /// Mean focal length in pixels (pixels per radian for EQUIRECTANGULAR; c over the mean
  /// pixel pitch for PHOTOGRAMMETRIC).
  double MeanFocalLength() const;

  /// Pixel of a point in the camera frame; nullopt where the model cannot image it.
  std::optional<Eigen::Vector2d> ImgFromCam(const Eigen::Vector3d& point_in_cam) const;
  /// Viewing ray of a pixel: (u, v, 1) for perspective models, unit vector for panoramas; NaN
  /// where the pixel is outside the model's domain (its ray does not image back to it within
  /// 0.01 px: a fisheye's corners beyond 90° from the axis).
  Eigen::Vector3d CamFromImg(const Eigen::Vector2d& xy) const;
  /// True for models whose residuals are measured on the sphere.
  bool IsSpherical() const { return model_id == CameraModelId::kEquirectangular; }
};

}  // namespace mmba::sensors
