#include "mmba/io/colmap_model.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kTiny = fs::path(MMBA_SOURCE_DIR) / "tests/data/colmap/tiny";
const fs::path kBalbianello = fs::path(MMBA_SOURCE_DIR) / "data/colmap/balbianello/sparse";

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void Spit(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

class ColmapModelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tmp_ = fs::temp_directory_path() /
           ("mmba_colmap_" + std::string(::testing::UnitTest::GetInstance()
                                             ->current_test_info()
                                             ->name()));
    fs::remove_all(tmp_);
    fs::create_directories(tmp_);
  }
  void TearDown() override { fs::remove_all(tmp_); }

  // A copy of the tiny model with `file`'s line `line` (1-based) replaced.
  fs::path Broken(const std::string& file, int line, const std::string& replacement) {
    const fs::path dir = tmp_ / "broken";
    fs::create_directories(dir);
    for (const char* name : {"cameras.txt", "images.txt", "points3D.txt"}) {
      fs::copy_file(kTiny / name, dir / name, fs::copy_options::overwrite_existing);
    }
    std::istringstream in(Slurp(dir / file));
    std::string out, l;
    for (int i = 1; std::getline(in, l); ++i) out += (i == line ? replacement : l) + "\n";
    Spit(dir / file, out);
    return dir;
  }

  std::string ErrorOf(const fs::path& dir) {
    try {
      ReadColmapModel(dir.string());
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  }

  fs::path tmp_;
};

TEST_F(ColmapModelTest, ReadsTheTinyModel) {
  ColmapFormat format;
  const ColmapModel model = ReadColmapModel(kTiny.string(), &format);
  EXPECT_EQ(format, ColmapFormat::kText);
  ASSERT_EQ(model.cameras.size(), 2u);
  EXPECT_EQ(model.cameras.at(CameraId(2)).model_id, sensors::CameraModelId::kOpenCV);
  EXPECT_EQ(model.cameras.at(CameraId(2)).params[4], -0.1);
  ASSERT_EQ(model.images.size(), 3u);
  const ColmapImage& b = model.images.at(ImageId(2));
  EXPECT_EQ(b.name, "b.jpg");
  EXPECT_EQ(b.cam_from_world.rotation.w(), 0.99);
  EXPECT_EQ(b.cam_from_world.translation.x(), -1.0);
  EXPECT_EQ(b.points2D[1], Eigen::Vector2d(390, 260));
  EXPECT_FALSE(model.images.at(ImageId(1)).point3D_ids[2].IsValid());
  ASSERT_EQ(model.points3D.size(), 3u);
  EXPECT_EQ(model.points3D.at(Point3DId(2)).track.size(), 3u);
  EXPECT_EQ(model.points3D.at(Point3DId(3)).color[2], 30);
  EXPECT_EQ(model.NumObservations(), 7u);
}

// text -> binary -> text gives exactly the text that text -> text gives, for the tiny
// model and for a real COLMAP reconstruction.
TEST_F(ColmapModelTest, ExactRoundTripTextBinaryText) {
  for (const fs::path& source : {kTiny, kBalbianello}) {
    SCOPED_TRACE(source.string());
    const ColmapModel model = ReadColmapText(source.string());
    WriteColmapModel(model, (tmp_ / "text1").string(), ColmapFormat::kText);
    WriteColmapModel(model, (tmp_ / "bin").string(), ColmapFormat::kBinary);
    const ColmapModel from_binary = ReadColmapBinary((tmp_ / "bin").string());
    WriteColmapModel(from_binary, (tmp_ / "text2").string(), ColmapFormat::kText);
    WriteColmapModel(ReadColmapText((tmp_ / "text2").string()), (tmp_ / "bin2").string(),
                     ColmapFormat::kBinary);
    for (const char* name : {"cameras.txt", "images.txt", "points3D.txt"}) {
      EXPECT_EQ(Slurp(tmp_ / "text1" / name), Slurp(tmp_ / "text2" / name)) << name;
    }
    for (const char* name : {"cameras.bin", "images.bin", "points3D.bin"}) {
      EXPECT_EQ(Slurp(tmp_ / "bin" / name), Slurp(tmp_ / "bin2" / name)) << name;
    }
    // Values survive bit for bit.
    EXPECT_EQ(from_binary.images.begin()->second.cam_from_world.translation,
              model.images.begin()->second.cam_from_world.translation);
    EXPECT_EQ(from_binary.points3D.rbegin()->second.xyz, model.points3D.rbegin()->second.xyz);
    fs::remove_all(tmp_ / "text1");
    fs::remove_all(tmp_ / "text2");
    fs::remove_all(tmp_ / "bin");
    fs::remove_all(tmp_ / "bin2");
  }
}

