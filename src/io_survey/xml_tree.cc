#include "xml_tree.h"

#include <iconv.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdio>

#include <pugixml.hpp>

#include "mmba/core/error.h"
#include "mmba/core/utf8.h"

namespace mmba::io::xml {

const std::string* Element::Attribute(const std::string& attribute) const {
  for (const auto& [key, value] : attributes) {
    if (key == attribute) return &value;
  }
  return nullptr;
}

namespace {

/// Deepest element nesting accepted. gama-local needs 5 levels; the bound keeps the tree's
/// recursive conversion (and destruction) far from the stack limit on any input.
constexpr int kMaxDepth = 256;

int CountLines(const std::string& text, size_t end) {
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + std::min(end, text.size()), '\n'));
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// The encoding named by the XML declaration at the start of ASCII-compatible `bytes`
/// ("" when there is no declaration or it names none).
std::string DeclaredEncoding(const std::string& bytes) {
  if (bytes.compare(0, 5, "<?xml") != 0) return "";
  const size_t end = bytes.find("?>");
  if (end == std::string::npos) return "";
  const std::string declaration = bytes.substr(0, end);
  const size_t key = declaration.find("encoding");
  if (key == std::string::npos) return "";
  size_t q = declaration.find_first_of("\"'", key);
  if (q == std::string::npos) return "";
  const size_t close = declaration.find(declaration[q], q + 1);
  if (close == std::string::npos) return "";
  return declaration.substr(q + 1, close - q - 1);
}

/// The iconv name of an encoding as written in a declaration: Gama's own spellings
/// "cp-1250"/"cp-1251" become CP1250/CP1251; other names go to iconv as written.
std::string IconvName(const std::string& declared) {
  const std::string lower = Lower(declared);
  if (lower.rfind("cp-", 0) == 0) return "CP" + declared.substr(3);
  return declared;
}

/// Converts `bytes` from `encoding` to UTF-8 with iconv; InputError at the line of the first
/// byte that is not text in that encoding.
std::string Convert(const std::string& bytes, const std::string& encoding, const std::string& shown,
                    const std::string& file) {
  iconv_t cd = iconv_open("UTF-8", IconvName(encoding).c_str());
  if (cd == reinterpret_cast<iconv_t>(-1)) {
    throw InputError(file, 1, "encoding", shown,
                     "an encoding iconv knows (e.g. UTF-8, ISO-8859-2, windows-1250, UTF-16)");
  }
  std::string out(bytes.size() * 4 + 16, '\0');
  char* in_ptr = const_cast<char*>(bytes.data());
  size_t in_left = bytes.size();
  char* out_ptr = out.data();
  size_t out_left = out.size();
  const size_t result = iconv(cd, &in_ptr, &in_left, &out_ptr, &out_left);
  const int error = errno;
  iconv_close(cd);
  out.resize(out.size() - out_left);
  if (result == static_cast<size_t>(-1)) {
    char hex[8];
    std::snprintf(hex, sizeof(hex), "0x%02X", in_left ? static_cast<unsigned char>(*in_ptr) : 0u);
    throw InputError(file, CountLines(out, out.size()), "text",
                     std::string(error == EINVAL ? "a truncated character" : "the byte ") +
                         (error == EINVAL ? "" : hex) + " at byte offset " +
                         std::to_string(bytes.size() - in_left),
                     "text in the declared encoding " + shown);
  }
  return out;
}

/// XML 1.0 Char production: #x9 | #xA | #xD | [#x20-#xD7FF] | [#xE000-#xFFFD] |
/// [#x10000-#x10FFFF].
bool IsXmlChar(uint32_t c) {
  return c == 0x9 || c == 0xA || c == 0xD || (c >= 0x20 && c <= 0xD7FF) ||
         (c >= 0xE000 && c <= 0xFFFD) || (c >= 0x10000 && c <= 0x10FFFF);
}

uint32_t DecodeUtf8(const std::string& text, size_t i, size_t length) {
  const auto b = [&](size_t k) { return static_cast<uint32_t>(static_cast<unsigned char>(text[i + k])); };
  if (length == 1) return b(0);
  if (length == 2) return ((b(0) & 0x1F) << 6) | (b(1) & 0x3F);
  if (length == 3) return ((b(0) & 0x0F) << 12) | ((b(1) & 0x3F) << 6) | (b(2) & 0x3F);
  return ((b(0) & 0x07) << 18) | ((b(1) & 0x3F) << 12) | ((b(2) & 0x3F) << 6) | (b(3) & 0x3F);
}

/// Throws InputError(file:line) at the first byte that is not UTF-8 or not an XML character
/// (e.g. a control character other than tab, line feed, carriage return).
void CheckCharacters(const std::string& text, const std::string& file) {
  int line = 1;
  for (size_t i = 0; i < text.size();) {
    const size_t length = Utf8SequenceLength(text, i);
    if (length == 0) {
      char hex[8];
      std::snprintf(hex, sizeof(hex), "0x%02X", static_cast<unsigned char>(text[i]));
      throw InputError(file, line, "text", std::string("invalid UTF-8 (byte ") + hex +
                                               " at byte offset " + std::to_string(i) + ")",
                       "UTF-8 text, or an encoding=\"...\" in the XML declaration");
    }
    const uint32_t c = DecodeUtf8(text, i, length);
    if (!IsXmlChar(c)) {
      char code[16];
      std::snprintf(code, sizeof(code), "U+%04X", static_cast<unsigned>(c));
      throw InputError(file, line, "text", std::string("the control character ") + code,
                       "XML characters only (tab, line feed, carriage return, printable text)");
    }
    if (c == '\n') ++line;
    i += length;
  }
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

class TreeBuilder {
 public:
  TreeBuilder(const std::string& text, const std::string& file) : text_(text), file_(file) {
    line_starts_.push_back(0);
    for (size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\n') line_starts_.push_back(i + 1);
    }
  }

  int LineOf(ptrdiff_t offset) const {
    if (offset < 0) return 0;
    return static_cast<int>(std::upper_bound(line_starts_.begin(), line_starts_.end(),
                                             static_cast<size_t>(offset)) -
                            line_starts_.begin());
  }

  std::unique_ptr<Element> Build(const pugi::xml_node& node, int depth) const {
    auto element = std::make_unique<Element>();
    element->name = node.name();
    element->line = LineOf(node.offset_debug());
    if (depth > kMaxDepth) {
      throw InputError(file_, element->line, "element",
                       "more than " + std::to_string(kMaxDepth) + " nested elements",
                       "at most " + std::to_string(kMaxDepth) + " levels of nesting");
    }
    for (const pugi::xml_attribute& a : node.attributes()) {
      element->attributes.emplace_back(a.name(), Decode(a.value(), element->line));
    }
    for (const pugi::xml_node& child : node.children()) {
      if (child.type() == pugi::node_element) {
        element->children.push_back(Build(child, depth + 1));
      } else if (child.type() == pugi::node_pcdata) {
        element->text += Decode(child.value(), LineOf(child.offset_debug()));
      } else if (child.type() == pugi::node_cdata) {
        element->text += child.value();
      }
    }
    return element;
  }

 private:
  /// `raw` with the predefined entities and character references replaced; `line` is the
  /// line where `raw` starts.
  std::string Decode(const std::string& raw, int line) const {
    std::string out;
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

  const std::string& text_;
  const std::string& file_;
  std::vector<size_t> line_starts_;
};

}  // namespace

std::string ToUtf8(const std::string& bytes, const std::string& file) {
  const auto starts = [&](const char* prefix, size_t n) { return bytes.compare(0, n, prefix, n) == 0; };
  if (starts("\xEF\xBB\xBF", 3)) return bytes.substr(3);
  if (starts("\x00\x00\xFE\xFF", 4) || starts("\xFF\xFE\x00\x00", 4)) return Convert(bytes, "UTF-32", "UTF-32", file);
  if (starts("\xFE\xFF", 2) || starts("\xFF\xFE", 2)) return Convert(bytes, "UTF-16", "UTF-16", file);
  if (starts("<\0?\0", 4)) return Convert(bytes, "UTF-16LE", "UTF-16LE", file);
  if (starts("\0<\0?", 4)) return Convert(bytes, "UTF-16BE", "UTF-16BE", file);
  const std::string declared = DeclaredEncoding(bytes);
  const std::string lower = Lower(declared);
  if (declared.empty() || lower == "utf-8" || lower == "utf8" || lower == "us-ascii" || lower == "ascii") {
    return bytes;
  }
  return Convert(bytes, declared, declared, file);
}

std::unique_ptr<Element> Parse(const std::string& bytes, const std::string& file) {
  const std::string text = ToUtf8(bytes, file);
  CheckCharacters(text, file);
  const TreeBuilder builder(text, file);
  pugi::xml_document document;
  // Entities are decoded by the builder (which checks character references); attribute
  // whitespace is normalised and line ends are \n as XML requires.
  const unsigned options = pugi::parse_cdata | pugi::parse_eol | pugi::parse_wconv_attribute;
  const pugi::xml_parse_result result =
      document.load_buffer(text.data(), text.size(), options, pugi::encoding_utf8);
  if (!result) {
    const size_t at = static_cast<size_t>(std::max<ptrdiff_t>(0, result.offset));
    std::string near = text.substr(at, 20);
    std::replace(near.begin(), near.end(), '\n', ' ');
    throw InputError(file, builder.LineOf(result.offset), "XML",
                     std::string(result.description()) + (near.empty() ? "" : " at '" + near + "'"),
                     "well-formed XML");
  }
  pugi::xml_node root;
  for (const pugi::xml_node& child : document.children()) {
    if (child.type() != pugi::node_element) continue;
    if (root) {
      throw InputError(file, builder.LineOf(child.offset_debug()), "document",
                       "a second root element <" + std::string(child.name()) + ">", "one root element");
    }
    root = child;
  }
  if (!root) throw InputError(file, 1, "document", "no element", "a root element");
  return builder.Build(root, 1);
}

}  // namespace mmba::io::xml
