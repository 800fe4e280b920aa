// EXIF GPS positions read with exiv2: degrees/minutes/seconds with their hemispheres, the
// altitude above and below sea level, an image without GPS, and broken tags and files.
// The fixtures are 16x12 JPEGs whose tags were set with the exiv2 command (tests/data/exif).
#include "mmba/io/exif_gps.h"

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
using ::testing::HasSubstr;

const std::string kData = std::string(MMBA_SOURCE_DIR) + "/tests/data/exif/";

TEST(ExifGps, DegreesMinutesSecondsWithHemispheres) {
  const auto ne = ReadExifGps(kData + "north_east.jpg");
  ASSERT_TRUE(ne.has_value());
  EXPECT_NEAR(ne->latitude_deg, 48 + 8 / 60.0 + 23.32 / 3600.0, 1e-12);
  EXPECT_NEAR(ne->longitude_deg, 11 + 34 / 60.0 + 50.12 / 3600.0, 1e-12);
  ASSERT_TRUE(ne->altitude_m.has_value());
  EXPECT_DOUBLE_EQ(*ne->altitude_m, 520.35);
  const auto sw = ReadExifGps(kData + "south_west.jpg");  // minutes with a fraction, no altitude
  ASSERT_TRUE(sw.has_value());
  EXPECT_NEAR(sw->latitude_deg, -(33 + 51.40 / 60.0), 1e-12);
  EXPECT_NEAR(sw->longitude_deg, -(70 + 39.30 / 60.0), 1e-12);
  EXPECT_FALSE(sw->altitude_m.has_value());
  const auto dead_sea = ReadExifGps(kData + "below_sea.jpg");  // GPSAltitudeRef 1
  ASSERT_TRUE(dead_sea.has_value());
  EXPECT_DOUBLE_EQ(*dead_sea->altitude_m, -430.5);
}

TEST(ExifGps, NoGpsIsNoPosition) { EXPECT_FALSE(ReadExifGps(kData + "no_gps.jpg").has_value()); }

TEST(ExifGps, BrokenTagsAndFilesNameTheFile) {
  const auto error = [](const std::string& name) -> std::string {
    try {
      ReadExifGps(kData + name);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_THAT(error("zero_denominator.jpg"), HasSubstr("zero_denominator.jpg"));
  EXPECT_THAT(error("zero_denominator.jpg"), HasSubstr("GPSLatitude: found 48/0"));
  EXPECT_THAT(error("broken.jpg"), HasSubstr("broken.jpg: cannot read the image's metadata"));
  EXPECT_THAT(error("absent.jpg"), HasSubstr("absent.jpg"));
}

}  // namespace
}  // namespace mmba::io
