// Leica GSI reader: unit conversions against hand values, records, broken fixtures, and the
// real field files of data/gsi.
#include "mmba/io_survey/gsi.h"

#include <cmath>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/io_survey/known_points.h"

namespace mmba::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
std::string Source(const std::string& path) { return std::string(MMBA_SOURCE_DIR) + "/" + path; }

double Angle(const std::string& digits, char unit) {
  double rad = 0;
  std::string problem;
  EXPECT_TRUE(GsiAngleRad(digits, unit, &rad, &problem)) << problem;
  return rad;
}

double Length(const std::string& digits, char unit) {
  double m = 0;
  std::string problem;
  EXPECT_TRUE(GsiLengthM(digits, unit, &m, &problem)) << problem;
  return m;
}

TEST(Gsi, AngleUnitsAsTheManualsTable) {
  // GSI Online "Units": 2 = 400 gon (5 decimals), 3 = 360° decimal (5), 4 = DDD.MMSSs, 5 = mil (4).
  EXPECT_NEAR(Angle("0000000016901313", '2'), 169.01313 * kPi / 200.0, 1e-15);
  EXPECT_NEAR(Angle("12345670", '3'), 123.4567 * kPi / 180.0, 1e-15);
  EXPECT_NEAR(Angle("12345120", '4'), (123 + 45 / 60.0 + 12.0 / 3600.0) * kPi / 180.0, 1e-15);
  EXPECT_NEAR(Angle("35959595", '4'), (359 + 59 / 60.0 + 59.5 / 3600.0) * kPi / 180.0, 1e-15);
  EXPECT_NEAR(Angle("12345670", '5'), 1234.567 * 2 * kPi / 6400.0, 1e-15);
  double rad = 0;
  std::string problem;
  EXPECT_FALSE(GsiAngleRad("12361120", '4', &rad, &problem));  // 61 minutes
  EXPECT_FALSE(GsiAngleRad("12345670", '0', &rad, &problem));  // a length unit
  EXPECT_NE(problem.find("angle unit"), std::string::npos);
  EXPECT_FALSE(GsiAngleRad("1234A670", '2', &rad, &problem));
}

TEST(Gsi, LengthUnitsAsTheManualsTable) {
  EXPECT_DOUBLE_EQ(Length("00012345", '0'), 12.345);
  EXPECT_DOUBLE_EQ(Length("00012345", '1'), 12.345 * 0.3048);
  EXPECT_DOUBLE_EQ(Length("00012345", '6'), 1.2345);
  EXPECT_DOUBLE_EQ(Length("00012345", '7'), 1.2345 * 0.3048);
  EXPECT_DOUBLE_EQ(Length("00012345", '8'), 0.12345);
  EXPECT_DOUBLE_EQ(Length("0000000000001538", '.'), 1.538);  // WI 43 instrument height [mm]
  EXPECT_DOUBLE_EQ(Length("000004.5", '.'), 4.5);             // information with a decimal point
  double m = 0;
  std::string problem;
  EXPECT_FALSE(GsiLengthM("00012345", '2', &m, &problem));
  EXPECT_NE(problem.find("length unit"), std::string::npos);
}

TEST(Gsi, Gsi8RecordsUnitsSignsAndMissingValues) {
  const survey::FieldBook book = ReadGsi(Source("tests/data/gsi/gsi8_units.gsi"));
  EXPECT_EQ(book.format, "GSI-8");
  ASSERT_EQ(book.setups.size(), 1u);
  const survey::Setup& s = book.setups[0];
  EXPECT_EQ(s.station, "ST01");
  EXPECT_DOUBLE_EQ(s.instrument_height_m, 1.45);
  ASSERT_EQ(s.observations.size(), 4u);
  const auto& p1 = s.observations[0];
  EXPECT_EQ(p1.target, "P1");
  EXPECT_EQ(p1.line, 2);
  EXPECT_NEAR(p1.hz_rad, 123.4567 * kPi / 180, 1e-15);
  EXPECT_NEAR(p1.v_rad, 90.0 * kPi / 180, 1e-15);
  EXPECT_DOUBLE_EQ(p1.slope_m, 12.345);
  EXPECT_DOUBLE_EQ(p1.reflector_height_m, 1.6);
  const auto& p2 = s.observations[1];
  EXPECT_NEAR(p2.v_rad, (359 + 59 / 60.0 + 59.5 / 3600.0) * kPi / 180, 1e-15);
  EXPECT_DOUBLE_EQ(p2.slope_m, 12.345 * 0.3048);
  EXPECT_TRUE(p2.has_reflector_height);  // carried over from P1
  EXPECT_DOUBLE_EQ(p2.reflector_height_m, 1.6);
  const auto& p3 = s.observations[2];
  EXPECT_NEAR(p3.hz_rad, 1234.567 * kPi / 3200, 1e-15);
  EXPECT_DOUBLE_EQ(p3.slope_m, 1.2345);
  EXPECT_DOUBLE_EQ(p3.horizontal_m, 1.2345 * 0.3048);
  EXPECT_DOUBLE_EQ(p3.height_diff_m, -0.12345);  // sign of WI 33
  const auto& p4 = s.observations[3];
  EXPECT_TRUE(p4.has_v);
  EXPECT_FALSE(p4.has_slope);  // "----" = not measured
}

