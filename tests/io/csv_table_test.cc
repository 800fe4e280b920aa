// Comma-separated tables: cells UTF-8, a header that lacks a column not quoted back.
#include "mmba/io/csv_table.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

std::string ErrorOf(const std::string& text) {
  // One file per process: ctest runs this binary's tests in parallel processes.
  const fs::path path = fs::temp_directory_path() / ("mmba_csv_table_" + std::to_string(::getpid()) + ".csv");
  std::ofstream(path, std::ios::binary) << text;
  std::string message = "ok";
  try {
    CsvTable::Read(path.string(), {"point_id", "x_px"});
  } catch (const InputError& e) {
    message = e.what();
  }
  fs::remove(path);
  return message;
}

TEST(CsvTable, CellsMustBeUtf8) {
  EXPECT_EQ(ErrorOf("point_id,x_px\ncaf\xC3\xA9,1.5\n"), "ok");
  EXPECT_THAT(ErrorOf("# points\npoint_id,x_px\np1,1.5\nab\xFF,2.5\n"),
              HasSubstr(".csv:4: field 'point_id': found 'invalid UTF-8 at byte 2 of the cell', expected UTF-8 text"));
}

// Any file can be named as a table (e.g. /etc/passwd): its first line is not quoted back.
TEST(CsvTable, AHeaderWithoutAColumnIsNotQuoted) {
  const std::string message = ErrorOf("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/:/bin/sh\n");
  EXPECT_THAT(message, HasSubstr(".csv:1: field 'header': found '1 cell, none named point_id', "
                                 "expected a header line naming the columns point_id, x_px"));
  EXPECT_THAT(message, Not(HasSubstr("bash")));
}

}  // namespace
}  // namespace mmba::io
