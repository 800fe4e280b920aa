#pragma once

// A small, strict XML reader for the survey inputs (gama-local): elements, attributes,
// character data, comments, processing instructions, CDATA and the five predefined
// entities plus numeric character references. No DTDs. Every node keeps its line so that
// errors name file:line. Private to mmba_io_survey.

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace mmba::io::xml {

struct Element {
  std::string name;  ///< local name (a namespace prefix is kept as written)
  std::vector<std::pair<std::string, std::string>> attributes;
  std::vector<std::unique_ptr<Element>> children;
  std::string text;  ///< concatenated character data directly inside this element
  int line = 0;

  /// Attribute value or nullptr.
  const std::string* Attribute(const std::string& attribute) const;
};

/// Parses a whole document; throws InputError(file, line, ...) on malformed XML, on text
/// that is not UTF-8 or holds a character XML does not allow (a control character, or a
/// character reference to 0, a surrogate or above U+10FFFF), and on elements nested deeper
/// than 256 levels.
std::unique_ptr<Element> Parse(const std::string& text, const std::string& file);

}  // namespace mmba::io::xml
