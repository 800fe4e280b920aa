#include "mmba/io/bal.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kDubrovnik = std::string(MMBA_SOURCE_DIR) + "/data/bal/dubrovnik-3-7-pre.txt";

std::string ErrorOf(const std::string& text) {
  // One file per process: ctest runs this binary's tests in parallel processes.
  const fs::path path = fs::temp_directory_path() / ("mmba_bal_test_" + std::to_string(::getpid()) + ".txt");
  std::ofstream(path) << text;
  try {
    ReadBal(path.string());
  } catch (const InputError& e) {
    fs::remove(path);
    return e.what();
  }
  fs::remove(path);
  return "no error";
}

// A 1-camera, 1-point, 1-observation problem with one value changed by the caller.
std::string Small(const std::string& header = "1 1 1", const std::string& obs = "0 0 1.5 -2.5",
                  const std::string& point = "0.1 0.2 -5") {
  return header + "\n" + obs + "\n0\n0\n0\n0\n0\n0\n500\n0\n0\n" + point + "\n";
}

TEST(Bal, ReadsDubrovnik) {
  const BalProblem problem = ReadBal(kDubrovnik);
  EXPECT_EQ(problem.num_cameras, 3);
  EXPECT_EQ(problem.num_points, 7);
  ASSERT_EQ(problem.observations.size(), 19u);
  EXPECT_EQ(problem.observations[0].camera_index, 0);
  EXPECT_DOUBLE_EQ(problem.observations[0].x, -385.99);
  EXPECT_DOUBLE_EQ(problem.observations[0].y, 387.12);
  EXPECT_EQ(problem.cameras.size(), 27u);
  EXPECT_EQ(problem.points.size(), 21u);
}

TEST(Bal, ReadsTheSmallProblem) {
  EXPECT_EQ(ErrorOf(Small()), "no error");
}

TEST(Bal, BadInputNamesLineFieldAndValue) {
  EXPECT_THAT(ErrorOf(Small("1 1 x")),
              HasSubstr(":1: field 'num_observations': found 'x', expected a positive integer"));
  EXPECT_THAT(ErrorOf(Small("-1 1 1")),
              HasSubstr(":1: field 'num_cameras': found '-1', expected a positive integer"));
  EXPECT_THAT(ErrorOf(Small("1 1 1", "3 0 1.5 -2.5")),
              HasSubstr(":2: field 'observation[0].camera_index': found '3', expected a camera "
                        "index in [0, 1)"));
  EXPECT_THAT(ErrorOf(Small("1 1 1", "0 0 nan -2.5")),
              HasSubstr(":2: field 'observation[0].x': found 'nan', expected a finite number"));
  EXPECT_THAT(ErrorOf(Small("1 1 1", "0 0 1.5 -2.5", "0.1 inf -5")),
              HasSubstr(":12: field 'point[0][1]': found 'inf', expected a finite number"));
  EXPECT_THAT(ErrorOf(Small("1 1 1", "0 0 1.5 -2.5", "0.1 0.2")),
              HasSubstr("field 'point[0][2]': found 'end of file'"));
  EXPECT_THAT(ErrorOf(Small("1 1 1", "0 0 1.5 -2.5", "0.1 0.2 -5 7")),
              HasSubstr(":12: field 'end of file': found '7'"));
  EXPECT_THAT(ErrorOf(Small("1 1 5000000")), HasSubstr("counts that fit the file"));
  EXPECT_THAT(ErrorOf(""), HasSubstr("field 'num_cameras': found 'end of file'"));
}

// A file that is not a BAL problem at all (any file can be named) is not quoted back.
TEST(Bal, AFileOfAnotherKindIsNotQuoted) {
  const std::string message = ErrorOf("root:x:0:0:root:/root:/bin/bash\n");
  EXPECT_THAT(message, HasSubstr(":1: field 'num_cameras': found 'a word that is not a number', "
                                 "expected a positive integer (not a BAL file?)"));
  EXPECT_THAT(message, Not(HasSubstr("root")));
}

TEST(Bal, MissingFile) {
  try {
    ReadBal("/nonexistent/problem.txt");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/problem.txt: file not found");
  }
}

}  // namespace
}  // namespace mmba::io
