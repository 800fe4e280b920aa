#pragma once

// Units and number formats shared by the survey's output files (result_json.cc,
// result_report.cc).

#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

namespace mmba::survey::internal {

/// Angle unit of the outputs, the input's: gon, or degrees (parameters angles="360").
struct AngleUnit {
  bool gons = true;
  double FromRad(double rad) const { return rad * (gons ? 200.0 : 180.0) / M_PI; }
  /// Small angles (residuals, σ): cc or arc seconds.
  double SmallFromRad(double rad) const { return rad * (gons ? 2.0e6 : 648000.0) / M_PI; }
  /// A full turn: 400 gon or 360°.
  double FullTurn() const { return gons ? 400.0 : 360.0; }
  const char* name() const { return gons ? "gon" : "deg"; }
  const char* small_name() const { return gons ? "cc" : "arcsec"; }
};

/// `value` reduced to [0, full).
inline double Full(double value, double full) {
  value = std::fmod(value, full);
  return value < 0 ? value + full : value;
}

/// `v` with `digits` decimals.
inline std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace mmba::survey::internal
