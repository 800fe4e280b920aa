// PLY writer: binary little/big endian (the host's) or ascii, with every attribute a cloud has.
// Format: Greg Turk, "The PLY Polygon File Format" (1994).

#include <fstream>
#include <iomanip>
#include <sstream>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/core/atomic_file.h"

namespace mmba::io {

namespace {

void WriteHeader(std::ostream& out, size_t n, const PointCloud& like, const char* format) {
  out << "ply\nformat " << format << " 1.0\ncomment written by mmba\nelement vertex " << n
      << "\nproperty double x\nproperty double y\nproperty double z\n";
  if (like.has_normals()) out << "property float nx\nproperty float ny\nproperty float nz\n";
  if (like.has_intensity()) out << "property float intensity\n";
  if (like.has_colors()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (like.has_time()) out << "property double time\n";
  out << "end_header\n";
}

}  // namespace

void WritePlyHeader(std::ostream& out, size_t n, const PointCloud& like) {
  WriteHeader(out, n, like, internal::HostIsLittleEndian() ? "binary_little_endian" : "binary_big_endian");
}

void AppendPlyRecords(std::ostream& out, const PointCloud& cloud) {
  std::string record;
  for (size_t i = 0; i < cloud.size(); ++i) {
    record.clear();
    auto put = [&record](const void* v, size_t size) { record.append(static_cast<const char*>(v), size); };
    put(cloud.points[i].data(), 3 * sizeof(double));
    if (cloud.has_normals()) {
      const float nf[3] = {static_cast<float>(cloud.normals[i].x()), static_cast<float>(cloud.normals[i].y()),
                           static_cast<float>(cloud.normals[i].z())};
      put(nf, sizeof(nf));
    }
    if (cloud.has_intensity()) put(&cloud.intensity[i], sizeof(float));
    if (cloud.has_colors()) put(cloud.colors[i].data(), 3);
    if (cloud.has_time()) put(&cloud.time[i], sizeof(double));
    out.write(record.data(), static_cast<std::streamsize>(record.size()));
  }
}

void WritePly(const PointCloud& cloud, const std::string& path, bool ascii) {
  const size_t n = cloud.size();
  auto check = [&](size_t size, const char* what) {
    if (size != 0 && size != n) {
      throw std::invalid_argument(std::string("WritePly: ") + what + " has " +
                                  std::to_string(size) + " entries for " + std::to_string(n) +
                                  " points");
    }
  };
  check(cloud.normals.size(), "normals");
  check(cloud.intensity.size(), "intensity");
  check(cloud.colors.size(), "colors");
  check(cloud.time.size(), "time");
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        if (!ascii) {
          WritePlyHeader(out, n, cloud);
          AppendPlyRecords(out, cloud);
          return;
        }
        WriteHeader(out, n, cloud, "ascii");
        {
          out << std::setprecision(17);
          for (size_t i = 0; i < n; ++i) {
            const auto& p = cloud.points[i];
            out << p.x() << ' ' << p.y() << ' ' << p.z();
            if (cloud.has_normals()) {
              out << std::setprecision(9) << ' ' << static_cast<float>(cloud.normals[i].x())
                  << ' ' << static_cast<float>(cloud.normals[i].y()) << ' '
                  << static_cast<float>(cloud.normals[i].z()) << std::setprecision(17);
            }
            if (cloud.has_intensity()) {
              out << std::setprecision(9) << ' ' << cloud.intensity[i] << std::setprecision(17);
            }
            if (cloud.has_colors()) {
              out << ' ' << int(cloud.colors[i][0]) << ' ' << int(cloud.colors[i][1]) << ' '
                  << int(cloud.colors[i][2]);
            }
            if (cloud.has_time()) out << ' ' << cloud.time[i];
            out << '\n';
          }
          return;
        }
      },
      /*binary=*/true);
}


}  // namespace mmba::io
