#include "mmba/io_cloud/point_cloud.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

namespace fs = std::filesystem;

class PointCloudIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mmba_io_cloud_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& content) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }
  fs::path dir_;
};

// Expects an InputError whose message contains every fragment.
template <typename F>
void ExpectInputError(F f, std::initializer_list<std::string> fragments) {
  try {
    f();
    FAIL() << "no InputError thrown";
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << "message '" << e.what() << "' lacks '" << fragment << "'";
    }
  }
}

template <typename T>
void Put(std::string* s, T v) {
  s->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <typename T>
void PutBe(std::string* s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  for (size_t i = 0; i < sizeof(T); ++i) s->push_back(b[sizeof(T) - 1 - i]);
}

PointCloud MakeCloud() {
  PointCloud c;
  c.points = {{1.5, -2.25, 3.125}, {1e6 + 0.001, 5e6 + 0.002, 100.0}, {0, 0, 0}};
  c.normals = {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}};
  c.intensity = {0.5f, 12.0f, 0.0f};
  c.colors = {{{255, 0, 10}}, {{1, 2, 3}}, {{200, 100, 50}}};
  return c;
}

TEST_F(PointCloudIoTest, PlyRoundTripBinaryAndAscii) {
  PointCloud c = MakeCloud();
  c.time = {1234.000001, 0.5, 1e9 + 0.25};  // per-point acquisition time (GPS seconds)
  for (bool ascii : {false, true}) {
    const std::string path = (dir_ / (ascii ? "a.ply" : "b.ply")).string();
    WritePly(c, path, ascii);
    ReadStats stats;
    const PointCloud r = ReadPly(path, {}, &stats);
    EXPECT_EQ(stats.format, ascii ? "ply-ascii" : "ply-binary-le");
    ASSERT_EQ(r.size(), c.size());
    ASSERT_TRUE(r.has_normals() && r.has_intensity() && r.has_colors());
    for (size_t i = 0; i < c.size(); ++i) {
      EXPECT_EQ(r.points[i], c.points[i]);  // double coordinates survive exactly
      EXPECT_NEAR((r.normals[i] - c.normals[i]).norm(), 0.0, 1e-7);
      EXPECT_EQ(r.intensity[i], c.intensity[i]);
      EXPECT_EQ(r.colors[i], c.colors[i]);
      ASSERT_TRUE(r.has_time());
      EXPECT_EQ(r.time[i], c.time[i]);  // doubles survive exactly
    }
  }
  EXPECT_FALSE(fs::exists(dir_ / "b.ply.tmp"));
}

TEST_F(PointCloudIoTest, PlyBigEndianWithOtherElementsAndListSkipped) {
  std::string s =
      "ply\nformat binary_big_endian 1.0\ncomment test\n"
      "element camera 1\nproperty float a\nproperty list uchar int idx\n"
      "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property ushort scalar_intensity\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  PutBe<float>(&s, 9.0f);
  s.push_back(2);
  PutBe<int32_t>(&s, 7);
  PutBe<int32_t>(&s, 8);
  for (int i = 0; i < 2; ++i) {
    PutBe<float>(&s, 1.0f + i);
    PutBe<float>(&s, 2.0f);
    PutBe<float>(&s, -3.0f);
    PutBe<uint16_t>(&s, 1000 + i);
    s.push_back(static_cast<char>(10));
    s.push_back(static_cast<char>(20));
    s.push_back(static_cast<char>(250));
  }
  s.push_back(3);  // face: checked to be whole, not read
  for (int32_t index : {0, 1, 0}) PutBe<int32_t>(&s, index);
  const PointCloud c = ReadPly(Write("be.ply", s));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3d(2, 2, -3));
  EXPECT_EQ(c.intensity[1], 1001.0f);
  EXPECT_EQ(c.colors[0][2], 250);
  EXPECT_FALSE(c.has_normals());
}

TEST_F(PointCloudIoTest, PlyAsciiStanfordStyle) {
  const std::string path = Write(
      "s.ply",
      "ply\r\nformat ascii 1.0\r\nobj_info is_cyberware_data 1\r\nelement vertex 2\r\n"
      "property float x\r\nproperty float y\r\nproperty float z\r\n"
      "element range_grid 3\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
      "-0.06325 0.0359793 0.0420873 \r\n1 2 3\r\n1 0\r\n0\r\n0\r\n");
  const PointCloud c = ReadPointCloud(path);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_DOUBLE_EQ(c.points[0].x(), -0.06325);
}

