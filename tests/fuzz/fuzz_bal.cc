// libFuzzer harness of the BAL reader (io::ReadBal): the input is the problem file.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io/bal.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("problem.txt", data, size);
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadBal(path); });
  return 0;
}
