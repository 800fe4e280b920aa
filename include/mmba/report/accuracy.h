#pragma once

// Positional accuracy from check points (coordinate differences adjusted − reference of points
// withheld from the adjustment), as the map-accuracy standards state it:
//  - FGDC-STD-007.3-1998 (NSSDA), Appendix 3-A: RMSE_x, RMSE_y, RMSE_r =
//    sqrt(RMSE_x² + RMSE_y²), RMSE_z; 95 % figures Accuracy_r = 1.7308·RMSE_r when
//    RMSE_x = RMSE_y, ≈ 2.4477·0.5·(RMSE_x + RMSE_y) when 0.6 < RMSE_min/RMSE_max < 1
//    (not defined below 0.6), Accuracy_z = 1.9600·RMSE_z; at least 20 check points.
//  - ASPRS Positional Accuracy Standards for Digital Geospatial Data, Edition 1 (2014): the
//    same 95 % figures and at least 20 check points.
//  - ASPRS Edition 2 (2023): RMSE_H (= RMSE_r), RMSE_V and RMSE_3D = sqrt(RMSE_H² + RMSE_V²),
//    no 95 % figures, at least 30 check points.
// Lengths in metres; axes east, north, up.

#include <array>
#include <string>
#include <vector>

namespace mmba::report {

struct CheckAccuracy {
  int count = 0;                ///< check points with all three differences finite
  std::array<double, 3> mean{};   ///< mean error (bias) per axis
  std::array<double, 3> stdev{};  ///< standard deviation per axis (n − 1), NaN for n < 2
  std::array<double, 3> rmse{};   ///< RMSE per axis
  double rmse_h = 0.0;          ///< RMSE_r = RMSE_H = sqrt(RMSE_x² + RMSE_y²)
  double rmse_v = 0.0;          ///< RMSE_z = RMSE_V
  double rmse_3d = 0.0;         ///< sqrt(RMSE_H² + RMSE_V²)
  double accuracy_h95 = 0.0;    ///< NSSDA horizontal accuracy at 95 %; NaN when not defined
  std::string horizontal_formula;  ///< which NSSDA formula gave accuracy_h95, or why none
  double accuracy_v95 = 0.0;    ///< 1.9600·RMSE_z
  /// Warnings when the count cannot support a stated accuracy (fewer than 20, or 30).
  std::vector<std::string> warnings;
};

inline constexpr int kNssdaMinCheckPoints = 20;     ///< FGDC-STD-007.3-1998 and ASPRS 2014
inline constexpr int kAsprs2023MinCheckPoints = 30;  ///< ASPRS Edition 2 (2023)

/// The figures above from the differences adjusted − reference [E, N, U] in metres; rows with
/// a non-finite component are left out. Zero rows: count 0 and NaN figures.
CheckAccuracy ComputeCheckAccuracy(const std::vector<std::array<double, 3>>& differences);

}  // namespace mmba::report
