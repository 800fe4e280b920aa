#include "xml_lite.h"

#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "mmba/core/error.h"

namespace mmba::io::xml {

const std::string* Element::Attribute(const std::string& attribute) const {
  for (const auto& [key, value] : attributes) {
    if (key == attribute) return &value;
  }
  return nullptr;
}

namespace {

/// Deepest element nesting accepted. gama-local needs 5 levels; the bound keeps the
/// recursive descent (and the destruction of the tree) far from the stack limit on any input.
constexpr int kMaxDepth = 256;

/// XML 1.0 Char production: #x9 | #xA | #xD | [#x20-#xD7FF] | [#xE000-#xFFFD] |
/// [#x10000-#x10FFFF].
bool IsXmlChar(uint32_t c) {
  return c == 0x9 || c == 0xA || c == 0xD || (c >= 0x20 && c <= 0xD7FF) ||
         (c >= 0xE000 && c <= 0xFFFD) || (c >= 0x10000 && c <= 0x10FFFF);
}

void AppendUtf8(uint32_t c, std::string* out) {
  if (c < 0x80) {
    *out += static_cast<char>(c);
  } else if (c < 0x800) {
    *out += static_cast<char>(0xC0 | (c >> 6));
    *out += static_cast<char>(0x80 | (c & 0x3F));
  } else if (c < 0x10000) {
    *out += static_cast<char>(0xE0 | (c >> 12));
    *out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
    *out += static_cast<char>(0x80 | (c & 0x3F));
  } else {
    *out += static_cast<char>(0xF0 | (c >> 18));
    *out += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
    *out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
    *out += static_cast<char>(0x80 | (c & 0x3F));
  }
}

/// Decodes the UTF-8 sequence at text[*pos] and advances past it; false on a malformed,
/// overlong or truncated sequence, a surrogate or a value above U+10FFFF.
bool NextUtf8(const std::string& text, size_t* pos, uint32_t* c) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char b0 = byte(*pos);
  int length = 0;
  uint32_t min = 0;
  if (b0 < 0x80) {
    *c = b0;
    ++*pos;
    return true;
  } else if ((b0 & 0xE0) == 0xC0) {
    length = 2, min = 0x80, *c = b0 & 0x1F;
  } else if ((b0 & 0xF0) == 0xE0) {
    length = 3, min = 0x800, *c = b0 & 0x0F;
  } else if ((b0 & 0xF8) == 0xF0) {
    length = 4, min = 0x10000, *c = b0 & 0x07;
  } else {
    return false;
  }
  if (*pos + length > text.size()) return false;
  for (int k = 1; k < length; ++k) {
    if ((byte(*pos + k) & 0xC0) != 0x80) return false;
    *c = (*c << 6) | (byte(*pos + k) & 0x3F);
  }
  if (*c < min || *c > 0x10FFFF || (*c >= 0xD800 && *c <= 0xDFFF)) return false;
  *pos += length;
  return true;
}

/// Throws InputError(file:line) at the first byte that is not UTF-8 or not an XML
/// character (e.g. a control character other than tab, line feed, carriage return).
void CheckCharacters(const std::string& text, const std::string& file) {
  int line = 1;
  size_t pos = 0;
  while (pos < text.size()) {
    const size_t start = pos;
    uint32_t c = 0;
    if (!NextUtf8(text, &pos, &c)) {
      char hex[8];
      std::snprintf(hex, sizeof(hex), "0x%02X", static_cast<unsigned char>(text[start]));
      throw InputError(file, line, "text", std::string("invalid UTF-8 (byte ") + hex +
                                               " at byte offset " + std::to_string(start) + ")",
                       "UTF-8 text");
    }
    if (!IsXmlChar(c)) {
      char code[16];
      std::snprintf(code, sizeof(code), "U+%04X", static_cast<unsigned>(c));
      throw InputError(file, line, "text", std::string("the control character ") + code,
                       "XML characters only (tab, line feed, carriage return, printable text)");
    }
    if (c == '\n') ++line;
  }
}

class Parser {
 public:
  Parser(const std::string& text, const std::string& file) : s_(text), file_(file) {}