// Intensity under the names other tools give it (SemanticKITTI's remission, CloudCompare's
// scalar fields).
TEST_F(PointCloudIoTest, PlyIntensityNames) {
  for (const std::string name : {"intensity", "scalar_Intensity", "reflectance", "scalar_Reflectance",
                                 "remission"}) {
    const std::string path = Write(
        "n.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                 "property float z\nproperty float " + name + "\nend_header\n0 0 0 0.25\n1 0 0 0.5\n");
    const PointCloud c = ReadPointCloud(path);
    ASSERT_TRUE(c.has_intensity()) << name;
    EXPECT_FLOAT_EQ(c.intensity[1], 0.5f) << name;
  }
}

TEST_F(PointCloudIoTest, PlyBrokenFixtures) {
  // The first line of a file of another kind is not quoted back (it may be any file).
  ExpectInputError([&] { ReadPly(Write("m.ply", "plx\nformat ascii 1.0\n")); },
                   {"m.ply:1: field 'magic': found 'a first line other than 'ply'', expected 'ply' (not a PLY file?)"});
  try {
    ReadPly(Write("passwd.ply", "root:x:0:0:root:/root:/bin/bash\n"));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("root"), std::string::npos) << e.what();
  }
  ExpectInputError(
      [&] { ReadPly(Write("f.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n")); },
      {"f.ply:2", "binary_middle_endian"});
  ExpectInputError([&] {
    ReadPly(Write("t.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\n"));
  }, {"t.ply:4", "flot"});
  ExpectInputError([&] {
    ReadPly(Write("h.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"));
  }, {"h.ply", "end_header"});
  ExpectInputError([&] {
    ReadPly(Write("noz.ply",
                  "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                  "property float y\nend_header\n1 2\n"));
  }, {"noz.ply", "missing z"});
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  ExpectInputError([&] { ReadPly(Write("tr.ply", head + "1 2 3\n4 5 6\n")); },
                   {"tr.ply:10", "end of file after 2 of 3"});
  ExpectInputError([&] { ReadPly(Write("v.ply", head + "1 2 3\n4 5\n7 8 9\n")); },
                   {"v.ply:9", "end of line"});
  ExpectInputError([&] { ReadPly(Write("w.ply", head + "1 2 3\n4 5 abc\n7 8 9\n")); },
                   {"w.ply:9", "'z'", "abc"});
  ExpectInputError([&] { ReadPly(Write("n.ply", head + "1 2 3\n4 nan 6\n7 8 9\n")); },
                   {"n.ply:9", "non-finite y = nan"});
  ReadOptions skip;
  skip.skip_invalid_points = true;
  ReadStats stats;
  const PointCloud c = ReadPly(Write("n2.ply", head + "1 2 3\n4 nan 6\n7 inf 9\n"), skip, &stats);
  EXPECT_EQ(c.size(), 1u);
  EXPECT_EQ(stats.num_skipped, 2u);
  // Binary truncated.
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  const size_t header = b.size();
  for (int i = 0; i < 5; ++i) Put<float>(&b, 1.0f);
  ExpectInputError([&] { ReadPly(Write("bt.ply", b)); },
                   {"bt.ply (byte " + std::to_string(header) + ")", "truncated"});
  ExpectInputError([&] { ReadPly((dir_ / "missing.ply").string()); }, {"missing.ply", "not found"});
}

// The elements after the vertices (a mesh's faces) are not read, but their records must all
// be there, with nothing after them: a file cut short or with wrong counts is damaged, even
// where its vertices are whole.
TEST_F(PointCloudIoTest, PlyElementsAfterTheVerticesAreChecked) {
  const std::string head =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n1 2 3\n4 5 6\n";
  EXPECT_EQ(ReadPly(Write("ok.ply", head + "3 0 1 0\n3 1 0 1\n\n")).size(), 2u);
  ExpectInputError([&] { ReadPly(Write("short.ply", head + "3 0 1 0\n")); },
                   {"short.ply:13: field 'face': found 'end of file after 1 of 2 items'"});
  ExpectInputError([&] { ReadPly(Write("count.ply", head + "3 0 1 0\n3 1 0\n")); },
                   {"count.ply:13: field 'face': found '3 values', expected 4 values (one per property)"});
  ExpectInputError([&] { ReadPly(Write("more.ply", head + "3 0 1 0\n3 1 0 1\n3 0 0 0\n")); },
                   {"more.ply:14: field 'end of file': found 'a line after the last element', expected nothing after the 2 "
                    "items of element 'face'"});
  // Binary: read whole and streamed.
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 6; ++i) Put<float>(&b, 1.0f);
  const size_t faces = b.size();
  for (int f = 0; f < 2; ++f) {
    b.push_back(3);
    for (int32_t index : {0, 1, 0}) Put<int32_t>(&b, index);
  }
  const auto stream = [](const std::string& path) { StreamPointCloud(path, 1, [](const PointCloud&, size_t, size_t) {}); };
  EXPECT_EQ(ReadPly(Write("ok_b.ply", b)).size(), 2u);
  stream(Write("ok_b.ply", b));
  const std::string cut = Write("cut_b.ply", b.substr(0, b.size() - 4));
  const std::string extra = Write("extra_b.ply", b + "junk");
  for (const bool streamed : {false, true}) {
    SCOPED_TRACE(streamed ? "streamed" : "whole");
    const auto read = [&](const std::string& path) { streamed ? stream(path) : (void)ReadPly(path); };
    ExpectInputError([&] { read(cut); },
                     {"cut_b.ply (byte " + std::to_string(faces + 14) + "): field 'vertex_indices': found 'end of file'"});
    ExpectInputError([&] { read(extra); },
                     {"extra_b.ply (byte " + std::to_string(b.size()) + "): field 'end of file': found '4 more bytes', "
                      "expected nothing after the 2 items of element 'face'"});
  }
  // An element before the vertices whose size wraps around 64 bits (2^62 records of 4 bytes)
  // is refused, not skipped by 0 bytes.
  std::string wrap =
      "ply\nformat binary_little_endian 1.0\nelement junk 4611686018427387904\nproperty float a\n"
      "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const size_t junk = wrap.size();
  for (int i = 0; i < 3; ++i) Put<float>(&wrap, 1.0f);
  const std::string wrapping = Write("wrap.ply", wrap);
  ExpectInputError([&] { ReadPly(wrapping); },
                   {"wrap.ply (byte " + std::to_string(junk) + "): field 'junk element': found 'end of file'"});
  ExpectInputError([&] { stream(wrapping); },
                   {"wrap.ply (byte " + std::to_string(junk) + "): field 'junk element': found 'end of file'"});
}

// The streamed reader starts the data where the header parser ends the header, as the whole
// reader does: also when the file ends on "end_header" without a newline (where the stream's
// position is -1) and when the end_header line has a trailing blank (where it reads on).
TEST_F(PointCloudIoTest, PlyStreamedDataStartWhereTheHeaderEnds) {
  const std::string head =
      "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
      "property float z\nend_header";
  const auto stream = [](const std::string& path) {
    std::vector<Eigen::Vector3d> points;
    StreamPointCloud(path, 3, [&](const PointCloud& chunk, size_t, size_t) {
      points.insert(points.end(), chunk.points.begin(), chunk.points.end());
    });
    return points;
  };
  const std::string empty = Write("empty.ply", head);
  EXPECT_EQ(ReadPly(empty).size(), 0u);
  EXPECT_TRUE(stream(empty).empty());

  std::string two = head;
  two.replace(two.find("vertex 0"), 8, "vertex 2");
  const std::string cut = Write("cut.ply", two);
  const std::string at = "cut.ply (byte " + std::to_string(two.size()) + "): field 'vertex element': found 'end of file'";
  ExpectInputError([&] { ReadPly(cut); }, {at, "truncated"});
  ExpectInputError([&] { stream(cut); }, {at, "truncated"});

  two += " \n";  // "end_header \n", then two points
  for (const float v : {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f}) Put<float>(&two, v);
  const std::string blank = Write("blank.ply", two);
  const std::vector<Eigen::Vector3d> expected = {{1, 2, 3}, {4, 5, 6}};
  EXPECT_EQ(ReadPly(blank).points, expected);
  EXPECT_EQ(stream(blank), expected);
}

// A list's count type is an integer type: a float count (here +inf, read as 00 00 80 7f) has
// no number of items, and is refused in the header, read whole or streamed.
TEST_F(PointCloudIoTest, PlyListCountTypeIsAnInteger) {
  std::string b =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty list float uchar idx\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n";
  Put<float>(&b, std::numeric_limits<float>::infinity());
  for (int i = 0; i < 3; ++i) Put<float>(&b, 1.0f);
  const std::string path = Write("count.ply", b);
  const std::string message =
      "count.ply:4: field 'count type': found 'float', expected an integer type: one of char uchar short ushort "
      "int uint";
  ExpectInputError([&] { ReadPly(path); }, {message});
  ExpectInputError([&] { StreamPointCloud(path, 3, [](const PointCloud&, size_t, size_t) {}); }, {message});
  b.replace(b.find("list float"), 10, "list double");
  ExpectInputError([&] { ReadPly(Write("count.ply", b)); }, {"found 'double', expected an integer type"});
  b.replace(b.find("list double"), 11, "list uint");
  ExpectInputError([&] { ReadPly(Write("count.ply", b)); }, {"count.ply (byte", "idx", "end of file"});
}

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

// Reads the cloud `path` with the address space limited to 1 GB, then exits: 2 on an InputError, 4 on
// std::bad_alloc, 0 on success, 3 when the limit cannot be set.
[[noreturn]] void ReadWithin1GB(const std::string& path) {
  const rlimit limit{rlim_t{1} << 30, rlim_t{1} << 30};
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(3);
  try {
    ReadPointCloud(path);
  } catch (const InputError&) {
    std::_Exit(2);
  } catch (const std::bad_alloc&) {
    std::_Exit(4);
  }
  std::_Exit(0);
}

// A header's vertex count reserves no more memory than the data can hold: a 300-byte file
// declaring 34294967295 vertices with all fields ends in the InputError of the truncated data,
// within 1 GB of address space (CloudBuilder's own cap, 2^26 points, would reserve 4 GB).
// Checked in a child process under RLIMIT_AS, which AddressSanitizer's shadow memory rules out.
TEST_F(PointCloudIoTest, PlyVertexCountReservesOnlyWhatTheDataHold) {
  const std::string path = Write(
      "huge.ply",
      "ply\nformat ascii 1.0\nelement vertex 34294967295\nproperty double x\nproperty double y\n"
      "property double z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float intensity\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty double time\nend_header\n"
      "1 2 3 0 0 1 0.5 10 20 30 100\n4 5 6 0 1 0 0.25 0 255 0 101\n");
  ExpectInputError([&] { ReadPly(path); }, {"huge.ply:18: field 'vertex': found 'end of file after 2 of 34294967295"});
  if (kAddressSanitizer) GTEST_SKIP() << "RLIMIT_AS and AddressSanitizer do not mix";
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(ReadWithin1GB(path), ::testing::ExitedWithCode(2), "");
}

// As PlyVertexCountReservesOnlyWhatTheDataHold, for an ASCII PCD declaring 60000000 points.
TEST_F(PointCloudIoTest, PcdPointCountReservesOnlyWhatTheDataHold) {
  const std::string path = Write(
      "huge.pcd",
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z normal_x normal_y normal_z intensity\nSIZE 4 4 4 4 4 4 4\n"
      "TYPE F F F F F F F\nCOUNT 1 1 1 1 1 1 1\nWIDTH 60000000\nHEIGHT 1\nPOINTS 60000000\nDATA ascii\n"
      "1 2 3 0 0 1 0.5\n");
  ExpectInputError([&] { ReadPcd(path); }, {"huge.pcd:12: field 'point': found 'end of file after 1 of 60000000"});
  if (kAddressSanitizer) GTEST_SKIP() << "RLIMIT_AS and AddressSanitizer do not mix";
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(ReadWithin1GB(path), ::testing::ExitedWithCode(2), "");
}

// A binary_compressed PCD declaring far more points than its LZF data can expand to is
// refused before the decompression buffer is allocated.
TEST_F(PointCloudIoTest, PcdCompressedSizeBeyondWhatLzfExpandsTo) {
  std::string text =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
      "WIDTH 300000000\nHEIGHT 1\nPOINTS 300000000\nDATA binary_compressed\n";
  const uint32_t sizes[2] = {4, 3600000000u};  // 4 bytes of LZF, 300 M points × 12 bytes
  text.append(reinterpret_cast<const char*>(sizes), sizeof(sizes));
  text.append("\x00\x00\x00\x00", 4);
  const std::string path = Write("lying.pcd", text);
  ExpectInputError([&] { ReadPcd(path); },
                   {"field 'uncompressed size': found '3600000000', expected at most 132 × the 4 bytes of LZF data"});
}

// A FIFO named as a cloud is refused before it is opened, by the streamed reader too. A
// writer thread serves a short text to every open, so that a reader that does open the FIFO
// returns (and the test fails instead of hanging).
TEST_F(PointCloudIoTest, AFifoIsNotOpened) {
  const std::string fifo = (dir_ / "pipe.ply").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto error_of = [&](const auto& read) {
    std::atomic<bool> done{false};
    std::thread writer([&] {
      while (true) {
        const int fd = ::open(fifo.c_str(), O_WRONLY);  // waits for a reader
        if (fd < 0 || done) {
          if (fd >= 0) ::close(fd);
          return;
        }
        (void)!::write(fd, "ply\n", 4);
        ::close(fd);
      }
    });
    std::string message = "no error";
    try {
      read();
    } catch (const InputError& e) {
      message = e.what();
    }
    done = true;
    const int release = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);  // frees the waiting writer
    writer.join();
    if (release >= 0) ::close(release);
    return message;
  };
  const std::string expected = fifo + ": is a FIFO (named pipe), expected a regular file";
  EXPECT_EQ(error_of([&] { ReadPointCloud(fifo); }), expected);
  EXPECT_EQ(error_of([&] { StreamPointCloud(fifo, 10, [](const PointCloud&, size_t, size_t) {}); }), expected);
}

