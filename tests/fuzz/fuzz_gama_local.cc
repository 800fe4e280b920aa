// libFuzzer harness of the gama-local XML reader (io::ReadGamaLocal): the input is the file.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io_survey/gama_local.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("network.gkf", data, size);
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadGamaLocal(path); });
  return 0;
}
