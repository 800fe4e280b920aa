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

}  // namespace
}  // namespace mmba
