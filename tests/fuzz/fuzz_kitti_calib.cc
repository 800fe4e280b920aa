// libFuzzer harness of the KITTI calibration reader (io::ReadKittiCalibration, then
// io::KittiCamera for cameras 0–3). An input without fuzz::kSplit is an
// object/odometry calib file; "A<kSplit>B" is a raw recording's calib_cam_to_cam.txt (A) and
// calib_velo_to_cam.txt (B), given as their folder.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_input.h"
#include "mmba/io_kitti/kitti.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<std::string_view> parts = mmba::fuzz::SplitInput(data, size, 2);
  std::string path;
  if (parts.size() == 1) {
    path = mmba::fuzz::WriteInput("calib.txt", parts[0]);
  } else {
    mmba::fuzz::WriteInput("raw/calib_cam_to_cam.txt", parts[0]);
    mmba::fuzz::WriteInput("raw/calib_velo_to_cam.txt", parts[1]);
    path = (mmba::fuzz::WorkDir() / "raw").string();
  }
  mmba::fuzz::ExpectOnlyInputError([&] {
    const mmba::io::KittiCalibration calibration = mmba::io::ReadKittiCalibration(path, -1);
    for (int index = 0; index < 4; ++index) {
      mmba::fuzz::ExpectOnlyInputError(
          [&] { mmba::io::KittiCamera(calibration, index, 1242, 375); });
    }
  });
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadKittiCalibration(path, 2); });
  return 0;
}
