#pragma once

// PHOTOGRAMMETRIC: the close-range camera of Brown (1971) with the affinity terms of Fraser
// (1997), in millimetres, as DBAT (Börlin & Grussenmeyer; lens distortion model 3),
// PhotoModeler and Australis define it, so that its parameters compare one by one with theirs.
//
// Parameter order (12):
//   0 c     camera constant (principal distance), mm
//   1 xp    principal point, mm from the left edge of the image (x right)
//   2 yp    principal point, mm from the top edge of the image (y down)
//   3 K1    radial distortion, mm^-2
//   4 K2    radial distortion, mm^-4
//   5 K3    radial distortion, mm^-6
//   6 P1    decentering distortion, mm^-1
//   7 P2    decentering distortion, mm^-1
//   8 b1    affinity (DBAT's "as", off-unit aspect; DBAT XML aspect = 1 - b1), unitless
//   9 b2    shear (DBAT's "sk"), unitless
//  10 pixel_width_mm    nominal pixel pitch along x (format width / image width), fixed
//  11 pixel_height_mm   pixel pitch along y (format height / image height), fixed
// Indices 10 and 11 describe the sensor, not the lens: they are never estimated
// (kFixedIdxs). DBAT's pitch is square (format height / image height) and its estimated
// format width is W · pixel_width_mm · (1 + b1).
//
// Equations. A pixel (x, y) — continuous, x right, y down, origin at the top-left corner of
// the image (the centre of the top-left pixel is (0.5, 0.5)) — is taken to millimetres in the
// photogrammetric image frame (origin at the principal point, x right, y UP):
//   x̄ = x · pixel_width_mm − xp,      ȳ = yp − y · pixel_height_mm
// the affinity is applied (DBAT affine2 before the lens correction, model 3):
//   x̂ = (1 + b1) x̄ + b2 ȳ,            ŷ = ȳ
// and the lens correction is ADDED to the measured coordinates (Brown 1971, "Close-range
// camera calibration"; Fraser 1997, "Digital camera self-calibration", ISPRS J. 52), r² = x̂² + ŷ²:
//   Δx = x̂ (K1 r² + K2 r⁴ + K3 r⁶) + P1 (r² + 2 x̂²) + 2 P2 x̂ ŷ
//   Δy = ŷ (K1 r² + K2 r⁴ + K3 r⁶) + P2 (r² + 2 ŷ²) + 2 P1 x̂ ŷ
// The corrected coordinates obey the collinearity equations of a camera looking along −Z of
// a frame (X right, Y up, Z back):  x̂ + Δx = −c X/Z,  ŷ + Δy = −c Y/Z.  In mmba's camera
// frame (x right, y down, z forward) that frame is (x, −y, −z), so
//   x̂ + Δx = c x/z,                   ŷ + Δy = −c y/z.
// CamFromImg applies the correction directly; ImgFromCam inverts it by Newton's method.
//
// Checked against DBAT 0.9.2 on its camcaldemo (tests/sensors/photogrammetric_dbat_test.cc):
// DBAT's adjusted camera and exterior orientations with this model reproduce its σ0 = 1.6148.
// Sources read: DBAT code/bundle/cameramodel/{brown_euler_cam4, multi_res, brown_affine,
// brown_dist, brown_rad, tang_scale, eulerpinhole, eulerrotmat, affine2}.m, its bundle's
// `aspect = 1 − as` when it writes a camera, and parsedbatxmlcamstruct.m (sensor "auto").

#include <array>
#include <cmath>
#include <limits>

#include <ceres/jet.h>

#include "mmba/sensors/camera_model_id.h"

namespace mmba::sensors {

namespace photogrammetric_internal {

inline double ValueOf(double value) { return value; }
template <typename S, int N>
double ValueOf(const ceres::Jet<S, N>& value) {
  return ValueOf(value.a);
}

}  // namespace photogrammetric_internal

struct PhotogrammetricModel {
  static constexpr CameraModelId kModelId = CameraModelId::kPhotogrammetric;
  static constexpr const char* kName = "PHOTOGRAMMETRIC";
  static constexpr int kNumParams = 12;
  static constexpr const char* kParamsInfo =
      "c, xp, yp, K1, K2, K3, P1, P2, b1, b2, pixel_width_mm, pixel_height_mm";
  static constexpr std::array<int, 1> kFocalIdxs{0};
  static constexpr std::array<int, 2> kPrincipalIdxs{1, 2};
  /// The pixel pitch: a property of the sensor, never estimated.
  static constexpr std::array<int, 2> kFixedIdxs{10, 11};
  /// Newton iterations of ImgFromCam stop below this step (mm) or after kMaxIterations.
  static constexpr double kStepToleranceMm = 1e-13;
  static constexpr int kMaxIterations = 50;

