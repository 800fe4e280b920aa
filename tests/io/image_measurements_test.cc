// Image measurement files and the image list: columns in any order, comma or blank separated,
// quoted fields, σ per file or per line; every error names file, line, column and value.
#include "mmba/io/image_measurements.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/io/column_text.h"

namespace mmba::io {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

const std::string kData = std::string(MMBA_SOURCE_DIR) + "/tests/data/photo_measurements/";

std::string TempFile(const std::string& text) {
  static int n = 0;
  const fs::path path = fs::temp_directory_path() /
                        ("mmba_measurements_" + std::to_string(::getpid()) + "_" + std::to_string(n++) + ".txt");
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ColumnText, SplitsCommasBlanksAndQuotes) {
  EXPECT_THAT(SplitColumnLine("1, 2,3.5 ,x", "f", 1), ::testing::ElementsAre("1", "2", "3.5", "x"));
  EXPECT_THAT(SplitColumnLine("1 \t 2   3.5", "f", 1), ::testing::ElementsAre("1", "2", "3.5"));
  EXPECT_THAT(SplitColumnLine("1,,2", "f", 1), ::testing::ElementsAre("1", "", "2"));
  EXPECT_THAT(SplitColumnLine("\"a, b\",\"say \"\"hi\"\"\",3", "f", 1),
              ::testing::ElementsAre("a, b", "say \"hi\"", "3"));
  EXPECT_THAT(SplitColumnLine("\"a b\" 2", "f", 1), ::testing::ElementsAre("a b", "2"));
  EXPECT_THAT(ErrorOf([] { SplitColumnLine("1,\"open", "f.txt", 7); }),
              HasSubstr("f.txt:7: field 'quoted field': found '\"open', expected a closing \""));
}

TEST(ImageMeasurements, ReadsColumnsInAnyOrder) {
  const auto m = ReadImageMeasurements({kData + "markpts.txt", {"image", "id", "x", "y", "sxy"}, 0.5});
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].image_id, "1");
  EXPECT_EQ(m[0].point_id, "2");
  EXPECT_DOUBLE_EQ(m[0].xy_px.x(), 1429.1871);  // corner origin = mmba's: used as read
  EXPECT_DOUBLE_EQ(m[0].xy_px.y(), 1456.4278);
  EXPECT_DOUBLE_EQ(m[0].sigma_px.x(), 0.1);
  EXPECT_EQ(m[2].line, 4);
  const auto p = ReadImageMeasurements({kData + "markpts.txt", {"image", "id", "x", "y", "_"}, 0.5});
  EXPECT_DOUBLE_EQ(p[1].sigma_px.y(), 0.5);  // the file's sigma_px
  EXPECT_EQ(p[1].point_id, "3");
}

TEST(ImageMeasurements, ErrorsNameFileLineColumnAndValue) {
  EXPECT_THAT(ErrorOf([] { ReadImageMeasurements({kData + "markpts.txt", {"image", "id", "x", "y"}, 0.5}); }),
              HasSubstr("markpts.txt:2: field 'line': found '5 fields', expected 4 fields"));
  EXPECT_THAT(ErrorOf([] { ReadImageMeasurements({TempFile("1 2 3.5\n"), {"image", "id", "x", "y"}, 0.5}); }),
              HasSubstr(":1: field 'y': found '3 fields', expected a value for column 4 (y)"));
  EXPECT_THAT(ErrorOf([] { ReadImageMeasurements({TempFile("1 2 3.5 4,5\n"), {"image", "id", "x", "y"}, 0.5}); }),
              HasSubstr(":1: field 'x': found '2 fields'"));  // a comma: comma-separated
  EXPECT_THAT(ErrorOf([] { ReadImageMeasurements({TempFile("#\n1 2 3.5 abc\n"), {"image", "id", "x", "y"}, 0.5}); }),
              HasSubstr(":2: field 'y': found 'abc', expected a finite number"));
  EXPECT_THAT(ErrorOf([] { ReadImageMeasurements({TempFile("1 2 3 4 0\n"), {"image", "id", "x", "y", "sx"}, 0.5}); }),
              HasSubstr(":1: field 'sx': found '0', expected a σ > 0 in pixels"));
  EXPECT_THAT(ErrorOf([] { ReadImageMeasurements({TempFile("1 2 3 4\n1 2 5 6\n"), {"image", "id", "x", "y"}, 0.5}); }),
              HasSubstr(":2: field 'id': found '2 (image 1, also on line 1)', expected each point measured once per image"));
}

TEST(ImageMeasurements, UnknownColumnNamesAreErrors) {
  EXPECT_THAT(ErrorOf([] { CheckMeasurementColumns({"id", "img", "x", "y"}, "p.yaml", 12, "columns"); }),
              HasSubstr("p.yaml:12: field 'columns': found 'img (unknown column)', expected one of id, image, x, y"));
  EXPECT_THAT(ErrorOf([] { CheckMeasurementColumns({"id", "x", "y"}, "p.yaml", 12, "columns"); }),
              HasSubstr("found 'no column image', expected a column named image"));
  EXPECT_THAT(ErrorOf([] { CheckMeasurementColumns({"id", "image", "x", "x", "y"}, "p.yaml", 3, "c"); }),
              HasSubstr("found 'x twice'"));
  EXPECT_EQ(ErrorOf([] { CheckMeasurementColumns({"label", "image", "_", "x", "y", "id", "_"}, "p", 1, "c"); }),
            "no error");
}

TEST(ImageMeasurements, OutsideTheImageIsAnError) {
  const auto m = ReadImageMeasurements({kData + "outside.txt", {"image", "id", "x", "y"}, 0.5});
  EXPECT_EQ(ErrorOf([&] { CheckInsideImage(m[0], 2272, 1704); }), "no error");
  EXPECT_THAT(ErrorOf([&] { CheckInsideImage(m[1], 2272, 1704); }),
              HasSubstr("outside.txt:3: field 'x': found '2300.000000 (point 3, image 1)', expected a pixel coordinate in "
                        "[0, 2272]"));
  ImageMeasurement corner = m[0];
  corner.xy_px = {0.0, 1704.0};  // the image's corners are inside
  EXPECT_EQ(ErrorOf([&] { CheckInsideImage(corner, 2272, 1704); }), "no error");
  corner.xy_px.y() = -0.01;
  EXPECT_THAT(ErrorOf([&] { CheckInsideImage(corner, 2272, 1704); }), HasSubstr("field 'y'"));
}

TEST(ImageList, ReadsIdsAndNames) {
  const auto list = ReadImageList(TempFile("# id, path\n 1, a/P1.JPG\n 2, \"b c/P2.JPG\"\n"));
  EXPECT_EQ(list.at("1"), "a/P1.JPG");
  EXPECT_EQ(list.at("2"), "b c/P2.JPG");
  EXPECT_THAT(ErrorOf([] { ReadImageList(TempFile("1, a\n1, b\n")); }),
              HasSubstr(":2: field 'image id': found '1 (also on line 1)', expected each image listed once"));
  EXPECT_THAT(ErrorOf([] { ReadImageList(TempFile("1 a b\n")); }), HasSubstr("found '3 fields', expected 2 fields"));
}

}  // namespace
}  // namespace mmba::io
