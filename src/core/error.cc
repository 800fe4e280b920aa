#include "mmba/core/error.h"

#include <cstdio>
#include <string_view>
#include <utility>

#include "mmba/core/utf8.h"

namespace mmba {
namespace {

// A field name or a value quoted from a file is cut to this many bytes: enough for any
// number, id or keyword, short enough that a binary file or a long line cannot flood the
// terminal.
constexpr size_t kMaxQuotedBytes = 100;

std::string Truncated(const std::string& text) {
  if (text.size() <= kMaxQuotedBytes) return text;
  size_t cut = kMaxQuotedBytes;
  // Back up to the start of a UTF-8 sequence (continuation bytes are 10xxxxxx).
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return text.substr(0, cut) + "… (" + std::to_string(text.size()) + " bytes)";
}

std::string HexEscape(unsigned char byte) {
  char buffer[5];
  std::snprintf(buffer, sizeof(buffer), "\\x%02x", byte);
  return buffer;
}

// The message as one line safe to print on a terminal: control characters (C0, DEL and the
// C1 range U+0080..U+009F, which some terminals obey as escape sequences) and bytes that are
// not UTF-8 are written as \t, \r, \n or \xHH; other characters are kept.
std::string Printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  size_t i = 0;
  while (i < text.size()) {
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte < 0x80) {
      if (byte == '\t') out += "\\t";
      else if (byte == '\r') out += "\\r";
      else if (byte == '\n') out += "\\n";
      else if (byte < 0x20 || byte == 0x7F) out += HexEscape(byte);
      else out += static_cast<char>(byte);
      ++i;
      continue;
    }
    const size_t length = Utf8SequenceLength(text, i);
    if (length == 0) {
      out += HexEscape(byte);
      ++i;
      continue;
    }
    if (byte == 0xC2 && static_cast<unsigned char>(text[i + 1]) <= 0x9F) {  // C1 control
      out += HexEscape(byte) + HexEscape(static_cast<unsigned char>(text[i + 1]));
    } else {
      out.append(text.substr(i, length));
    }
    i += length;
  }
  return out;
}

std::string Location(const std::string& file, int64_t line) {
  if (line <= 0) return file;
  return file + ":" + std::to_string(line);
}

std::string Body(const std::string& field, const std::string& found,
                 const std::string& expected) {
  return "field '" + Truncated(field) + "': found '" + Truncated(found) + "', expected " + expected;
}

}  // namespace

InputError::InputError(const std::string& file, int64_t line, const std::string& field,
                       const std::string& found, const std::string& expected)
    : InputError(Location(file, line) + ": " + Body(field, found, expected), file) {}

InputError::InputError(const std::string& message, std::string file)
    : std::runtime_error(Printable(message)), file_(std::move(file)) {}

InputError InputError::AtByte(const std::string& file, uint64_t byte_offset,
                              const std::string& field, const std::string& found,
                              const std::string& expected) {
  return InputError(file + " (byte " + std::to_string(byte_offset) + "): " +
                        Body(field, found, expected),
                    file);
}

InputError InputError::Message(const std::string& where, const std::string& message) {
  return InputError(where + ": " + message, where);
}

}  // namespace mmba
