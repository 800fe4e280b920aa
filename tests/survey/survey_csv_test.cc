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

// gama-local-subset.csv as a spreadsheet saves it (UTF-8 byte order mark, CRLF, text cells
// in quotes, a point id holding a comma and quotes) reads as the same network, line for line.
TEST(SurveyCsv, ASpreadsheetFileWithQuotedFieldsReadsAsThePlainOne) {
  const std::string dir = std::string(MMBA_SOURCE_DIR) + "/tests/data/gama/";
  survey::SurveyNetwork plain = ReadSurveyCsv(dir + "gama-local-subset.csv");
  survey::SurveyNetwork sheet = ReadSurveyCsv(dir + "spreadsheet-subset.csv");
  const std::string renamed = "422, \"Hill\"";
  ASSERT_NE(sheet.Find(renamed), nullptr);
  EXPECT_EQ(sheet.Find(renamed)->line, plain.Find("422")->line);
  ASSERT_EQ(sheet.points.size(), plain.points.size());
  ASSERT_EQ(sheet.clusters.size(), plain.clusters.size());
  for (size_t c = 0; c < plain.clusters.size(); ++c) {
    ASSERT_EQ(sheet.clusters[c].observations.size(), plain.clusters[c].observations.size());
    for (size_t i = 0; i < plain.clusters[c].observations.size(); ++i) {
      const survey::Observation& a = plain.clusters[c].observations[i];
      const survey::Observation& b = sheet.clusters[c].observations[i];
      EXPECT_EQ(b.line, a.line);
      EXPECT_EQ(b.value, a.value);
      EXPECT_EQ(b.sigma, a.sigma);
      EXPECT_EQ(b.to == renamed ? std::string("422") : b.to, a.to);
    }
  }
}

TEST(SurveyCsv, AQuoteLeftOpenOrTextAfterItNamesTheLine) {
  std::string e = ParseError(std::string(kPoints) + "distance,\"A,B,100.001,2\n\n");
  EXPECT_NE(e.find("net.csv:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("no closing quote"), std::string::npos) << e;
  e = ParseError(std::string(kPoints) + "distance,\"A\"x,B,100.001,2\n");
  EXPECT_NE(e.find("net.csv:3:"), std::string::npos) << e;
  EXPECT_NE(e.find("after the closing quote"), std::string::npos) << e;
  // A '#' inside quotes is text, outside it starts a comment.
  EXPECT_EQ(ParseError("point,\"A#1\",0,0,,xy,\npoint,B,100,0,,,xy # comment\n"
                       "distance,\"A#1\",B,100.001,2\n"),
            "no error");
}

}  // namespace
}  // namespace mmba::io
