// libFuzzer harness of the calibration YAML readers of io/camera_yaml.h: the input is one YAML
// file read as a camera (io::ReadCameraYaml), a camera rig (io::ReadRigYaml) and a mobile
// LiDAR mount (io::ReadLidarMountYaml).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io/camera_yaml.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("camera.yaml", data, size);
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadCameraYaml(path); });
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadRigYaml(path); });
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadLidarMountYaml(path); });
  return 0;
}
