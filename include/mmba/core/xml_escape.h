#pragma once

#include <string>

namespace mmba {

/// `text` as XML or HTML character data or an attribute value in either quotes: &, <, >, " and
/// ' as character references (XML 1.0 §2.4 and §3.3.3; &#39; as HTML 4 has no &apos;); the
/// rest, UTF-8 included, unchanged.
inline std::string XmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace mmba