  std::unique_ptr<Element> Document() {
    std::unique_ptr<Element> root;
    while (true) {
      SkipSpace();
      if (pos_ >= s_.size()) break;
      if (StartsWith("<?")) {
        SkipPast("?>", "processing instruction");
      } else if (StartsWith("<!--")) {
        SkipPast("-->", "comment");
      } else if (StartsWith("<!DOCTYPE")) {
        SkipPast(">", "DOCTYPE");
      } else if (StartsWith("<")) {
        if (root) Fail("document", "a second root element", "one root element");
        root = ParseElement(1);
      } else {
        Fail("document", Snippet(), "an element");
      }
    }
    if (!root) Fail("document", "no element", "a root element");
    return root;
  }

 private:
  [[noreturn]] void Fail(const std::string& field, const std::string& found,
                         const std::string& expected) const {
    throw InputError(file_, line_, field, found, expected);
  }

  std::string Snippet() const {
    std::string out = s_.substr(pos_, 20);
    for (char& c : out) {
      if (c == '\n' || c == '\r') c = ' ';
    }
    return out;
  }

  bool StartsWith(const char* prefix) const {
    return s_.compare(pos_, std::strlen(prefix), prefix) == 0;
  }

  void Advance(size_t n) {
    for (size_t i = 0; i < n && pos_ < s_.size(); ++i) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  void SkipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) Advance(1);
  }

  void SkipPast(const char* end, const char* what) {
    const size_t found = s_.find(end, pos_);
    if (found == std::string::npos) Fail(what, "end of file", std::string("'") + end + "'");
    Advance(found + std::strlen(end) - pos_);
  }

