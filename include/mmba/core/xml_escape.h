#pragma once

#include <string>

namespace mmba {

/// `text` as XML character data or a double-quoted attribute value: &, <, > and " as entity
/// references (XML 1.0 §2.4 and §3.3.3); the rest, UTF-8 included, unchanged.
inline std::string XmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace mmba
