// libFuzzer harness of the PLY reader: the input is the file, read whole (io::ReadPly) and in
// chunks of 3 points (io::StreamPointCloud, which reads binary PLY from disk chunk by chunk),
// with NaN/Inf points refused (even size) or skipped (odd size). The two must agree: both
// fail, or both give the same points; a disagreement aborts (a finding).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fuzz_input.h"
#include "mmba/io_cloud/point_cloud.h"

namespace {

constexpr size_t kChunkPoints = 3;

// Bitwise: both read the same bytes, so they must give the very same doubles.
bool SamePoints(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  if (a.size() != b.size()) return false;
  return a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(Eigen::Vector3d)) == 0;
}

[[noreturn]] void Disagree(const std::string& what) {
  std::fprintf(stderr, "ReadPly and StreamPointCloud disagree: %s\n", what.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = mmba::fuzz::WriteInput("cloud.ply", data, size);
  mmba::io::ReadOptions options;
  options.skip_invalid_points = size % 2 == 1;
  bool whole_ok = false, streamed_ok = false;
  mmba::io::PointCloud whole;
  std::vector<Eigen::Vector3d> streamed;
  mmba::fuzz::ExpectOnlyInputError([&] {
    whole = mmba::io::ReadPly(path, options);
    whole_ok = true;
  });
  mmba::fuzz::ExpectOnlyInputError([&] {
    mmba::io::StreamPointCloud(
        path, kChunkPoints,
        [&](const mmba::io::PointCloud& chunk, size_t, size_t) {
          if (chunk.size() > kChunkPoints) Disagree("a chunk larger than asked for");
          streamed.insert(streamed.end(), chunk.points.begin(), chunk.points.end());
        },
        options);
    streamed_ok = true;
  });
  if (whole_ok != streamed_ok) {
    Disagree(whole_ok ? "only the whole read succeeded" : "only the streamed read succeeded");
  }
  if (whole_ok && !SamePoints(whole.points, streamed)) {
    Disagree(std::to_string(whole.points.size()) + " points read whole, " +
             std::to_string(streamed.size()) + " streamed");
  }
  return 0;
}