TEST_F(PointCloudIoTest, PcdAsciiBinaryAndCompressed) {
  // ascii with packed float rgb (PCL writes rgb as the float with the colour's bits).
  const uint32_t bits = (10u << 16) | (20u << 8) | 30u;
  float packed;
  std::memcpy(&packed, &bits, 4);
  char rgb_text[64];
  std::snprintf(rgb_text, sizeof(rgb_text), "%.9g", packed);
  const std::string ascii = std::string(
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
      "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1 2 3 ") +
      rgb_text + "\nnan nan nan " + rgb_text + "\n";
  ExpectInputError([&] { ReadPcd(Write("a.pcd", ascii)); }, {"a.pcd:13", "non-finite"});
  ReadOptions skip;
  skip.skip_invalid_points = true;
  PointCloud c = ReadPointCloud(Write("a2.pcd", ascii), skip);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_EQ(c.colors[0], (std::array<uint8_t, 3>{10, 20, 30}));
  {
    // An organised cloud (HEIGHT > 1: a depth camera's pixel grid) marks pixels without a
    // return by all-NaN points: dropped and counted without skip_invalid_points; a point
    // with only some coordinates NaN is still an error.
    std::string organised = ascii;
    organised.replace(organised.find("WIDTH 2\nHEIGHT 1"), 16, "WIDTH 1\nHEIGHT 2");
    ReadStats organised_stats;
    const PointCloud o = ReadPointCloud(Write("org.pcd", organised), {}, &organised_stats);
    ASSERT_EQ(o.size(), 1u);
    EXPECT_EQ(organised_stats.num_skipped, 1u);
    std::string partial = organised;
    partial.replace(partial.find("nan nan nan"), 11, "1 nan 3");
    ExpectInputError([&] { ReadPcd(Write("org2.pcd", partial)); }, {"org2.pcd:13", "non-finite"});
  }

  // binary (AoS) with normals and a uint8 intensity.
  std::string bin =
      "VERSION 0.7\nFIELDS x y z normal_x normal_y normal_z intensity\nSIZE 4 4 4 4 4 4 1\n"
      "TYPE F F F F F F U\nCOUNT 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n";
  for (int i = 0; i < 2; ++i) {
    for (float v : {1.0f * i, 2.0f, 3.0f, 0.0f, 0.0f, 1.0f}) Put<float>(&bin, v);
    bin.push_back(static_cast<char>(7 + i));
  }
  c = ReadPcd(Write("b.pcd", bin));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(c.normals[1], Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(c.intensity[1], 8.0f);
  ExpectInputError([&] { ReadPcd(Write("bt.pcd", bin.substr(0, bin.size() - 3))); },
                   {"bt.pcd", "truncated"});

  // binary_compressed with an LZF stream made of literal runs only (valid LZF).
  std::string soa;
  for (float v : {1.0f, 4.0f}) Put<float>(&soa, v);
  for (float v : {2.0f, 5.0f}) Put<float>(&soa, v);
  for (float v : {3.0f, 6.0f}) Put<float>(&soa, v);
  std::string lzf;
  lzf.push_back(static_cast<char>(soa.size() - 1));  // one literal run of 24 bytes
  lzf += soa;
  std::string comp =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
      "POINTS 2\nDATA binary_compressed\n";
  Put<uint32_t>(&comp, static_cast<uint32_t>(lzf.size()));
  Put<uint32_t>(&comp, static_cast<uint32_t>(soa.size()));
  comp += lzf;
  ReadStats stats;
  c = ReadPcd(Write("c.pcd", comp), {}, &stats);
  EXPECT_EQ(stats.format, "pcd-binary-compressed");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3d(4, 5, 6));
  std::string corrupt = comp;
  corrupt[corrupt.size() - lzf.size()] = 40;  // literal run longer than the data
  ExpectInputError([&] { ReadPcd(Write("cc.pcd", corrupt)); }, {"cc.pcd", "LZF"});

  ExpectInputError([&] { ReadPcd(Write("h.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4\n")); },
                   {"h.pcd:3", "SIZE"});
  // Damaged counts that wrap around 64 bits (POINTS × 12 bytes; WIDTH × HEIGHT): refused, not
  // read past the data.
  const std::string wrapping = std::to_string(std::numeric_limits<uint64_t>::max() / 12 + 1);
  ExpectInputError([&] {
    ReadPcd(Write("w.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + wrapping +
                               "\nHEIGHT 1\nPOINTS " + wrapping + "\nDATA binary\n" + std::string(48, '\0')));
  }, {"w.pcd", "POINTS", "damaged header"});
  ExpectInputError([&] {
    ReadPcd(Write("wh.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4294967297\n"
                            "HEIGHT 4294967297\nDATA binary\n" + std::string(48, '\0')));
  }, {"wh.pcd", "WIDTH", "64 bits"});
  ExpectInputError([&] {
    ReadPcd(Write("p.pcd", "FIELDS rgba\nSIZE 4\nTYPE U\nCOUNT 1\nWIDTH 1\nHEIGHT 1\n"
                           "POINTS 1\nDATA ascii\n5\n"));
  }, {"p.pcd", "no x"});
}

