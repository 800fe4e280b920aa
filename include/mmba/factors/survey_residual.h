#pragma once

#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <ceres/dynamic_autodiff_cost_function.h>

namespace mmba::factors {

/// One scalar survey observation inside a (possibly correlated) residual block. Parameter
/// indices refer to the block's parameter list; -1 = not used.
///   from_xy/to_xy/fs_xy: (east, north) of a point [m], 2 doubles
///   from_z/to_z/fs_z:    up [m], 1 double
///   orientation:         direction-set orientation [rad], 1 double
/// Angles are clockwise radians, azimuths from north. With `station_from_world` = I and no
/// curvature these are the plane predictions of gama-local:
///   bearing(a→b) = atan2(ΔE, ΔN); direction = bearing − orientation;
///   angle = bearing(fs) − bearing(bs); distance = ‖ΔEN‖;
///   Δh = (z_to + to_dh) − (z_from + from_dh); slope = sqrt(‖ΔEN‖² + Δh²);
///   zenith = atan2(‖ΔEN‖, Δh); dh = z_to − z_from;
///   coordinate / vector components in the input axes: xy = Mᵀ·(E, N), M = en_from_xy.
struct SurveyRow {
  enum Kind {
    kDirection, kAngle, kDistance, kSlopeDistance, kZenithAngle, kAzimuth, kHeightDiff,
    kCoordX, kCoordY, kCoordZ, kVectorX, kVectorY, kVectorZ
  };
  Kind kind = kDistance;
  double value = 0.0;
  double from_dh = 0.0, to_dh = 0.0, fs_dh = 0.0;
  int from_xy = -1, from_z = -1, to_xy = -1, to_z = -1, fs_xy = -1, fs_z = -1;
  int orientation = -1;
  /// Geodetic networks: rotation from the world ENU frame to the station's own local
  /// vertical (ENU at the station), constant during the solve; identity in a plane.
  Eigen::Matrix3d station_from_world = Eigen::Matrix3d::Identity();
  /// Normal-section radius of curvature of the line (m); 0 = plane (no Earth curvature).
  /// Levelled height differences add d²/(2R) to the up component in the station frame;
  /// zenith angles subtract the refraction k·d/(2R) (Eq. 7.35, Torge & Müller, Geodesy 2012).
  double curvature_radius_m = 0.0;
  double refraction_k = 0.0;
  bool is_angle() const {
    return kind == kDirection || kind == kAngle || kind == kZenithAngle || kind == kAzimuth;
  }
};

/// Wraps an angle difference to (−π, π].
template <typename T>
T WrapAngle(const T& a) {
  using std::atan2;
  using std::cos;
  using std::sin;
  return atan2(sin(a), cos(a));
}

/// Prediction − observation for one row (angles wrapped).
template <typename T>
T SurveyRowResidual(const SurveyRow& row, const Eigen::Matrix2d& en_from_xy,
                    T const* const* p) {
  using std::atan2;
  using std::sqrt;
  const Eigen::Matrix3d& r = row.station_from_world;
  // Difference a -> b in the station's local vertical (z = 0 for blocks not given).
  auto delta = [&](int a_xy, int a_z, int b_xy, int b_z, T* d) {
    const T w[3] = {p[b_xy][0] - p[a_xy][0], p[b_xy][1] - p[a_xy][1],
                    (b_z >= 0 ? p[b_z][0] : T(0.0)) - (a_z >= 0 ? p[a_z][0] : T(0.0))};
    for (int i = 0; i < 3; ++i) d[i] = T(r(i, 0)) * w[0] + T(r(i, 1)) * w[1] + T(r(i, 2)) * w[2];
  };
  auto bearing = [&](int b_xy, int b_z) {
    T d[3];
    delta(row.from_xy, row.from_z, b_xy, b_z, d);
    return atan2(d[0], d[1]);
  };
  switch (row.kind) {
    case SurveyRow::kDirection:
      return WrapAngle(bearing(row.to_xy, row.to_z) - p[row.orientation][0] - T(row.value));
    case SurveyRow::kAngle:
      return WrapAngle(bearing(row.fs_xy, row.fs_z) - bearing(row.to_xy, row.to_z) -
                       T(row.value));
    case SurveyRow::kAzimuth:
      return WrapAngle(bearing(row.to_xy, row.to_z) - T(row.value));
    case SurveyRow::kDistance: {
      T d[3];
      delta(row.from_xy, row.from_z, row.to_xy, row.to_z, d);
      return sqrt(d[0] * d[0] + d[1] * d[1]) - T(row.value);
    }
    case SurveyRow::kSlopeDistance:
    case SurveyRow::kZenithAngle: {
      T d[3];
      delta(row.from_xy, row.from_z, row.to_xy, row.to_z, d);
      const T dh = d[2] + T(row.to_dh) - T(row.from_dh);
      const T horizontal = sqrt(d[0] * d[0] + d[1] * d[1]);
      if (row.kind == SurveyRow::kSlopeDistance) {
        return sqrt(horizontal * horizontal + dh * dh) - T(row.value);
      }
      T zenith = atan2(horizontal, dh);
      if (row.curvature_radius_m > 0.0) {
        zenith -= T(row.refraction_k) * horizontal / T(2.0 * row.curvature_radius_m);
      }
      return WrapAngle(zenith - T(row.value));
    }
    case SurveyRow::kHeightDiff: {
      if (row.curvature_radius_m > 0.0 && row.from_xy >= 0 && row.to_xy >= 0) {
        T d[3];
        delta(row.from_xy, row.from_z, row.to_xy, row.to_z, d);
        const T horizontal2 = d[0] * d[0] + d[1] * d[1];
        return d[2] + horizontal2 / T(2.0 * row.curvature_radius_m) - T(row.value);
      }
      return p[row.to_z][0] - p[row.from_z][0] - T(row.value);
    }
    case SurveyRow::kCoordX:
    case SurveyRow::kCoordY: {
      const int axis = row.kind == SurveyRow::kCoordX ? 0 : 1;
      // x_input = M(0,axis)·E + M(1,axis)·N (Mᵀ row `axis`)
      return T(en_from_xy(0, axis)) * p[row.from_xy][0] +
             T(en_from_xy(1, axis)) * p[row.from_xy][1] - T(row.value);
    }
    case SurveyRow::kCoordZ:
      return p[row.from_z][0] - T(row.value);
    case SurveyRow::kVectorX:
    case SurveyRow::kVectorY: {
      const int axis = row.kind == SurveyRow::kVectorX ? 0 : 1;
      const T de = p[row.to_xy][0] - p[row.from_xy][0];
      const T dn = p[row.to_xy][1] - p[row.from_xy][1];
      return T(en_from_xy(0, axis)) * de + T(en_from_xy(1, axis)) * dn - T(row.value);
    }
    case SurveyRow::kVectorZ:
      return (p[row.to_z][0] + T(row.to_dh)) - (p[row.from_z][0] + T(row.from_dh)) -
             T(row.value);
  }
  return T(0.0);
}

/// A block of survey rows with one covariance C = L·Lᵀ: residual = L⁻¹ · (prediction −
/// observation) (whitened; for one row simply (prediction − observation)/σ).
class SurveyBlockResidual {
 public:
  SurveyBlockResidual(std::vector<SurveyRow> rows, Eigen::MatrixXd sqrt_information,
                      Eigen::Matrix2d en_from_xy)
      : rows_(std::move(rows)),
        sqrt_information_(std::move(sqrt_information)),
        en_from_xy_(en_from_xy) {}

