#include "mmba/core/atomic_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

namespace mmba {
namespace {
namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mmba_atomic_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(AtomicFileTest, WritesAllFilesAndCreatesFolders) {
  AtomicFileSet set;
  set.Add(dir_ / "a" / "x.txt", [](std::ostream& o) { o << "x"; });
  set.Add(dir_ / "y.bin", [](std::ostream& o) { o << "y"; }, true);
  set.Commit();
  EXPECT_EQ(Slurp(dir_ / "a" / "x.txt"), "x");
  EXPECT_EQ(Slurp(dir_ / "y.bin"), "y");
  size_t n = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir_)) n += entry.is_regular_file();
  EXPECT_EQ(n, 2u);  // no temporaries left behind
}

TEST_F(AtomicFileTest, AFailingWriterLeavesExistingFilesUntouched) {
  fs::create_directories(dir_);
  { std::ofstream(dir_ / "keep.txt") << "old"; }
  AtomicFileSet set;
  set.Add(dir_ / "keep.txt", [](std::ostream& o) { o << "new"; });
  set.Add(dir_ / "other.txt", [](std::ostream&) { throw std::runtime_error("disk full"); });
  EXPECT_THROW(set.Commit(), std::runtime_error);
  EXPECT_EQ(Slurp(dir_ / "keep.txt"), "old");
  EXPECT_FALSE(fs::exists(dir_ / "other.txt"));
  size_t n = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) n += entry.is_regular_file();
  EXPECT_EQ(n, 1u);
}


// "<name>.tmp-<pid>" of a process that no longer runs (a run killed while writing) goes with
// the next Commit of that file; one of a running process (pid 1) and other files stay.
TEST_F(AtomicFileTest, AStaleTemporaryOfAProcessGoneIsRemoved) {
  fs::create_directories(dir_);
  { std::ofstream(dir_ / "cameras.txt.tmp-999999999") << "half"; }  // above any pid_max
  { std::ofstream(dir_ / "cameras.txt.tmp-1") << "init's"; }
  { std::ofstream(dir_ / "images.txt.tmp-999999999") << "another file's"; }
  WriteFileAtomically(dir_ / "cameras.txt", [](std::ostream& o) { o << "new"; });
  EXPECT_EQ(Slurp(dir_ / "cameras.txt"), "new");
  EXPECT_FALSE(fs::exists(dir_ / "cameras.txt.tmp-999999999"));
  EXPECT_TRUE(fs::exists(dir_ / "cameras.txt.tmp-1"));
  EXPECT_TRUE(fs::exists(dir_ / "images.txt.tmp-999999999"));
}

// A result JSON and its error map: a run without a map removes the earlier run's map, so the
// new JSON never stands beside it.
TEST_F(AtomicFileTest, ARemovedPartnerDoesNotSurviveBesideTheNewIndex) {
  fs::create_directories(dir_);
  { std::ofstream(dir_ / "result.json") << "old"; }
  { std::ofstream(dir_ / "error_map.ply") << "old map"; }
  AtomicFileSet set;
  set.Add(dir_ / "result.json", [](std::ostream& o) { o << "new"; });
  set.Remove(dir_ / "error_map.ply");
  set.Commit();
  EXPECT_EQ(Slurp(dir_ / "result.json"), "new");
  EXPECT_FALSE(fs::exists(dir_ / "error_map.ply"));
}

// The index (first file) goes last and its old version first: when a partner cannot be put in
// place, the old index is gone too, so no index stands beside a partner of another run.
TEST_F(AtomicFileTest, WhenAPartnerFailsTheOldIndexIsGoneNotMixed) {
  fs::create_directories(dir_ / "error_map.ply" / "a folder in the way");
  { std::ofstream(dir_ / "result.json") << "old"; }
  AtomicFileSet set;
  set.Add(dir_ / "result.json", [](std::ostream& o) { o << "new"; });
  set.Add(dir_ / "error_map.ply", [](std::ostream& o) { o << "new map"; });
  EXPECT_THROW(set.Commit(), std::runtime_error);
  EXPECT_FALSE(fs::exists(dir_ / "result.json"));
  size_t n = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) n += entry.is_regular_file();
  EXPECT_EQ(n, 0u);  // no temporaries either
}

}  // namespace
}  // namespace mmba
