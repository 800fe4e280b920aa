#include "mmba/core/settings_table.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace mmba {
namespace {

struct Inner {
  int levels = 3;
};

struct Options {
  double radius_m = 0.5;
  int iterations = 200;
  bool verify = true;
  std::string smoothing = "bspline";
  double fraction = 0.25;
  Inner inner;
  std::vector<double> steps = {1.0, 1.0, 1.0};
};

const SettingsTable<Options>& Table() {
  static const SettingsTable<Options> table = [] {
    SettingsTable<Options> t("test --help lists them");
    t.Number("radius_m", &Options::radius_m, SettingRange::Above(0), "search radius, m")
        .Integer("iterations", &Options::iterations, SettingRange::AtLeast(1), "iterations per level")
        .Flag("verify", &Options::verify, "verify the result")
        .Choice("smoothing", &Options::smoothing, {"none", "parzen", "bspline"}, "histogram smoothing")
        .Number("fraction", &Options::fraction, SettingRange::Closed(0, 1.0 / 3.0).Described("0..1/3"),
                "a fraction up to a third")
        .Integer("levels", {&Options::inner, &Inner::levels}, SettingRange::Closed(1, 6), "pyramid levels")
        .Number("step", {[](const Options& o) { return o.steps[0]; },
                         [](Options* o, double v) { o->steps.assign(3, v); }},
                SettingRange::Above(0), "every step");
    return t;
  }();
  return table;
}

TEST(SettingsTable, SetsEachKindByNameIncludingNestedAndDerivedFields) {
  Options o;
  std::string problem;
  ASSERT_TRUE(Table().Set("radius_m", "0.75", &o, &problem)) << problem;
  EXPECT_EQ(o.radius_m, 0.75);
  ASSERT_TRUE(Table().Set("iterations", "50", &o, &problem)) << problem;
  EXPECT_EQ(o.iterations, 50);
  ASSERT_TRUE(Table().Set("verify", "false", &o, &problem)) << problem;
  EXPECT_FALSE(o.verify);
  ASSERT_TRUE(Table().Set("verify", "1", &o, &problem)) << problem;
  EXPECT_TRUE(o.verify);
  ASSERT_TRUE(Table().Set("smoothing", "parzen", &o, &problem)) << problem;
  EXPECT_EQ(o.smoothing, "parzen");
  ASSERT_TRUE(Table().Set("levels", "5", &o, &problem)) << problem;
  EXPECT_EQ(o.inner.levels, 5);
  ASSERT_TRUE(Table().Set("step", "0.25", &o, &problem)) << problem;
  EXPECT_EQ(o.steps, (std::vector<double>{0.25, 0.25, 0.25}));
}

TEST(SettingsTable, RefusesValuesOfTheWrongKindOrRangeAndLeavesTheOptionsUnchanged) {
  for (const auto& [name, value, message] : std::vector<std::tuple<std::string, std::string, std::string>>{
           {"radius_m", "0", "found '0', expected a number > 0"},
           {"radius_m", "abc", "found 'abc', expected a number > 0"},
           {"radius_m", "nan", "found 'nan', expected a finite number > 0"},
           {"radius_m", "inf", "found 'inf', expected a finite number > 0"},
           {"radius_m", "", "found '', expected a number > 0"},
           {"iterations", "2.5", "found '2.5', expected an integer >= 1"},
           {"iterations", "0", "found '0', expected an integer >= 1"},
           {"levels", "7", "found '7', expected an integer [1, 6]"},
           {"fraction", "0.5", "found '0.5', expected a number 0..1/3"},
           {"verify", "yes", "found 'yes', expected true or false"},
           {"smoothing", "gauss", "found 'gauss', expected none, parzen, bspline"},
           {"radius", "1", "unknown setting 'radius' (closest: 'radius_m'; test --help lists them)"},
           {"colour", "1", "unknown setting 'colour' (test --help lists them)"}}) {
    Options o;
    std::string problem;
    EXPECT_FALSE(Table().Set(name, value, &o, &problem)) << name << "=" << value;
    EXPECT_EQ(problem, message);
    EXPECT_EQ(o.radius_m, Options().radius_m);
    EXPECT_EQ(o.iterations, Options().iterations);
    EXPECT_EQ(o.inner.levels, Options().inner.levels);
    EXPECT_EQ(o.fraction, Options().fraction);
    EXPECT_EQ(o.smoothing, Options().smoothing);
  }
}

TEST(SettingsTable, AppliesNameValueListsInOrderAndNamesTheRefusedOne) {
  Options o;
  std::string problem;
  std::vector<std::string> names;
  ASSERT_TRUE(Table().Apply({"iterations=10", "radius_m=2", "iterations=20"}, &o, &problem, &names)) << problem;
  EXPECT_EQ(o.iterations, 20);  // the last one has the last word
  EXPECT_EQ(o.radius_m, 2.0);
  EXPECT_EQ(names, (std::vector<std::string>{"iterations", "radius_m", "iterations"}));
  EXPECT_FALSE(Table().Apply({"radius_m=1", "iterations"}, &o, &problem));
  EXPECT_EQ(problem, "found 'iterations', expected NAME=VALUE");
  EXPECT_FALSE(Table().Apply({"levels=0"}, &o, &problem));
  EXPECT_EQ(problem, "levels: found '0', expected an integer [1, 6]");
  EXPECT_FALSE(Table().Apply({"levls=2"}, &o, &problem));
  EXPECT_EQ(problem, "unknown setting 'levls' (closest: 'levels'; test --help lists them)");
}

TEST(SettingsTable, ChecksAWholeStructAgainstTheRanges) {
  std::string problem;
  EXPECT_TRUE(Table().Check(Options(), &problem)) << problem;
  Options o;
  o.inner.levels = 9;
  EXPECT_FALSE(Table().Check(o, &problem));
  EXPECT_EQ(problem, "levels: found 9, expected an integer [1, 6]");
  o = Options();
  o.radius_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(Table().Check(o, &problem));
  EXPECT_EQ(problem, "radius_m: found nan, expected a finite number > 0");
  o = Options();
  o.smoothing = "box";
  EXPECT_FALSE(Table().Check(o, &problem));
  EXPECT_EQ(problem, "smoothing: found 'box', expected none, parzen, bspline");
}

TEST(SettingsTable, ListsEverySettingWithItsDefaultAndTheFooterShowsThem) {
  const std::vector<SettingInfo> all = Table().List();
  ASSERT_EQ(all.size(), 7u);
  EXPECT_EQ(all[0].name, "radius_m");
  EXPECT_EQ(all[0].kind, "number");
  EXPECT_EQ(all[0].range, "> 0");
  EXPECT_EQ(all[0].default_value, "0.5");
  EXPECT_EQ(all[2].kind, "true|false");
  EXPECT_EQ(all[2].default_value, "true");
  EXPECT_EQ(all[3].range, "none|parzen|bspline");
  EXPECT_EQ(all[5].default_value, "3");
  // Each default reads back as its own value.
  for (const SettingInfo& s : all) {
    Options o;
    std::string problem;
    EXPECT_TRUE(Table().Set(s.name, s.default_value, &o, &problem)) << s.name << ": " << problem;
  }
  const std::string footer = Table().Footer("Settings:");
  EXPECT_EQ(footer.rfind("Settings:\n", 0), 0u);
  EXPECT_NE(footer.find("  iterations = 200 (>= 1): iterations per level\n"), std::string::npos) << footer;
  EXPECT_NE(footer.find("  fraction = 0.25 (0..1/3): a fraction up to a third\n"), std::string::npos) << footer;
  EXPECT_EQ(Table().Value("levels", Options()), "3");
  EXPECT_TRUE(Table().Has("step"));
  EXPECT_FALSE(Table().Has("steps"));
}

TEST(SettingsTable, ClosestNameIsOnlyGivenWhenNear) {
  EXPECT_EQ(ClosestSettingName("restart", {"restarts", "bins"}), "restarts");
  EXPECT_EQ(ClosestSettingName("bin", {"restarts", "bins"}), "bins");
  EXPECT_EQ(ClosestSettingName("colour", {"restarts", "bins"}), "");
}

TEST(EditDistance, CountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(EditDistance("", ""), 0u);
  EXPECT_EQ(EditDistance("bins", ""), 4u);
  EXPECT_EQ(EditDistance("bins", "bins"), 0u);
  EXPECT_EQ(EditDistance("bins", "bin"), 1u);      // a deletion
  EXPECT_EQ(EditDistance("restart", "restarts"), 1u);  // an insertion
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3u);    // two substitutions and an insertion
}

}  // namespace
}  // namespace mmba