TEST(Gsi, StationRecordByWi84To88AndCoordinateRecords) {
  const survey::FieldBook book = ReadGsi(Source("tests/data/gsi/station_84.gsi"));
  EXPECT_EQ(book.format, "GSI-16");
  ASSERT_EQ(book.setups.size(), 1u);
  EXPECT_EQ(book.setups[0].station, "ST01");
  EXPECT_DOUBLE_EQ(book.setups[0].instrument_height_m, 1.62);
  ASSERT_EQ(book.setups[0].observations.size(), 2u);
  const auto& p1 = book.setups[0].observations[0];
  EXPECT_DOUBLE_EQ(p1.ppm, 12);
  EXPECT_DOUBLE_EQ(p1.prism_constant_mm, -34);
  EXPECT_DOUBLE_EQ(book.setups[0].observations[1].reflector_height_m, 1.3);
  ASSERT_EQ(book.points.size(), 2u);
  EXPECT_EQ(book.points[0].id, "ST01");
  EXPECT_DOUBLE_EQ(book.points[0].en_h.x(), 100.0);
  EXPECT_DOUBLE_EQ(book.points[0].en_h.y(), 200.0);
  EXPECT_DOUBLE_EQ(book.points[0].en_h.z(), 10.0);
  EXPECT_EQ(book.points[1].id, "K1");
  EXPECT_DOUBLE_EQ(book.points[1].en_h.y(), -654.321);
  EXPECT_TRUE(book.points[1].has_xy);
  EXPECT_FALSE(book.points[1].has_z);  // "-----"
}

void ExpectFails(const std::string& fixture, const std::string& where, const std::string& what) {
  const std::string path = Source("tests/data/gsi/" + fixture);
  try {
    ReadGsi(path);
    ADD_FAILURE() << fixture << " was read";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path + ":" + where), std::string::npos) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  }
}

TEST(Gsi, BrokenFilesNameFileLineAndWord) {
  ExpectFails("bad_word_index.gsi", "2:", "a GSI word index 11..89");
  ExpectFails("truncated.gsi", "2:", "truncated");
  ExpectFails("bad_sign.gsi", "2:", "'+' or '-'");
  ExpectFails("bad_unit.gsi", "2:", "angle unit (position 6)");
  ExpectFails("no_station.gsi", "1:", "a station record before the first measurement");
  ExpectFails("bad_dms.gsi", "2:", "minutes and seconds below 60");
  ExpectFails("bad_digits.gsi", "2:", "digits of an angle");
  EXPECT_THROW(ParseGsi("\n! comment only\n", "empty.gsi"), InputError);
  // An easting without its northing, in a station record (84/85) and a coordinate record (81/82).
  for (const auto& [text, word] :
       {std::pair<std::string, std::string>{"*110001+000000000000ST01 84..10+0000000000100000 "
                                            "86..10+0000000000010000\n",
                                            "WI 85"},
        {"*110001+000000000000ST01 88..10+0000000000001620\n*110004+00000000000000K1 82..10-0000000000654321\n",
         "WI 81"}}) {
    try {
      ParseGsi(text, "half.gsi");
      ADD_FAILURE() << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("or neither"), std::string::npos) << e.what();
    }
  }
}

TEST(Gsi, RealNetworkFile) {
  const survey::FieldBook book = ReadGsi(Source("data/gsi/network.GSI"));
  EXPECT_EQ(book.format, "GSI-16");
  EXPECT_EQ(book.setups.size(), 22u);
  EXPECT_EQ(book.RawObservationCount(), 1400u);
  EXPECT_EQ(book.setups[0].station, "BP04");
  EXPECT_DOUBLE_EQ(book.setups[0].instrument_height_m, 1.538);
  const auto& first = book.setups[0].observations[0];
  EXPECT_EQ(first.target, "BP03");
  EXPECT_NEAR(first.hz_rad, 169.01313 * kPi / 200, 1e-15);
  EXPECT_DOUBLE_EQ(first.slope_m, 29.462);
  EXPECT_DOUBLE_EQ(first.reflector_height_m, 1.565);
  EXPECT_DOUBLE_EQ(first.ppm, 8);
  EXPECT_TRUE(book.points.empty());
}

TEST(Gsi, KnownPointsFromGsiAndCsv) {
  const auto gsi = ReadKnownPoints(Source("data/gsi/coords.gsi"));
  EXPECT_EQ(gsi.size(), 40u);  // 48 records, 9001-9006 recorded again: the first counts
  EXPECT_EQ(gsi[0].id, "9001");
  EXPECT_DOUBLE_EQ(gsi[0].en_h.x(), 698460.332);
  EXPECT_DOUBLE_EQ(gsi[0].en_h.y(), 173419.641);
  EXPECT_DOUBLE_EQ(gsi[0].en_h.z(), -0.092);
  EXPECT_TRUE(IsGsiPath("x/job.GSI"));
  EXPECT_FALSE(IsGsiPath("x/job.gsi.xml"));
}

}  // namespace
}  // namespace mmba::io
