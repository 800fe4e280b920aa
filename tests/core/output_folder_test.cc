#include "mmba/core/output_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class OutputFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mmba_output_folder_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The names in the test folder (no staging folder or lock file may be left there).
  std::set<std::string> Names(const fs::path& folder) const {
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename().string());
    return names;
  }
  // The message of the InputError `make` throws ("" when none).
  template <typename F>
  static std::string InputErrorOf(F make) {
    try {
      make();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  // A result written by mmba into `out`: one file `name`.
  static void WriteResult(const fs::path& out, const std::string& name, const std::string& text = "x") {
    OutputFolder folder(out.string(), "--output", "test", {});
    std::ofstream(folder.staging() / name) << text;
    folder.Commit();
  }
  fs::path dir_;
};

TEST_F(OutputFolderTest, ANewFolderIsWrittenWholeWithTheMarker) {
  const fs::path out = dir_ / "a" / "b" / "out";
  {
    OutputFolder folder(out.string(), "--output", "mmba test", {});
    EXPECT_EQ(folder.path(), out);
    EXPECT_TRUE(OutputFolder::HoldsMarker(folder.staging()));
    EXPECT_FALSE(fs::exists(out));  // nothing in place before Commit
    std::ofstream(folder.staging() / "result.txt") << "new";
    folder.Commit();
  }
  EXPECT_EQ(Slurp(out / "result.txt"), "new");
  EXPECT_THAT(Slurp(out / OutputFolder::kMarkerName), HasSubstr("written by mmba test"));
  EXPECT_EQ(Names(out.parent_path()), std::set<std::string>{"out"});  // no staging, no lock file
}

TEST_F(OutputFolderTest, AnEmptyFolderIsAccepted) {
  fs::create_directories(dir_ / "out");
  WriteResult(dir_ / "out", "result.txt");
  EXPECT_TRUE(fs::exists(dir_ / "out" / "result.txt"));
}

TEST_F(OutputFolderTest, AFolderMmbaWroteIsReplacedWhole) {
  WriteResult(dir_ / "out", "first.txt");
  std::ofstream(dir_ / "out" / "added later.txt") << "in an mmba output folder";
  WriteResult(dir_ / "out", "second.txt");
  EXPECT_EQ(Names(dir_ / "out"), (std::set<std::string>{".mmba-output", "second.txt"}));
  EXPECT_EQ(Names(dir_), std::set<std::string>{"out"});
}

TEST_F(OutputFolderTest, AFolderOfUserDataIsRefusedAndKept) {
  fs::create_directories(dir_ / "data" / "sub");
  std::ofstream(dir_ / "data" / "notes.txt") << "mine";
  const std::string error =
      InputErrorOf([&] { OutputFolder folder((dir_ / "data").string(), "--output", "test", {}); });
  EXPECT_THAT(error, HasSubstr("--output: '" + (dir_ / "data").string() + "' is a folder mmba did not write"));
  EXPECT_THAT(error, HasSubstr("it holds 2 entries and no .mmba-output"));
  EXPECT_THAT(error, HasSubstr("give a new or empty folder"));
  EXPECT_EQ(Slurp(dir_ / "data" / "notes.txt"), "mine");
  EXPECT_EQ(Names(dir_), std::set<std::string>{"data"});  // no staging, no lock file
}

TEST_F(OutputFolderTest, AnExistingFileIsRefused) {
  std::ofstream(dir_ / "file") << "mine";
  const std::string error =
      InputErrorOf([&] { OutputFolder folder((dir_ / "file").string(), "--output", "test", {}); });
  EXPECT_THAT(error, HasSubstr("--output: cannot write '" + (dir_ / "file").string() +
                               "': it is an existing file, not a folder"));
  EXPECT_EQ(Slurp(dir_ / "file"), "mine");
}

// The swap would delete an input inside the folder, even in a folder mmba wrote.
TEST_F(OutputFolderTest, AFolderThatIsOrHoldsAnInputIsRefused) {
  WriteResult(dir_ / "out", "result.txt");
  fs::create_directories(dir_ / "out" / "project");
  std::ofstream(dir_ / "out" / "project" / "project.yaml") << "mine";
  const std::string input = (dir_ / "out" / "project" / "project.yaml").string();
  const std::string holds = InputErrorOf(
      [&] { OutputFolder folder((dir_ / "out").string(), "--output", "test", {{"the project file", input}}); });
  EXPECT_THAT(holds, HasSubstr("--output: '" + (dir_ / "out").string() + "' holds the input the project file ('" +
                               input + "')"));
  // The same folder spelled differently.
  const std::string is = InputErrorOf([&] {
    OutputFolder folder((dir_ / "out" / "project" / ".." / "project").string(), "--output", "test",
                        {{"--input", (dir_ / "out" / "project").string()}});
  });
  EXPECT_THAT(is, HasSubstr("is the input --input; mmba never overwrites its inputs"));
  EXPECT_EQ(Slurp(input), "mine");
  // A folder inside an input folder is fine.
  OutputFolder inside((dir_ / "out" / "project" / "eval").string(), "--output", "test",
                      {{"--scene", (dir_ / "out" / "project").string()}});
}

TEST_F(OutputFolderTest, AFolderHoldingTheCurrentFolderIsRefused) {
  fs::create_directories(dir_ / "out" / "here");
  const fs::path before = fs::current_path();
  fs::current_path(dir_ / "out" / "here");
  const std::string error = InputErrorOf([&] { OutputFolder folder((dir_ / "out").string(), "--output", "test", {}); });
  fs::current_path(before);
  EXPECT_THAT(error, HasSubstr("it is or holds the current folder"));
}

TEST_F(OutputFolderTest, ASecondRunIntoTheSameFolderIsRefusedAsInUse) {
  fs::create_directories(dir_ / "real");
  fs::create_directory_symlink(dir_ / "real", dir_ / "link");
  {
    OutputFolder first((dir_ / "real").string(), "--output", "test", {});
    const std::string error =
        InputErrorOf([&] { OutputFolder second((dir_ / "link").string(), "--output", "test", {}); });
    EXPECT_THAT(error, HasSubstr("--output: '" + (dir_ / "real").string() + "' is in use by another mmba run"));
    EXPECT_TRUE(fs::exists(first.staging()));  // the refused run leaves the first one's staging alone
  }
  OutputFolder after((dir_ / "real").string(), "--output", "test", {});  // the lock is released
}

TEST_F(OutputFolderTest, ALockHeldByAnotherProcessIsInUse) {
  const fs::path lock = dir_ / "out.mmba-lock";
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  const std::string error = InputErrorOf([&] { OutputFolder folder((dir_ / "out").string(), "--output", "test", {}); });
  ::close(fd);
  EXPECT_THAT(error, HasSubstr("is in use by another mmba run (it holds '" + lock.string() + "')"));
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// Leftovers of a run killed outright: staging folders holding the marker (or empty) go; a
// folder of that name without the marker is not mmba's and stays; so does an unlocked lock file.
TEST_F(OutputFolderTest, StaleStagingFoldersAreRemovedByTheNextRun) {
  fs::create_directories(dir_ / "out.mmba-staging-Ab12Cd");
  std::ofstream(dir_ / "out.mmba-staging-Ab12Cd" / OutputFolder::kMarkerName) << "mmba";
  std::ofstream(dir_ / "out.mmba-staging-Ab12Cd" / "report.json.tmp-123") << "half";
  fs::create_directories(dir_ / "out.mmba-staging-Ef34Gh");
  fs::create_directories(dir_ / "out.mmba-staging-user");
  std::ofstream(dir_ / "out.mmba-staging-user" / "notes.txt") << "mine";
  std::ofstream(dir_ / "out.mmba-lock") << "";
  WriteResult(dir_ / "out", "result.txt");
  EXPECT_EQ(Names(dir_), (std::set<std::string>{"out", "out.mmba-staging-user"}));
}

TEST_F(OutputFolderTest, ARunWithoutCommitKeepsTheEarlierResultAndLeavesNothing) {
  WriteResult(dir_ / "out", "earlier.txt");
  {
    OutputFolder folder((dir_ / "out").string(), "--output", "test", {});
    std::ofstream(folder.staging() / "new.txt") << "half";
  }
  EXPECT_EQ(Names(dir_ / "out"), (std::set<std::string>{".mmba-output", "earlier.txt"}));
  EXPECT_EQ(Names(dir_), std::set<std::string>{"out"});
  {
    OutputFolder folder((dir_ / "new" / "deeper" / "out").string(), "--output", "test", {});
  }
  EXPECT_FALSE(fs::exists(dir_ / "new"));  // the parent folders it created, removed
}

TEST_F(OutputFolderTest, FilesPutIntoTheFolderDuringTheRunStopTheCommit) {
  fs::create_directories(dir_ / "out");
  OutputFolder folder((dir_ / "out").string(), "--output", "test", {});
  std::ofstream(dir_ / "out" / "user.txt") << "mine";
  EXPECT_THROW(folder.Commit(), InputError);
  EXPECT_EQ(Slurp(dir_ / "out" / "user.txt"), "mine");
}

}  // namespace
}  // namespace mmba
