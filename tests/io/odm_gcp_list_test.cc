// OpenDroneMap gcp_list.txt: the projection line (EPSG, PROJ string, "WGS84 UTM 32N"), points
// by name or by coordinates, pixels moved by +0.5 to mmba's convention, and every broken file
// named by file:line and field.
#include "mmba/io/odm_gcp_list.h"

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
using ::testing::HasSubstr;

const std::string kData = std::string(MMBA_SOURCE_DIR) + "/tests/data/odm/";

std::string ErrorOf(const std::string& name) {
  try {
    ReadOdmGcpList(kData + name);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(OdmGcpList, ReadsNamedAndUnnamedPoints) {
  const GcpList list = ReadOdmGcpList(kData + "gcp_list.txt");
  EXPECT_EQ(list.crs, "EPSG:32632");
  EXPECT_EQ(list.crs_line, 2);
  ASSERT_EQ(list.observations.size(), 6u);
  const GcpObservation& first = list.observations[0];
  EXPECT_EQ(first.point_id, "GCP1");
  EXPECT_EQ(first.image, "DJI_0001.JPG");
  EXPECT_EQ(first.line, 3);
  EXPECT_EQ(first.geo, Eigen::Vector3d(481367.125, 5782936.250, 101.5));
  EXPECT_EQ(first.xy_px, Eigen::Vector2d(1539.5, 1337.5));  // OpenSfM pixel centres -> mmba's
  EXPECT_EQ(list.observations[1].xy_px, Eigen::Vector2d(2949, 2666.5));
  EXPECT_EQ(list.observations[2].point_id, "GCP2");  // tab-separated, an extra field after the name
  // Unnamed points are grouped by their coordinates, as ODM does.
  EXPECT_EQ(list.observations[3].point_id, "gcp1");
  EXPECT_EQ(list.observations[4].point_id, "gcp1");
  EXPECT_EQ(list.observations[5].point_id, "gcp2");
}

TEST(OdmGcpList, WgsUtmHeaderIsAnEpsgCode) {
  EXPECT_EQ(ReadOdmGcpList(kData + "gcp_utm_header.txt").crs, "EPSG:32632");
  EXPECT_EQ(ReadOdmGcpList(kData + "gcp_utm_south.txt").crs, "EPSG:32733");
}

TEST(OdmGcpList, BrokenFilesAreNamedByLineAndField) {
  EXPECT_THAT(ErrorOf("gcp_bad_zone.txt"), HasSubstr("gcp_bad_zone.txt:1: field 'projection': found 'WGS84 UTM 61N'"));
  EXPECT_THAT(ErrorOf("gcp_short_line.txt"), HasSubstr("gcp_short_line.txt:2: field 'line': found '5 fields'"));
  EXPECT_THAT(ErrorOf("gcp_bad_number.txt"), HasSubstr("gcp_bad_number.txt:2: field 'geo_z': found '1e400'"));
  EXPECT_THAT(ErrorOf("gcp_moved_point.txt"), HasSubstr("gcp_moved_point.txt:3: field 'geo_x geo_y geo_z'"));
  EXPECT_THAT(ErrorOf("gcp_moved_point.txt"), HasSubstr("(line 2:"));
  EXPECT_THAT(ErrorOf("gcp_twice_in_image.txt"), HasSubstr("gcp_twice_in_image.txt:3: field 'image_name': found 'P1 in a.jpg (also on line 2)'"));
  EXPECT_THAT(ErrorOf("gcp_no_points.txt"), HasSubstr("no ground control point line"));
  EXPECT_THAT(ErrorOf("missing.txt"), HasSubstr("missing.txt"));
}

}  // namespace
}  // namespace mmba::io
