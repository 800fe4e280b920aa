// PCD v0.7 reader (ascii, binary, binary_compressed), written here so that mmba_io_cloud does
// not need PCL. Format: https://pointclouds.org/documentation/tutorials/pcd_file_format.html;
// binary_compressed = u32 compressed size, u32 uncompressed size, LZF data holding the
// fields one after the other (structure of arrays).

#include <algorithm>
#include <limits>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/io_cloud/lzf.h"
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

// The header of a PCD file: its fields, point count and where and how its data are stored.
struct PcdHeader {
  std::vector<PcdField> fields;
  uint64_t width = 0, height = 1, points = 0;
  bool have_points = false;               // a POINTS line (else POINTS = WIDTH·HEIGHT)
  std::string mode;                       // ascii, binary or binary_compressed
  size_t data_start = std::string::npos;  // byte offset of the data
  int64_t data_line = 0;                  // line number of the DATA line
};

// Reads one SIZE, TYPE or COUNT line into the fields.
void ParseFieldProperty(const TokenLine& t, const std::string& key, std::vector<PcdField>* fields) {
  t.ExpectCount(fields->size() + 1, key + " (one per field)");
  for (size_t i = 1; i < t.size(); ++i) {
    PcdField& f = (*fields)[i - 1];
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
}

// Reads the header lines up to and including DATA.
PcdHeader ReadPcdHeaderLines(const std::string& path, const std::string& data) {
  PcdHeader h;
  LineCursor cursor(data, path);
  bool have_keyword = false;  // a PCD keyword read: the file is a PCD, its words may be quoted
  std::string_view line;
  while (cursor.Next(&line)) {
    if (line.empty() || line[0] == '#') continue;
    TokenLine t(path, cursor.line_number(), line);
    if (t.size() == 0) continue;
    const std::string key = t.Str(0, "keyword");
    if (key == "VERSION" || key == "VIEWPOINT") {
      have_keyword = true;
      continue;
    }
    if (key == "FIELDS") {
      t.ExpectAtLeast(2, "FIELDS");
      h.fields.resize(t.size() - 1);
      for (size_t i = 1; i < t.size(); ++i) h.fields[i - 1].name = t.Str(i, "field");
    } else if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      ParseFieldProperty(t, key, &h.fields);
    } else if (key == "WIDTH") {
      t.ExpectCount(2, "WIDTH");
      h.width = t.UInt(1, "WIDTH");
    } else if (key == "HEIGHT") {
      t.ExpectCount(2, "HEIGHT");
      h.height = t.UInt(1, "HEIGHT");
    } else if (key == "POINTS") {
      t.ExpectCount(2, "POINTS");
      h.points = t.UInt(1, "POINTS");
      h.have_points = true;
    } else if (key == "DATA") {
      t.ExpectCount(2, "DATA");
      h.mode = t.Str(1, "DATA");
      if (h.mode != "ascii" && h.mode != "binary" && h.mode != "binary_compressed") {
        t.Fail("DATA", h.mode, "ascii, binary or binary_compressed");
      }
      h.data_start = static_cast<size_t>(line.data() + line.size() - data.data());
      if (h.data_start < data.size() && data[h.data_start] == '\r') ++h.data_start;
      if (h.data_start < data.size() && data[h.data_start] == '\n') ++h.data_start;
      h.data_line = cursor.line_number();
      break;
    } else {
      t.Fail("keyword", have_keyword ? key : "a first word that is not a PCD keyword",
             "one of VERSION FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT POINTS DATA" +
                 std::string(have_keyword ? "" : " (not a PCD file?)"));
    }
    have_keyword = true;
  }
  return h;
}

