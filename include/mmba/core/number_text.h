#pragma once

#include <sstream>
#include <string>

namespace mmba {

/// `v` with 17 significant digits, so that it reads back as the same double: how an error
/// message quotes a number that was read or computed.
inline std::string ExactNumber(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

}  // namespace mmba