  template <typename T>
  bool operator()(T const* const* parameters, T* residuals) const {
    const int n = static_cast<int>(rows_.size());
    std::vector<T> raw(n);
    for (int i = 0; i < n; ++i) raw[i] = SurveyRowResidual(rows_[i], en_from_xy_, parameters);
    for (int i = 0; i < n; ++i) {
      T sum(0.0);
      for (int j = 0; j <= i; ++j) sum += T(sqrt_information_(i, j)) * raw[j];
      residuals[i] = sum;
    }
    return true;
  }

  /// `block_sizes`: size of every parameter block (2 for xy, 1 for z or orientation).
  /// `sqrt_information` = L⁻¹ (lower triangular).
  static ceres::CostFunction* Create(std::vector<SurveyRow> rows,
                                     const Eigen::MatrixXd& sqrt_information,
                                     const Eigen::Matrix2d& en_from_xy,
                                     const std::vector<int>& block_sizes) {
    const int n = static_cast<int>(rows.size());
    auto* cost = new ceres::DynamicAutoDiffCostFunction<SurveyBlockResidual, 4>(
        new SurveyBlockResidual(std::move(rows), sqrt_information, en_from_xy));
    for (int size : block_sizes) cost->AddParameterBlock(size);
    cost->SetNumResiduals(n);
    return cost;
  }

 private:
  std::vector<SurveyRow> rows_;
  Eigen::MatrixXd sqrt_information_;
  Eigen::Matrix2d en_from_xy_;
};

}  // namespace mmba::factors
