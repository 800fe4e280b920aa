#include "mmba/io/pose_json.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

using json = nlohmann::json;

Rigid3d SomePose() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
                 Eigen::Vector3d(1.5, -2.0, 0.25));
}

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() / name).string();
  std::ofstream(path) << text;
  return path;
}

TEST(PoseJson, MatrixRoundTripInBothForms) {
  const Rigid3d pose = SomePose();
  const json rows = PoseToJson(pose);
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_DOUBLE_EQ(rows[0][3].get<double>(), 1.5);  // translation in the last column
  EXPECT_DOUBLE_EQ(rows[3][3].get<double>(), 1.0);
  json flat = json::array();
  for (const json& row : rows) {
    for (const json& v : row) flat.push_back(v);
  }
  for (const json& form : {rows, flat}) {
    const Rigid3d back = PoseFromJson(form, "f.json", "pose");
    EXPECT_LT(back.rotation.angularDistance(pose.rotation), 1e-12);
    EXPECT_LT((back.translation - pose.translation).norm(), 1e-12);
  }
}

TEST(PoseJson, QvecTvecForm) {
  const Rigid3d pose = SomePose();
  const json value = {{"qvec_wxyz", {pose.rotation.w(), pose.rotation.x(), pose.rotation.y(), pose.rotation.z()}},
                      {"tvec", {1.5, -2.0, 0.25}}};
  const Rigid3d back = PoseFromJson(value, "f.json", "truth");
  EXPECT_LT(back.rotation.angularDistance(pose.rotation), 1e-12);
  EXPECT_LT((back.translation - pose.translation).norm(), 1e-12);
  const json not_unit = {{"qvec_wxyz", {2, 0, 0, 0}}, {"tvec", {0, 0, 0}}};
  EXPECT_THROW(PoseFromJson(not_unit, "f.json", "truth"), InputError);
  const json short_t = {{"qvec_wxyz", {1, 0, 0, 0}}, {"tvec", {0, 0}}};
  EXPECT_THROW(PoseFromJson(short_t, "f.json", "truth"), InputError);
}

TEST(PoseJson, RefusesWhatIsNotARigidMatrix) {
  std::string problem;
  double v[16];
  EXPECT_FALSE(Matrix4FromJson(json::array({1, 2, 3}), v, &problem));
  EXPECT_EQ(problem, "a list of 3 values");
  EXPECT_FALSE(Matrix4FromJson(json::parse(R"([[1,0,0,0],[0,1,0,0],[0,0,1,"a"],[0,0,0,1]])"), v, &problem));
  EXPECT_EQ(problem, "[2][3] is \"a\", not a number");
  const json scaled = json::parse("[[2,0,0,0],[0,2,0,0],[0,0,2,0],[0,0,0,1]]");
  try {
    PoseFromJson(scaled, "f.json", "pose");
    FAIL() << "a scaled matrix was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("orthonormal"), std::string::npos) << e.what();
  }
  const json last_row = json::parse("[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]");
  EXPECT_THROW(PoseFromJson(last_row, "f.json", "pose"), InputError);
}

TEST(PoseJson, ReadsTheKeyOfAFileAndNamesWhatIsWrong) {
  const std::string good = WriteFile("mmba_pose_json_good.json",
                                     R"({"other": 1, "cam_from_lidar": [[1,0,0,0.5],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})");
  EXPECT_DOUBLE_EQ(ReadPoseJson(good, "cam_from_lidar").translation.x(), 0.5);
  try {
    ReadPoseJson(good, "target_from_source");
    FAIL() << "a missing key was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("target_from_source"), std::string::npos) << e.what();
  }
  const std::string broken = WriteFile("mmba_pose_json_broken.json", "{\n\"cam_from_lidar\": [1, 2,\n");
  EXPECT_THROW(ReadPoseJson(broken, "cam_from_lidar"), InputError);
  const std::string overflow = WriteFile("mmba_pose_json_overflow.json", "{\n\"cam_from_lidar\": [1e400]}\n");
  try {
    ReadPoseJson(overflow, "cam_from_lidar");
    FAIL() << "1e400 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(":2"), std::string::npos) << e.what();  // the line
  }
  std::filesystem::remove(good);
  std::filesystem::remove(broken);
  std::filesystem::remove(overflow);
}

}  // namespace
}  // namespace mmba::io
