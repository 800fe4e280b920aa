#pragma once

// An XML document read with pugixml as a tree whose elements keep their line, so that the
// survey readers' errors name file:line. Any encoding the XML declaration names (or a
// UTF-16 byte order mark) is converted to UTF-8 with iconv before parsing; the text must
// then be UTF-8 of XML characters. Entities: the five predefined ones and character
// references; no DTDs. Private to mmba_io_survey.

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace mmba::io::xml {

struct Element {
  std::string name;  ///< local name (a namespace prefix is kept as written)
  std::vector<std::pair<std::string, std::string>> attributes;  ///< entities decoded
  std::vector<std::unique_ptr<Element>> children;
  std::string text;  ///< character data (and CDATA) directly inside this element, decoded
  int line = 0;      ///< line of the element's start tag

  /// Attribute value or nullptr.
  const std::string* Attribute(const std::string& attribute) const;
};

/// The text as UTF-8: converted with iconv from the encoding named by the XML declaration
/// (`<?xml ... encoding="ISO-8859-2"?>`, any name iconv knows, Gama's "cp-1250" spelling
/// too) or by a UTF-16/UTF-32 byte order mark; a UTF-8 byte order mark is dropped. Line
/// breaks stay where they were, so lines of the result are lines of the file. Throws
/// InputError(file, line, "encoding", name, ...) for an encoding iconv does not know and
/// for bytes that are not text in the named encoding.
std::string ToUtf8(const std::string& bytes, const std::string& file);

/// Parses a whole document (ToUtf8 first); throws InputError(file, line, ...) on malformed
/// XML (pugixml's reason), on text that is not UTF-8 or holds a character XML does not
/// allow (a control character, or a character reference to 0, a surrogate or above
/// U+10FFFF), on an unknown entity and on elements nested deeper than 256 levels.
std::unique_ptr<Element> Parse(const std::string& bytes, const std::string& file);

}  // namespace mmba::io::xml