TEST_F(ColmapModelTest, BadTextInputNamesFileLineAndValue) {
  struct Case {
    std::string file;
    int line;
    std::string replacement;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"cameras.txt", 3, "1 PINHOL 640 480 500 510 320 240",
       "cameras.txt:3: field 'MODEL': found 'PINHOL', expected one of SIMPLE_PINHOLE"},
      {"cameras.txt", 3, "1 PINHOLE 640 480 500 510 320",
       "cameras.txt:3: field 'PARAMS[]': found '3 values', expected 4 values for PINHOLE"},
      {"cameras.txt", 3, "-1 PINHOLE 640 480 500 510 320 240",
       "cameras.txt:3: field 'CAMERA_ID': found '-1', expected a non-negative integer"},
      {"cameras.txt", 4, "1 OPENCV 640 480 500 510 320 240 -0.1 0.02 0.001 -0.002",
       "cameras.txt:4: field 'CAMERA_ID': found '1', expected a unique id"},
      {"cameras.txt", 3, "1 PINHOLE 640 480 nan 510 320 240",
       "cameras.txt:3: field 'PARAMS[0]': found 'nan', expected a finite number"},
      {"cameras.txt", 3, "1 PINHOLE 640 480 5x0 510 320 240",
       "cameras.txt:3: field 'PARAMS[0]': found '5x0', expected a finite number"},
      {"images.txt", 6, "2 0.99 0.01 0.1 0.02 -1 inf 0.1 1 b.jpg",
       "images.txt:6: field 'TY': found 'inf', expected a finite number"},
      {"images.txt", 6, "2 0.99 0.01 0.1 0.02 -1 0 0.1 7 b.jpg",
       "field 'CAMERA_ID': found 7, expected the id of a camera"},
      {"images.txt", 7, "300.5 230.5 1 390 260",
       "images.txt:7: field 'POINTS2D[]': found '5 values', expected a multiple of 3"},
      {"points3D.txt", 3, "1 0 0 10 255 0 0 0.5 1 0 2 0 9 0",
       "field 'TRACK.IMAGE_ID': found 9, expected the id of an image"},
      {"points3D.txt", 3, "1 0 0 10 255 0 0 0.5 1 0 2 0 3 7",
       "field 'TRACK.POINT2D_IDX': found 7, expected an index < 3"},
      {"points3D.txt", 3, "1 0 0 10 256 0 0 0.5 1 0 2 0 3 0",
       "points3D.txt:3: field 'R': found '256', expected an integer 0..255"},
      {"points3D.txt", 4, "1 1.5 0.2 9.5 0 255 0 0.25 1 1 2 1 3 1",
       "points3D.txt:4: field 'POINT3D_ID': found '1', expected a unique id"},
      // A size that no image has (2^40 px) would overflow pixel counts further on.
      {"cameras.txt", 3, "1 PINHOLE 1099511627776 480 500 510 320 240",
       "cameras.txt:3: field 'WIDTH/HEIGHT': found '1099511627776x480', expected an image size of 1 to 1000000 px"},
      // A name reaches the JSON outputs: invalid UTF-8 is refused where it is read.
      {"images.txt", 6, "2 0.99 0.01 0.1 0.02 -1 0 0.1 1 b\xff.jpg",
       "images.txt:6: field 'NAME': found 'invalid UTF-8 at byte 1 of the value', expected UTF-8 text"},
  };
  for (const Case& c : cases) {
    const std::string message = ErrorOf(Broken(c.file, c.line, c.replacement));
    EXPECT_THAT(message, HasSubstr(c.expected)) << c.file << ":" << c.line;
    EXPECT_THAT(message, HasSubstr(c.file));
  }
}

