#include "mmba/io/gama_local.h"

#include <cmath>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/survey/adjust.h"

namespace mmba::io {
namespace {

std::string Fixture(const std::string& name) {
  return std::string(MMBA_SOURCE_DIR) + "/tests/data/gama/" + name;
}

std::string ErrorOf(const std::string& name, bool adjust = false) {
  try {
    survey::SurveyNetwork net = ReadGamaLocal(Fixture(name));
    if (adjust) survey::AdjustNetwork(&net, survey::SurveyAdjustOptions());
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(GamaReader, BrokenInputsNameLineFieldAndReason) {
  std::string e = ErrorOf("unknown-point.gkf");
  EXPECT_NE(e.find("unknown-point.gkf:10"), std::string::npos) << e;
  EXPECT_NE(e.find("'Q'"), std::string::npos) << e;
  e = ErrorOf("self-observation.gkf");
  EXPECT_NE(e.find(":9"), std::string::npos) << e;
  EXPECT_NE(e.find("different from the station A"), std::string::npos) << e;
  e = ErrorOf("zero-sigma.gkf");
  EXPECT_NE(e.find("stdev"), std::string::npos) << e;
  EXPECT_NE(e.find("> 0"), std::string::npos) << e;
  e = ErrorOf("missing-sigma.gkf");
  EXPECT_NE(e.find("dh@stdev"), std::string::npos) << e;
  e = ErrorOf("bad-number.gkf");
  EXPECT_NE(e.find("12.3x"), std::string::npos) << e;
  EXPECT_NE(e.find("a number"), std::string::npos) << e;
  e = ErrorOf("unknown-element.gkf");
  EXPECT_NE(e.find("<distanse>"), std::string::npos) << e;
  EXPECT_NE(e.find(":9"), std::string::npos) << e;
  e = ErrorOf("datum-defect.gkf", /*adjust=*/true);
  EXPECT_NE(e.find("datum defect"), std::string::npos) << e;
  EXPECT_NE(e.find("line"), std::string::npos) << e;
}

TEST(GamaReader, UnitsAxesAndDms) {
  double degrees = 0.0;
  ASSERT_TRUE(ParseDms("359-59-50.00", &degrees));
  EXPECT_NEAR(degrees, 360.0 - 10.0 / 3600.0, 1e-12);
  EXPECT_FALSE(ParseDms("12.5", &degrees));
  const std::string text = R"(<?xml version="1.0"?>
<gama-local xmlns="http://www.gnu.org/software/gama/gama-local">
<network axes-xy="sw" angles="right-handed">
<parameters sigma-apr="3" conf-pr="0.9" sigma-act="apriori"/>
<points-observations distance-stdev="2 3 1" direction-stdev="3.24">
<point id="1" x="10" y="20" z="5" fix="xyz"/>
<point id="2" x="40" y="60" adj="XY"/>
<obs from="1">
  <direction to="2" val="100-0-0"/>
  <distance to="2" val="2000"/>
  <direction to="2" val="50" stdev="10"/>
</obs>
</points-observations>
</network>
</gama-local>)";
  const survey::SurveyNetwork net = ParseGamaLocal(text, "inline.xml");
  const survey::SurveyPoint& p = *net.Find("1");
  EXPECT_DOUBLE_EQ(p.coords.x(), -20.0);  // east = −y
  EXPECT_DOUBLE_EQ(p.coords.y(), -10.0);  // north = −x
  EXPECT_EQ(net.Find("2")->xy, survey::CoordStatus::kConstrained);
  EXPECT_TRUE(net.sigma_act_apriori);
  EXPECT_DOUBLE_EQ(net.sigma0_apriori, 3.0);
  const auto& obs = net.clusters.at(0).observations;
  EXPECT_NEAR(obs[0].value, -100.0 * M_PI / 180.0, 1e-15);  // right-handed -> clockwise
  EXPECT_NEAR(obs[0].sigma, 3.24 * M_PI / 648000.0, 1e-18);  // seconds for d-m-s
  EXPECT_NEAR(obs[1].sigma, (2.0 + 3.0 * 2.0) * 1e-3, 1e-15);  // a + b·D[km]^c mm
  EXPECT_NEAR(obs[2].value, -50.0 * M_PI / 200.0, 1e-15);
  EXPECT_NEAR(obs[2].sigma, 10.0 * M_PI / 2.0e6, 1e-18);  // cc
}

}  // namespace
}  // namespace mmba::io
