// Raw float32 LiDAR sweeps: KITTI velodyne `.bin` (x y z reflectance) and nuScenes
// `.pcd.bin` (x y z intensity ring index), little endian, no header.

#include "io_cloud/point_cloud_internal.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

using internal::CloudBuilder;

// Reads `floats_per_point` float32 per point: x y z intensity [ring]. `what` names the layout
// for the size error, `format` the ReadStats format.
PointCloud ReadFloatRecords(const std::string& path, size_t floats_per_point, const char* what,
                            const char* format, const ReadOptions& options, ReadStats* stats) {
  const size_t record = 4 * floats_per_point;
  const bool ring = floats_per_point == 5;
  const std::string data = ReadWholeFile(path);
  if (data.size() % record != 0) {
    throw InputError::AtByte(path, data.size() - data.size() % record, "file size",
                             std::to_string(data.size()) + " bytes",
                             "a multiple of " + std::to_string(record) + " (" + what + " per point)");
  }
  const size_t n = data.size() / record;
  const bool swap = !internal::HostIsLittleEndian();
  CloudBuilder builder(path, options, false, true, false, n);
  if (ring) builder.EnableRing();
  for (size_t i = 0; i < n; ++i) {
    const char* p = data.data() + record * i;
    double xyz[3];
    for (int k = 0; k < 3; ++k) xyz[k] = internal::ReadScalar(p + 4 * k, internal::ScalarType::kFloat32, swap);
    const float intensity = static_cast<float>(internal::ReadScalar(p + 12, internal::ScalarType::kFloat32, swap));
    const auto where = [&] { return path + " (byte " + std::to_string(record * i) + ")"; };
    if (builder.Add(xyz, nullptr, intensity, nullptr, where) && ring) {
      builder.AddRing(internal::ReadScalar(p + 16, internal::ScalarType::kFloat32, swap), where);
    }
  }
  return builder.Finish(format, stats);
}

}  // namespace

PointCloud ReadKittiBin(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  return ReadFloatRecords(path, 4, "float32 x y z reflectance", "kitti-bin", options, stats);
}

PointCloud ReadNuScenesBin(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  return ReadFloatRecords(path, 5, "float32 x y z intensity ring, the nuScenes .pcd.bin layout",
                          "nuscenes-pcd-bin", options, stats);
}

}  // namespace mmba::io
