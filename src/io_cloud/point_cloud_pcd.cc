// PCD v0.7 reader (ascii, binary, binary_compressed), written here so that mmba_io_cloud does
// not need PCL. Format: https://pointclouds.org/documentation/tutorials/pcd_file_format.html;
// binary_compressed = u32 compressed size, u32 uncompressed size, LZF data holding the
// fields one after the other (structure of arrays).

#include <algorithm>
#include <limits>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

using internal::CloudBuilder;
using internal::ScalarType;

struct PcdField {
  std::string name;
  size_t size = 4;
  char type = 'F';
  size_t count = 1;
  ScalarType scalar = ScalarType::kFloat32;
  size_t offset = 0;  // byte offset within a point (AoS) / token offset (ascii)
};

// LZF decompression (Marc Lehmann's liblzf format). Returns false on corrupt input.
bool LzfDecompress(const uint8_t* in, size_t in_size, uint8_t* out, size_t out_size) {
  const uint8_t* ip = in;
  const uint8_t* const in_end = in + in_size;
  uint8_t* op = out;
  uint8_t* const out_end = out + out_size;
  while (ip < in_end) {
    unsigned ctrl = *ip++;
    if (ctrl < 32) {  // literal run
      const size_t len = ctrl + 1;
      if (op + len > out_end || ip + len > in_end) return false;
      std::copy(ip, ip + len, op);
      op += len;
      ip += len;
    } else {  // back reference
      size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_end) return false;
        len += *ip++;
      }
      if (ip >= in_end) return false;
      const size_t back = ((ctrl & 0x1f) << 8) + *ip++ + 1;
      len += 2;
      if (back > static_cast<size_t>(op - out) || op + len > out_end) return false;
      const uint8_t* ref = op - back;
      for (size_t k = 0; k < len; ++k) *op++ = *ref++;  // may overlap
    }
  }
  return op == out_end;
}

}  // namespace

