#include "mmba/io_cloud/las_writer.h"

#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "mmba/core/atomic_file.h"
#include "mmba/core/error.h"
#include "mmba/geodesy/crs.h"

namespace mmba::io {
namespace {

namespace fs = std::filesystem;

class LasWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mmba_las_writer_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

template <typename T>
T At(const std::string& data, size_t pos) {
  T v;
  std::memcpy(&v, data.data() + pos, sizeof(T));
  return v;
}

// The WKT a project in ETRS89 / UTM zone 32N hands the writer.
std::string Utm32Wkt() { return geodesy::Crs("EPSG:25832", "test").wkt1(); }

// A mobile-mapping-like cloud in UTM 32N coordinates: survey-size numbers, raw intensity
// counts, GPS week seconds, colours, a signed distance and a σ per point.
struct Sample {
  PointCloud cloud;
  std::vector<LasExtraField> extra;
};

Sample MakeSample(size_t n) {
  Sample s;
  s.extra = {{"distance_m", "signed distance to the reference", false, {}},
             {"sigma_m", "1-sigma of the point", true, {}}};
  for (size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i);
    s.cloud.points.emplace_back(512345.6789 + 0.0371 * t, 5403210.1234 - 0.0213 * t, 243.5678 + 0.00457 * t);
    s.cloud.intensity.push_back(static_cast<float>((i * 37) % 4096));
    s.cloud.time.push_back(302400.0 + 1e-5 * t + 1.0 / 3.0);
    s.cloud.colors.push_back({static_cast<uint8_t>(i % 256), static_cast<uint8_t>((3 * i) % 256), 255});
    s.extra[0].values.push_back(-0.05 + 1e-4 * t + 1.0 / 7.0);
    s.extra[1].values.push_back(0.002 + 1e-6 * t + 1e-9 / 3.0);
  }
  return s;
}

TEST_F(LasWriterTest, RoundTripThroughReadLas) {
  const Sample s = MakeSample(2000);
  LasWriteOptions options;
  options.crs_wkt = Utm32Wkt();
  ASSERT_NE(options.crs_wkt.find("UTM zone 32N"), std::string::npos);
  WriteLas(s.cloud, Path("a.las"), options, s.extra);

  LasInfo info;
  ReadStats stats;
  const PointCloud back = ReadLas(Path("a.las"), {}, &stats, &info);
  EXPECT_EQ(stats.format, "las-1.4-fmt7");
  ASSERT_EQ(back.size(), s.cloud.size());
  EXPECT_EQ(info.crs_wkt, options.crs_wkt);
  EXPECT_EQ(info.point_format, 7);
  EXPECT_EQ(info.global_encoding, 0x18);  // WKT + synthetic return numbers
  EXPECT_EQ(info.generating_software.rfind("mmba ", 0), 0u) << info.generating_software;
  EXPECT_EQ(info.offset, Eigen::Vector3d(512345, 5403167, 243));  // each minimum, floored
  double max_xyz_error = 0.0, max_distance_error = 0.0, max_sigma_error = 0.0;
  const LasExtraField* distance = info.Field("distance_m");
  const LasExtraField* sigma = info.Field("sigma_m");
  ASSERT_NE(distance, nullptr);
  ASSERT_NE(sigma, nullptr);
  EXPECT_EQ(distance->description, "signed distance to the reference");
  EXPECT_FALSE(distance->is_double);
  EXPECT_TRUE(sigma->is_double);
  for (size_t i = 0; i < back.size(); ++i) {
    max_xyz_error = std::max(max_xyz_error, (back.points[i] - s.cloud.points[i]).cwiseAbs().maxCoeff());
    EXPECT_EQ(back.intensity[i], s.cloud.intensity[i]);
    EXPECT_EQ(back.time[i], s.cloud.time[i]);
    EXPECT_EQ(back.colors[i], s.cloud.colors[i]);
    max_distance_error = std::max(max_distance_error, std::abs(distance->values[i] - s.extra[0].values[i]));
    max_sigma_error = std::max(max_sigma_error, std::abs(sigma->values[i] - s.extra[1].values[i]));
  }
  // Coordinates are rounded to the 1 mm grid: at most half of it off (plus double rounding).
  EXPECT_LE(max_xyz_error, 0.0005 + 1e-9);
  EXPECT_LE(max_distance_error, 2e-8);  // float32 of values below 0.4 m
  EXPECT_EQ(max_sigma_error, 0.0);
  std::cout << "round trip, 2000 points: max |xyz error| " << max_xyz_error << " m, distance_m (float32) "
            << max_distance_error << " m, sigma_m (float64) " << max_sigma_error << " m\n";
}

TEST_F(LasWriterTest, ReflectanceScaledToSixteenBitsAndWithoutTimeOrColour) {
  PointCloud cloud;
  cloud.points = {{1.25, 2.5, -3.75}, {1.0, 2.0, 3.0}};
  cloud.intensity = {0.0f, 1.0f};
  WriteLas(cloud, Path("r.las"));
  LasInfo info;
  const PointCloud back = ReadLas(Path("r.las"), {}, nullptr, &info);
  EXPECT_EQ(info.point_format, 6);
  EXPECT_TRUE(info.crs_wkt.empty());
  EXPECT_TRUE(info.extra_fields.empty());
  EXPECT_EQ(back.intensity, (std::vector<float>{0.0f, 65535.0f}));
  EXPECT_LE((back.points[0] - cloud.points[0]).norm(), 1e-12);  // on the millimetre grid
  EXPECT_EQ(back.time, (std::vector<double>{0.0, 0.0}));
}

// The bytes the specification puts where (LAS 1.4 R15 Tables 3, 15, 24, 13), by hand.
TEST_F(LasWriterTest, HeaderAndRecordsByHand) {
  PointCloud cloud;
  cloud.points = {{100.0004, 200.5, 3.0}, {101.25, 199.9996, 4.5}};
  cloud.intensity = {7.0f, 300.0f};
  const std::string wkt = "LOCAL_CS[\"site\"]";
  std::vector<LasExtraField> extra = {{"distance_m", "signed distance", false, {-0.25, 0.5}}};
  LasWriteOptions options;
  options.crs_wkt = wkt;
  WriteLas(cloud, Path("h.las"), options, extra);
  const std::string d = Slurp(Path("h.las"));
  const size_t wkt_vlr = 375, extra_vlr = 375 + 54 + wkt.size() + 1, points = extra_vlr + 54 + 192;
  ASSERT_EQ(d.size(), points + 2 * 34);
  EXPECT_EQ(d.substr(0, 4), "LASF");
  EXPECT_EQ(At<uint16_t>(d, 6), 0x18);
  EXPECT_EQ(d[24], 1);
  EXPECT_EQ(d[25], 4);
  EXPECT_EQ(d.substr(26, 6), std::string("OTHER\0", 6));
  EXPECT_EQ(At<uint16_t>(d, 94), 375);
  EXPECT_EQ(At<uint32_t>(d, 96), points);
  EXPECT_EQ(At<uint32_t>(d, 100), 2u);
  EXPECT_EQ(d[104], 6);
  EXPECT_EQ(At<uint16_t>(d, 105), 34);    // 30 + one float32
  EXPECT_EQ(At<uint32_t>(d, 107), 0u);    // legacy count: 0 for formats >= 6
  EXPECT_EQ(At<double>(d, 131), 0.001);
  EXPECT_EQ(At<double>(d, 155), 100.0);   // x offset: the minimum floored
  EXPECT_EQ(At<double>(d, 163), 199.0);
  EXPECT_EQ(At<double>(d, 171), 3.0);
  EXPECT_DOUBLE_EQ(At<double>(d, 179), 101.25);  // max x
  EXPECT_DOUBLE_EQ(At<double>(d, 187), 100.0);   // min x: 100.0004 on the 1 mm grid
  EXPECT_DOUBLE_EQ(At<double>(d, 203), 200.0);   // min y: 199.9996 rounded
  EXPECT_EQ(At<uint64_t>(d, 235), 0u);           // no EVLR
  EXPECT_EQ(At<uint64_t>(d, 247), 2u);
  EXPECT_EQ(At<uint64_t>(d, 255), 2u);           // two first returns
  // VLR 1: the WKT, NUL-terminated.
  EXPECT_EQ(d.substr(wkt_vlr + 2, 16), std::string("LASF_Projection\0", 16));
  EXPECT_EQ(At<uint16_t>(d, wkt_vlr + 18), 2112);
  EXPECT_EQ(At<uint16_t>(d, wkt_vlr + 20), wkt.size() + 1);
  EXPECT_EQ(d.substr(wkt_vlr + 54, wkt.size() + 1), wkt + '\0');
  // VLR 2: one Extra Bytes descriptor, float (type 9) with min and max (options 6).
  EXPECT_EQ(d.substr(extra_vlr + 2, 10), std::string("LASF_Spec\0", 10));
  EXPECT_EQ(At<uint16_t>(d, extra_vlr + 18), 4);
  EXPECT_EQ(At<uint16_t>(d, extra_vlr + 20), 192);
  const size_t desc = extra_vlr + 54;
  EXPECT_EQ(d[desc + 2], 9);
  EXPECT_EQ(d[desc + 3], 6);
  EXPECT_EQ(d.substr(desc + 4, 11), std::string("distance_m\0", 11));
  EXPECT_EQ(At<double>(d, desc + 64), -0.25);
  EXPECT_EQ(At<double>(d, desc + 88), 0.5);
  EXPECT_EQ(d.substr(desc + 160, 15), "signed distance");
  // Point 0: X = (100.0004 - 100) / 0.001 = 0.4 -> 0; Y = 1500; Z = 0; return 1 of 1.
  EXPECT_EQ(At<int32_t>(d, points), 0);
  EXPECT_EQ(At<int32_t>(d, points + 4), 1500);
  EXPECT_EQ(At<int32_t>(d, points + 8), 0);
  EXPECT_EQ(At<uint16_t>(d, points + 12), 7);
  EXPECT_EQ(d[points + 14], 0x11);
  EXPECT_EQ(d[points + 16], 0);  // classification: never classified
  EXPECT_EQ(At<float>(d, points + 30), -0.25f);
  // Point 1: X = 1250, Y = round(999.6) = 1000, Z = 1500.
  EXPECT_EQ(At<int32_t>(d, points + 34), 1250);
  EXPECT_EQ(At<int32_t>(d, points + 38), 1000);
  EXPECT_EQ(At<int32_t>(d, points + 42), 1500);
}

// Runs the independent reader (tests/io_cloud/las14_dump.py, written from the specification
// with Python's struct module) and returns its lines.
std::vector<std::string> DumpWithPython(const std::string& path, int* status) {
  const std::string command = "/usr/bin/python3 " MMBA_SOURCE_DIR "/tests/io_cloud/las14_dump.py '" + path + "' 2>&1";
  std::vector<std::string> lines;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return lines;
  std::string text;
  char buf[4096];
  for (size_t got; (got = std::fread(buf, 1, sizeof(buf), pipe)) > 0;) text.append(buf, got);
  *status = ::pclose(pipe);
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// What the independent reader found, checked against the cloud written.
void ExpectIndependentReaderAgrees(const std::string& path, const Sample& s, const std::string& wkt) {
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  int status = -1;
  const std::vector<std::string> lines = DumpWithPython(path, &status);
  ASSERT_EQ(status, 0) << (lines.empty() ? "" : lines.back());
  std::vector<std::string> point_lines, extra_lines;
  std::string found_wkt;
  for (const std::string& line : lines) {
    if (line.rfind("point ", 0) == 0) point_lines.push_back(line.substr(6));
    if (line.rfind("extra ", 0) == 0) extra_lines.push_back(line.substr(6));
    if (line.rfind("wkt ", 0) == 0) found_wkt = line.substr(4);
  }
  std::string one_line_wkt;  // the dump writes line breaks as \n
  for (char c : wkt) one_line_wkt += c == '\n' ? std::string("\\n") : std::string(1, c);
  EXPECT_EQ(found_wkt, one_line_wkt);
  ASSERT_EQ(extra_lines.size(), 2u);
  EXPECT_EQ(extra_lines[0], "distance_m 9 signed distance to the reference");
  EXPECT_EQ(extra_lines[1], "sigma_m 10 1-sigma of the point");
  ASSERT_EQ(point_lines.size(), s.cloud.size());
  double max_xyz_error = 0.0, max_distance_error = 0.0;
  for (size_t i = 0; i < point_lines.size(); ++i) {
    std::istringstream in(point_lines[i]);
    double x, y, z, time, distance, sigma;
    int intensity, returns, classification, r, g, b;
    in >> x >> y >> z >> intensity >> returns >> classification >> time >> r >> g >> b >> distance >> sigma;
    ASSERT_FALSE(in.fail()) << point_lines[i];
    max_xyz_error = std::max(max_xyz_error, (Eigen::Vector3d(x, y, z) - s.cloud.points[i]).cwiseAbs().maxCoeff());
    EXPECT_EQ(intensity, s.cloud.intensity[i]);
    EXPECT_EQ(returns, 0x11);
    EXPECT_EQ(classification, 0);
    EXPECT_EQ(time, s.cloud.time[i]);
    EXPECT_EQ(r, s.cloud.colors[i][0] * 257);
    EXPECT_EQ(g, s.cloud.colors[i][1] * 257);
    EXPECT_EQ(b, s.cloud.colors[i][2] * 257);
    max_distance_error = std::max(max_distance_error, std::abs(distance - s.extra[0].values[i]));
    EXPECT_EQ(sigma, s.extra[1].values[i]);
  }
  EXPECT_LE(max_xyz_error, 0.0005 + 1e-9);
  EXPECT_LE(max_distance_error, 2e-8);
  std::cout << "independent reader, " << point_lines.size() << " points: max |xyz error| " << max_xyz_error
            << " m, distance_m " << max_distance_error << " m\n";
}

TEST_F(LasWriterTest, IndependentPythonReaderAgrees) {
  const Sample s = MakeSample(500);
  LasWriteOptions options;
  options.crs_wkt = Utm32Wkt();
  WriteLas(s.cloud, Path("p.las"), options, s.extra);
  ExpectIndependentReaderAgrees(Path("p.las"), s, options.crs_wkt);
}

TEST_F(LasWriterTest, StreamedInChunksEqualsWhole) {
  const Sample s = MakeSample(1000);
  LasWriteOptions options;
  options.crs_wkt = Utm32Wkt();
  std::vector<LasExtraField> layout = s.extra;
  for (LasExtraField& f : layout) f.values.clear();
  WriteFileAtomically(
      Path("s.las"),
      [&](std::ostream& out) {
        std::unique_ptr<LasStreamWriter> writer;
        for (size_t begin = 0; begin < s.cloud.size(); begin += 300) {
          const size_t end = std::min(begin + 300, s.cloud.size());
          PointCloud chunk;
          std::vector<LasExtraField> extra = layout;
          for (size_t i = begin; i < end; ++i) {
            chunk.points.push_back(s.cloud.points[i]);
            chunk.intensity.push_back(s.cloud.intensity[i]);
            chunk.time.push_back(s.cloud.time[i]);
            chunk.colors.push_back(s.cloud.colors[i]);
            for (size_t k = 0; k < extra.size(); ++k) extra[k].values.push_back(s.extra[k].values[i]);
          }
          if (begin == 0) writer = std::make_unique<LasStreamWriter>(&out, chunk, options, layout);
          writer->Append(chunk, extra);
          if (end == s.cloud.size()) {
            writer->Finish();
            EXPECT_EQ(writer->num_points(), s.cloud.size());
            writer.reset();
          }
        }
      },
      /*binary=*/true);
  LasInfo info;
  const PointCloud back = ReadLas(Path("s.las"), {}, nullptr, &info);
  ASSERT_EQ(back.size(), s.cloud.size());
  // The offset comes from the first chunk (points 0..299): y falls along the cloud.
  EXPECT_EQ(info.offset, Eigen::Vector3d(512345, 5403203, 243));
  double max_xyz_error = 0.0;
  for (size_t i = 0; i < back.size(); ++i) {
    max_xyz_error = std::max(max_xyz_error, (back.points[i] - s.cloud.points[i]).cwiseAbs().maxCoeff());
  }
  EXPECT_LE(max_xyz_error, 0.0005 + 1e-9);
  EXPECT_EQ(back.time, s.cloud.time);
  EXPECT_EQ(info.crs_wkt, options.crs_wkt);
  ASSERT_EQ(info.extra_fields.size(), 2u);
  EXPECT_EQ(info.extra_fields[1].values, s.extra[1].values);
  // Counts and bounds rewritten by Finish: the independent reader checks every point lies
  // within the header's bounds and that the file holds exactly the declared records.
  ExpectIndependentReaderAgrees(Path("s.las"), s, options.crs_wkt);
}

TEST_F(LasWriterTest, WktInAnExtendedRecordIsRead) {
  PointCloud cloud;
  cloud.points = {{1.0, 2.0, 3.0}};
  WriteLas(cloud, Path("e.las"));
  std::string d = Slurp(Path("e.las"));
  const std::string wkt = Utm32Wkt();
  std::string evlr(60, '\0');
  evlr.replace(2, 15, "LASF_Projection");
  const uint16_t id = 2112;
  const uint64_t length = wkt.size() + 1;
  std::memcpy(&evlr[18], &id, 2);
  std::memcpy(&evlr[20], &length, 8);
  const uint64_t start = d.size();
  const uint32_t count = 1;
  std::memcpy(&d[235], &start, 8);
  std::memcpy(&d[243], &count, 4);
  std::ofstream(Path("e.las"), std::ios::binary) << d << evlr << wkt << '\0';
  LasInfo info;
  ReadLas(Path("e.las"), {}, nullptr, &info);
  EXPECT_EQ(info.crs_wkt, wkt);
  // Cut inside the EVLR's WKT: named with its byte.
  const std::string cut = Slurp(Path("e.las")).substr(0, start + 100);
  std::ofstream(Path("ec.las"), std::ios::binary) << cut;
  try {
    ReadLas(Path("ec.las"), {}, nullptr, &info);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ec.las (byte " + std::to_string(start + 20) + ")"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("EVLR record length"), std::string::npos) << e.what();
  }
}

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

TEST_F(LasWriterTest, BrokenRecordsAreNamedByFileAndByte) {
  PointCloud cloud;
  cloud.points = {{1.0, 2.0, 3.0}, {4.0, 5.0, 6.0}};
  std::vector<LasExtraField> extra = {{"distance_m", "", false, {0.5, -0.5}}};
  LasWriteOptions options;
  options.crs_wkt = "LOCAL_CS[\"site\"]";
  WriteLas(cloud, Path("ok.las"), options, extra);
  const std::string ok = Slurp(Path("ok.las"));
  auto write = [&](const std::string& name, const std::string& data) {
    std::ofstream(Path(name), std::ios::binary) << data;
    return Path(name);
  };
  // The WKT record claims more bytes than lie before the point data.
  std::string vlr = ok;
  const uint16_t too_long = 60000;
  std::memcpy(&vlr[375 + 20], &too_long, 2);
  ExpectInputError([&] { ReadLas(write("vlr.las", vlr)); },
                   {"vlr.las (byte 395)", "record length after header", "60000"});
  // A file cut inside the second VLR.
  ExpectInputError([&] { ReadLas(write("cut.las", ok.substr(0, 375 + 54 + 18 + 60))); }, {"cut.las (byte"});
  // An Extra Bytes payload that is not whole descriptors.
  const size_t extra_vlr = 375 + 54 + options.crs_wkt.size() + 1;
  std::string part = ok;
  const uint16_t odd = 100;
  std::memcpy(&part[extra_vlr + 20], &odd, 2);
  ExpectInputError([&] { ReadLas(write("part.las", part)); },
                   {"part.las (byte " + std::to_string(extra_vlr + 20) + ")", "multiple of 192"});
  // A descriptor of a double (8 bytes) where the record has 4 extra bytes.
  std::string wide = ok;
  wide[extra_vlr + 54 + 2] = 10;
  ExpectInputError([&] { ReadLas(write("wide.las", wide)); },
                   {"wide.las (byte " + std::to_string(extra_vlr + 54) + ")", "distance_m", "record length 34"});
  // A data type the specification does not define.
  std::string type = ok;
  type[extra_vlr + 54 + 2] = 31;
  ExpectInputError([&] { ReadLas(write("type.las", type)); },
                   {"type.las (byte " + std::to_string(extra_vlr + 54 + 2) + ")", "extra bytes data type", "31"});
}

TEST_F(LasWriterTest, WriterRefusesInconsistentInput) {
  PointCloud cloud;
  cloud.points = {{1.0, 2.0, 3.0}};
  EXPECT_THROW(WriteLas(cloud, Path("x.las"), {}, {{"d", "", false, {1.0, 2.0}}}), std::invalid_argument);
  EXPECT_THROW(WriteLas(cloud, Path("x.las"), {}, {{std::string(33, 'n'), "", false, {1.0}}}), std::invalid_argument);
  EXPECT_THROW(WriteLas(cloud, Path("x.las"), {}, {{"d", "", false, {1.0}}, {"d", "", true, {1.0}}}),
               std::invalid_argument);
  LasWriteOptions bad;
  bad.scale_m = 0.0;
  EXPECT_THROW(WriteLas(cloud, Path("x.las"), bad), std::invalid_argument);
  bad = {};
  bad.offset_m = Eigen::Vector3d(-3e6, 0, 0);  // 3000 km from the point: beyond int32 at 1 mm
  EXPECT_THROW(WriteLas(cloud, Path("x.las"), bad), std::invalid_argument);
  EXPECT_FALSE(fs::exists(Path("x.las")));  // nothing half-written
}

}  // namespace
}  // namespace mmba::io