TEST_F(PointCloudIoTest, PclTestFilesFromDataFolder) {
  const std::string dir = std::string(MMBA_SOURCE_DIR) + "/data/pointclouds/pcl_test/";
  if (!fs::exists(dir + "bun0.pcd")) GTEST_SKIP() << "data/pointclouds/pcl_test absent";
  const PointCloud bun0 = ReadPointCloud(dir + "bun0.pcd");
  EXPECT_EQ(bun0.size(), 397u);
  EXPECT_TRUE(bun0.has_normals());
  EXPECT_NEAR(bun0.points[0].x(), 0.0054215998, 1e-9);
  if (fs::exists(dir + "milk_color.pcd")) {
    ReadStats stats;
    const PointCloud milk = ReadPointCloud(dir + "milk_color.pcd", {}, &stats);
    EXPECT_EQ(stats.format, "pcd-binary-compressed");
    EXPECT_EQ(milk.size(), 13704u);
    EXPECT_TRUE(milk.has_colors());
  }
}

TEST_F(PointCloudIoTest, XyzVariants) {
  PointCloud c = ReadPointCloud(Write("a.xyz", "# comment\n1 2 3\n4 5 6\n\n"));
  EXPECT_EQ(c.size(), 2u);
  c = ReadPointCloud(Write("b.txt", "1,2,3,255,0,7\n4,5,6,1,2,3\n"));
  ASSERT_TRUE(c.has_colors());
  EXPECT_EQ(c.colors[0][2], 7);
  c = ReadPointCloud(Write("c.xyz", "1 2 3 0 0.6 0.8\n"));
  ASSERT_TRUE(c.has_normals());
  EXPECT_DOUBLE_EQ(c.normals[0].z(), 0.8);
  // Six unnamed columns: colours 0..1 are not taken for a normal (they are not a unit vector);
  // a normal guessed from the first line must be one on every line.
  c = ReadPointCloud(Write("c2.xyz", "1 2 3 0.2 0.5 1\n4 5 6 0 1 0.5\n"));
  ASSERT_TRUE(c.has_colors());
  EXPECT_FALSE(c.has_normals());
  EXPECT_EQ(c.colors[0][1], 128);
  EXPECT_EQ(c.colors[1][2], 128);
  ExpectInputError([&] { ReadPointCloud(Write("c3.xyz", "1 2 3 0 0.6 0.8\n4 5 6 0.3 0.2 0.1\n")); },
                   {"c3.xyz:2", "unit normal", "line 1"});
  ExpectInputError([&] { ReadPointCloud(Write("c4.xyz", "1 2 3 0.5 -2 7\n")); },
                   {"c4.xyz:1", "columns 4-6", "0.5 -2 7"});
  ExpectInputError([&] { ReadPointCloud(Write("c5.xyz", "1 2 3 0.2 0.5 1\n4 5 6 0 1 2\n")); },
                   {"c5.xyz:2", "0..1"});
  c = ReadPointCloud(Write("d.csv", "X,Y,Z,Intensity\n1,2,3,0.25\n"));
  ASSERT_TRUE(c.has_intensity());
  EXPECT_FLOAT_EQ(c.intensity[0], 0.25f);
  c = ReadPointCloud(Write("e.pts", "2\n1 2 3 5 1 2 3\n1 2 3 6 4 5 6\n"));
  ASSERT_TRUE(c.has_intensity() && c.has_colors());
  EXPECT_FLOAT_EQ(c.intensity[1], 6.0f);
  c = ReadPointCloud(Write("f.txt", "//X,Y,Z,R,G,B\n1,2,3,4,5,6\n"));
  EXPECT_EQ(c.colors[0][0], 4);
  ExpectInputError([&] { ReadPointCloud(Write("g.xyz", "1 2 3\n4 5\n")); }, {"g.xyz:2", "2 values"});
  ExpectInputError([&] { ReadPointCloud(Write("h.xyz", "1 2 3\n4 5 z\n")); }, {"h.xyz:2", "'z'"});
  ExpectInputError([&] { ReadPointCloud(Write("i.xyz", "1 2 3\n4 NaN 6\n")); },
                   {"i.xyz:2", "non-finite y = nan"});
  ExpectInputError([&] { ReadPointCloud(Write("i2.xyz", "1 2 3 1\n4 5 -inf inf\n")); },
                   {"i2.xyz:2", "non-finite z = -inf, intensity = inf"});
  ExpectInputError([&] { ReadPointCloud(Write("j.xyz", "1 2 3 4 5\n")); },
                   {"j.xyz:1", "column count"});
  // A file without a point is an empty cloud, as a PLY with 0 vertices is.
  EXPECT_TRUE(ReadPointCloud(Write("k.xyz", "# nothing\n")).empty());
  EXPECT_TRUE(ReadPointCloud(Write("k2.xyz", "")).empty());
  EXPECT_TRUE(ReadPointCloud(Write("k3.xyz", "x y z intensity\n")).empty());
  // ... but a header that names no coordinates, or binary data, is not a cloud.
  ExpectInputError([&] { ReadPointCloud(Write("k4.xyz", "alpha beta gamma\n")); }, {"k4.xyz", "x, y and z"});
  ExpectInputError([&] { ReadPointCloud(Write("k5.xyz", std::string("1 2 3\n\0\0\0\n", 10))); },
                   {"k5.xyz:2", "NUL byte"});
  ExpectInputError([&] { ReadPointCloud(Write("l.obj", "v 1 2 3\n")); }, {"l.obj", ".obj"});
}

