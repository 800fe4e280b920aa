// libFuzzer harness of the survey CSV reader (io::ReadSurveyCsv): the input is the file.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io_survey/survey_csv.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("network.csv", data, size);
  mmba::fuzz::ExpectOnlyInputError([&] { mmba::io::ReadSurveyCsv(path); });
  return 0;
}