TEST_F(ColmapModelTest, TruncatedImagesFileIsReported) {
  const fs::path dir = Broken("images.txt", 9, "");  // last image without its points line
  std::string text = Slurp(dir / "images.txt");
  text = text.substr(0, text.rfind("3 0.98"));
  text += "3 0.98 -0.02 -0.19 0.01 1 0.1 0 2 c.jpg";
  Spit(dir / "images.txt", text);
  EXPECT_THAT(ErrorOf(dir), HasSubstr("images.txt:9: field 'POINTS2D[]': found 'end of file'"));
}

TEST_F(ColmapModelTest, MissingFolderAndMissingFiles) {
  EXPECT_THAT(ErrorOf(tmp_ / "nope"), HasSubstr("model folder not found"));
  EXPECT_THAT(ErrorOf(tmp_), HasSubstr("holds neither cameras.bin nor cameras.txt"));
  fs::copy_file(kTiny / "cameras.txt", tmp_ / "cameras.txt");
  EXPECT_THAT(ErrorOf(tmp_), HasSubstr("images.txt: file not found"));
}

TEST_F(ColmapModelTest, BadBinaryInputNamesTheByteOffset) {
  const ColmapModel model = ReadColmapText(kTiny.string());
  const fs::path dir = tmp_ / "bin";
  WriteColmapModel(model, dir.string(), ColmapFormat::kBinary);
  const std::string cameras = Slurp(dir / "cameras.bin");
  const std::string images = Slurp(dir / "images.bin");

  // Truncated: cut the last camera's parameters.
  Spit(dir / "cameras.bin", cameras.substr(0, cameras.size() - 5));
  EXPECT_THAT(ErrorOf(dir), HasSubstr("cameras.bin (byte "));
  EXPECT_THAT(ErrorOf(dir), HasSubstr("file truncated?"));

  // A count larger than the file can hold.
  std::string wrong_count = cameras;
  const uint64_t huge = 1000000;
  std::memcpy(wrong_count.data(), &huge, 8);
  Spit(dir / "cameras.bin", wrong_count);
  EXPECT_THAT(ErrorOf(dir), HasSubstr("cameras.bin (byte 0): field 'num_cameras': found "
                                      "'1000000'"));

  // Unknown model id (the first camera's model_id is at byte 8 + 4).
  std::string bad_model = cameras;
  const int32_t model_id = 77;
  std::memcpy(bad_model.data() + 12, &model_id, 4);
  Spit(dir / "cameras.bin", bad_model);
  EXPECT_THAT(ErrorOf(dir), HasSubstr("cameras.bin (byte 12): field 'model_id': found '77'"));

  // NaN in the first image's translation (byte 8 + 4 + 4*8 = 44).
  Spit(dir / "cameras.bin", cameras);
  std::string bad_image = images;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(bad_image.data() + 44, &nan, 8);
  Spit(dir / "images.bin", bad_image);
  EXPECT_THAT(ErrorOf(dir), HasSubstr("images.bin (byte 44): field 'tvec[0]'"));

  // A width of 2^40 px (the first camera's width is at byte 8 + 4 + 4).
  std::string wide = cameras;
  const uint64_t width = uint64_t{1} << 40;
  std::memcpy(wide.data() + 16, &width, 8);
  Spit(dir / "cameras.bin", wide);
  EXPECT_THAT(ErrorOf(dir), HasSubstr("cameras.bin (byte 8): field 'width/height': found '1099511627776x480', "
                                      "expected an image size of 1 to 1000000 px"));
  Spit(dir / "cameras.bin", cameras);

  // Extra bytes after the last record.
  Spit(dir / "images.bin", images + "xx");
  EXPECT_THAT(ErrorOf(dir), HasSubstr("2 extra bytes"));
}

}  // namespace
}  // namespace mmba::io
