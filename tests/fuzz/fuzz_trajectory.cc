// libFuzzer harness of the trajectory CSV reader (io::ReadTrajectory): the input is the file;
// a trajectory read is also interpolated at its first time, halfway and past its end.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "mmba/io/trajectory.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("trajectory.csv", data, size);
  mmba::fuzz::ExpectOnlyInputError([&] {
    const auto rows = mmba::io::ReadTrajectory(path);
    mmba::io::InterpolateTrajectory(rows, rows.front().first);
    mmba::io::InterpolateTrajectory(rows, 0.5 * (rows.front().first + rows.back().first));
    mmba::io::InterpolateTrajectory(rows, rows.back().first + 1.0);
  });
  return 0;
}
