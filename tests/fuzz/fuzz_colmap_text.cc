// libFuzzer harness of the COLMAP text model reader (io::ReadColmapText, then
// io::ReadColmapModel, which detects the format): the input is cameras.txt, images.txt and
// points3D.txt joined by fuzz::kSplit; a file without its part is absent.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io/colmap_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mmba::fuzz::WriteParts(data, size,
                         {"model/cameras.txt", "model/images.txt", "model/points3D.txt"});
  const std::string dir = (mmba::fuzz::WorkDir() / "model").string();
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadColmapText(dir); });
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadColmapModel(dir); });
  return 0;
}
