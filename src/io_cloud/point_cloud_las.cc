// LAS 1.2–1.4 reader, uncompressed point data record formats 0–3 and 6–8.
// Written here because Debian bookworm packages no LAS library (liblas is gone, PDAL has no
// -dev package usable from C++ here). Layout from the ASPRS LAS Specification 1.4 R15
// (public header block, Table 3; point data record formats, Tables 7–16).

#include <algorithm>
#include <limits>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

using internal::CloudBuilder;
using internal::ScalarType;

template <typename T>
T Get(const std::string& data, size_t offset) {
  T v;
  std::memcpy(&v, data.data() + offset, sizeof(T));
  if (!internal::HostIsLittleEndian()) {
    char* b = reinterpret_cast<char*>(&v);
    std::reverse(b, b + sizeof(T));
  }
  return v;
}

// The variable length records (VLRs) lie between the header and the point data, each a
// 54-byte header (its payload length, uint16, at byte 52) and its payload (LAS 1.4 R15,
// Table 4): the count at byte 100 must name records that fit there, as a reader that walks
// them (to find a projection, say) trusts it.
void CheckVariableLengthRecords(const std::string& path, const std::string& data, uint16_t header_size,
                                uint32_t offset_to_points) {
  constexpr size_t kVlrHeaderBytes = 54;
  const uint32_t count = Get<uint32_t>(data, 100);
  const size_t limit = std::min<size_t>(offset_to_points, data.size());  // a truncated file ends sooner
  size_t pos = header_size;
  for (uint32_t i = 0; i < count; ++i) {
    if (pos + kVlrHeaderBytes > limit) {
      throw InputError::AtByte(path, 100, "number of variable length records", std::to_string(count),
                               "records that fit between the header and the point data (byte " +
                                   std::to_string(offset_to_points) + "): record " + std::to_string(i) +
                                   " would start at byte " + std::to_string(pos));
    }
    const size_t end = pos + kVlrHeaderBytes + Get<uint16_t>(data, pos + 52);
    if (end > limit) {
      throw InputError::AtByte(path, pos + 52, "record length after header", std::to_string(end - pos - kVlrHeaderBytes),
                               "a variable length record " + std::to_string(i) + " that ends by the point data (byte " +
                                   std::to_string(offset_to_points) + ")");
    }
    pos = end;
  }
}

}  // namespace

