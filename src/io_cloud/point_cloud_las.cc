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
// 54-byte header (its payload length, uint16, at byte 20) and its payload (LAS 1.4 R15,
// Table 15): the count at byte 100 must name records that fit there, as a reader that walks
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
    const size_t end = pos + kVlrHeaderBytes + Get<uint16_t>(data, pos + 20);
    if (end > limit) {
      throw InputError::AtByte(path, pos + 20, "record length after header", std::to_string(end - pos - kVlrHeaderBytes),
                               "a variable length record " + std::to_string(i) + " that ends by the point data (byte " +
                                   std::to_string(offset_to_points) + ")");
    }
    pos = end;
  }
}


// A field of char[size] at `pos` without its trailing NULs.
std::string Text(const std::string& data, size_t pos, size_t size) {
  std::string t = data.substr(pos, size);
  return t.substr(0, t.find('\0'));
}

// One extra-byte field of a point record: where it lies and how to decode it.
struct ExtraSlot {
  int type = 0;         // data type 1–10 (Table 25); 0 = undocumented bytes, not returned
  size_t offset = 0;    // byte within the record
  size_t size = 0;      // bytes
  double scale = 1.0, add = 0.0;
};

// Extra Bytes VLR (Table 24): 192-byte descriptors laid out from byte `first` of each record.
// Types 11–30 (deprecated arrays of 2 or 3) are sized and skipped.
std::vector<ExtraSlot> ReadDescriptors(const std::string& path, const std::string& data, size_t pos, size_t length,
                                       size_t first, size_t record_length, LasInfo* info) {
  constexpr size_t kDescriptorBytes = 192;
  static const size_t kTypeSize[] = {0, 1, 1, 2, 2, 4, 4, 8, 8, 4, 8};
  if (length % kDescriptorBytes != 0) {
    throw InputError::AtByte(path, pos - 34, "Extra Bytes record length", std::to_string(length),
                             "a multiple of 192 (one descriptor per field)");
  }
  std::vector<ExtraSlot> slots;
  size_t at = first;
  for (size_t d = pos; d < pos + length; d += kDescriptorBytes) {
    ExtraSlot slot;
    const int type = static_cast<uint8_t>(data[d + 2]);
    const uint8_t options = static_cast<uint8_t>(data[d + 3]);
    if (type > 30) {
      throw InputError::AtByte(path, d + 2, "extra bytes data type", std::to_string(type), "0 to 30");
    }
    slot.type = type <= 10 ? type : 0;
    slot.size = type == 0 ? options : kTypeSize[(type - 1) % 10 + 1] * (type <= 10 ? 1 : (type - 1) / 10 + 1);
    slot.offset = at;
    if (type >= 1 && type <= 10) {
      if (options & 0x08) slot.scale = Get<double>(data, d + 112);
      if (options & 0x10) slot.add = Get<double>(data, d + 136);
    }
    at += slot.size;
    if (at > record_length) {
      throw InputError::AtByte(path, d, "extra bytes descriptor " + Text(data, d + 4, 32), std::to_string(at) + " bytes",
                               "fields within the point record length " + std::to_string(record_length));
    }
    if (slot.type != 0) {
      LasExtraField field;
      field.name = Text(data, d + 4, 32);
      field.description = Text(data, d + 160, 32);
      field.is_double = type == 10;
      info->extra_fields.push_back(std::move(field));
      slots.push_back(slot);
    }
  }
  return slots;
}

// Walks the VLRs (already checked to fit) and the LAS 1.4 EVLRs for the WKT (record 2112 of
// "LASF_Projection") and the extra-byte descriptors (record 4 of "LASF_Spec").
std::vector<ExtraSlot> ReadLasRecords(const std::string& path, const std::string& data, uint16_t header_size,
                                      int minor, size_t first_extra, size_t record_length, LasInfo* info) {
  std::vector<ExtraSlot> slots;
  const uint32_t count = Get<uint32_t>(data, 100);
  size_t pos = header_size;
  for (uint32_t i = 0; i < count; ++i) {
    const std::string user = Text(data, pos + 2, 16);
    const uint16_t id = Get<uint16_t>(data, pos + 18);
    const size_t length = Get<uint16_t>(data, pos + 20);
    const size_t payload = pos + 54;
    if (user == "LASF_Projection" && id == 2112) info->crs_wkt = Text(data, payload, length);
    if (user == "LASF_Spec" && id == 4) {
      slots = ReadDescriptors(path, data, payload, length, first_extra, record_length, info);
    }
    pos = payload + length;
  }
  if (minor < 4) return slots;
  uint64_t evlr = Get<uint64_t>(data, 235);
  const uint32_t num_evlrs = Get<uint32_t>(data, 243);
  for (uint32_t i = 0; i < num_evlrs && evlr != 0; ++i) {
    if (evlr > data.size() || data.size() - evlr < 60) {
      throw InputError::AtByte(path, evlr, "extended variable length record " + std::to_string(i), "end of file",
                               "a 60-byte record header (truncated file?)");
    }
    const uint64_t length = Get<uint64_t>(data, evlr + 20);
    if (length > data.size() - evlr - 60) {
      throw InputError::AtByte(path, evlr + 20, "EVLR record length after header", std::to_string(length),
                               "a record that ends by the end of the file (byte " + std::to_string(data.size()) + ")");
    }
    if (Text(data, evlr + 2, 16) == "LASF_Projection" && Get<uint16_t>(data, evlr + 18) == 2112) {
      info->crs_wkt = Text(data, evlr + 60, length);
    }
    evlr += 60 + length;
  }
  return slots;
}

