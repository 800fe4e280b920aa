// The job's policy (job.h): the orientation classes' defaults, the request's checks, and a
// KITTI frame prepared as register-mi --kitti-calib prepares it.
#include "mmba/registration/mi/job.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "mmba/core/error.h"

namespace mmba::registration::mi {
namespace {

TEST(Job, OrientationClassesByDefaultOnlyForTheIntensityWithoutSurfaceClasses) {
  EXPECT_EQ(OrientationSectors(-1, Representation::kIntensity, false), kDefaultOrientationSectors);
  EXPECT_EQ(OrientationSectors(-1, Representation::kIntensity, true), 0);
  EXPECT_EQ(OrientationSectors(-1, Representation::kDepth, false), 0);
  EXPECT_EQ(OrientationSectors(-1, Representation::kPoints, false), 0);
  EXPECT_EQ(OrientationSectors(6, Representation::kIntensity, false), 6);
  EXPECT_EQ(OrientationSectors(0, Representation::kIntensity, false), 0);
  // Facing up, facing down, the sectors, no plane.
  EXPECT_EQ(OrientationClassCount(4), 7);
}

// The message of the InputError `request` throws from ListFrames ("" when none).
std::string ListError(const JobRequest& request) {
  try {
    ListFrames(request);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Job, ListFramesNamesTheOptionOfABadRequest) {
  JobRequest request;
  request.image = {"a.png"};
  request.lidar = {"a.bin"};
  EXPECT_NE(ListError(request).find("--camera/--kitti-calib"), std::string::npos);
  request.camera = "camera.yaml";
  request.lidar.push_back("b.bin");
  EXPECT_NE(ListError(request).find("--image/--lidar"), std::string::npos);
  request.lidar.pop_back();
  request.perturb = {0.1, 0.0};
  EXPECT_NE(ListError(request).find("--perturb"), std::string::npos);
  request.perturb.clear();
  request.orientation_classes = 4;
  request.surface_classes = true;
  EXPECT_NE(ListError(request).find("--orientation-classes"), std::string::npos);
  request.orientation_classes = -1;
  EXPECT_EQ(ListError(request), "");
}

// KITTI frame 000000 (data/kitti, CC BY-NC-SA; skipped when absent).
TEST(Job, KittiFrameIsPreparedWithIncidenceCorrectionAndOrientationClasses) {
  const std::string dir = std::string(MMBA_SOURCE_DIR) + "/data/kitti/";
  JobRequest request;
  request.image = {dir + "image_2/000000.png"};
  request.lidar = {dir + "velodyne/000000.bin"};
  request.kitti_calib = dir + "calib/000000.txt";
  for (const std::string& path : {request.image[0], request.lidar[0], request.kitti_calib}) {
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "KITTI sample absent (data/kitti)";
  }
  const Job job = PrepareJob(request, ListFrames(request));
  ASSERT_EQ(job.frames.size(), 1u);
  EXPECT_EQ(job.view_name, "image");
  ASSERT_EQ(job.frames[0].views.size(), 1u);
  EXPECT_EQ(job.frames[0].points, &job.clouds[0]);
  EXPECT_TRUE(job.origin.isZero());  // a scan in its sensor's frame
  EXPECT_EQ(job.orientation_sectors, kDefaultOrientationSectors);
  EXPECT_EQ(job.options.metric.lidar_classes, OrientationClassCount(kDefaultOrientationSectors));
  EXPECT_FALSE(job.incidence_json.at(0).is_null());  // the scanner at the scan's origin
  EXPECT_TRUE(job.have_calibration_pose);
  EXPECT_TRUE(job.start.translation.isApprox(job.calibration.translation));
}

}  // namespace
}  // namespace mmba::registration::mi