// The header, checked: a DATA line, fields, and POINTS = WIDTH·HEIGHT (POINTS defaults to it).
PcdHeader ParsePcdHeader(const std::string& path, const std::string& data) {
  PcdHeader h = ReadPcdHeaderLines(path, data);
  if (h.data_start == std::string::npos) {
    throw InputError::Message(path, "PCD header has no DATA line (not a PCD file, or truncated)");
  }
  if (h.fields.empty()) throw InputError::Message(path, "PCD header has no FIELDS line");
  // A damaged header's counts must not wrap around (the reads below would run off the data).
  if (h.height != 0 && h.width > std::numeric_limits<uint64_t>::max() / h.height) {
    throw InputError(path, 0, "WIDTH", std::to_string(h.width) + " x HEIGHT " + std::to_string(h.height),
                     "a point count that fits in 64 bits (a damaged header?)");
  }
  if (!h.have_points) h.points = h.width * h.height;
  if (h.points != h.width * h.height) {
    throw InputError(path, 0, "POINTS", std::to_string(h.points),
                     "WIDTH*HEIGHT = " + std::to_string(h.width * h.height));
  }
  return h;
}

// Where the fields of a point lie and which of them mmba reads.
struct PcdLayout {
  size_t point_size = 0, tokens_per_point = 0;  // bytes (binary), values (ascii)
  std::vector<size_t> token_offset;             // first value of each field in an ascii line
  int ix[3] = {-1, -1, -1}, inormal[3] = {-1, -1, -1}, iintensity = -1, irgb = -1, iring = -1;
  bool normals = false;
};

// The names LiDAR drivers give the return strength: PCL's `intensity`, `i` (Livox, some ROS
// exporters), `reflectivity` (Ouster), `reflectance`. Any numeric type is read as a float.
bool IsIntensityName(const std::string& name) {
  return name == "intensity" || name == "i" || name == "reflectivity" || name == "reflectance";
}

// The laser (beam) index of a point: `ring` (Velodyne, Hesai, Ouster drivers) or `laser_id`.
bool IsRingName(const std::string& name) { return name == "ring" || name == "laser_id"; }

// Each field's scalar type and offset, the fields mmba reads; x, y and z are required.
PcdLayout ResolveLayout(const std::string& path, std::vector<PcdField>* fields) {
  PcdLayout layout;
  for (size_t i = 0; i < fields->size(); ++i) {
    PcdField& f = (*fields)[i];
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
    f.offset = layout.point_size;
    layout.point_size += f.size * f.count;
    const int idx = static_cast<int>(i);
    if (f.name == "x") layout.ix[0] = idx;
    else if (f.name == "y") layout.ix[1] = idx;
    else if (f.name == "z") layout.ix[2] = idx;
    else if (f.name == "normal_x") layout.inormal[0] = idx;
    else if (f.name == "normal_y") layout.inormal[1] = idx;
    else if (f.name == "normal_z") layout.inormal[2] = idx;
    else if (IsIntensityName(f.name) && f.count == 1) layout.iintensity = idx;
    else if (IsRingName(f.name) && f.count == 1 && f.type != 'F') layout.iring = idx;
    else if ((f.name == "rgb" || f.name == "rgba") && f.size == 4) layout.irgb = idx;
  }
  for (int k = 0; k < 3; ++k) {
    if (layout.ix[k] < 0) {
      throw InputError(path, 0, "FIELDS", "no " + std::string(1, "xyz"[k]),
                       "fields x, y and z (this PCD holds no coordinates)");
    }
  }
  layout.token_offset.resize(fields->size());
  for (size_t i = 0; i < fields->size(); ++i) {
    layout.token_offset[i] = layout.tokens_per_point;
    layout.tokens_per_point += (*fields)[i].count;
  }
  layout.normals = layout.inormal[0] >= 0 && layout.inormal[1] >= 0 && layout.inormal[2] >= 0;
  return layout;
}

// Adds one point to the builder from its field values.
class PcdPointEmitter {
 public:
  PcdPointEmitter(const PcdLayout& layout, const ReadOptions& options, bool organised, CloudBuilder* builder)
      : layout_(layout), options_(options), organised_(organised), builder_(builder) {}