// The value of an extra-byte field in the record at `r`, scale and offset applied.
double ExtraValue(const std::string& data, size_t r, const ExtraSlot& s) {
  const size_t at = r + s.offset;
  double v = 0.0;
  switch (s.type) {
    case 1: v = static_cast<uint8_t>(data[at]); break;
    case 2: v = static_cast<int8_t>(data[at]); break;
    case 3: v = Get<uint16_t>(data, at); break;
    case 4: v = Get<int16_t>(data, at); break;
    case 5: v = Get<uint32_t>(data, at); break;
    case 6: v = Get<int32_t>(data, at); break;
    case 7: v = static_cast<double>(Get<uint64_t>(data, at)); break;
    case 8: v = static_cast<double>(Get<int64_t>(data, at)); break;
    case 9: v = Get<float>(data, at); break;
    default: v = Get<double>(data, at); break;
  }
  return v * s.scale + s.add;
}

/// The public header block's fields that ReadLas uses, checked.
struct LasHeader {
  int minor = 0;
  std::string version;
  uint16_t header_size = 0;
  uint32_t offset_to_points = 0;
  int format = 0;
  uint16_t record_length = 0;
  uint64_t count = 0;
  double scale[3] = {0, 0, 0};
  double offset[3] = {0, 0, 0};
  size_t min_record_length = 0;
};

/// Reads and checks the header (LAS 1.4 R15, Table 3); InputError at the byte of the first
/// field that is wrong.
LasHeader ReadLasHeader(const std::string& path, const std::string& data) {
  if (data.size() < 227) {
    throw InputError::AtByte(path, data.size(), "public header block", "end of file",
                             "at least 227 bytes (LAS header; truncated or not a LAS file)");
  }
  if (data.compare(0, 4, "LASF") != 0) {
    throw InputError::AtByte(path, 0, "file signature", "other bytes", "'LASF' (not a LAS file?)");
  }
  LasHeader h;
  const int major = static_cast<uint8_t>(data[24]);
  const int minor = h.minor = static_cast<uint8_t>(data[25]);
  const std::string version = h.version = std::to_string(major) + "." + std::to_string(minor);
  if (major != 1 || minor < 2 || minor > 4) {
    throw InputError::AtByte(path, 24, "version", version, "1.2, 1.3 or 1.4");
  }
  const uint16_t header_size = h.header_size = Get<uint16_t>(data, 94);
  const uint32_t offset_to_points = h.offset_to_points = Get<uint32_t>(data, 96);
  const uint8_t format_byte = static_cast<uint8_t>(data[104]);
  const uint16_t record_length = h.record_length = Get<uint16_t>(data, 105);
  const uint32_t legacy_count = Get<uint32_t>(data, 107);
  double* scale = h.scale;
  double* offset = h.offset;
  for (int k = 0; k < 3; ++k) {
    scale[k] = Get<double>(data, 131 + 8 * k);
    offset[k] = Get<double>(data, 155 + 8 * k);
  }
  if (format_byte & 0xc0) {
    throw InputError::AtByte(path, 104, "point data format", std::to_string(format_byte),
                             "an uncompressed format (bit 7/6 set = LAZ compressed; "
                             "decompress with laszip or pdal first)");
  }
  const int format = h.format = format_byte;
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
  uint64_t& count = h.count = legacy_count;
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
  h.min_record_length = kMinLength[format];
  return h;
}

}  // namespace

const LasExtraField* LasInfo::Field(const std::string& name) const {
  for (const LasExtraField& f : extra_fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

PointCloud ReadLas(const std::string& path, const ReadOptions& options, ReadStats* stats, LasInfo* info) {
  const std::string data = ReadWholeFile(path);
  const LasHeader h = ReadLasHeader(path, data);
  const int format = h.format;
  const uint64_t count = h.count;
  const uint16_t record_length = h.record_length;
  const uint32_t offset_to_points = h.offset_to_points;
  const double* scale = h.scale;
  const double* offset = h.offset;
  LasInfo local_info;
  LasInfo& found = info != nullptr ? *info : local_info;
  found = LasInfo{};
  const std::vector<ExtraSlot> extra =
      ReadLasRecords(path, data, h.header_size, h.minor, h.min_record_length, record_length, &found);
  found.system_identifier = Text(data, 26, 32);
  found.generating_software = Text(data, 58, 32);
  found.global_encoding = Get<uint16_t>(data, 6);
  found.point_format = format;
  found.scale = Eigen::Vector3d(scale[0], scale[1], scale[2]);
  found.offset = Eigen::Vector3d(offset[0], offset[1], offset[2]);
  for (LasExtraField& f : found.extra_fields) f.values.reserve(count);
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
    const bool kept = builder.Add(xyz, nullptr, intensity, rgb, [&] { return path + " (byte " + std::to_string(r) + ")"; },
                                  has_time ? Get<double>(data, r + time_offset) : 0.0);
    for (size_t k = 0; kept && k < extra.size(); ++k) found.extra_fields[k].values.push_back(ExtraValue(data, r, extra[k]));
  }
  return builder.Finish("las-" + h.version + "-fmt" + std::to_string(format), stats);
}

}  // namespace mmba::io