PointCloud ReadPcd(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  const std::string data = ReadWholeFile(path);
  LineCursor cursor(data, path);
  bool have_keyword = false;  // a PCD keyword read: the file is a PCD, its words may be quoted
  std::string_view line;
  std::vector<PcdField> fields;
  uint64_t width = 0, height = 1, points = 0;
  bool have_points = false;
  std::string mode;
  size_t data_start = std::string::npos;
  int64_t data_line = 0;
  while (cursor.Next(&line)) {
    if (line.empty() || line[0] == '#') continue;
    TokenLine t(path, cursor.line_number(), line);
    if (t.size() == 0) continue;
    const std::string key = t.Str(0, "keyword");
    if (key == "VERSION") {
      have_keyword = true;
      continue;
    }
    if (key == "FIELDS") {
      t.ExpectAtLeast(2, "FIELDS");
      fields.resize(t.size() - 1);
      for (size_t i = 1; i < t.size(); ++i) fields[i - 1].name = t.Str(i, "field");
    } else if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      t.ExpectCount(fields.size() + 1, key + " (one per field)");
      for (size_t i = 1; i < t.size(); ++i) {
        PcdField& f = fields[i - 1];
        if (key == "SIZE") {
          f.size = t.UInt(i, "SIZE");
          if (f.size != 1 && f.size != 2 && f.size != 4 && f.size != 8) {
            t.Fail("SIZE", t.Str(i, "SIZE"), "1, 2, 4 or 8");
          }
        } else if (key == "TYPE") {
          const std::string& s = t.Str(i, "TYPE");
          if (s != "F" && s != "I" && s != "U") t.Fail("TYPE", s, "F, I or U");
          f.type = s[0];
        } else {
          f.count = t.UInt(i, "COUNT");
          if (f.count == 0) t.Fail("COUNT", "0", "a positive count");
        }
      }
    } else if (key == "WIDTH") {
      t.ExpectCount(2, "WIDTH");
      width = t.UInt(1, "WIDTH");
    } else if (key == "HEIGHT") {
      t.ExpectCount(2, "HEIGHT");
      height = t.UInt(1, "HEIGHT");
    } else if (key == "VIEWPOINT") {
      have_keyword = true;
      continue;
    } else if (key == "POINTS") {
      t.ExpectCount(2, "POINTS");
      points = t.UInt(1, "POINTS");
      have_points = true;
    } else if (key == "DATA") {
      t.ExpectCount(2, "DATA");
      mode = t.Str(1, "DATA");
      if (mode != "ascii" && mode != "binary" && mode != "binary_compressed") {
        t.Fail("DATA", mode, "ascii, binary or binary_compressed");
      }
      data_start = static_cast<size_t>(line.data() + line.size() - data.data());
      if (data_start < data.size() && data[data_start] == '\r') ++data_start;
      if (data_start < data.size() && data[data_start] == '\n') ++data_start;
      data_line = cursor.line_number();
      break;
    } else {
      t.Fail("keyword", have_keyword ? key : "a first word that is not a PCD keyword",
             "one of VERSION FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT POINTS DATA" +
                 std::string(have_keyword ? "" : " (not a PCD file?)"));
    }
    have_keyword = true;
  }
  if (data_start == std::string::npos) {
    throw InputError::Message(path, "PCD header has no DATA line (not a PCD file, or truncated)");
  }
  if (fields.empty()) throw InputError::Message(path, "PCD header has no FIELDS line");
  // A damaged header's counts must not wrap around (the reads below would run off the data).
  if (height != 0 && width > std::numeric_limits<uint64_t>::max() / height) {
    throw InputError(path, 0, "WIDTH", std::to_string(width) + " x HEIGHT " + std::to_string(height),
                     "a point count that fits in 64 bits (a damaged header?)");
  }
  if (!have_points) points = width * height;
  if (points != width * height) {
    throw InputError(path, 0, "POINTS", std::to_string(points),
                     "WIDTH*HEIGHT = " + std::to_string(width * height));
  }
  // Types and layout.
  size_t point_size = 0, tokens_per_point = 0;
  int ix[3] = {-1, -1, -1}, inormal[3] = {-1, -1, -1}, iintensity = -1, irgb = -1;
  for (size_t i = 0; i < fields.size(); ++i) {
    PcdField& f = fields[i];
    if (f.type == 'F') {
      if (f.size == 4) f.scalar = ScalarType::kFloat32;
      else if (f.size == 8) f.scalar = ScalarType::kFloat64;
      else throw InputError(path, 0, "SIZE of " + f.name, std::to_string(f.size), "4 or 8 for TYPE F");
    } else {
      const bool u = f.type == 'U';
      switch (f.size) {
        case 1: f.scalar = u ? ScalarType::kUInt8 : ScalarType::kInt8; break;
        case 2: f.scalar = u ? ScalarType::kUInt16 : ScalarType::kInt16; break;
        case 4: f.scalar = u ? ScalarType::kUInt32 : ScalarType::kInt32; break;
        default: throw InputError(path, 0, "SIZE of " + f.name, "8", "1, 2 or 4 for TYPE I/U");
      }
    }
    f.offset = point_size;
    point_size += f.size * f.count;
    const int idx = static_cast<int>(i);
    if (f.name == "x") ix[0] = idx;
    else if (f.name == "y") ix[1] = idx;
    else if (f.name == "z") ix[2] = idx;
    else if (f.name == "normal_x") inormal[0] = idx;
    else if (f.name == "normal_y") inormal[1] = idx;
    else if (f.name == "normal_z") inormal[2] = idx;
    else if (f.name == "intensity") iintensity = idx;
    else if ((f.name == "rgb" || f.name == "rgba") && f.size == 4) irgb = idx;
  }
  for (int k = 0; k < 3; ++k) {
    if (ix[k] < 0) {
      throw InputError(path, 0, "FIELDS", "no " + std::string(1, "xyz"[k]),
                       "fields x, y and z (this PCD holds no coordinates)");
    }
  }
  std::vector<size_t> token_offset(fields.size());
  for (size_t i = 0; i < fields.size(); ++i) {
    token_offset[i] = tokens_per_point;
    tokens_per_point += fields[i].count;
  }
  const bool normals = inormal[0] >= 0 && inormal[1] >= 0 && inormal[2] >= 0;
  // The header's point count reserves memory only as far as the data can hold the points, not
  // up to CloudBuilder's cap (2^26 points, 2.4 GB with normals and intensity, for a 250-byte
  // file): a point takes at least 2 bytes per ASCII value ("0 ") and point_size bytes in binary.
  // A compressed point's size is unknown until its data are decompressed.
  const uint64_t data_bytes = data.size() - data_start;
  uint64_t reserve = points;
  if (mode == "ascii") reserve = std::min<uint64_t>(points, data_bytes / std::max<size_t>(1, 2 * tokens_per_point));
  if (mode == "binary") reserve = std::min<uint64_t>(points, data_bytes / std::max<size_t>(1, point_size));
  CloudBuilder builder(path, options, normals, iintensity >= 0, irgb >= 0, static_cast<size_t>(reserve));
  const bool organised = height > 1;

  auto emit = [&](auto value_of, auto rgb_bits_of, auto describe) {
    double xyz[3], n[3];
    for (int k = 0; k < 3; ++k) xyz[k] = value_of(ix[k]);
    if (normals) {
      for (int k = 0; k < 3; ++k) n[k] = value_of(inormal[k]);
    }
    // PCL pads organised clouds (HEIGHT > 1: a depth camera's or a scanner's pixel grid)
    // with all-NaN points: those are pixels without a return, no data rather than bad data,
    // and are dropped (counted in the stats) without --skip-invalid. In an unorganised
    // cloud a NaN point is an error unless skip_invalid_points.
    if (std::isnan(xyz[0]) && std::isnan(xyz[1]) && std::isnan(xyz[2]) &&
        (organised || options.skip_invalid_points)) {
      builder.CountSkipped();
      return;
    }
    uint8_t rgb[3] = {0, 0, 0};
    if (irgb >= 0) {
      const uint32_t bits = rgb_bits_of(irgb);
      rgb[0] = (bits >> 16) & 0xff;
      rgb[1] = (bits >> 8) & 0xff;
      rgb[2] = bits & 0xff;
    }
    const float inten = iintensity >= 0 ? static_cast<float>(value_of(iintensity)) : 0.0f;
    builder.Add(xyz, normals ? n : nullptr, inten, rgb, describe);
  };

  if (mode == "ascii") {
    LineCursor body(data, path);
    std::string_view l;
    for (int64_t k = 0; k < data_line; ++k) body.Next(&l);
    uint64_t i = 0;
    while (i < points) {
      if (!body.Next(&l)) {
        throw InputError(path, body.line_number() + 1, "point",
                         "end of file after " + std::to_string(i) + " of " +
                             std::to_string(points) + " points",
                         "one line per point (truncated file?)");
      }
      TokenLine t(path, body.line_number(), l);
      if (t.size() == 0) continue;
      t.ExpectCount(tokens_per_point, "point");
      auto value_of = [&](int f) -> double {
        double v;
        if (internal::NonFiniteText(t.Str(token_offset[f], fields[f].name), &v)) return v;
        return t.Double(token_offset[f], fields[f].name);
      };
      auto rgb_bits_of = [&](int f) -> uint32_t {
        if (fields[f].type == 'F') {
          double v = 0.0;
          if (!ParseDouble(t.Str(token_offset[f], fields[f].name), &v)) {
            t.Fail(fields[f].name, t.Str(token_offset[f], fields[f].name), "a packed rgb float");
          }
          const float fv = static_cast<float>(v);
          uint32_t bits;
          std::memcpy(&bits, &fv, 4);
          return bits;
        }
        return static_cast<uint32_t>(t.UInt(token_offset[f], fields[f].name));
      };
      emit(value_of, rgb_bits_of, [&] { return path + ":" + std::to_string(t.line_number()); });
      ++i;
    }
    return builder.Finish("pcd-ascii", stats);
  }

  const bool swap = !internal::HostIsLittleEndian();  // PCD binary is host (little) endian
  if (point_size > 0 && points > std::numeric_limits<size_t>::max() / point_size) {
    throw InputError(path, 0, "POINTS", std::to_string(points),
                     "at most " + std::to_string(std::numeric_limits<size_t>::max() / point_size) +
                         " points of " + std::to_string(point_size) + " bytes (a damaged header?)");
  }
  const size_t total = static_cast<size_t>(points) * point_size;
  const char* base = nullptr;
  std::vector<uint8_t> decompressed;
  bool soa = false;
  if (mode == "binary") {
    if (total > data.size() - data_start) {
      throw InputError::AtByte(path, data.size(), "binary data", "end of file",
                               std::to_string(data_start + total) + " bytes for " +
                                   std::to_string(points) + " points (truncated file?)");
    }
    base = data.data() + data_start;
  } else {
    if (data_start + 8 > data.size()) {
      throw InputError::AtByte(path, data_start, "compressed size", "end of file",
                               "two uint32 sizes (truncated file?)");
    }
    const uint32_t compressed = static_cast<uint32_t>(
        internal::ReadScalar(data.data() + data_start, ScalarType::kUInt32, swap));
    const uint32_t uncompressed = static_cast<uint32_t>(
        internal::ReadScalar(data.data() + data_start + 4, ScalarType::kUInt32, swap));
    if (uncompressed != total) {
      throw InputError::AtByte(path, data_start + 4, "uncompressed size",
                               std::to_string(uncompressed),
                               std::to_string(total) + " (POINTS × point size)");
    }
    if (data_start + 8 + compressed > data.size()) {
      throw InputError::AtByte(path, data.size(), "compressed data", "end of file",
                               std::to_string(compressed) + " bytes (truncated file?)");
    }
    // An LZF back-reference of 2–3 bytes writes at most 264 bytes and a literal run writes
    // fewer bytes than it takes, so LZF data expand at most 132-fold: a larger declared size
    // is a lie to refuse before allocating it.
    if (static_cast<double>(total) > 132.0 * compressed + 264.0) {
      throw InputError::AtByte(path, data_start + 4, "uncompressed size", std::to_string(uncompressed),
                               "at most 132 × the " + std::to_string(compressed) +
                                   " bytes of LZF data (the most LZF expands)");
    }
    decompressed.resize(total);
    if (total > 0 &&
        !LzfDecompress(reinterpret_cast<const uint8_t*>(data.data() + data_start + 8),
                       compressed, decompressed.data(), total)) {
      throw InputError::AtByte(path, data_start + 8, "compressed data", "corrupt LZF stream",
                               "valid LZF data");
    }
    base = reinterpret_cast<const char*>(decompressed.data());
    soa = true;
  }
  // SoA field start offsets.
  std::vector<size_t> soa_start(fields.size());
  {
    size_t o = 0;
    for (size_t f = 0; f < fields.size(); ++f) {
      soa_start[f] = o;
      o += static_cast<size_t>(points) * fields[f].size * fields[f].count;
    }
  }
  for (uint64_t i = 0; i < points; ++i) {
    auto address = [&](int f) {
      const PcdField& fd = fields[f];
      return soa ? base + soa_start[f] + i * fd.size * fd.count
                 : base + i * point_size + fd.offset;
    };
    auto value_of = [&](int f) { return internal::ReadScalar(address(f), fields[f].scalar, swap); };
    auto rgb_bits_of = [&](int f) {
      return static_cast<uint32_t>(internal::ReadScalar(address(f), ScalarType::kUInt32, swap));
    };
    emit(value_of, rgb_bits_of, [&] {
      return path + " (point " + std::to_string(i) + " of the " + mode + " data)";
    });
  }
  return builder.Finish(soa ? "pcd-binary-compressed" : "pcd-binary", stats);
}

}  // namespace mmba::io
