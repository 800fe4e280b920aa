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

/// The table CsvTable::Read makes of `text` (a temporary file), with columns a, b.
CsvTable TableOf(const std::string& text) {
  const fs::path path = fs::temp_directory_path() / ("mmba_csv_table_rows_" + std::to_string(::getpid()) + ".csv");
  std::ofstream(path, std::ios::binary) << text;
  CsvTable table = CsvTable::Read(path.string(), {"a", "b"});
  fs::remove(path);
  return table;
}

// RFC 4180 as spreadsheets write it: a byte order mark, CRLF, quoted fields with commas,
// doubled quotes and a line break; each row keeps the line it starts on.
TEST(CsvTable, QuotedFieldsAsSpreadsheetsWriteThem) {
  const CsvTable table = TableOf(
      "\xEF\xBB\xBF" "a,b\r\n"
      "\"P1, north\",\"say \"\"hi\"\"\"\r\n"
      "\"two\r\nlines\",  3.5 \r\n"
      "  \"x\"  ,\"\"\r\n"
      "plain,4\r\n");
  ASSERT_EQ(table.rows().size(), 4u);
  EXPECT_EQ(table.String(table.rows()[0], "a"), "P1, north");
  EXPECT_EQ(table.String(table.rows()[0], "b"), "say \"hi\"");
  EXPECT_EQ(table.rows()[0].line, 2);
  EXPECT_EQ(table.String(table.rows()[1], "a"), "two\nlines");
  EXPECT_EQ(table.Double(table.rows()[1], "b"), 3.5);
  EXPECT_EQ(table.rows()[1].line, 3);
  EXPECT_EQ(table.String(table.rows()[2], "a"), "x");
  EXPECT_EQ(table.String(table.rows()[2], "b"), "");
  EXPECT_EQ(table.rows()[2].line, 5);
  EXPECT_EQ(table.rows()[3].line, 6);
  EXPECT_EQ(table.String(table.rows()[3], "a"), "plain");
}

TEST(CsvTable, AQuoteLeftOpenNamesTheLineItOpensOn) {
  EXPECT_THAT(ErrorOf("point_id,x_px\np1,1.5\n\"p2,2.5\np3,3.5\n"),
              HasSubstr(".csv:3: field 'quoted field': found 'no closing quote"));
  EXPECT_THAT(ErrorOf("point_id,x_px\n\"p1\" x,1.5\n"),
              HasSubstr(".csv:2: field 'quoted field': found ''x,1.5' after the closing quote'"));
  // A row with a quoted comma is one cell, so a wrong count names the row.
  EXPECT_THAT(ErrorOf("point_id,x_px\n\"p1,extra\",1.5,2\n"),
              HasSubstr(".csv:2: field 'row': found '3 cells'"));
}

}  // namespace
}  // namespace mmba::io