  // value_of(field) → double, rgb_bits_of(field) → uint32_t, describe() → the point's place.
  template <typename ValueOf, typename RgbBitsOf, typename Describe>
  void Emit(ValueOf value_of, RgbBitsOf rgb_bits_of, Describe describe) const {
    double xyz[3], n[3];
    for (int k = 0; k < 3; ++k) xyz[k] = value_of(layout_.ix[k]);
    if (layout_.normals) {
      for (int k = 0; k < 3; ++k) n[k] = value_of(layout_.inormal[k]);
    }
    // PCL pads organised clouds (HEIGHT > 1: a depth camera's or a scanner's pixel grid)
    // with all-NaN points: those are pixels without a return, no data rather than bad data,
    // and are dropped (counted in the stats) without --skip-invalid. In an unorganised
    // cloud a NaN point is an error unless skip_invalid_points.
    if (std::isnan(xyz[0]) && std::isnan(xyz[1]) && std::isnan(xyz[2]) &&
        (organised_ || options_.skip_invalid_points)) {
      builder_->CountSkipped();
      return;
    }
    uint8_t rgb[3] = {0, 0, 0};
    if (layout_.irgb >= 0) {
      const uint32_t bits = rgb_bits_of(layout_.irgb);
      rgb[0] = (bits >> 16) & 0xff;
      rgb[1] = (bits >> 8) & 0xff;
      rgb[2] = bits & 0xff;
    }
    const float inten = layout_.iintensity >= 0 ? static_cast<float>(value_of(layout_.iintensity)) : 0.0f;
    if (builder_->Add(xyz, layout_.normals ? n : nullptr, inten, rgb, describe) && layout_.iring >= 0) {
      builder_->AddRing(value_of(layout_.iring), describe);
    }
  }

 private:
  const PcdLayout& layout_;
  const ReadOptions& options_;
  bool organised_;
  CloudBuilder* builder_;
};

// The ascii data: one line of tokens_per_point values per point.
void ReadPcdAscii(const std::string& path, const std::string& data, const PcdHeader& h, const PcdLayout& layout,
                  const PcdPointEmitter& emitter) {
  const std::vector<PcdField>& fields = h.fields;
  LineCursor body(data, path);
  std::string_view l;
  for (int64_t k = 0; k < h.data_line; ++k) body.Next(&l);
  uint64_t i = 0;
  while (i < h.points) {
    if (!body.Next(&l)) {
      throw InputError(path, body.line_number() + 1, "point",
                       "end of file after " + std::to_string(i) + " of " +
                           std::to_string(h.points) + " points",
                       "one line per point (truncated file?)");
    }
    TokenLine t(path, body.line_number(), l);
    if (t.size() == 0) continue;
    t.ExpectCount(layout.tokens_per_point, "point");
    auto value_of = [&](int f) -> double {
      double v;
      if (internal::NonFiniteText(t.Str(layout.token_offset[f], fields[f].name), &v)) return v;
      return t.Double(layout.token_offset[f], fields[f].name);
    };
    auto rgb_bits_of = [&](int f) -> uint32_t {
      if (fields[f].type == 'F') {
        double v = 0.0;
        if (!ParseDouble(t.Str(layout.token_offset[f], fields[f].name), &v)) {
          t.Fail(fields[f].name, t.Str(layout.token_offset[f], fields[f].name), "a packed rgb float");
        }
        const float fv = static_cast<float>(v);
        uint32_t bits;
        std::memcpy(&bits, &fv, 4);
        return bits;
      }
      return static_cast<uint32_t>(t.UInt(layout.token_offset[f], fields[f].name));
    };
    emitter.Emit(value_of, rgb_bits_of, [&] { return path + ":" + std::to_string(t.line_number()); });
    ++i;
  }
}