  std::string Name() {
    const size_t start = pos_;
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
          c == '.' || static_cast<unsigned char>(c) >= 0x80) {
        ++pos_;
      } else {
        break;
      }
    }
    if (pos_ == start) Fail("name", Snippet(), "an XML name");
    return s_.substr(start, pos_ - start);
  }

  /// Replaces the entities and character references of `raw`, which starts at line
  /// `first_line` (for the line of an error).
  std::string Decode(const std::string& raw, int first_line) const {
    std::string out;
    int line = first_line;
    for (size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] == '\n') ++line;
      if (raw[i] != '&') {
        out += raw[i];
        continue;
      }
      const size_t semi = raw.find(';', i);
      if (semi == std::string::npos) {
        throw InputError(file_, line, "entity", raw.substr(i, 10), "an entity ending in ';'");
      }
      const std::string entity = raw.substr(i + 1, semi - i - 1);
      if (entity == "lt") out += '<';
      else if (entity == "gt") out += '>';
      else if (entity == "amp") out += '&';
      else if (entity == "quot") out += '"';
      else if (entity == "apos") out += '\'';
      else if (!entity.empty() && entity[0] == '#') AppendUtf8(CharacterReference(entity, line), &out);
      else {
        throw InputError(file_, line, "entity", "&" + entity.substr(0, 20) + ";",
                         "one of &lt; &gt; &amp; &quot; &apos; &#N; &#xH;");
      }
      i = semi;
    }
    return out;
  }

  /// The character of a reference "#N" (decimal) or "#xH" (hexadecimal) without '&' and ';':
  /// digits only, and a character XML allows (not 0, a surrogate or above U+10FFFF).
  uint32_t CharacterReference(const std::string& entity, int line) const {
    const bool hex = entity.size() > 1 && entity[1] == 'x';
    const std::string digits = entity.substr(hex ? 2 : 1);
    const std::string shown = "&" + entity.substr(0, 20) + ";";
    const char* expected = "a character reference &#N; or &#xH; of a character XML allows "
                           "(U+0009, U+000A, U+000D, U+0020..U+D7FF, U+E000..U+FFFD, "
                           "U+10000..U+10FFFF)";
    if (digits.empty()) throw InputError(file_, line, "entity", shown, expected);
    uint32_t code = 0;
    for (char d : digits) {
      int value = -1;
      if (d >= '0' && d <= '9') value = d - '0';
      else if (hex && d >= 'a' && d <= 'f') value = d - 'a' + 10;
      else if (hex && d >= 'A' && d <= 'F') value = d - 'A' + 10;
      if (value < 0 || code > 0x10FFFF) throw InputError(file_, line, "entity", shown, expected);
      code = code * (hex ? 16 : 10) + static_cast<uint32_t>(value);  // < 2^25: no overflow
    }
    if (!IsXmlChar(code)) throw InputError(file_, line, "entity", shown, expected);
    return code;
  }

  std::unique_ptr<Element> ParseElement(int depth) {
    if (depth > kMaxDepth) {
      Fail("element", "more than " + std::to_string(kMaxDepth) + " nested elements",
           "at most " + std::to_string(kMaxDepth) + " levels of nesting");
    }
    auto element = std::make_unique<Element>();
    element->line = line_;
    Advance(1);  // '<'
    element->name = Name();
    while (true) {
      SkipSpace();
      if (pos_ >= s_.size()) Fail(element->name, "end of file", "'>'");
      if (StartsWith("/>")) {
        Advance(2);
        return element;
      }
      if (s_[pos_] == '>') {
        Advance(1);
        break;
      }
      const int attribute_line = line_;
      const std::string key = Name();
      SkipSpace();
      if (pos_ >= s_.size() || s_[pos_] != '=') {
        Fail(element->name + "@" + key, Snippet(), "'=' and a quoted value");
      }
      Advance(1);
      SkipSpace();
      if (pos_ >= s_.size() || (s_[pos_] != '"' && s_[pos_] != '\'')) {
        Fail(element->name + "@" + key, Snippet(), "a quoted value");
      }
      const char quote = s_[pos_];
      Advance(1);
      const int value_line = line_;
      const size_t end = s_.find(quote, pos_);
      if (end == std::string::npos) Fail(element->name + "@" + key, "end of file", "a closing quote");
      const std::string raw = s_.substr(pos_, end - pos_);
      Advance(end + 1 - pos_);
      if (element->Attribute(key) != nullptr) {
        throw InputError(file_, attribute_line, element->name + "@" + key, "a repeated attribute",
                         "each attribute once");
      }
      element->attributes.emplace_back(key, Decode(raw, value_line));
    }
    // Content.
    while (true) {
      if (pos_ >= s_.size()) Fail(element->name, "end of file", "</" + element->name + ">");
      if (StartsWith("</")) {
        Advance(2);
        const std::string name = Name();
        if (name != element->name) Fail("</" + name + ">", name, "</" + element->name + ">");
        SkipSpace();
        if (pos_ >= s_.size() || s_[pos_] != '>') Fail("</" + name + ">", Snippet(), "'>'");
        Advance(1);
        return element;
      }
      if (StartsWith("<!--")) {
        SkipPast("-->", "comment");
      } else if (StartsWith("<![CDATA[")) {
        Advance(9);
        const size_t end = s_.find("]]>", pos_);
        if (end == std::string::npos) Fail("CDATA", "end of file", "']]>'");
        element->text += s_.substr(pos_, end - pos_);
        Advance(end + 3 - pos_);
      } else if (StartsWith("<?")) {
        SkipPast("?>", "processing instruction");
      } else if (s_[pos_] == '<') {
        element->children.push_back(ParseElement(depth + 1));
      } else {
        const size_t end = s_.find('<', pos_);
        const size_t stop = end == std::string::npos ? s_.size() : end;
        element->text += Decode(s_.substr(pos_, stop - pos_), line_);
        Advance(stop - pos_);
      }
    }
  }

  const std::string& s_;
  const std::string& file_;
  size_t pos_ = 0;
  int line_ = 1;
};

}  // namespace

std::unique_ptr<Element> Parse(const std::string& text, const std::string& file) {
  CheckCharacters(text, file);
  return Parser(text, file).Document();
}

}  // namespace mmba::io::xml
