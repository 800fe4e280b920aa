// One command-line convention: a mistyped command or option is named first with the closest
// valid name (exit 2); inputs as --input or a first argument; outputs as --output.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "shell.h"

namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using mmba::test::RunResult;

RunResult Mmba(const std::string& args) { return mmba::test::RunShell(std::string(MMBA_EXECUTABLE) + " " + args); }

const std::string kNetwork = std::string(MMBA_SOURCE_DIR) + "/data/gama/gama-local.gkf";

std::string Tmp(const std::string& name) {
  return (fs::path(testing::TempDir()) / ("mmba_convention_" + std::to_string(getpid()) + "_" + name)).string();
}

TEST(CliConvention, AMistypedCommandIsNamedWithTheClosest) {
  const RunResult run = Mmba("adjsut project.yaml");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.output,
            "mmba: error: unknown command 'adjsut'; did you mean 'adjust'? (mmba --help lists the commands)\n");
  const RunResult far = Mmba("frobnicate");
  EXPECT_EQ(far.exit_code, 2);
  EXPECT_EQ(far.output, "mmba: error: unknown command 'frobnicate' (mmba --help lists the commands)\n");
}

TEST(CliConvention, AMistypedOptionIsNamedBeforeMissingOnes) {
  const RunResult run = Mmba("survey --inptu " + kNetwork + " --output " + Tmp("a"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.output,
            "mmba: error: unknown option '--inptu' of mmba survey; did you mean '--input'? "
            "(mmba survey --help lists the options)\n");
  const RunResult value = Mmba("survey --input " + kNetwork + " --confidense=0.9 --output " + Tmp("b"));
  EXPECT_EQ(value.exit_code, 2);
  EXPECT_THAT(value.output, HasSubstr("unknown option '--confidense' of mmba survey; did you mean '--confidence'?"));
  EXPECT_FALSE(fs::exists(Tmp("a")));
  EXPECT_FALSE(fs::exists(Tmp("b")));
}

// Negative numbers are values, not options.
TEST(CliConvention, NegativeNumbersAreValues) {
  const RunResult run = Mmba("register-cloud --source a.ply --target b.ply --output " + Tmp("r.json") + " --up 0 0 -1");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.output, ::testing::Not(HasSubstr("unknown option")));
}

TEST(CliConvention, TheInputAsOptionOrFirstArgument) {
  const RunResult positional = Mmba("survey " + kNetwork + " --output " + Tmp("p") + " -q");
  EXPECT_EQ(positional.exit_code, 0) << positional.output;
  const RunResult option = Mmba("survey --input " + kNetwork + " --output " + Tmp("o") + " -q");
  EXPECT_EQ(option.exit_code, 0) << option.output;
  EXPECT_TRUE(fs::exists(Tmp("p") + "/adjusted.json"));
  EXPECT_TRUE(fs::exists(Tmp("o") + "/adjusted.json"));
  fs::remove_all(Tmp("p"));
  fs::remove_all(Tmp("o"));
}

TEST(CliConvention, SimulateTakesOutputAndOut) {
  for (const std::string flag : {"--output", "--out"}) {
    const RunResult run = Mmba("simulate --scene nowhere.yaml " + flag + " " + Tmp("sim"));
    EXPECT_EQ(run.exit_code, 2) << flag;
    EXPECT_THAT(run.output, ::testing::Not(HasSubstr("unknown option"))) << flag;
  }
}

// An option name given where a value belongs is a forgotten value (exit 2, naming the option),
// never a file or folder of that name; negative numbers and NAME=-1 stay values.
TEST(CliConvention, AnOptionNameIsNotAValue) {
  const std::string dir = Tmp("names");
  fs::create_directories(dir);
  const std::string cd = "cd " + dir + " && ";
  for (const auto& [args, option] : std::vector<std::pair<std::string, std::string>>{
           {"simulate --out --help", "--output"},
           {"simulate --output --quiet", "--output"},
           {"simulate --out -q", "--output"},
           {"adjust x.yaml --output --help", "--output"},
           {"survey " + kNetwork + " --output --help", "--output"},
           {"register-cloud --source a.ply --target b.ply --output --verbose", "--output"},
           {"register-cloud --source --help --target b.ply --output o.json", "--source"}}) {
    const RunResult run = mmba::test::RunShell(cd + MMBA_EXECUTABLE + " " + args);
    EXPECT_EQ(run.exit_code, 2) << args << ": " << run.output;
    EXPECT_THAT(run.output, HasSubstr(option + ": needs a value, found the option name '")) << args;
  }
  EXPECT_TRUE(fs::is_empty(dir)) << "an option name was taken for a file or folder name";
  // Negative numbers and NAME=-1 are values: refused (or not) for what they are, not as names.
  for (const std::string args : {"register-cloud --source a.ply --target b.ply --output o.json --up 0 0 -1",
                                 "register-cloud --source a.ply --target b.ply --output o.json --set icp_iterations=-1",
                                 "ba --input nowhere --output o --loss-scale -2"}) {
    const RunResult run = mmba::test::RunShell(cd + MMBA_EXECUTABLE + " " + args);
    EXPECT_EQ(run.exit_code, 2) << args;
    EXPECT_THAT(run.output, ::testing::Not(HasSubstr("option name"))) << args;
  }
  fs::remove_all(dir);
}

}  // namespace
