#pragma once

// UTF-8 validation of text read from user files (names, ids, YAML strings), so that a bad
// byte is reported where it is read rather than when a JSON or YAML output is written.

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace mmba {

/// Length of the well-formed UTF-8 sequence starting at `text[i]` (1 to 4 bytes), or 0 when
/// the bytes there are not one: a stray continuation byte, a truncated sequence, an overlong
/// encoding, a UTF-16 surrogate (U+D800..U+DFFF) or a code point above U+10FFFF (RFC 3629,
/// section 4).
inline size_t Utf8SequenceLength(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(text[k]); };
  const uint8_t lead = byte(i);
  if (lead < 0x80) return 1;
  size_t length = 0;
  uint8_t lo = 0x80, hi = 0xBF;  // range of the second byte
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) lo = 0xA0;  // overlong
    if (lead == 0xED) hi = 0x9F;  // surrogates
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) lo = 0x90;  // overlong
    if (lead == 0xF4) hi = 0x8F;  // above U+10FFFF
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  }
  return length;
}

/// Offset of the first byte of `text` that does not start a well-formed UTF-8 sequence, or
/// std::string_view::npos when the whole text is valid UTF-8.
inline size_t InvalidUtf8Offset(std::string_view text) {
  size_t i = 0;
  while (i < text.size()) {
    if (static_cast<uint8_t>(text[i]) < 0x80) {
      ++i;
      continue;
    }
    const size_t length = Utf8SequenceLength(text, i);
    if (length == 0) return i;
    i += length;
  }
  return std::string_view::npos;
}

}  // namespace mmba
