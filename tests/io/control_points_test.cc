// Control files: σ per axis, one σ for all axes, or the project's σ; fixed where σ is 0; a
// missing σ, an unknown column or a duplicate point is an error naming file, line and value.
#include "mmba/io/control_points.h"

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
using ::testing::HasSubstr;

const std::string kData = std::string(MMBA_SOURCE_DIR) + "/tests/data/photo_measurements/";

template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ControlPoints, FixedByTheProjectSigma) {
  const auto c = ReadControlPoints(kData + "control_fixed.txt", {"id", "label", "x", "y", "z"}, 0.0);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[1].id, "1002");
  EXPECT_EQ(c[1].label, "CP 2, corner");  // a quoted field holding a comma
  EXPECT_EQ(c[1].xyz_m, Eigen::Vector3d(1, 1, 0));
  EXPECT_TRUE(c[1].Fixed());
  const auto w = ReadControlPoints(kData + "control_fixed.txt", {"id", "label", "x", "y", "z"}, 0.002);
  EXPECT_FALSE(w[0].Fixed());
  EXPECT_EQ(w[0].sigma_m, Eigen::Vector3d::Constant(0.002));
}

TEST(ControlPoints, SigmaPerAxis) {
  const std::string path = kData + "control_missing_sigma.txt";
  // The first line has sxyz; the second lacks it.
  EXPECT_THAT(ErrorOf([&] { ReadControlPoints(path, {"id", "label", "x", "y", "z", "sxyz"}, std::nullopt); }),
              HasSubstr("control_missing_sigma.txt:3: field 'sxyz': found '5 fields', expected a value for column 6 (sxyz)"));
}

TEST(ControlPoints, WithoutSigmaAnywhereIsAnError) {
  EXPECT_THAT(ErrorOf([] { ReadControlPoints(kData + "control_fixed.txt", {"id", "label", "x", "y", "z"}, std::nullopt); }),
              HasSubstr("control_fixed.txt: field 'columns': found 'no σ column (sx, sy, sz or sxyz)', expected σ in the file, "
                        "or the project's control sigma_m (0 = fixed)"));
}

TEST(ControlPoints, ColumnChecks) {
  EXPECT_THAT(ErrorOf([] { CheckControlColumns({"id", "x", "y", "z", "sx", "sy"}, "p.yaml", 4, "control.columns"); }),
              HasSubstr("p.yaml:4: field 'control.columns': found '2 of sx, sy, sz', expected σ columns sx, sy, sz"));
  EXPECT_THAT(ErrorOf([] { CheckControlColumns({"id", "x", "y", "height"}, "p.yaml", 4, "c"); }),
              HasSubstr("found 'height (unknown column)'"));
  EXPECT_EQ(ErrorOf([] { CheckControlColumns({"id", "label", "x", "y", "z", "sx", "sy", "sz"}, "p", 1, "c"); }),
            "no error");
}

TEST(ControlPoints, ValuesAreChecked) {
  const std::vector<std::string> columns{"id", "x", "y", "z", "sx", "sy", "sz"};
  EXPECT_THAT(ErrorOf([&] { ReadControlPoints(kData + "control_negative_sigma.txt", columns, std::nullopt); }),
              HasSubstr("control_negative_sigma.txt:3: field 'sy': found '-0.01', expected a σ in metres in [0, 100]"));
  EXPECT_THAT(ErrorOf([&] { ReadControlPoints(kData + "control_duplicate.txt", columns, std::nullopt); }),
              HasSubstr("control_duplicate.txt:2: field 'id': found 'A (also on line 1)', expected each control point once"));
}

}  // namespace
}  // namespace mmba::io