// The binary_compressed data, decompressed into `decompressed` (structure of arrays), after
// checking the declared sizes against the file and against LZF's largest expansion.
void DecompressPcd(const std::string& path, const std::string& data, const PcdHeader& h, size_t total,
                   std::vector<uint8_t>* decompressed) {
  const bool swap = !internal::HostIsLittleEndian();  // PCD binary is host (little) endian
  const size_t data_start = h.data_start;
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
  decompressed->resize(total);
  size_t at = 0;
  const LzfProblem problem =
      total == 0 ? LzfProblem::kNone
                 : LzfDecompress(reinterpret_cast<const uint8_t*>(data.data() + data_start + 8), compressed,
                                 decompressed->data(), total, &at);
  if (problem != LzfProblem::kNone) {
    throw InputError::AtByte(path, data_start + 8 + at, "compressed data",
                             std::string("corrupt LZF stream: ") + LzfProblemText(problem),
                             std::to_string(compressed) + " bytes of LZF data decoding to " +
                                 std::to_string(total) + " bytes (POINTS x point size)");
  }
}

// The binary (array of structures) or binary_compressed (structure of arrays) data.
void ReadPcdBinary(const std::string& path, const std::string& data, const PcdHeader& h, const PcdLayout& layout,
                   const PcdPointEmitter& emitter) {
  const std::vector<PcdField>& fields = h.fields;
  const uint64_t points = h.points;
  const size_t point_size = layout.point_size;
  const bool swap = !internal::HostIsLittleEndian();  // PCD binary is host (little) endian
  if (point_size > 0 && points > std::numeric_limits<size_t>::max() / point_size) {
    throw InputError(path, 0, "POINTS", std::to_string(points),
                     "at most " + std::to_string(std::numeric_limits<size_t>::max() / point_size) +
                         " points of " + std::to_string(point_size) + " bytes (a damaged header?)");
  }
  const size_t total = static_cast<size_t>(points) * point_size;
  const char* base = nullptr;
  std::vector<uint8_t> decompressed;
  const bool soa = h.mode != "binary";
  if (!soa) {
    if (total > data.size() - h.data_start) {
      throw InputError::AtByte(path, data.size(), "binary data", "end of file",
                               std::to_string(h.data_start + total) + " bytes for " +
                                   std::to_string(points) + " points (truncated file?)");
    }
    base = data.data() + h.data_start;
  } else {
    DecompressPcd(path, data, h, total, &decompressed);
    base = reinterpret_cast<const char*>(decompressed.data());
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
    emitter.Emit(value_of, rgb_bits_of, [&] {
      return path + " (point " + std::to_string(i) + " of the " + h.mode + " data)";
    });
  }
}

}  // namespace

PointCloud ReadPcd(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  const std::string data = ReadWholeFile(path);
  PcdHeader h = ParsePcdHeader(path, data);
  const PcdLayout layout = ResolveLayout(path, &h.fields);
  // The header's point count reserves memory only as far as the data can hold the points, not
  // up to CloudBuilder's cap (2^26 points, 2.4 GB with normals and intensity, for a 250-byte
  // file): a point takes at least 2 bytes per ASCII value ("0 ") and point_size bytes in binary.
  // A compressed point's size is unknown until its data are decompressed.
  const uint64_t data_bytes = data.size() - h.data_start;
  uint64_t reserve = h.points;
  if (h.mode == "ascii") {
    reserve = std::min<uint64_t>(h.points, data_bytes / std::max<size_t>(1, 2 * layout.tokens_per_point));
  }
  if (h.mode == "binary") reserve = std::min<uint64_t>(h.points, data_bytes / std::max<size_t>(1, layout.point_size));
  CloudBuilder builder(path, options, layout.normals, layout.iintensity >= 0, layout.irgb >= 0,
                       static_cast<size_t>(reserve));
  if (layout.iring >= 0) builder.EnableRing();
  const PcdPointEmitter emitter(layout, options, h.height > 1, &builder);
  if (h.mode == "ascii") {
    ReadPcdAscii(path, data, h, layout, emitter);
    return builder.Finish("pcd-ascii", stats);
  }
  ReadPcdBinary(path, data, h, layout, emitter);
  return builder.Finish(h.mode == "binary" ? "pcd-binary" : "pcd-binary-compressed", stats);
}

}  // namespace mmba::io
