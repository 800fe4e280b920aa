// The LiDAR formats of camera–LiDAR data sets: PCD binary_compressed (LZF) with the fields
// drivers write (intensity under other names and types, ring, timestamp), the ascii PCD of
// OpenCalib's manual_calib, nuScenes .pcd.bin, and the LZF decoder on hand-made streams.

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/core/error.h"
#include "mmba/io_cloud/lzf.h"
#include "mmba/io_cloud/point_cloud.h"

namespace mmba::io {
namespace {

namespace fs = std::filesystem;

const std::string kPjlab = std::string(MMBA_SOURCE_DIR) + "/data/lidar_camera/pjlab/";
const std::string kFixtures = std::string(MMBA_SOURCE_DIR) + "/tests/data/pcd/";

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

class LidarFormatsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mmba_lidar_formats_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
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

std::vector<uint8_t> Bytes(std::initializer_list<int> values) {
  std::vector<uint8_t> out;
  for (int v : values) out.push_back(static_cast<uint8_t>(v));
  return out;
}

LzfProblem Decode(const std::vector<uint8_t>& in, size_t out_size, std::string* out, size_t* at = nullptr) {
  std::vector<uint8_t> buffer(out_size);
  const LzfProblem problem = LzfDecompress(in.data(), in.size(), buffer.data(), out_size, at);
  out->assign(buffer.begin(), buffer.end());
  return problem;
}

TEST(Lzf, HandMadeStreams) {
  std::string out;
  // A literal run: control 2 = 3 bytes follow.
  EXPECT_EQ(Decode(Bytes({2, 'a', 'b', 'c'}), 3, &out), LzfProblem::kNone);
  EXPECT_EQ(out, "abc");
  // "abc" then a back reference of length (4 + 2) = 6 at offset 2 + 1 = 3: overlapping copy.
  EXPECT_EQ(Decode(Bytes({2, 'a', 'b', 'c', 4 << 5, 2}), 9, &out), LzfProblem::kNone);
  EXPECT_EQ(out, "abcabcabc");
  // A long back reference: control 7 << 5, length 7 + 11 + 2 = 20, offset 0 + 1 = 1.
  EXPECT_EQ(Decode(Bytes({0, 'x', 7 << 5, 11, 0}), 21, &out), LzfProblem::kNone);
  EXPECT_EQ(out, std::string(21, 'x'));
  // A back reference's high offset bits sit in the control byte: offset (1 << 8) + 0 + 1 = 257.
  std::vector<uint8_t> far = {31};
  for (int i = 0; i < 32; ++i) far.push_back(static_cast<uint8_t>(i));
  for (int run = 0; run < 7; ++run) {
    far.push_back(31);
    for (int i = 0; i < 32; ++i) far.push_back(static_cast<uint8_t>(32 * (run + 1) + i));
  }
  far.push_back(static_cast<uint8_t>((1 << 5) | 1));  // length 3, offset 257 of 256 written
  far.push_back(0);
  EXPECT_EQ(Decode(far, 259, &out), LzfProblem::kBadBackReference);
  far.insert(far.end() - 2, {0, 0xAA});  // one more literal byte: 257 written
  EXPECT_EQ(Decode(far, 260, &out), LzfProblem::kNone);
  EXPECT_EQ(static_cast<uint8_t>(out[257]), 0);
  EXPECT_EQ(static_cast<uint8_t>(out[259]), 2);
}

TEST(Lzf, BrokenStreams) {
  std::string out;
  size_t at = 99;
  // A literal run of 4 announced, 2 present: a cut-off block, found at its control byte.
  EXPECT_EQ(Decode(Bytes({1, 'a', 'b', 3, 'c', 'd'}), 6, &out, &at), LzfProblem::kTruncatedInput);
  EXPECT_EQ(at, 3u);
  // A back reference without its offset byte; a long one without its length byte.
  EXPECT_EQ(Decode(Bytes({0, 'a', 1 << 5}), 4, &out), LzfProblem::kTruncatedInput);
  EXPECT_EQ(Decode(Bytes({0, 'a', 7 << 5}), 20, &out), LzfProblem::kTruncatedInput);
  // Offset 2 with 1 byte written.
  EXPECT_EQ(Decode(Bytes({0, 'a', 1 << 5, 1}), 4, &out), LzfProblem::kBadBackReference);
  // More or fewer bytes than declared.
  EXPECT_EQ(Decode(Bytes({2, 'a', 'b', 'c'}), 2, &out), LzfProblem::kOutputOverflow);
  EXPECT_EQ(Decode(Bytes({0, 'a', 1 << 5, 0}), 3, &out), LzfProblem::kOutputOverflow);
  EXPECT_EQ(Decode(Bytes({2, 'a', 'b', 'c'}), 5, &out), LzfProblem::kShortOutput);
  EXPECT_NE(std::string(LzfProblemText(LzfProblem::kTruncatedInput)).find("end of the compressed data"),
            std::string::npos);
}

// ours_1/calib.pcd of OpenCalib's auto_calib_v2.0: binary_compressed, x y z intensity (F4)
// ring (U2) timestamp (F8). Values checked against a separate decoding of the file (Python).
TEST(PjlabClouds, CompressedPcdWithRingAndTimestamp) {
  const std::string path = kPjlab + "ours_1/calib.pcd";
  if (!fs::exists(path)) GTEST_SKIP() << path << " absent";
  ReadStats stats;
  const PointCloud cloud = ReadPointCloud(path, {}, &stats);
  EXPECT_EQ(stats.format, "pcd-binary-compressed");
  ASSERT_EQ(cloud.size(), 101340u);
  ASSERT_TRUE(cloud.has_intensity());
  ASSERT_TRUE(cloud.has_ring());
  EXPECT_FALSE(cloud.has_time());  // the timestamp field is not read
  EXPECT_NEAR(cloud.points[0].x(), -129.12721252441406, 1e-9);
  EXPECT_NEAR(cloud.points[0].y(), 7.275851249694824, 1e-9);
  EXPECT_NEAR(cloud.points[0].z(), -3.0501368045806885, 1e-9);
  EXPECT_EQ(cloud.intensity[0], 40.0f);
  EXPECT_EQ(cloud.ring[0], 38);
  EXPECT_EQ(cloud.ring[1], 36);
  EXPECT_NEAR(cloud.points.back().x(), -4.465167999267578, 1e-9);
  EXPECT_EQ(cloud.ring.back(), 0);
  EXPECT_EQ(*std::max_element(cloud.ring.begin(), cloud.ring.end()), 63);
  EXPECT_EQ(*std::max_element(cloud.intensity.begin(), cloud.intensity.end()), 254.0f);
}

// manual_calib/0.pcd of OpenCalib's manual_calib: ascii, x y z intensity.
TEST(PjlabClouds, AsciiPcd) {
  const std::string path = kPjlab + "manual_calib/0.pcd";
  if (!fs::exists(path)) GTEST_SKIP() << path << " absent";
  ReadStats stats;
  const PointCloud cloud = ReadPointCloud(path, {}, &stats);
  EXPECT_EQ(stats.format, "pcd-ascii");
  ASSERT_EQ(cloud.size(), 78238u);
  EXPECT_FALSE(cloud.has_ring());
  EXPECT_EQ(cloud.points[0], Eigen::Vector3d(21.647913, 0.19822195, -1.8524752));
  EXPECT_EQ(cloud.intensity[0], 11.0f);
  EXPECT_EQ(cloud.points.back(), Eigen::Vector3d(8.4264965, -0.11148447, -1.9415526));
  EXPECT_EQ(cloud.intensity.back(), 25.0f);
}

// The real file cut 600 bytes into its compressed block (tests/data/pcd).
TEST(PjlabClouds, TruncatedCompressedBlockNamesTheFile) {
  ExpectInputError([] { ReadPointCloud(kFixtures + "calib_truncated_compressed.pcd"); },
                   {"calib_truncated_compressed.pcd", "compressed data", "end of file", "1452426 bytes"});
}

// A binary_compressed PCD of two points with `fields` (name size type), each field's values
// given per point as doubles, compressed as literal runs.
std::string CompressedPcd(const std::vector<std::string>& names, const std::vector<int>& sizes,
                          const std::string& types, const std::vector<std::vector<double>>& values) {
  std::string header = "VERSION 0.7\nFIELDS";
  for (const auto& n : names) header += " " + n;
  header += "\nSIZE";
  for (int s : sizes) header += " " + std::to_string(s);
  header += "\nTYPE";
  for (char t : types) header += std::string(" ") + t;
  header += "\nCOUNT";
  for (size_t i = 0; i < names.size(); ++i) header += " 1";
  header += "\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary_compressed\n";
  std::string soa;
  for (size_t f = 0; f < names.size(); ++f) {
    for (double v : values[f]) {
      if (types[f] == 'F' && sizes[f] == 4) Put<float>(&soa, static_cast<float>(v));
      else if (types[f] == 'F') Put<double>(&soa, v);
      else if (sizes[f] == 1) Put<uint8_t>(&soa, static_cast<uint8_t>(v));
      else if (sizes[f] == 2) Put<uint16_t>(&soa, static_cast<uint16_t>(v));
      else Put<uint32_t>(&soa, static_cast<uint32_t>(v));
    }
  }
  std::string lzf;
  for (size_t at = 0; at < soa.size(); at += 32) {
    const size_t n = std::min<size_t>(32, soa.size() - at);
    lzf.push_back(static_cast<char>(n - 1));
    lzf += soa.substr(at, n);
  }
  Put<uint32_t>(&header, static_cast<uint32_t>(lzf.size()));
  Put<uint32_t>(&header, static_cast<uint32_t>(soa.size()));
  return header + lzf;
}

TEST_F(LidarFormatsTest, IntensityUnderAnyNameAndType) {
  const std::vector<std::vector<double>> xyz = {{1, 4}, {2, 5}, {3, 6}};
  struct Case {
    std::string name;
    int size;
    char type;
  };
  for (const Case& c : {Case{"intensity", 4, 'F'}, Case{"i", 4, 'F'}, Case{"reflectivity", 2, 'U'},
                        Case{"reflectance", 1, 'U'}, Case{"intensity", 1, 'I'}, Case{"i", 4, 'U'},
                        Case{"intensity", 8, 'F'}}) {
    auto values = xyz;
    values.push_back({7, 100});
    const std::string path = Write(c.name + std::to_string(c.size) + c.type + ".pcd",
                                   CompressedPcd({"x", "y", "z", c.name}, {4, 4, 4, c.size},
                                                 std::string("FFF") + c.type, values));
    const PointCloud cloud = ReadPcd(path);
    ASSERT_TRUE(cloud.has_intensity()) << c.name << " " << c.size << c.type;
    EXPECT_EQ(cloud.intensity[1], 100.0f) << c.name << " " << c.size << c.type;
    EXPECT_EQ(cloud.points[1], Eigen::Vector3d(4, 5, 6));
  }
}

TEST_F(LidarFormatsTest, RingKeptTimestampSkipped) {
  const std::string path =
      Write("ring.pcd", CompressedPcd({"x", "y", "z", "intensity", "ring", "timestamp"}, {4, 4, 4, 4, 2, 8}, "FFFFUF",
                                      {{1, 4}, {2, 5}, {3, 6}, {9, 8}, {5, 31}, {1.6e9, 1.6e9 + 0.1}}));
  const PointCloud cloud = ReadPcd(path);
  ASSERT_EQ(cloud.ring, (std::vector<uint16_t>{5, 31}));
  EXPECT_EQ(cloud.intensity[0], 9.0f);
  // Dropped points leave no ring behind (WithoutMarked keeps the attributes in step).
  const PointCloud kept = WithoutMarked(cloud, {1, 0});
  EXPECT_EQ(kept.ring, (std::vector<uint16_t>{31}));
  // A laser_id field is a ring too.
  const PointCloud laser = ReadPcd(Write("laser.pcd", CompressedPcd({"x", "y", "z", "laser_id"}, {4, 4, 4, 1}, "FFFU",
                                                                   {{1, 4}, {2, 5}, {3, 6}, {0, 2}})));
  EXPECT_EQ(laser.ring, (std::vector<uint16_t>{0, 2}));
  EXPECT_FALSE(laser.has_intensity());
}

TEST_F(LidarFormatsTest, CorruptCompressedBlockNamesTheProblem) {
  std::string pcd = CompressedPcd({"x", "y", "z"}, {4, 4, 4}, "FFF", {{1, 4}, {2, 5}, {3, 6}});
  pcd[pcd.size() - 24 - 1] = static_cast<char>(1 << 5);  // a back reference before any output
  ExpectInputError([&] { ReadPcd(Write("bad.pcd", pcd)); },
                   {"bad.pcd", "corrupt LZF stream", "before the start"});
}

TEST_F(LidarFormatsTest, NuScenesPcdBin) {
  std::string s;
  for (float v : {1.0f, 2.0f, 3.0f, 0.5f, 0.0f, -1.0f, -2.0f, -3.0f, 17.0f, 31.0f}) Put<float>(&s, v);
  ReadStats stats;
  const PointCloud cloud = ReadPointCloud(Write("n015-2018-07-24__LIDAR_TOP__1532402927647951.pcd.bin", s), {}, &stats);
  EXPECT_EQ(stats.format, "nuscenes-pcd-bin");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.points[1], Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(cloud.intensity[1], 17.0f);
  EXPECT_EQ(cloud.ring, (std::vector<uint16_t>{0, 31}));
  // The same 40 bytes as KITTI's 4-float .bin are 2.5 points: refused.
  ExpectInputError([&] { ReadPointCloud(Write("sweep.bin", s)); }, {"sweep.bin", "multiple of 16"});
  ExpectInputError([&] { ReadPointCloud(Write("cut.pcd.bin", s.substr(0, 36))); },
                   {"cut.pcd.bin", "36 bytes", "multiple of 20", "nuScenes"});
  std::string fractional = s;
  const float ring = 2.5f;
  std::memcpy(&fractional[16], &ring, 4);
  ExpectInputError([&] { ReadPointCloud(Write("frac.pcd.bin", fractional)); },
                   {"frac.pcd.bin (byte 0)", "ring 2.5", "0..65535"});
}

}  // namespace
}  // namespace mmba::io
