#include "mmba/io_survey/gama_local.h"

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

/// The message of the InputError ParseGamaLocal throws on `text`, or "no error".
std::string ParseError(const std::string& text) {
  try {
    ParseGamaLocal(text, "net.gkf");
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

/// A small valid network whose description (on line 3) is `description`.
std::string WithDescription(const std::string& description) {
  return "<?xml version=\"1.0\"?>\n<gama-local>\n<network><description>" + description +
         "</description>\n"
         "<points-observations distance-stdev=\"2\">\n"
         "<point id=\"A\" x=\"0\" y=\"0\" fix=\"xy\"/>\n"
         "<point id=\"B\" x=\"100\" y=\"0\" adj=\"xy\"/>\n"
         "<obs from=\"A\"><distance to=\"B\" val=\"100.001\"/></obs>\n"
         "</points-observations></network>\n</gama-local>\n";
}

TEST(GamaReader, DeepNestingIsAnInputErrorNotACrash) {
  // 50,000 nested elements overflowed the stack of a recursive descent without a bound.
  const int depth = 50000;
  std::string text = "<gama-local>\n";
  text.reserve(depth * 8);
  for (int i = 0; i < depth; ++i) text += "<a>";
  for (int i = 0; i < depth; ++i) text += "</a>";
  text += "\n</gama-local>\n";
  const std::string e = ParseError(text);
  EXPECT_NE(e.find("net.gkf:2:"), std::string::npos) << e.substr(0, 300);
  EXPECT_NE(e.find("more than 256 nested elements"), std::string::npos) << e.substr(0, 300);
  // The gama-local structure itself (5 levels) is far below the bound.
  EXPECT_EQ(ParseError(WithDescription("deep enough")), "no error");
}

TEST(GamaReader, CharacterReferencesMustNameXmlCharacters) {
  const survey::SurveyNetwork net =
      ParseGamaLocal(WithDescription("&#65;&#x42;&#xe4;&#x20AC;&#x1F600;&#x0000000041;"), "net.gkf");
  EXPECT_EQ(net.description, "AB\xC3\xA4\xE2\x82\xAC\xF0\x9F\x98\x80" "A");
  for (const std::string reference :
       {"&#xFFFFFFFF;", "&#x110000;", "&#xD800;", "&#0;", "&#x0;", "&#1;",
        "&#99999999999999999999999;", "&#x;", "&#;", "&#12a;", "&#x-41;", "&#+65;", "&# 65;"}) {
    const std::string e = ParseError(WithDescription("text " + reference));
    EXPECT_NE(e.find("net.gkf:3:"), std::string::npos) << reference << ": " << e;
    EXPECT_NE(e.find("character reference"), std::string::npos) << reference << ": " << e;
  }
  // In an attribute, on the line of its value.
  std::string text = WithDescription("ok");
  text.replace(text.find("id=\"B\""), 6, "id=\"&#xFFFFFFFF;\"");
  const std::string e = ParseError(text);
  EXPECT_NE(e.find("net.gkf:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("&#xFFFFFFFF;"), std::string::npos) << e;
}

TEST(GamaReader, TextMustBeUtf8AndXmlCharacters) {
  for (const std::string& bad : {std::string("\xFF"), std::string("\xC3\x28"),
                                std::string("\xC0\xAF"), std::string("\xED\xA0\x80"),
                                std::string("\xF4\x90\x80\x80"), std::string("\xE2\x82")}) {
    const std::string e = ParseError(WithDescription("caf" + bad + " bar"));
    EXPECT_NE(e.find("net.gkf:3:"), std::string::npos) << e;
    EXPECT_NE(e.find("invalid UTF-8"), std::string::npos) << e;
  }
  std::string text = WithDescription("ok");
  text.insert(text.find("<point id=\"B\""), "\x01");  // line 6
  const std::string e = ParseError(text);
  EXPECT_NE(e.find("net.gkf:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("U+0001"), std::string::npos) << e;
  EXPECT_EQ(ParseError(WithDescription("caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80\t")), "no error");
}

TEST(GamaReader, ADuplicatePointIdNamesBothLines) {
  std::string text = WithDescription("twice");
  text.insert(text.find("<obs"), "<point id=\"A\" x=\"5\" y=\"5\" adj=\"xy\"/>\n");  // line 7
  const std::string e = ParseError(text);
  EXPECT_NE(e.find("net.gkf:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("'A'"), std::string::npos) << e;
  EXPECT_NE(e.find("defined at line 5"), std::string::npos) << e;
}

// A cluster of uncorrelated observations keeps its σ's, not an n × n covariance: a levelling
// line of 3,000 dh in one <height-differences> is 3,000 numbers, not 9 million. A <cov-mat>
// with off-diagonal band is kept whole; a band of 0 only sets the σ's.
TEST(GamaReader, UncorrelatedClustersHoldNoDenseCovariance) {
  const int n = 3000;
  std::string text = "<gama-local><network><points-observations>\n<point id=\"B0\" z=\"0\" fix=\"z\"/>\n";
  for (int i = 1; i <= n; ++i) text += "<point id=\"B" + std::to_string(i) + "\" adj=\"z\"/>\n";
  text += "<height-differences>\n";
  for (int i = 0; i < n; ++i) {
    text += "<dh from=\"B" + std::to_string(i) + "\" to=\"B" + std::to_string(i + 1) +
            "\" val=\"0.5\" stdev=\"" + std::to_string(1 + i % 3) + "\"/>\n";
  }
  text += "</height-differences>\n<height-differences>\n"
          "<dh from=\"B0\" to=\"B1\" val=\"0.5\"/><dh from=\"B1\" to=\"B2\" val=\"0.5\"/>\n"
          "<cov-mat dim=\"2\" band=\"1\">4 1 9</cov-mat>\n</height-differences>\n"
          "<height-differences>\n"
          "<dh from=\"B0\" to=\"B1\" val=\"0.5\"/><dh from=\"B1\" to=\"B2\" val=\"0.5\"/>\n"
          "<cov-mat dim=\"2\" band=\"0\">16 25</cov-mat>\n</height-differences>\n"
          "</points-observations></network></gama-local>\n";
  const survey::SurveyNetwork net = ParseGamaLocal(text, "line.gkf");
  ASSERT_EQ(net.clusters.size(), 3u);
  const survey::Cluster& line = net.clusters[0];
  ASSERT_EQ(line.observations.size(), static_cast<size_t>(n));
  EXPECT_EQ(line.covariance.size(), 0);
  EXPECT_FALSE(line.correlated);
  EXPECT_NEAR(line.Covariance(4, 4), std::pow(2e-3, 2), 1e-18);  // stdev 2 mm
  EXPECT_EQ(line.Covariance(4, 5), 0.0);
  const survey::Cluster& correlated = net.clusters[1];
  EXPECT_TRUE(correlated.correlated);
  ASSERT_EQ(correlated.covariance.rows(), 2);
  EXPECT_NEAR(correlated.Covariance(0, 1), 1e-6, 1e-18);  // mm² -> m²
  EXPECT_NEAR(correlated.observations[1].sigma, 3e-3, 1e-15);
  const survey::Cluster& diagonal = net.clusters[2];
  EXPECT_FALSE(diagonal.correlated);
  EXPECT_EQ(diagonal.covariance.size(), 0);
  EXPECT_NEAR(diagonal.observations[0].sigma, 4e-3, 1e-15);
  EXPECT_NEAR(diagonal.Covariance(1, 1), 25e-6, 1e-18);
  EXPECT_NE(ParseError("<gama-local><network><points-observations>\n"
                       "<point id=\"A\" z=\"0\" fix=\"z\"/><point id=\"B\" adj=\"z\"/>\n"
                       "<height-differences><dh from=\"A\" to=\"B\" val=\"1\"/>\n"
                       "<cov-mat dim=\"1\" band=\"0\">-4</cov-mat></height-differences>\n"
                       "</points-observations></network></gama-local>\n")
                .find("positive definite"),
            std::string::npos);
}

// A network declaring ISO-8859-2, windows-1250 (also in Gama's own spelling cp-1250) or
// UTF-16 (with a byte order mark) reads as the same UTF-8 network; an encoding iconv does not
// know and a byte the declared encoding does not define are input errors naming file and line.
TEST(GamaReader, AnyDeclaredEncodingIsReadAsUtf8) {
  for (const char* name : {"encoding-iso-8859-2.gkf", "encoding-windows-1250.gkf",
                                  "encoding-gama-cp-1250.gkf", "encoding-utf-16.gkf"}) {
    SCOPED_TRACE(name);
    survey::SurveyNetwork net = ReadGamaLocal(Fixture(name));
    EXPECT_EQ(net.description.rfind("M\xC4\x9B\xC5\x99" "en\xC3\xAD s\xC3\xADt\xC4\x9B "
                                    "\xC5\xBDi\xC5\xBEkov (", 0),  // Měření sítě Žižkov
              0u)
        << net.description;
    ASSERT_NE(net.Find("\xC5\xA0\xC5\xA5\xC3\xA1va"), nullptr);  // Šťáva
    EXPECT_EQ(net.Find("\xC4\x8C\xC3\xA1p")->line, 7);               // Čáp
    const survey::SurveyAdjustment adj = survey::AdjustNetwork(&net, survey::SurveyAdjustOptions());
    EXPECT_TRUE(adj.converged);
    EXPECT_EQ(adj.statistics.degrees_of_freedom, 2);
  }

  std::string e = ErrorOf("encoding-unknown.gkf");
  EXPECT_NE(e.find("encoding-unknown.gkf:1"), std::string::npos) << e;
  EXPECT_NE(e.find("'KOI-9'"), std::string::npos) << e;
  EXPECT_NE(e.find("encoding"), std::string::npos) << e;
  e = ErrorOf("encoding-bad-byte.gkf");
  EXPECT_NE(e.find("encoding-bad-byte.gkf:6"), std::string::npos) << e;
  EXPECT_NE(e.find("0x81"), std::string::npos) << e;
  EXPECT_NE(e.find("windows-1250"), std::string::npos) << e;
}

// Malformed XML is reported by pugixml with the line of the fault.
TEST(GamaReader, MalformedXmlNamesTheLine) {
  std::string text = WithDescription("ok");
  text.replace(text.find("</obs>"), 6, "</ob>");  // line 7
  const std::string e = ParseError(text);
  EXPECT_NE(e.find("net.gkf:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("well-formed XML"), std::string::npos) << e;
}

}  // namespace
}  // namespace mmba::io
