// libFuzzer harness of the LAS reader (io::ReadLas): the input is the file,
// read with NaN/Inf points refused (even size) or skipped (odd size).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io_cloud/point_cloud.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("cloud.las", data, size);
  mmba::io::ReadOptions options;
  options.skip_invalid_points = size % 2 == 1;
  mmba::io::ReadStats stats;
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadLas(path, options, &stats); });
  return 0;
}
