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

}  // namespace
}  // namespace mmba
