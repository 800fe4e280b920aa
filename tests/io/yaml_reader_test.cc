// Strict YAML reading: keys known and given once, strings UTF-8, only regular files.
#include "mmba/io/yaml_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

class YamlReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mmba_yaml_reader_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Reads `text` as a mapping of the string keys name and path; returns the error or "ok".
  std::string ErrorOf(const std::string& text) {
    const std::string path = (dir_ / "project.yaml").string();
    std::ofstream(path, std::ios::binary) << text;
    const YamlReader r(path);
    try {
      std::string name, file;
      r.Map(r.Load("project"), "", {{"name", [&](const YAML::Node& n, const std::string& f) { name = r.String(n, f); }},
                                    {"path", [&](const YAML::Node& n, const std::string& f) { file = r.String(n, f); }}});
    } catch (const InputError& e) {
      return e.what();
    }
    return "ok";
  }

  fs::path dir_;
};

TEST_F(YamlReaderTest, AKeyGivenTwiceIsRefused) {
  EXPECT_EQ(ErrorOf("name: a\npath: b\n"), "ok");
  EXPECT_THAT(ErrorOf("name: a\npath: b\nname: c\n"),
              HasSubstr("project.yaml:3: field 'name': found 'the key a second time (first on line 1)', "
                        "expected each key once"));
  EXPECT_THAT(ErrorOf("nmae: a\n"), HasSubstr("project.yaml:1: field 'nmae': found 'nmae (unknown key)'"));
}

// Invalid UTF-8 is found where it is read (naming the line and the key), not when an output
// is written at the end of a run.
TEST_F(YamlReaderTest, StringsAndKeysMustBeUtf8) {
  EXPECT_EQ(ErrorOf("name: caf\xC3\xA9\n"), "ok");
  EXPECT_THAT(ErrorOf("path: b\nname: ab\xFF\xFE\n"),
              HasSubstr("project.yaml:2: field 'name': found 'invalid UTF-8 at byte 2 of the value', "
                        "expected UTF-8 text"));
  EXPECT_THAT(ErrorOf("na\xE9me: a\n"), HasSubstr("project.yaml:1: field '(key)': found 'invalid UTF-8 at byte 2"));
}

// A FIFO is refused from its status alone (opening it would wait for a writer). A writer
// thread stands ready, so that a reader that does open it gets a document and returns (the
// test then fails instead of hanging).
TEST_F(YamlReaderTest, OnlyRegularFilesAreRead) {
  const std::string fifo = (dir_ / "fifo.yaml").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::thread writer([&] {
    const int fd = ::open(fifo.c_str(), O_WRONLY);
    if (fd >= 0) {
      (void)!::write(fd, "name: a\n", 8);
      ::close(fd);
    }
  });
  std::string message = "no error";
  try {
    YamlReader(fifo).Load("project");
  } catch (const InputError& e) {
    message = e.what();
  }
  const int release = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);  // frees a waiting writer
  writer.join();
  if (release >= 0) ::close(release);
  EXPECT_EQ(message, fifo + ": is a FIFO (named pipe), expected a regular file");
  EXPECT_THROW(YamlReader((dir_ / "none.yaml").string()).Load("project"), InputError);
}

}  // namespace
}  // namespace mmba::io
