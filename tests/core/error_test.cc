#include "mmba/core/error.h"

#include <gtest/gtest.h>

namespace mmba {
namespace {

TEST(InputError, NamesFileLineFieldValueAndExpectation) {
  const InputError e("model/cameras.txt", 4, "MODEL", "PINHOL", "one of PINHOLE, ...");
  EXPECT_STREQ(e.what(),
               "model/cameras.txt:4: field 'MODEL': found 'PINHOL', expected one of PINHOLE, ...");
  EXPECT_EQ(e.file(), "model/cameras.txt");
}

TEST(InputError, ByteOffsetForBinaryFiles) {
  const InputError e = InputError::AtByte("images.bin", 1234, "num_points2D", "99", "less");
  EXPECT_STREQ(e.what(), "images.bin (byte 1234): field 'num_points2D': found '99', expected less");
}

TEST(InputError, LineZeroOmitsTheLine) {
  const InputError e("f.txt", 0, "x", "y", "z");
  EXPECT_STREQ(e.what(), "f.txt: field 'x': found 'y', expected z");
}

// A value quoted from a file may hold escape sequences (clear the screen, retitle the
// terminal): what() writes every control character escaped, and stays one line.
TEST(InputError, ControlCharactersAreEscaped) {
  const InputError e("in\x1b[2J.txt", 2, "name", "\x1b]0;title\x07\x1b[2J\tx\ry\nz\x7f", "a\nname");
  EXPECT_STREQ(e.what(),
               "in\\x1b[2J.txt:2: field 'name': found '\\x1b]0;title\\x07\\x1b[2J\\tx\\ry\\nz\\x7f', "
               "expected a\\nname");
  const InputError m = InputError::Message("f.txt", "line one\nline two \x1b[31m");
  EXPECT_STREQ(m.what(), "f.txt: line one\\nline two \\x1b[31m");
  EXPECT_EQ(m.file(), "f.txt");  // the file itself as given
}

// UTF-8 text is kept; C1 controls (U+0080..U+009F, which some terminals obey like ESC) and
// bytes that are not UTF-8 are escaped.
TEST(InputError, NonUtf8BytesAndC1ControlsAreEscaped) {
  const InputError e("f.txt", 1, "x", "caf\xC3\xA9 \xC2\x9B" "2J \xFF\xE9", "z");
  EXPECT_STREQ(e.what(), "f.txt:1: field 'x': found 'caf\xC3\xA9 \\xc2\\x9b2J \\xff\\xe9', expected z");
}

TEST(InputError, LongValuesAreCut) {
  const InputError e("f.txt", 1, "x", std::string(500, 'a'), "z");
  EXPECT_STREQ(e.what(), ("f.txt:1: field 'x': found '" + std::string(100, 'a') + "… (500 bytes)', expected z").c_str());
  // Not inside a UTF-8 sequence: 99 bytes, then a 2-byte character across the cut.
  const InputError u("f.txt", 1, "x", std::string(99, 'a') + "\xC3\xA9" + std::string(50, 'b'), "z");
  EXPECT_STREQ(u.what(), ("f.txt:1: field 'x': found '" + std::string(99, 'a') + "… (151 bytes)', expected z").c_str());
}

}  // namespace
}  // namespace mmba
