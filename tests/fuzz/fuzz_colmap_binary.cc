// libFuzzer harness of the COLMAP binary model reader (io::ReadColmapBinary, then
// io::ReadColmapModel, which detects the format): the input is cameras.bin, images.bin and
// points3D.bin joined by fuzz::kSplit; a file without its part is absent.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io/colmap_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mmba::fuzz::WriteParts(data, size,
                         {"model/cameras.bin", "model/images.bin", "model/points3D.bin"});
  const std::string dir = (mmba::fuzz::WorkDir() / "model").string();
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadColmapBinary(dir); });
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadColmapModel(dir); });
  return 0;
}