// Spreadsheets in most of Europe write a decimal comma: with ';' between the values, or with
// blanks. Such a line must not be read as six numbers (x y z r g b, as the comma-separated
// "1000,11,2002,27,120,81" is), and a comma-separated file must still read as one.
TEST_F(PointCloudIoTest, XyzDecimalCommas) {
  for (const std::string& text : {std::string("1000,11;2002,27;120,81\n-1,5;0,25;3\n"),
                                  std::string("X;Y;Z\n1000,11;2002,27;120,81\n-1,5;0,25;3\n"),
                                  std::string("x y z\n1000,11 2002,27 120,81\n-1,5\t0,25 3\n"),
                                  std::string("1000,11 2002,27 120,81\n-1,5 0,25 3\n"),
                                  std::string("1000.11;2002.27;120.81\n-1.5;0.25;3\n")}) {
    SCOPED_TRACE(text);
    const PointCloud c = ReadPointCloud(Write("eu.csv", text));
    ASSERT_EQ(c.size(), 2u);
    EXPECT_FALSE(c.has_colors());
    EXPECT_NEAR((c.points[0] - Eigen::Vector3d(1000.11, 2002.27, 120.81)).norm(), 0.0, 1e-9);
    EXPECT_NEAR((c.points[1] - Eigen::Vector3d(-1.5, 0.25, 3.0)).norm(), 0.0, 1e-12);
  }
  // Commas that separate (with or without blanks after them) stay separators.
  for (const std::string& text : {std::string("1.5,2.5,3.5\n4,5,6\n"), std::string("1.5, 2.5, 3.5\n4, 5, 6\n")}) {
    const PointCloud c = ReadPointCloud(Write("us.csv", text));
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c.points[0], Eigen::Vector3d(1.5, 2.5, 3.5));
    EXPECT_EQ(c.points[1], Eigen::Vector3d(4, 5, 6));
  }
  // A decimal-comma file whose later line separates by commas is refused at that line.
  ExpectInputError([&] { ReadPointCloud(Write("mixed.csv", "1,5;2,5;3,5\n4.5,5.5,6.5\n")); },
                   {"mixed.csv:2", "'4.5,5.5,6.5'", "decimal comma", "as line 1"});
}

