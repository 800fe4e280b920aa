#pragma once

// Camera models as structs of statics, templated for ceres::Jet (after COLMAP's
// src/colmap/sensor/models.h: same model names, ids and parameter order).
//
// Frame of a camera: x right, y down, z forward. Pixel coordinates are continuous with the
// centre of the top-left pixel at (0.5, 0.5) (COLMAP).
//
// Every model provides
//   static bool ImgFromCam(const T* params, const T* point_in_cam, T* xy);
//     Projects a 3-D point in the camera frame to pixels. Returns false where the model
//     cannot image the point (behind a perspective camera, at the centre of a sphere);
//     `xy` is then left unchanged. Callers filter such points before building residuals.
//   static void CamFromImg(const T* params, const T& x, const T& y, T* ray);
//     The viewing ray of a pixel: (u, v, 1) for perspective models (normalised image
//     coordinates, distortion removed), a unit bearing for EQUIRECTANGULAR.
// and kFocalIdxs, kPrincipalIdxs; a model whose parameters include constants of the sensor
// (PHOTOGRAMMETRIC's pixel pitch) lists them in kFixedIdxs (CameraModelFixedIdxs).

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <ceres/jet.h>

#include "mmba/sensors/camera_model_id.h"
#include "mmba/sensors/photogrammetric_model.h"