PointCloud ReadLas(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  const std::string data = ReadWholeFile(path);
  if (data.size() < 227) {
    throw InputError::AtByte(path, data.size(), "public header block", "end of file",
                             "at least 227 bytes (LAS header; truncated or not a LAS file)");
  }
  if (data.compare(0, 4, "LASF") != 0) {
    throw InputError::AtByte(path, 0, "file signature", "other bytes", "'LASF' (not a LAS file?)");
  }
  const int major = static_cast<uint8_t>(data[24]);
  const int minor = static_cast<uint8_t>(data[25]);
  const std::string version = std::to_string(major) + "." + std::to_string(minor);
  if (major != 1 || minor < 2 || minor > 4) {
    throw InputError::AtByte(path, 24, "version", version, "1.2, 1.3 or 1.4");
  }
  const uint16_t header_size = Get<uint16_t>(data, 94);
  const uint32_t offset_to_points = Get<uint32_t>(data, 96);
  const uint8_t format_byte = static_cast<uint8_t>(data[104]);
  const uint16_t record_length = Get<uint16_t>(data, 105);
  const uint32_t legacy_count = Get<uint32_t>(data, 107);
  const double scale[3] = {Get<double>(data, 131), Get<double>(data, 139), Get<double>(data, 147)};
  const double offset[3] = {Get<double>(data, 155), Get<double>(data, 163), Get<double>(data, 171)};
  if (format_byte & 0xc0) {
    throw InputError::AtByte(path, 104, "point data format", std::to_string(format_byte),
                             "an uncompressed format (bit 7/6 set = LAZ compressed; "
                             "decompress with laszip or pdal first)");
  }
  const int format = format_byte;
  static const size_t kMinLength[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  if (!(format <= 3 || (format >= 6 && format <= 8))) {
    throw InputError::AtByte(path, 104, "point data format", std::to_string(format),
                             "0, 1, 2, 3, 6, 7 or 8");
  }
  if (format >= 6 && minor < 4) {
    throw InputError::AtByte(path, 104, "point data format", std::to_string(format),
                             "0–3 for LAS " + version + " (formats 6–8 need LAS 1.4)");
  }
  if (record_length < kMinLength[format]) {
    throw InputError::AtByte(path, 105, "point data record length",
                             std::to_string(record_length),
                             ">= " + std::to_string(kMinLength[format]) + " for format " +
                                 std::to_string(format));
  }
  const size_t min_header = minor == 4 ? 375 : (minor == 3 ? 235 : 227);
  if (header_size < min_header || header_size > data.size()) {
    throw InputError::AtByte(path, 94, "header size", std::to_string(header_size),
                             ">= " + std::to_string(min_header) + " for LAS " + version +
                                 " and within the file");
  }
  uint64_t count = legacy_count;
  if (minor == 4) {
    const uint64_t count64 = Get<uint64_t>(data, 247);
    if (count64 != 0) count = count64;
    if (legacy_count != 0 && count64 != 0 && legacy_count != count64) {
      throw InputError::AtByte(path, 107, "legacy number of point records",
                               std::to_string(legacy_count),
                               "0 or equal to the 64-bit count " + std::to_string(count64));
    }
  }
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(scale[k]) || scale[k] == 0.0) {
      throw InputError::AtByte(path, 131 + 8 * k, std::string(1, "xyz"[k]) + " scale factor",
                               std::to_string(scale[k]), "a finite non-zero number");
    }
    if (!std::isfinite(offset[k])) {
      throw InputError::AtByte(path, 155 + 8 * k, std::string(1, "xyz"[k]) + " offset",
                               std::to_string(offset[k]), "a finite number");
    }
  }
  if (offset_to_points < header_size) {
    throw InputError::AtByte(path, 96, "offset to point data", std::to_string(offset_to_points),
                             ">= header size " + std::to_string(header_size));
  }
  CheckVariableLengthRecords(path, data, header_size, offset_to_points);
  // Compared by division: a damaged 64-bit count times the record length could wrap around.
  const uint64_t available = data.size() > offset_to_points ? data.size() - offset_to_points : 0;
  if (record_length > 0 && count > available / record_length) {
    const bool fits = count <= (std::numeric_limits<uint64_t>::max() - offset_to_points) / record_length;
    const std::string needed = fits ? std::to_string(offset_to_points + count * record_length) : "more than 2^64";
    throw InputError::AtByte(path, data.size(), "point data", "end of file",
                             needed + " bytes for " + std::to_string(count) +
                                 " records of " + std::to_string(record_length) +
                                 " bytes (truncated file?)");
  }
  const bool has_rgb = format == 2 || format == 3 || format == 7 || format == 8;
  const size_t rgb_offset = format == 2 ? 20 : (format == 3 ? 28 : 30);
  // 16-bit colours: reduce to 8 bits unless the writer stored 8-bit values.
  int color_shift = 0;
  if (has_rgb) {
    for (uint64_t i = 0; i < count && color_shift == 0; ++i) {
      const size_t r = offset_to_points + i * record_length + rgb_offset;
      for (int k = 0; k < 3; ++k) {
        if (Get<uint16_t>(data, r + 2 * k) > 255) color_shift = 8;
      }
    }
  }
  // GPS time (double): formats 1 and 3 at byte 20, formats 6–8 at byte 22.
  const bool has_time = format == 1 || format == 3 || format >= 6;
  const size_t time_offset = format >= 6 ? 22 : 20;
  CloudBuilder builder(path, options, false, true, has_rgb, count, has_time);
  for (uint64_t i = 0; i < count; ++i) {
    const size_t r = offset_to_points + i * record_length;
    double xyz[3];
    for (int k = 0; k < 3; ++k) {
      xyz[k] = Get<int32_t>(data, r + 4 * k) * scale[k] + offset[k];
    }
    const float intensity = Get<uint16_t>(data, r + 12);
    uint8_t rgb[3] = {0, 0, 0};
    if (has_rgb) {
      for (int k = 0; k < 3; ++k) {
        rgb[k] = static_cast<uint8_t>(Get<uint16_t>(data, r + rgb_offset + 2 * k) >> color_shift);
      }
    }
    builder.Add(xyz, nullptr, intensity, rgb, [&] { return path + " (byte " + std::to_string(r) + ")"; },
                has_time ? Get<double>(data, r + time_offset) : 0.0);
  }
  return builder.Finish("las-" + version + "-fmt" + std::to_string(format), stats);
}

}  // namespace mmba::io
