#pragma once

namespace mmba::sensors {

/// Model ids, as COLMAP numbers them; EQUIRECTANGULAR (100) and PHOTOGRAMMETRIC (101) are
/// mmba's own.
enum class CameraModelId : int {
  kInvalid = -1,
  kSimplePinhole = 0,
  kPinhole = 1,
  kSimpleRadial = 2,
  kRadial = 3,
  kOpenCV = 4,
  kOpenCVFisheye = 5,
  kFullOpenCV = 6,
  kFOV = 7,
  kSimpleRadialFisheye = 8,
  kRadialFisheye = 9,
  kThinPrismFisheye = 10,
  kEquirectangular = 100,
  kPhotogrammetric = 101,
};

}  // namespace mmba::sensors
