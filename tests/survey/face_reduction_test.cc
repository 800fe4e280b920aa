// Face reduction: rounds, face pairs, collimation and index error against hand values, the
// 0/400 gon wrap, single faces, the tolerance check naming the blunder; on data/gsi/network.GSI
// the figures of the real field book.
#include "mmba/survey/face_reduction.h"

#include <cmath>

#include <gtest/gtest.h>

#include "mmba/io_survey/gsi.h"

namespace mmba::survey {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kGon = kPi / 200.0;

RawObservation Pointing(const std::string& target, int line, double hz_gon, double v_gon,
                        double slope_m = 0.0) {
  RawObservation o;
  o.target = target;
  o.line = line;
  o.has_hz = o.has_v = true;
  o.hz_rad = std::fmod(hz_gon + 400.0, 400.0) * kGon;
  o.v_rad = v_gon * kGon;
  o.has_slope = slope_m > 0;
  o.slope_m = slope_m;
  o.has_reflector_height = true;
  o.reflector_height_m = 1.5;
  return o;
}

/// Face I and II readings of a target with direction t, zenith z, collimation c, index i [gon].
RawObservation FaceOne(const std::string& id, int line, double t, double z, double c, double i,
                       double d = 0) {
  return Pointing(id, line, t + c, z + i, d);
}
RawObservation FaceTwo(const std::string& id, int line, double t, double z, double c, double i,
                       double d = 0) {
  return Pointing(id, line, t + 200 - c, 400 - z + i, d);
}

FieldBook Book() {
  const double c = 0.001, i = -0.0005;  // 1 mgon, -0.5 mgon
  FieldBook book;
  book.source = "job.gsi";
  Setup s;
  s.station = "S";
  s.instrument_height_m = 1.6;
  s.line = 1;
  s.observations = {FaceOne("A", 2, 10, 95, c, i, 50.000),  FaceOne("B", 3, 120, 101, c, i),
                    FaceOne("C", 4, 399.9995, 100, c, i),   FaceTwo("C", 5, 399.9995, 100, c, i),
                    FaceTwo("B", 6, 120, 101, c, i),        FaceTwo("A", 7, 10, 95, c, i, 50.002),
                    FaceTwo("D", 8, 250, 98, c, i),
                    // round 2: B's face II pointed 10 mgon off
                    FaceOne("A", 9, 10, 95, c, i),          FaceOne("B", 10, 120, 101, c, i),
                    FaceTwo("B", 11, 120.010, 101, c, i),   FaceTwo("A", 12, 10, 95, c, i)};
  book.setups.push_back(s);
  Setup t;
  t.station = "T";
  t.line = 13;
  t.observations = {FaceOne("X", 14, 5, 100, 0, 0), FaceOne("Y", 15, 50, 100, 0, 0),
                    FaceOne("X", 16, 5.001, 100, 0, 0), FaceOne("Y", 17, 50.001, 100, 0, 0)};
  t.observations[0].has_horizontal = true;  // a horizontal distance only (WI 32)
  t.observations[0].horizontal_m = 30.0;
  book.setups.push_back(t);
  return book;
}

TEST(FaceReduction, PairsRoundsAndFaceDifferencesAsByHand) {
  const FaceReduction r = ReduceFaces(Book(), FaceReductionOptions());
  ASSERT_EQ(r.sets.size(), 4u);  // S: 2 rounds, T: 2 rounds (X, Y repeated in face I)
  EXPECT_EQ(r.sets[0].round, 1);
  EXPECT_EQ(r.sets[1].round, 2);
  EXPECT_DOUBLE_EQ(r.sets[0].instrument_height_m, 1.6);
  ASSERT_EQ(r.sets[0].observations.size(), 4u);
  const ReducedObservation& a = r.sets[0].observations[0];
  EXPECT_EQ(a.target, "A");
  EXPECT_EQ(a.faces, 2);
  EXPECT_NEAR(a.direction_rad, 10 * kGon, 1e-12);
  EXPECT_NEAR(a.zenith_rad, 95 * kGon, 1e-12);
  EXPECT_NEAR(a.slope_m, 50.001, 1e-12);
  EXPECT_DOUBLE_EQ(a.reflector_height_m, 1.5);
  const ReducedObservation& c = r.sets[0].observations[2];
  EXPECT_NEAR(c.direction_rad, 399.9995 * kGon, 1e-12);  // across the 0/400 gon seam
  const ReducedObservation& d = r.sets[0].observations[3];
  EXPECT_EQ(d.faces, 1);  // face II only: turned by 200 gon, zenith 400 - V
  EXPECT_NEAR(d.direction_rad, (250 - 0.001) * kGon, 1e-12);
  EXPECT_NEAR(d.zenith_rad, (98 + 0.0005) * kGon, 1e-12);  // 400 - V_II = z - i

  ASSERT_GE(r.pairs.size(), 4u);
  EXPECT_NEAR(r.pairs[0].collimation_mgon, 1.0, 1e-9);
  EXPECT_NEAR(r.pairs[0].index_mgon, -0.5, 1e-9);
  EXPECT_NEAR(r.pairs[0].distance_difference_mm, -2.0, 1e-9);
  EXPECT_NEAR(r.pairs[2].collimation_mgon, 1.0, 1e-9);  // C across the seam
  EXPECT_TRUE(r.sets[2].observations[0].has_horizontal);
  EXPECT_DOUBLE_EQ(r.sets[2].observations[0].horizontal_m, 30.0);
  EXPECT_FALSE(r.sets[0].observations[0].has_horizontal);  // A has a slope distance
  ASSERT_EQ(r.setups.size(), 2u);
  EXPECT_EQ(r.setups[0].rounds, 2);
  EXPECT_EQ(r.setups[0].pairs, 5);
  EXPECT_EQ(r.setups[0].single_face, 1);
  EXPECT_NEAR(r.setups[0].collimation_median_mgon, 1.0, 1e-9);
  EXPECT_NEAR(r.setups[0].index_median_mgon, -0.5, 1e-9);
}

TEST(FaceReduction, PairBeyondToleranceIsNamed) {
  const FaceReduction r = ReduceFaces(Book(), FaceReductionOptions());
  ASSERT_EQ(r.blunders.size(), 1u);
  EXPECT_NE(r.blunders[0].find("job.gsi:10 (face II at line 11) S -> B round 2"), std::string::npos)
      << r.blunders[0];
  EXPECT_NE(r.blunders[0].find("collimation -4.00 mgon"), std::string::npos) << r.blunders[0];
  EXPECT_EQ(r.setups[0].blunders, 1);
  // Its direction is the mean all the same: 10 mgon / 2 off.
  EXPECT_NEAR(r.sets[1].observations[1].direction_rad, (120 + 0.005) * kGon, 1e-12);
  FaceReductionOptions loose;
  loose.collimation_tolerance_mgon = 6.0;
  EXPECT_TRUE(ReduceFaces(Book(), loose).blunders.empty());
}

TEST(FaceReduction, SettingsTableChecksRanges) {
  FaceReductionOptions o;
  std::string problem;
  EXPECT_TRUE(o.Check(&problem));
  EXPECT_FALSE(FaceReductionSettingsTable().Apply({"direction_sigma_cc=0"}, &o, &problem));
  EXPECT_NE(problem.find("direction_sigma_cc"), std::string::npos);
  EXPECT_TRUE(FaceReductionSettingsTable().Apply({"height_sigma_mm=2"}, &o, &problem));
  EXPECT_DOUBLE_EQ(o.height_sigma_mm, 2.0);
}

TEST(FaceReduction, RealNetworkFieldBook) {
  const FieldBook book = io::ReadGsi(std::string(MMBA_SOURCE_DIR) + "/data/gsi/network.GSI");
  const FaceReduction r = ReduceFaces(book, FaceReductionOptions());
  EXPECT_EQ(r.sets.size(), 154u);   // 22 set-ups x 7 rounds
  EXPECT_EQ(r.pairs.size(), 700u);  // every target in both faces
  for (const SetupFaceSummary& s : r.setups) {
    EXPECT_EQ(s.rounds, 7) << s.station;
    EXPECT_EQ(s.single_face, 0) << s.station;
    EXPECT_LT(std::abs(s.collimation_mean_mgon), 1.5) << s.station;
    EXPECT_LT(std::abs(s.index_mean_mgon), 1.0) << s.station;
  }
  EXPECT_NEAR(r.collimation_std_mgon, 0.60, 0.01);
  EXPECT_NEAR(r.index_std_mgon, 0.52, 0.01);
  EXPECT_TRUE(r.blunders.empty());
  // A face-II circle reading 20 mgon off is named with its line.
  FieldBook bad = book;
  bad.setups[3].observations[5].hz_rad += 0.020 * kGon;
  const FaceReduction rb = ReduceFaces(bad, FaceReductionOptions());
  ASSERT_EQ(rb.blunders.size(), 1u);
  EXPECT_NE(rb.blunders[0].find("face II at line " + std::to_string(bad.setups[3].observations[5].line)),
            std::string::npos)
      << rb.blunders[0];
}

}  // namespace
}  // namespace mmba::survey