  /// Image-plane coordinates (x̂, ŷ) in mm, y up, of pixel (x, y): pitch, principal point,
  /// affinity.
  template <typename T>
  static void AffineFromPixel(const T* p, const T& x, const T& y, T* xh, T* yh) {
    const T xbar = x * p[10] - p[1];
    const T ybar = p[2] - y * p[11];
    *xh = (T(1) + p[8]) * xbar + p[9] * ybar;
    *yh = ybar;
  }

  /// The corrected coordinates (x̂ + Δx, ŷ + Δy) and, if `jac` is given, their 2×2 Jacobian
  /// with respect to (x̂, ŷ), row-major.
  template <typename T>
  static void Correct(const T* p, const T& xh, const T& yh, T* xc, T* yc, T* jac = nullptr) {
    const T& k1 = p[3];
    const T& k2 = p[4];
    const T& k3 = p[5];
    const T& p1 = p[6];
    const T& p2 = p[7];
    const T r2 = xh * xh + yh * yh;
    const T radial = r2 * (k1 + r2 * (k2 + r2 * k3));
    *xc = xh * (T(1) + radial) + p1 * (r2 + T(2) * xh * xh) + T(2) * p2 * xh * yh;
    *yc = yh * (T(1) + radial) + p2 * (r2 + T(2) * yh * yh) + T(2) * p1 * xh * yh;
    if (jac) {
      // d(radial)/dx̂ = 2 x̂ (K1 + 2 K2 r² + 3 K3 r⁴), likewise for ŷ.
      const T dradial = T(2) * (k1 + r2 * (T(2) * k2 + T(3) * k3 * r2));
      jac[0] = T(1) + radial + xh * xh * dradial + T(6) * p1 * xh + T(2) * p2 * yh;
      jac[1] = xh * yh * dradial + T(2) * p1 * yh + T(2) * p2 * xh;
      jac[2] = jac[1];
      jac[3] = T(1) + radial + yh * yh * dradial + T(6) * p2 * yh + T(2) * p1 * xh;
    }
  }

  template <typename T>
  static void CamFromImg(const T* params, const T& x, const T& y, T* ray) {
    T xh, yh, xc, yc;
    AffineFromPixel(params, x, y, &xh, &yh);
    Correct(params, xh, yh, &xc, &yc);
    ray[0] = xc / params[0];
    ray[1] = -yc / params[0];
    ray[2] = T(1);
  }

  /// Pixel of a point in the camera frame. The corrected coordinates (c x/z, −c y/z) are
  /// known; (x̂, ŷ) is found by Newton's method on the values, then one Newton step in T
  /// carries the derivatives (implicit function theorem: exact to first order at the
  /// solution). False behind the camera or where Newton does not converge (far outside the
  /// image, where the polynomial folds back).
  template <typename T>
  static bool ImgFromCam(const T* params, const T* point_in_cam, T* xy) {
    using photogrammetric_internal::ValueOf;
    if (!(point_in_cam[2] > T(std::numeric_limits<double>::epsilon()))) return false;
    const T target_x = params[0] * point_in_cam[0] / point_in_cam[2];
    const T target_y = -params[0] * point_in_cam[1] / point_in_cam[2];
    std::array<double, kNumParams> p;
    for (int i = 0; i < kNumParams; ++i) p[i] = ValueOf(params[i]);
    const double tx = ValueOf(target_x), ty = ValueOf(target_y);
    double xh = tx, yh = ty;
    bool converged = false;
    for (int i = 0; i < kMaxIterations && !converged; ++i) {
      double xc, yc, j[4];
      Correct(p.data(), xh, yh, &xc, &yc, j);
      const double det = j[0] * j[3] - j[1] * j[2];
      if (!(std::abs(det) > 1e-12)) return false;
      const double sx = (j[3] * (xc - tx) - j[1] * (yc - ty)) / det;
      const double sy = (-j[2] * (xc - tx) + j[0] * (yc - ty)) / det;
      xh -= sx;
      yh -= sy;
      converged = std::abs(sx) + std::abs(sy) < kStepToleranceMm * (1.0 + std::abs(xh) + std::abs(yh));
    }
    if (!converged || !std::isfinite(xh) || !std::isfinite(yh)) return false;
    // One step in T from the converged values.
    T xc, yc, j[4];
    Correct(params, T(xh), T(yh), &xc, &yc, j);
    const T det = j[0] * j[3] - j[1] * j[2];
    const T xh_t = T(xh) - (j[3] * (xc - target_x) - j[1] * (yc - target_y)) / det;
    const T yh_t = T(yh) - (-j[2] * (xc - target_x) + j[0] * (yc - target_y)) / det;
    // Undo the affinity and the pitch.
    const T xbar = (xh_t - params[9] * yh_t) / (T(1) + params[8]);
    xy[0] = (xbar + params[1]) / params[10];
    xy[1] = (params[2] - yh_t) / params[11];
    return true;
  }
};

}  // namespace mmba::sensors
