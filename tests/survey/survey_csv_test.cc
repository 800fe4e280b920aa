// The survey CSV reader refuses input that would otherwise be "adjusted" with exit 0: no
// records, no observations, a point id given twice.
#include "mmba/io_survey/survey_csv.h"

#include <string>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

/// The message of the InputError ParseSurveyCsv throws on `text`, or "no error".
std::string ParseError(const std::string& text) {
  try {
    ParseSurveyCsv(text, "net.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

const char* kPoints =
    "point,A,0,0,,xy,\n"       // line 1
    "point,B,100,0,,,xy\n";    // line 2
const char* kDistance = "distance,A,B,100.001,2\n";

TEST(SurveyCsv, AFileWithoutRecordsIsAnInputError) {
  for (const std::string text : {"", "\n\n", "# only a comment\n  # and another\n", "   \n\t\n"}) {
    const std::string e = ParseError(text);
    EXPECT_NE(e.find("net.csv:"), std::string::npos) << e;
    EXPECT_NE(e.find("the file is empty or only comments"), std::string::npos) << e;
  }
}

TEST(SurveyCsv, AFileWithoutObservationsIsAnInputError) {
  for (const std::string& text : {std::string(kPoints), std::string(kPoints) + "set,A\n",
                                 "param,sigma-apr,3\n" + std::string(kPoints)}) {
    const std::string e = ParseError(text);
    EXPECT_NE(e.find("no observation"), std::string::npos) << e;
  }
  EXPECT_EQ(ParseError(std::string(kPoints) + kDistance), "no error");
}

TEST(SurveyCsv, ADuplicatePointIdNamesBothLines) {
  std::string e = ParseError(std::string(kPoints) + "point,A,5,5,,,xy\n" + kDistance);
  EXPECT_NE(e.find("net.csv:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("'A'"), std::string::npos) << e;
  EXPECT_NE(e.find("defined at line 1"), std::string::npos) << e;
  // A geodetic point with the id of a plane point is the same mistake.
  e = ParseError("param,origin,45,7,300\n" + std::string(kPoints) +
                 "# comment line\ngpoint,B,45.001,7,300,,xyz\n" + kDistance);
  EXPECT_NE(e.find("net.csv:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("'B'"), std::string::npos) << e;
  EXPECT_NE(e.find("defined at line 3"), std::string::npos) << e;
}

}  // namespace
}  // namespace mmba::io
