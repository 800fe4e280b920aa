// The strict number conversions every text reader uses.
#include "mmba/io/text_reader.h"

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace mmba::io {
namespace {

TEST(ParseDouble, WholeTokensOfFiniteNumbersOnly) {
  double v = 0.0;
  for (const auto& [token, value] : std::vector<std::pair<std::string, double>>{
           {"1.5", 1.5}, {"+1.5", 1.5}, {"-2", -2.0}, {"1e-3", 1e-3}, {"-0.06325", -0.06325},
           {".5", 0.5}, {"3.", 3.0}, {"4E2", 400.0}}) {
    ASSERT_TRUE(ParseDouble(token, &v)) << token;
    EXPECT_EQ(v, value) << token;  // correctly rounded, as strtod
  }
  for (const std::string token : {"", "+", "-", "+-1", "--1", "1.5x", "1,5", " 1", "1 ", "nan",
                                  "inf", "-inf", "1e999", "abc", "0x10"}) {
    v = 7.0;
    EXPECT_FALSE(ParseDouble(token, &v)) << token;
    EXPECT_EQ(v, 7.0) << token;  // untouched
  }
}

}  // namespace
}  // namespace mmba::io