namespace mmba::sensors {

namespace internal {

using ceres::abs;
using std::abs;
using std::atan;
using std::atan2;
using ceres::tan;
using std::tan;
using std::sqrt;
using ceres::atan;
using ceres::atan2;
using ceres::sqrt;

// Iterative removal of distortion for models whose forward map is
// (u, v) -> (u, v) + Distortion(extra, u, v). Newton with a numeric Jacobian, as COLMAP's
// IterativeUndistortion; converges in a few steps for physical distortions.
template <typename Model, typename T>
void IterativeUndistortion(const T* extra, T* u, T* v) {
  constexpr int kMaxIterations = 100;
  constexpr double kMaxStepNorm = 1e-10;
  constexpr double kRelStepSize = 1e-6;
  const T x0u = *u;
  const T x0v = *v;
  T xu = *u;
  T xv = *v;
  for (int i = 0; i < kMaxIterations; ++i) {
    const T step_u = std::max(T(std::numeric_limits<double>::epsilon()), abs(xu * kRelStepSize));
    const T step_v = std::max(T(std::numeric_limits<double>::epsilon()), abs(xv * kRelStepSize));
    T du, dv;
    Model::Distortion(extra, xu, xv, &du, &dv);
    T du0b, dv0b, du0f, dv0f, du1b, dv1b, du1f, dv1f;
    Model::Distortion(extra, T(xu - step_u), xv, &du0b, &dv0b);
    Model::Distortion(extra, T(xu + step_u), xv, &du0f, &dv0f);
    Model::Distortion(extra, xu, T(xv - step_v), &du1b, &dv1b);
    Model::Distortion(extra, xu, T(xv + step_v), &du1f, &dv1f);
    const T j00 = T(1) + (du0f - du0b) / (T(2) * step_u);
    const T j10 = (dv0f - dv0b) / (T(2) * step_u);
    const T j01 = (du1f - du1b) / (T(2) * step_v);
    const T j11 = T(1) + (dv1f - dv1b) / (T(2) * step_v);
    const T ru = xu + du - x0u;
    const T rv = xv + dv - x0v;
    const T det = j00 * j11 - j01 * j10;
    const T su = (j11 * ru - j01 * rv) / det;
    const T sv = (-j10 * ru + j00 * rv) / det;
    xu -= su;
    xv -= sv;
    if (abs(su) * abs(su) + abs(sv) * abs(sv) < T(kMaxStepNorm)) break;
  }
  *u = xu;
  *v = xv;
}

// Shared code of the perspective models: fx = params[fx_idx], etc.
template <typename Model, typename T>
bool PerspectiveImgFromCam(const T* params, const T* point_in_cam, T* xy) {
  if (!(point_in_cam[2] > T(std::numeric_limits<double>::epsilon()))) return false;
  const T u = point_in_cam[0] / point_in_cam[2];
  const T v = point_in_cam[1] / point_in_cam[2];
  T du, dv;
  Model::Distortion(params + Model::kNumFocalAndPrincipal, u, v, &du, &dv);
  T fx, fy, cx, cy;
  Model::Intrinsics(params, &fx, &fy, &cx, &cy);
  xy[0] = fx * (u + du) + cx;
  xy[1] = fy * (v + dv) + cy;
  return true;
}

template <typename Model, typename T>
void PerspectiveCamFromImg(const T* params, const T& x, const T& y, T* ray) {
  T fx, fy, cx, cy;
  Model::Intrinsics(params, &fx, &fy, &cx, &cy);
  T u = (x - cx) / fx;
  T v = (y - cy) / fy;
  if (Model::kNumParams > Model::kNumFocalAndPrincipal) {
    IterativeUndistortion<Model>(params + Model::kNumFocalAndPrincipal, &u, &v);
  }
  ray[0] = u;
  ray[1] = v;
  ray[2] = T(1);
}

}  // namespace internal

/// Defines the static members every perspective model shares.
#define MMBA_PERSPECTIVE_MODEL_METHODS                                              \
  template <typename T>                                                             \
  static bool ImgFromCam(const T* params, const T* point_in_cam, T* xy) {           \
    return internal::PerspectiveImgFromCam<Self>(params, point_in_cam, xy);         \
  }                                                                                 \
  template <typename T>                                                             \
  static void CamFromImg(const T* params, const T& x, const T& y, T* ray) {         \
    internal::PerspectiveCamFromImg<Self>(params, x, y, ray);                       \
  }

/// SIMPLE_PINHOLE: f, cx, cy.
struct SimplePinholeModel {
  using Self = SimplePinholeModel;
  static constexpr CameraModelId kModelId = CameraModelId::kSimplePinhole;
  static constexpr const char* kName = "SIMPLE_PINHOLE";
  static constexpr int kNumParams = 3;
  static constexpr int kNumFocalAndPrincipal = 3;
  static constexpr const char* kParamsInfo = "f, cx, cy";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[0]; *cx = p[1]; *cy = p[2];
  }
  template <typename T>
  static void Distortion(const T*, const T&, const T&, T* du, T* dv) {
    *du = T(0); *dv = T(0);
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// PINHOLE: fx, fy, cx, cy.
struct PinholeModel {
  using Self = PinholeModel;
  static constexpr CameraModelId kModelId = CameraModelId::kPinhole;
  static constexpr const char* kName = "PINHOLE";
  static constexpr int kNumParams = 4;
  static constexpr int kNumFocalAndPrincipal = 4;
  static constexpr const char* kParamsInfo = "fx, fy, cx, cy";
  static constexpr std::array<int, 2> kFocalIdxs{0, 1};
  static constexpr std::array<int, 2> kPrincipalIdxs{2, 3};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[1]; *cx = p[2]; *cy = p[3];
  }
  template <typename T>
  static void Distortion(const T*, const T&, const T&, T* du, T* dv) {
    *du = T(0); *dv = T(0);
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// SIMPLE_RADIAL: f, cx, cy, k.
struct SimpleRadialModel {
  using Self = SimpleRadialModel;
  static constexpr CameraModelId kModelId = CameraModelId::kSimpleRadial;
  static constexpr const char* kName = "SIMPLE_RADIAL";
  static constexpr int kNumParams = 4;
  static constexpr int kNumFocalAndPrincipal = 3;
  static constexpr const char* kParamsInfo = "f, cx, cy, k";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[0]; *cx = p[1]; *cy = p[2];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T radial = extra[0] * (u * u + v * v);
    *du = u * radial;
    *dv = v * radial;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// RADIAL: f, cx, cy, k1, k2.
struct RadialModel {
  using Self = RadialModel;
  static constexpr CameraModelId kModelId = CameraModelId::kRadial;
  static constexpr const char* kName = "RADIAL";
  static constexpr int kNumParams = 5;
  static constexpr int kNumFocalAndPrincipal = 3;
  static constexpr const char* kParamsInfo = "f, cx, cy, k1, k2";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[0]; *cx = p[1]; *cy = p[2];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T r2 = u * u + v * v;
    const T radial = extra[0] * r2 + extra[1] * r2 * r2;
    *du = u * radial;
    *dv = v * radial;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// OPENCV: fx, fy, cx, cy, k1, k2, p1, p2.
struct OpenCVModel {
  using Self = OpenCVModel;
  static constexpr CameraModelId kModelId = CameraModelId::kOpenCV;
  static constexpr const char* kName = "OPENCV";
  static constexpr int kNumParams = 8;
  static constexpr int kNumFocalAndPrincipal = 4;
  static constexpr const char* kParamsInfo = "fx, fy, cx, cy, k1, k2, p1, p2";
  static constexpr std::array<int, 2> kFocalIdxs{0, 1};
  static constexpr std::array<int, 2> kPrincipalIdxs{2, 3};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[1]; *cx = p[2]; *cy = p[3];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T& k1 = extra[0];
    const T& k2 = extra[1];
    const T& p1 = extra[2];
    const T& p2 = extra[3];
    const T u2 = u * u;
    const T uv = u * v;
    const T v2 = v * v;
    const T r2 = u2 + v2;
    const T radial = k1 * r2 + k2 * r2 * r2;
    *du = u * radial + T(2) * p1 * uv + p2 * (r2 + T(2) * u2);
    *dv = v * radial + T(2) * p2 * uv + p1 * (r2 + T(2) * v2);
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// OPENCV_FISHEYE: fx, fy, cx, cy, k1, k2, k3, k4 (equidistant, θ_d = θ(1+k1θ²+…+k4θ⁸)).
struct OpenCVFisheyeModel {
  using Self = OpenCVFisheyeModel;
  static constexpr CameraModelId kModelId = CameraModelId::kOpenCVFisheye;
  static constexpr const char* kName = "OPENCV_FISHEYE";
  static constexpr int kNumParams = 8;
  static constexpr int kNumFocalAndPrincipal = 4;
  static constexpr const char* kParamsInfo = "fx, fy, cx, cy, k1, k2, k3, k4";
  static constexpr std::array<int, 2> kFocalIdxs{0, 1};
  static constexpr std::array<int, 2> kPrincipalIdxs{2, 3};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[1]; *cx = p[2]; *cy = p[3];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    using internal::atan;
    using internal::sqrt;
    const T r2 = u * u + v * v;
    if (r2 > T(std::numeric_limits<double>::epsilon())) {
      const T r = sqrt(r2);
      const T theta = atan(r);
      const T t2 = theta * theta;
      const T t4 = t2 * t2;
      const T t6 = t4 * t2;
      const T t8 = t4 * t4;
      const T thetad =
          theta * (T(1) + extra[0] * t2 + extra[1] * t4 + extra[2] * t6 + extra[3] * t8);
      *du = u * thetad / r - u;
      *dv = v * thetad / r - v;
    } else {
      *du = T(0);
      *dv = T(0);
    }
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// FULL_OPENCV: fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6 (rational radial).
struct FullOpenCVModel {
  using Self = FullOpenCVModel;
  static constexpr CameraModelId kModelId = CameraModelId::kFullOpenCV;
  static constexpr const char* kName = "FULL_OPENCV";
  static constexpr int kNumParams = 12;
  static constexpr int kNumFocalAndPrincipal = 4;
  static constexpr const char* kParamsInfo = "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6";
  static constexpr std::array<int, 2> kFocalIdxs{0, 1};
  static constexpr std::array<int, 2> kPrincipalIdxs{2, 3};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[1]; *cx = p[2]; *cy = p[3];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T& k1 = extra[0];
    const T& k2 = extra[1];
    const T& p1 = extra[2];
    const T& p2 = extra[3];
    const T& k3 = extra[4];
    const T& k4 = extra[5];
    const T& k5 = extra[6];
    const T& k6 = extra[7];
    const T u2 = u * u;
    const T uv = u * v;
    const T v2 = v * v;
    const T r2 = u2 + v2;
    const T r4 = r2 * r2;
    const T r6 = r4 * r2;
    const T radial = (T(1) + k1 * r2 + k2 * r4 + k3 * r6) / (T(1) + k4 * r2 + k5 * r4 + k6 * r6);
    *du = u * radial + T(2) * p1 * uv + p2 * (r2 + T(2) * u2) - u;
    *dv = v * radial + T(2) * p2 * uv + p1 * (r2 + T(2) * v2) - v;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};


/// FOV (Devernay & Faugeras 2001, as in COLMAP): fx, fy, cx, cy, omega.
/// Distorted radius r_d = atan(2 r tan(ω/2)) / ω; Taylor forms near ω = 0 and r = 0.
struct FOVModel {
  using Self = FOVModel;
  static constexpr CameraModelId kModelId = CameraModelId::kFOV;
  static constexpr const char* kName = "FOV";
  static constexpr int kNumParams = 5;
  static constexpr int kNumFocalAndPrincipal = 4;
  static constexpr const char* kParamsInfo = "fx, fy, cx, cy, omega";
  static constexpr std::array<int, 2> kFocalIdxs{0, 1};
  static constexpr std::array<int, 2> kPrincipalIdxs{2, 3};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[1]; *cx = p[2]; *cy = p[3];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    using internal::atan;
    using internal::sqrt;
    using internal::tan;
    const T& omega = extra[0];
    const T omega2 = omega * omega;
    const T radius2 = u * u + v * v;
    constexpr double kEpsilon = 1e-4;
    T factor;
    if (omega2 < T(kEpsilon)) {
      // second-order Taylor expansion in ω of atan(2 r tan(ω/2)) / (r ω)
      factor = (omega2 * radius2) / T(3) - omega2 / T(12) + T(1);
    } else if (radius2 < T(kEpsilon)) {
      // second-order Taylor expansion in r
      const T t = tan(omega / T(2));
      factor = (T(-2) * t * (T(4) * radius2 * t * t - T(3))) / (T(3) * omega);
    } else {
      const T radius = sqrt(radius2);
      factor = atan(radius * T(2) * tan(omega / T(2))) / (radius * omega);
    }
    *du = u * factor - u;
    *dv = v * factor - v;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// Equidistant fisheye term θ_d/r of the *_FISHEYE models; 1 near the axis.
template <typename T, typename Poly>
T FisheyeScale(const T& u, const T& v, Poly poly) {
  using internal::atan;
  using internal::sqrt;
  const T r2 = u * u + v * v;
  if (!(r2 > T(std::numeric_limits<double>::epsilon()))) return T(1);
  const T r = sqrt(r2);
  const T theta = atan(r);
  return theta * poly(theta * theta) / r;
}

/// SIMPLE_RADIAL_FISHEYE: f, cx, cy, k (θ_d = θ(1 + kθ²)).
struct SimpleRadialFisheyeModel {
  using Self = SimpleRadialFisheyeModel;
  static constexpr CameraModelId kModelId = CameraModelId::kSimpleRadialFisheye;
  static constexpr const char* kName = "SIMPLE_RADIAL_FISHEYE";
  static constexpr int kNumParams = 4;
  static constexpr int kNumFocalAndPrincipal = 3;
  static constexpr const char* kParamsInfo = "f, cx, cy, k";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[0]; *cx = p[1]; *cy = p[2];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T scale = FisheyeScale(u, v, [&](const T& t2) { return T(1) + extra[0] * t2; });
    *du = u * scale - u;
    *dv = v * scale - v;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// RADIAL_FISHEYE: f, cx, cy, k1, k2 (θ_d = θ(1 + k1θ² + k2θ⁴)).
struct RadialFisheyeModel {
  using Self = RadialFisheyeModel;
  static constexpr CameraModelId kModelId = CameraModelId::kRadialFisheye;
  static constexpr const char* kName = "RADIAL_FISHEYE";
  static constexpr int kNumParams = 5;
  static constexpr int kNumFocalAndPrincipal = 3;
  static constexpr const char* kParamsInfo = "f, cx, cy, k1, k2";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[0]; *cx = p[1]; *cy = p[2];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T scale = FisheyeScale(
        u, v, [&](const T& t2) { return T(1) + extra[0] * t2 + extra[1] * t2 * t2; });
    *du = u * scale - u;
    *dv = v * scale - v;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

/// THIN_PRISM_FISHEYE: fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1. The equidistant
/// angle (θ u/r, θ v/r) is distorted by radial (k1..k4), tangential (p1, p2) and thin-prism
/// (sx1, sy1) terms, as in COLMAP.
struct ThinPrismFisheyeModel {
  using Self = ThinPrismFisheyeModel;
  static constexpr CameraModelId kModelId = CameraModelId::kThinPrismFisheye;
  static constexpr const char* kName = "THIN_PRISM_FISHEYE";
  static constexpr int kNumParams = 12;
  static constexpr int kNumFocalAndPrincipal = 4;
  static constexpr const char* kParamsInfo = "fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1";
  static constexpr std::array<int, 2> kFocalIdxs{0, 1};
  static constexpr std::array<int, 2> kPrincipalIdxs{2, 3};
  template <typename T>
  static void Intrinsics(const T* p, T* fx, T* fy, T* cx, T* cy) {
    *fx = p[0]; *fy = p[1]; *cx = p[2]; *cy = p[3];
  }
  template <typename T>
  static void Distortion(const T* extra, const T& u, const T& v, T* du, T* dv) {
    const T scale = FisheyeScale(u, v, [](const T&) { return T(1); });
    const T a = u * scale;
    const T b = v * scale;
    const T a2 = a * a;
    const T ab = a * b;
    const T b2 = b * b;
    const T r2 = a2 + b2;
    const T r4 = r2 * r2;
    const T radial = extra[0] * r2 + extra[1] * r4 + extra[4] * r4 * r2 + extra[5] * r4 * r4;
    *du = a + a * radial + T(2) * extra[2] * ab + extra[3] * (r2 + T(2) * a2) + extra[6] * r2 - u;
    *dv = b + b * radial + T(2) * extra[3] * ab + extra[2] * (r2 + T(2) * b2) + extra[7] * r2 - v;
  }
  MMBA_PERSPECTIVE_MODEL_METHODS
};

#undef MMBA_PERSPECTIVE_MODEL_METHODS

/// EQUIRECTANGULAR (mmba): f, cx, cy — a spherical panorama W×H with H = W/2.
///
/// Eq. (5)–(6) of Wang, Ferrie & Macfarlane 2012, θ = arccos(z/‖p‖), φ = atan2(y, x),
/// r = θ/π·H, c = (φ/2π + 0.5)·W, written in the camera frame of mmba (x right, y down,
/// z forward), so that the panorama is not mirrored and its centre looks along +z:
///   polar angle from "up" (−y):  θ = atan2(√(x²+z²), −y)   (= arccos(−y/‖p‖))
///   longitude from +z to +x:     φ = atan2(x, z)
///   column c = cx + f·φ,  row r = cy + f·(θ − π/2).
/// With f = W/2π, cx = W/2, cy = H/2 this is exactly the paper's mapping; cx, cy are the
/// principal offsets a spherical line-scan calibration estimates. The ±180° seam lies at
/// c = cx ± π f (behind the camera); residuals on this model are measured as angles on
/// the sphere (factors/reprojection_error.h), so the seam and poles are harmless.
struct EquirectangularModel {
  static constexpr CameraModelId kModelId = CameraModelId::kEquirectangular;
  static constexpr const char* kName = "EQUIRECTANGULAR";
  static constexpr int kNumParams = 3;
  static constexpr int kNumFocalAndPrincipal = 3;
  static constexpr const char* kParamsInfo = "f, cx, cy";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};

  /// Default parameters of a W×H panorama: f = W/2π, cx = W/2, cy = H/2.
  static std::array<double, 3> DefaultParams(double width, double height) {
    return {width / (2.0 * M_PI), width / 2.0, height / 2.0};
  }

  template <typename T>
  static bool ImgFromCam(const T* params, const T* point_in_cam, T* xy) {
    using internal::atan2;
    using internal::sqrt;
    const T horizontal = sqrt(point_in_cam[0] * point_in_cam[0] +
                              point_in_cam[2] * point_in_cam[2]);
    const T norm2 = horizontal * horizontal + point_in_cam[1] * point_in_cam[1];
    if (!(norm2 > T(std::numeric_limits<double>::min()))) return false;
    const T theta = atan2(horizontal, -point_in_cam[1]);
    // At the poles (horizontal == 0) the longitude is undefined; atan2(0, 0) = 0 is used,
    // which places the pole at the principal column.
    const T phi = atan2(point_in_cam[0], point_in_cam[2]);
    xy[0] = params[1] + params[0] * phi;
    xy[1] = params[2] + params[0] * (theta - T(M_PI / 2.0));
    return true;
  }

  /// Unit bearing of pixel (x, y).
  template <typename T>
  static void CamFromImg(const T* params, const T& x, const T& y, T* ray) {
    using std::cos;
    using std::sin;
    using ceres::cos;
    using ceres::sin;
    const T phi = (x - params[1]) / params[0];
    const T theta = (y - params[2]) / params[0] + T(M_PI / 2.0);
    const T sin_theta = sin(theta);
    ray[0] = sin_theta * sin(phi);
    ray[1] = -cos(theta);
    ray[2] = sin_theta * cos(phi);
  }
};

/// Calls `FUNC(Model)` for every model; used to dispatch on a runtime CameraModelId, as
/// COLMAP's CAMERA_MODEL_CASES.
#define MMBA_FOR_EACH_CAMERA_MODEL(FUNC)       \
  FUNC(::mmba::sensors::SimplePinholeModel)    \
  FUNC(::mmba::sensors::PinholeModel)          \
  FUNC(::mmba::sensors::SimpleRadialModel)     \
  FUNC(::mmba::sensors::RadialModel)           \
  FUNC(::mmba::sensors::OpenCVModel)           \
  FUNC(::mmba::sensors::OpenCVFisheyeModel)    \
  FUNC(::mmba::sensors::FullOpenCVModel)       \
  FUNC(::mmba::sensors::FOVModel)              \
  FUNC(::mmba::sensors::SimpleRadialFisheyeModel) \
  FUNC(::mmba::sensors::RadialFisheyeModel)    \
  FUNC(::mmba::sensors::ThinPrismFisheyeModel) \
  FUNC(::mmba::sensors::EquirectangularModel)  \
  FUNC(::mmba::sensors::PhotogrammetricModel)

}  // namespace mmba::sensors