// Headers as other programs write them: a UTF-8 byte-order mark, quoted names, a surveyor's
// easting/northing/height, a unit after the name. A header without x, y and z names its line
// and the names it holds.
TEST_F(PointCloudIoTest, XyzHeadersOfOtherPrograms) {
  for (const std::string& header : {std::string("\xEF\xBB\xBFx,y,z"), std::string("\"X\",\"Y\",\"Z\""),
                                    std::string("Easting,Northing,Height"), std::string("E N H"),
                                    std::string("X [m],Y [m],Z [m]"), std::string("X[m] Y[m] Z[m]")}) {
    SCOPED_TRACE(header);
    const PointCloud c = ReadPointCloud(Write("h.csv", header + "\n1,2,3\n4,5,6\n"));
    ASSERT_EQ(c.size(), 2u);
    EXPECT_EQ(c.points[1], Eigen::Vector3d(4, 5, 6));
  }
  // A byte-order mark before the first point (no header) is not part of its x.
  const PointCloud bom = ReadPointCloud(Write("bom.xyz", "\xEF\xBB\xBF" "1 2 3\n"));
  ASSERT_EQ(bom.size(), 1u);
  EXPECT_EQ(bom.points[0], Eigen::Vector3d(1, 2, 3));
  // The header is described, not quoted (any file can be named as a cloud).
  ExpectInputError([&] { ReadPointCloud(Write("lat.csv", "# exported\nLat,Lon,Alt\n1,2,3\n")); },
                   {"lat.csv:2: field 'columns': found '3 column names, none of them x, y or z'", "x, y and z"});
  ExpectInputError([&] { ReadPointCloud(Write("xy.csv", "x,y,alt\n")); },
                   {"xy.csv:1: field 'columns': found '3 column names, of x, y and z only x, y (and no point)'"});
  // A PLY with a byte-order mark before "ply".
  WritePly(MakeCloud(), (dir_ / "plain.ply").string(), /*ascii=*/true);
  std::ifstream in(dir_ / "plain.ply", std::ios::binary);
  const std::string ply((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(ReadPointCloud(Write("bom.ply", "\xEF\xBB\xBF" + ply)).points,
            ReadPointCloud((dir_ / "plain.ply").string()).points);
}

// A LAS file made by hand after the ASPRS LAS 1.4 R15 tables.
std::string MakeLas(int minor, int format, const std::vector<Eigen::Vector3i>& raw,
                    uint16_t extra_record_bytes = 0) {
  static const uint16_t kLength[] = {20, 28, 26, 34, 57, 63, 30, 36, 38};
  const uint16_t header_size = minor == 4 ? 375 : (minor == 3 ? 235 : 227);
  const uint16_t length = kLength[format] + extra_record_bytes;
  std::string s = "LASF";
  Put<uint16_t>(&s, 0);  // file source id
  Put<uint16_t>(&s, 0);  // global encoding
  s.append(16, '\0');    // GUID
  s.push_back(1);
  s.push_back(static_cast<char>(minor));
  s.append(64, ' ');  // system id, generating software
  Put<uint16_t>(&s, 1);
  Put<uint16_t>(&s, 2026);
  Put<uint16_t>(&s, header_size);
  Put<uint32_t>(&s, header_size + 10);  // offset to point data (10 bytes of padding)
  Put<uint32_t>(&s, 0);                 // number of VLRs
  s.push_back(static_cast<char>(format));
  Put<uint16_t>(&s, length);
  Put<uint32_t>(&s, format >= 6 ? 0 : static_cast<uint32_t>(raw.size()));
  for (int i = 0; i < 5; ++i) Put<uint32_t>(&s, 0);
  for (double v : {0.001, 0.001, 0.01}) Put<double>(&s, v);      // scale
  for (double v : {500000.0, 4000000.0, 100.0}) Put<double>(&s, v);  // offset
  for (int i = 0; i < 6; ++i) Put<double>(&s, 0.0);              // bounds
  if (minor >= 3) Put<uint64_t>(&s, 0);
  if (minor == 4) {
    Put<uint64_t>(&s, 0);
    Put<uint32_t>(&s, 0);
    Put<uint64_t>(&s, raw.size());
    for (int i = 0; i < 15; ++i) Put<uint64_t>(&s, 0);
  }
  EXPECT_EQ(s.size(), header_size);
  s.append(10, '\0');
  for (size_t i = 0; i < raw.size(); ++i) {
    const size_t start = s.size();
    for (int k = 0; k < 3; ++k) Put<int32_t>(&s, raw[i][k]);
    Put<uint16_t>(&s, static_cast<uint16_t>(100 + i));  // intensity
    if (format <= 5) {
      s.append(4, '\0');  // return bits, class, scan angle, user data
      Put<uint16_t>(&s, 0);
      if (format == 1 || format == 3) Put<double>(&s, 10.5 + i);  // GPS time
    } else {
      s.append(4, '\0');
      Put<int16_t>(&s, 0);
      Put<uint16_t>(&s, 0);
      Put<double>(&s, 10.5 + i);  // GPS time
    }
    if (format == 2 || format == 3 || format == 7 || format == 8) {
      for (uint16_t c : {uint16_t(65535), uint16_t(256 * 10), uint16_t(0)}) Put<uint16_t>(&s, c);
    }
    if (format == 8) Put<uint16_t>(&s, 0);
    s.append(extra_record_bytes, '\0');
    EXPECT_EQ(s.size() - start, length);
  }
  return s;
}

TEST_F(PointCloudIoTest, LasFormatsAndVersions) {
  const std::vector<Eigen::Vector3i> raw = {{1000, -2000, 50}, {-1, 0, 123456}};
  struct Case { int minor, format; };
  for (const Case& k : {Case{2, 0}, Case{2, 1}, Case{2, 2}, Case{3, 3}, Case{4, 1}, Case{4, 6},
                        Case{4, 7}, Case{4, 8}}) {
    SCOPED_TRACE("LAS 1." + std::to_string(k.minor) + " format " + std::to_string(k.format));
    ReadStats stats;
    const PointCloud c = ReadLas(Write("a.las", MakeLas(k.minor, k.format, raw, 3)), {}, &stats);
    ASSERT_EQ(c.size(), 2u);
    EXPECT_NEAR(c.points[0].x(), 500001.0, 1e-9);
    EXPECT_NEAR(c.points[0].y(), 3999998.0, 1e-9);
    EXPECT_NEAR(c.points[0].z(), 100.5, 1e-9);
    EXPECT_NEAR(c.points[1].z(), 1334.56, 1e-9);
    EXPECT_EQ(c.intensity[1], 101.0f);
    const bool rgb = k.format == 2 || k.format == 3 || k.format >= 7;
    EXPECT_EQ(c.has_colors(), rgb);
    if (rgb) {
      EXPECT_EQ(c.colors[0], (std::array<uint8_t, 3>{255, 10, 0}));
    }
    const bool time = k.format == 1 || k.format == 3 || k.format >= 6;
    ASSERT_EQ(c.has_time(), time);
    if (time) {
      EXPECT_EQ(c.time[0], 10.5);
      EXPECT_EQ(c.time[1], 11.5);
    }
  }
}

TEST_F(PointCloudIoTest, LasBrokenFixtures) {
  const std::vector<Eigen::Vector3i> raw = {{1, 2, 3}, {4, 5, 6}};
  std::string ok = MakeLas(2, 1, raw);
  ExpectInputError([&] { ReadLas(Write("s.las", "LASX" + ok.substr(4))); },
                   {"s.las (byte 0)", "signature"});
  ExpectInputError([&] { ReadLas(Write("t.las", ok.substr(0, ok.size() - 5))); },
                   {"t.las", "truncated"});
  ExpectInputError([&] { ReadLas(Write("h.las", ok.substr(0, 100))); }, {"h.las", "227 bytes"});
  std::string v = ok;
  v[25] = 0;
  ExpectInputError([&] { ReadLas(Write("v.las", v)); }, {"v.las (byte 24)", "1.0"});
  std::string z = MakeLas(4, 6, raw);
  z[104] = static_cast<char>(0x86);
  ExpectInputError([&] { ReadLas(Write("z.las", z)); }, {"z.las (byte 104)", "LAZ"});
  std::string f = ok;
  f[104] = 4;
  ExpectInputError([&] { ReadLas(Write("f.las", f)); }, {"point data format", "'4'"});
  std::string sc = ok;
  const double zero = 0.0;
  std::memcpy(&sc[131], &zero, 8);
  ExpectInputError([&] { ReadLas(Write("sc.las", sc)); }, {"sc.las (byte 131)", "x scale"});
  ExpectInputError([&] { ReadPointCloud(Write("c.laz", ok)); }, {"c.laz", "LAZ"});
  // A damaged LAS 1.4 64-bit point count (byte 247) whose product with the record length
  // wraps around 64 bits: refused as truncated, not read past the data.
  std::string wrap = MakeLas(4, 6, raw);
  const uint64_t wrapping = std::numeric_limits<uint64_t>::max() / 30 + 1;
  std::memcpy(&wrap[247], &wrapping, 8);
  ExpectInputError([&] { ReadLas(Write("wrap.las", wrap)); }, {"wrap.las", "more than 2^64", "truncated"});
  // A count of variable length records (byte 100) that cannot fit before the point data.
  std::string vlr = ok;
  const uint32_t all_ones = 0xFFFFFFFFu;
  std::memcpy(&vlr[100], &all_ones, 4);
  ExpectInputError([&] { ReadLas(Write("vlr.las", vlr)); },
                   {"vlr.las (byte 100): field 'number of variable length records': found '4294967295', expected records "
                    "that fit between the header and the point data (byte 237): record 0 would start at byte 227"});
}

// A file of another kind is not quoted back.
TEST_F(PointCloudIoTest, PcdAndLasOfAnotherKindAreNotQuoted) {
  const std::string passwd = "root:x:0:0:root:/root:/bin/bash\n";
  ExpectInputError([&] { ReadPcd(Write("p.pcd", passwd)); },
                   {"p.pcd:1: field 'keyword': found 'a first word that is not a PCD keyword'", "(not a PCD file?)"});
  ExpectInputError([&] { ReadLas(Write("p.las", passwd + std::string(300, 'x'))); },
                   {"p.las (byte 0): field 'file signature': found 'other bytes', expected 'LASF' (not a LAS file?)"});
  // Once the file is known to be a PCD, a wrong keyword is quoted.
  ExpectInputError([&] { ReadPcd(Write("k.pcd", "VERSION 0.7\nFIELDZ x y z\n")); }, {"k.pcd:2", "'FIELDZ'"});
}

TEST_F(PointCloudIoTest, KittiBin) {
  std::string s;
  for (float v : {1.0f, 2.0f, 3.0f, 0.5f, -1.0f, -2.0f, -3.0f, 0.25f}) Put<float>(&s, v);
  const PointCloud c = ReadPointCloud(Write("000000.bin", s));
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(c.intensity[1], 0.25f);
  ExpectInputError([&] { ReadPointCloud(Write("t.bin", s.substr(0, 30))); },
                   {"t.bin (byte 16)", "multiple of 16"});
  std::string n = s;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&n[4], &nan, 4);
  ExpectInputError([&] { ReadPointCloud(Write("n.bin", n)); }, {"n.bin (byte 0)", "non-finite y = nan"});
  const PointCloud empty = ReadPointCloud(Write("e.bin", ""));
  EXPECT_TRUE(empty.empty());
}

// StreamPointCloud hands over the same points as ReadPointCloud, in file order and in chunks
// of the size asked, from binary PLY read piecewise and from every other format read whole;
// a cloud written as header + chunks of records reads back equal.
TEST_F(PointCloudIoTest, StreamedChunksEqualTheWholeCloud) {
  PointCloud c;
  for (int i = 0; i < 1003; ++i) {
    c.points.emplace_back(0.5 * i, -0.25 * i, 1000.0 + i);
    c.intensity.push_back(static_cast<float>(i % 7));
    c.time.push_back(100.0 + 0.001 * i);
  }
  const std::string binary = (dir_ / "c.ply").string(), ascii = (dir_ / "a.ply").string();
  {
    std::ofstream out(binary, std::ios::binary);
    WritePlyHeader(out, c.size(), c);
    PointCloud piece;
    for (size_t first = 0; first < c.size(); first += 400) {
      const size_t end = std::min(c.size(), first + 400);
      piece.points.assign(c.points.begin() + first, c.points.begin() + end);
      piece.intensity.assign(c.intensity.begin() + first, c.intensity.begin() + end);
      piece.time.assign(c.time.begin() + first, c.time.begin() + end);
      AppendPlyRecords(out, piece);
    }
  }
  WritePly(c, ascii, /*ascii=*/true);
  for (const std::string& path : {binary, ascii}) {
    SCOPED_TRACE(path);
    const PointCloud whole = ReadPointCloud(path);
    ASSERT_EQ(whole.size(), c.size());
    PointCloud joined;
    std::vector<size_t> sizes;
    ReadStats stats;
    StreamPointCloud(path, 250, [&](const PointCloud& chunk, size_t first, size_t total) {
      EXPECT_EQ(first, joined.size());
      EXPECT_EQ(total, c.size());
      sizes.push_back(chunk.size());
      joined.points.insert(joined.points.end(), chunk.points.begin(), chunk.points.end());
      joined.intensity.insert(joined.intensity.end(), chunk.intensity.begin(), chunk.intensity.end());
      joined.time.insert(joined.time.end(), chunk.time.begin(), chunk.time.end());
    }, {}, &stats);
    EXPECT_EQ(sizes, (std::vector<size_t>{250, 250, 250, 250, 3}));
    EXPECT_EQ(stats.num_read, c.size());
    EXPECT_EQ(stats.format, path == binary ? "ply-binary-le" : "ply-ascii");
    EXPECT_EQ(joined.points, whole.points);
    EXPECT_EQ(joined.intensity, whole.intensity);
    EXPECT_EQ(joined.time, whole.time);
    EXPECT_EQ(joined.time, c.time);
  }
  // A truncated binary file: the error names the file and the points that are missing, and a
  // non-finite point names its index in the whole file, not in its chunk.
  std::string bytes;
  {
    std::ifstream in(binary, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string cut = Write("cut.ply", bytes.substr(0, bytes.size() - 10));
  ExpectInputError([&] { StreamPointCloud(cut, 250, [](const PointCloud&, size_t, size_t) {}); },
                   {"cut.ply", "truncated", "points 1000"});
  std::string bad = bytes;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const size_t record = 3 * sizeof(double) + sizeof(float) + sizeof(double);
  std::memcpy(&bad[bytes.size() - (c.size() - 777) * record], &nan, sizeof(double));
  const std::string with_nan = Write("nan.ply", bad);
  ExpectInputError([&] { StreamPointCloud(with_nan, 250, [](const PointCloud&, size_t, size_t) {}); },
                   {"nan.ply", "point 777", "non-finite"});
}

}  // namespace
}  // namespace mmba::io
