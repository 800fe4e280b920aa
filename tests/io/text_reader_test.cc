// The strict number conversions, the file opening and the line splitting every text reader
// uses.
#include "mmba/io/text_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

TEST(ParseDouble, WholeTokensOfFiniteNumbersOnly) {
  double v = 0.0;
  for (const auto& [token, value] : std::vector<std::pair<std::string, double>>{
           {"1.5", 1.5}, {"+1.5", 1.5}, {"-2", -2.0}, {"1e-3", 1e-3}, {"-0.06325", -0.06325},
           {".5", 0.5}, {"3.", 3.0}, {"4E2", 400.0}}) {
    ASSERT_TRUE(ParseDouble(token, &v)) << token;
    EXPECT_EQ(v, value) << token;  // correctly rounded, as strtod
  }
  for (const std::string token : {"", "+", "-", "+-1", "--1", "1.5x", "1,5", " 1", "1 ", "nan",
                                  "inf", "-inf", "1e999", "abc", "0x10"}) {
    v = 7.0;
    EXPECT_FALSE(ParseDouble(token, &v)) << token;
    EXPECT_EQ(v, 7.0) << token;  // untouched
  }
}

using ::testing::HasSubstr;
namespace fs = std::filesystem;

template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

class ReadWholeFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mmba_text_reader_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// Opening a FIFO waits for a writer: the reader must refuse it from its status alone. A writer
// thread stands ready, so that a reader that does open it gets data and returns (the test then
// fails instead of hanging).
TEST_F(ReadWholeFileTest, RefusesAFifoWithoutOpeningIt) {
  const std::string fifo = (dir_ / "pipe.txt").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::thread writer([&] {
    const int fd = ::open(fifo.c_str(), O_WRONLY);
    if (fd >= 0) {
      (void)!::write(fd, "1 2 3\n", 6);
      ::close(fd);
    }
  });
  const std::string message = ErrorOf([&] { ReadWholeFile(fifo); });
  // Releases the writer when the reader did not open the FIFO.
  const int release = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  writer.join();
  if (release >= 0) ::close(release);
  EXPECT_EQ(message, fifo + ": is a FIFO (named pipe), expected a regular file");
}

TEST_F(ReadWholeFileTest, RefusesDevicesAndFolders) {
  // /dev/null first: a reader that reads devices returns "" at once and fails here, before
  // /dev/zero (which it would read until memory runs out).
  ASSERT_EQ(ErrorOf([] { ReadWholeFile("/dev/null"); }),
            "/dev/null: is a character device, expected a regular file");
  EXPECT_EQ(ErrorOf([] { ReadWholeFile("/dev/zero"); }),
            "/dev/zero: is a character device, expected a regular file");
  EXPECT_EQ(ErrorOf([&] { ReadWholeFile(dir_.string()); }),
            dir_.string() + ": is a directory, expected a regular file");
  EXPECT_EQ(ErrorOf([&] { ReadWholeFile((dir_ / "none.txt").string()); }),
            (dir_ / "none.txt").string() + ": file not found");
  // A link to a regular file is read.
  const fs::path target = dir_ / "target.txt", link = dir_ / "link.txt";
  { std::ofstream(target) << "1 2 3\n"; }
  fs::create_symlink(target, link);
  EXPECT_EQ(ReadWholeFile(link.string()), "1 2 3\n");
}

TEST(LineCursor, RefusesALineLongerThanTheLimit) {
  const std::string text = "short\n" + std::string(kMaxLineBytes + 1, 'a') + "\nshort\n";
  LineCursor cursor(text, "big.txt");
  std::string_view line;
  ASSERT_TRUE(cursor.Next(&line));
  EXPECT_EQ(ErrorOf([&] { cursor.Next(&line); }),
            "big.txt:2: field 'line': found '1048577 bytes', expected at most 1048576 bytes per line "
            "(not a text file of this format?)");
  // A line of exactly the limit, and a larger limit given by the reader.
  const std::string at_limit(kMaxLineBytes, 'b');
  LineCursor fits(at_limit, "fits.txt");
  ASSERT_TRUE(fits.Next(&line));
  EXPECT_EQ(line.size(), kMaxLineBytes);
  LineCursor larger(text, "big.txt", 2 * kMaxLineBytes);
  int lines = 0;
  while (larger.Next(&line)) ++lines;
  EXPECT_EQ(lines, 3);
}

TEST(TokenLine, NameMustBeUtf8) {
  const TokenLine line("images.txt", 7, "1 caf\xC3\xA9.jpg caf\xE9.jpg \xED\xA0\x80.jpg");
  EXPECT_EQ(line.Name(1, "NAME"), "caf\xC3\xA9.jpg");
  EXPECT_EQ(ErrorOf([&] { line.Name(2, "NAME"); }),
            "images.txt:7: field 'NAME': found 'invalid UTF-8 at byte 3 of the value', expected UTF-8 text");
  // A UTF-16 surrogate encoded as UTF-8 (CESU-8) is not UTF-8 either.
  EXPECT_THAT(ErrorOf([&] { line.Name(3, "NAME"); }), HasSubstr("invalid UTF-8 at byte 0"));
}

}  // namespace
}  // namespace mmba::io
