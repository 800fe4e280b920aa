// PLY reader (ascii, binary little/big endian); the writer is point_cloud_ply_write.cc.
// Format: Greg Turk, "The PLY Polygon File Format" (1994), as used by the Stanford 3D
// Scanning Repository.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <limits>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

using internal::CloudBuilder;
using internal::ScalarType;

struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  bool is_list = false;
  ScalarType count_type = ScalarType::kUInt8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLe, kBinaryBe };

bool ParsePlyType(const std::string& s, ScalarType* type) {
  static const std::pair<const char*, ScalarType> kTypes[] = {
      {"char", ScalarType::kInt8},     {"int8", ScalarType::kInt8},
      {"uchar", ScalarType::kUInt8},   {"uint8", ScalarType::kUInt8},
      {"short", ScalarType::kInt16},   {"int16", ScalarType::kInt16},
      {"ushort", ScalarType::kUInt16}, {"uint16", ScalarType::kUInt16},
      {"int", ScalarType::kInt32},     {"int32", ScalarType::kInt32},
      {"uint", ScalarType::kUInt32},   {"uint32", ScalarType::kUInt32},
      {"float", ScalarType::kFloat32}, {"float32", ScalarType::kFloat32},
      {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64}};
  for (const auto& [name, t] : kTypes) {
    if (s == name) {
      *type = t;
      return true;
    }
  }
  return false;
}

constexpr const char* kTypeNames =
    "one of char uchar short ushort int uint float double (or int8 … float64)";
constexpr const char* kCountTypeNames =
    "an integer type: one of char uchar short ushort int uint (or int8 … uint32)";

// Property roles within the vertex element.
struct VertexLayout {
  int xyz[3] = {-1, -1, -1};
  int normal[3] = {-1, -1, -1};
  int intensity = -1;
  int rgb[3] = {-1, -1, -1};
  int time = -1;
};

VertexLayout FindVertexLayout(const PlyElement& vertex) {
  VertexLayout layout;
  for (size_t i = 0; i < vertex.properties.size(); ++i) {
    const PlyProperty& p = vertex.properties[i];
    if (p.is_list) continue;
    const std::string& n = p.name;
    const int idx = static_cast<int>(i);
    if (n == "x") layout.xyz[0] = idx;
    else if (n == "y") layout.xyz[1] = idx;
    else if (n == "z") layout.xyz[2] = idx;
    else if (n == "nx" || n == "normal_x") layout.normal[0] = idx;
    else if (n == "ny" || n == "normal_y") layout.normal[1] = idx;
    else if (n == "nz" || n == "normal_z") layout.normal[2] = idx;
    else if ((n == "intensity" || n == "scalar_intensity" || n == "reflectance" ||
              n == "scalar_Intensity" || n == "scalar_reflectance" || n == "scalar_Reflectance" ||
              n == "remission") && layout.intensity < 0) {
      layout.intensity = idx;
    } else if ((n == "time" || n == "gps_time" || n == "timestamp") && layout.time < 0) {
      layout.time = idx;
    } else if (n == "red" || n == "diffuse_red" || n == "r") layout.rgb[0] = idx;
    else if (n == "green" || n == "diffuse_green" || n == "g") layout.rgb[1] = idx;
    else if (n == "blue" || n == "diffuse_blue" || n == "b") layout.rgb[2] = idx;
  }
  return layout;
}

uint8_t ColorByte(double v, ScalarType type) {
  switch (type) {
    case ScalarType::kFloat32:
    case ScalarType::kFloat64:
      return static_cast<uint8_t>(std::clamp(v * 255.0 + 0.5, 0.0, 255.0));
    case ScalarType::kUInt16:
    case ScalarType::kInt16:
      return static_cast<uint8_t>(std::clamp(v / 257.0 + 0.5, 0.0, 255.0));
    default:
      return static_cast<uint8_t>(std::clamp(v, 0.0, 255.0));
  }
}

// The parsed header: format, elements, where the data start, how many lines the header has,
// and which element holds the vertices.
struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t header_end = 0;
  int64_t header_lines = 0;
  size_t vertex_index = 0;
};

// The format of a "format FORMAT 1.0" header line.
PlyFormat ParsePlyFormatLine(const TokenLine& t) {
  t.ExpectCount(3, "format");
  PlyFormat format = PlyFormat::kAscii;
  const std::string& f = t.Str(1, "format");
  if (f == "ascii") format = PlyFormat::kAscii;
  else if (f == "binary_little_endian") format = PlyFormat::kBinaryLe;
  else if (f == "binary_big_endian") format = PlyFormat::kBinaryBe;
  else t.Fail("format", f, "ascii, binary_little_endian or binary_big_endian");
  if (t.Str(2, "version") != "1.0") t.Fail("version", t.Str(2, "version"), "1.0");
  return format;
}

// A "property TYPE NAME" or "property list COUNT_TYPE ITEM_TYPE NAME" header line.
PlyProperty ParsePlyPropertyLine(const TokenLine& t) {
  PlyProperty p;
  if (t.size() >= 2 && t.Str(1, "type") == "list") {
    t.ExpectCount(5, "list property");
    p.is_list = true;
    // A count is an integer: a float count (NaN, 1e30, 2.5) has no number of items.
    if (!ParsePlyType(t.Str(2, "count type"), &p.count_type) || p.count_type == ScalarType::kFloat32 ||
        p.count_type == ScalarType::kFloat64) {
      t.Fail("count type", t.Str(2, "count type"), kCountTypeNames);
    }
    if (!ParsePlyType(t.Str(3, "item type"), &p.type)) {
      t.Fail("item type", t.Str(3, "item type"), kTypeNames);
    }
    p.name = t.Str(4, "name");
  } else {
    t.ExpectCount(3, "property");
    if (!ParsePlyType(t.Str(1, "type"), &p.type)) t.Fail("type", t.Str(1, "type"), kTypeNames);
    p.name = t.Str(2, "name");
  }
  return p;
}

// The index of the first element named "vertex"; InputError if there is none.
size_t FindVertexElement(const std::string& path, const std::vector<PlyElement>& elements) {
  for (size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].name == "vertex") return i;
  }
  throw InputError::Message(path, "PLY header declares no 'vertex' element");
}

// Parses the header at the start of `data` (the whole file or a prefix ending after
// end_header).
PlyHeader ParsePlyHeader(const std::string& path, std::string_view data) {
  PlyHeader header;
  // The first line is checked before it is read as a line: a file of another kind is named
  // as such, its content not quoted back (it can be any file) and not split into lines.
  const std::string_view start = data.substr(data.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0, 5);
  if (start.substr(0, 4) != "ply\n" && start != "ply\r\n") {
    throw InputError(path, 1, "magic", "a first line other than 'ply'", "'ply' (not a PLY file?)");
  }
  LineCursor cursor(data, path);
  std::string_view line;
  cursor.Next(&line);
  bool have_format = false;
  std::vector<PlyElement>& elements = header.elements;
  size_t header_end = std::string::npos;
  while (cursor.Next(&line)) {
    TokenLine t(path, cursor.line_number(), line);
    if (t.size() == 0) continue;
    const std::string& key = t.Str(0, "keyword");
    if (key == "comment" || key == "obj_info") continue;
    if (key == "format") {
      header.format = ParsePlyFormatLine(t);
      have_format = true;
    } else if (key == "element") {
      t.ExpectCount(3, "element");
      PlyElement e;
      e.name = t.Str(1, "element name");
      e.count = t.UInt(2, "element count");
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) t.Fail("property", std::string(line), "an 'element' line before it");
      elements.back().properties.push_back(ParsePlyPropertyLine(t));
    } else if (key == "end_header") {
      header_end = static_cast<size_t>(line.data() + line.size() - data.data());
      // Skip the line terminator ("\n" or "\r\n").
      if (header_end < data.size() && data[header_end] == '\r') ++header_end;
      if (header_end < data.size() && data[header_end] == '\n') ++header_end;
      break;
    } else {
      t.Fail("keyword", key, "one of format, comment, obj_info, element, property, end_header");
    }
  }
  if (!have_format) throw InputError::Message(path, "PLY header has no 'format' line");
  if (header_end == std::string::npos) {
    throw InputError::Message(path, "PLY header has no 'end_header' line (truncated file?)");
  }
  header.header_end = header_end;
  header.header_lines = cursor.line_number();
  header.vertex_index = FindVertexElement(path, elements);
  return header;
}

// The vertex layout of a header, with x, y, z required.
VertexLayout RequireXyz(const std::string& path, const PlyElement& vertex) {
  const VertexLayout layout = FindVertexLayout(vertex);
  for (int k = 0; k < 3; ++k) {
    if (layout.xyz[k] < 0) {
      throw InputError(path, 0, "vertex property", "missing " + std::string(1, "xyz"[k]),
                       "vertex properties x, y and z (scalar)");
    }
  }
  return layout;
}

// Hands one vertex's property values to the builder.
template <typename Describe>
void EmitVertex(const VertexLayout& layout, const PlyElement& vertex, const std::vector<double>& values,
                CloudBuilder* builder, Describe describe) {
  const bool normals = layout.normal[0] >= 0 && layout.normal[1] >= 0 && layout.normal[2] >= 0;
  const bool colors = layout.rgb[0] >= 0 && layout.rgb[1] >= 0 && layout.rgb[2] >= 0;
  double xyz[3], n[3];
  uint8_t rgb[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) xyz[k] = values[layout.xyz[k]];
  if (normals) {
    for (int k = 0; k < 3; ++k) n[k] = values[layout.normal[k]];
  }
  if (colors) {
    for (int k = 0; k < 3; ++k) rgb[k] = ColorByte(values[layout.rgb[k]], vertex.properties[layout.rgb[k]].type);
  }
  const float inten = layout.intensity >= 0 ? static_cast<float>(values[layout.intensity]) : 0.0f;
  builder->Add(xyz, normals ? n : nullptr, inten, rgb, describe, layout.time >= 0 ? values[layout.time] : 0.0);
}

CloudBuilder MakeBuilder(const std::string& path, const ReadOptions& options, const VertexLayout& layout,
                         size_t reserve) {
  return CloudBuilder(path, options, layout.normal[0] >= 0 && layout.normal[1] >= 0 && layout.normal[2] >= 0,
                      layout.intensity >= 0, layout.rgb[0] >= 0 && layout.rgb[1] >= 0 && layout.rgb[2] >= 0,
                      reserve, layout.time >= 0);
}

// One ASCII line of an element other than the vertices: one value per scalar property, and
// a count followed by that many values per list property.
void CheckAsciiItem(const TokenLine& t, const PlyElement& element) {
  size_t token = 0;
  for (const PlyProperty& prop : element.properties) {
    if (prop.is_list) {
      const uint64_t count = t.UInt(token, prop.name + " count");
      if (count > t.size()) t.Fail(prop.name + " count", std::to_string(count), "at most the values on the line");
      token += 1 + count;
    } else {
      token += 1;
    }
  }
  if (token != t.size()) {
    t.Fail(element.name, std::to_string(t.size()) + " values", std::to_string(token) + " values (one per property)");
  }
}

// The vertices of an ASCII PLY into the builder (the other elements' lines checked), and
// nothing but blank lines after the last element.
void ReadPlyAsciiBody(const std::string& path, const std::string& data, const PlyHeader& header,
                      const VertexLayout& layout, std::vector<double>& values, CloudBuilder* builder) {
  const std::vector<PlyElement>& elements = header.elements;
  const size_t vertex_index = header.vertex_index;
  const PlyElement& vertex = elements[vertex_index];
  auto emit = [&](auto describe) { EmitVertex(layout, vertex, values, builder, describe); };
  // A plain vertex line (no list property; one finite number per property) is parsed in
  // place; any other line goes through TokenLine, for NaN/Inf values or a located error.
  bool has_list = false;
  for (const PlyProperty& prop : vertex.properties) has_list = has_list || prop.is_list;
  auto plain_line = [&](std::string_view line) {
    size_t i = 0, p = 0;
    while (true) {
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      if (i == line.size()) return p == values.size();
      size_t j = i;
      while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
      if (p == values.size() || !ParseDouble(line.substr(i, j - i), &values[p])) return false;
      ++p;
      i = j;
    }
  };
  LineCursor body(data, path);
  std::string_view l;
  for (int64_t k = 0; k < header.header_lines; ++k) body.Next(&l);
  for (size_t e = 0; e < elements.size(); ++e) {
    const PlyElement& element = elements[e];
    for (uint64_t i = 0; i < element.count; ++i) {
      if (!body.Next(&l)) {
        throw InputError(path, body.line_number() + 1, element.name,
                         "end of file after " + std::to_string(i) + " of " +
                             std::to_string(element.count) + " items",
                         "one line per item (truncated file?)");
      }
      if (e != vertex_index) {
        CheckAsciiItem(TokenLine(path, body.line_number(), l), element);
        continue;
      }
      if (!has_list && plain_line(l)) {
        emit([&] { return path + ":" + std::to_string(body.line_number()); });
        continue;
      }
      TokenLine t(path, body.line_number(), l);
      size_t token = 0;
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& prop = element.properties[p];
        if (prop.is_list) {
          const uint64_t count = t.UInt(token++, prop.name + " count");
          token += count;
          continue;
        }
        if (!internal::NonFiniteText(t.Str(token, prop.name), &values[p])) {
          values[p] = t.Double(token, prop.name);
        }
        ++token;
      }
      if (token != t.size()) {
        t.Fail("vertex", std::to_string(t.size()) + " values",
               std::to_string(token) + " values (one per property)");
      }
      emit([&] { return path + ":" + std::to_string(t.line_number()); });
    }
  }
  while (body.Next(&l)) {
    if (TokenLine(path, body.line_number(), l).size() == 0) continue;
    throw InputError(path, body.line_number(), "end of file", "a line after the last element",
                     "nothing after the " + std::to_string(elements.back().count) + " items of element '" +
                         elements.back().name + "' (element counts in the header too small?)");
  }
}

// The vertices of a binary PLY (little or big endian) into the builder, the other elements
// skipped, and no byte after the last element.
void ReadPlyBinaryBody(const std::string& path, const std::string& data, const PlyHeader& header,
                       const VertexLayout& layout, std::vector<double>& values, CloudBuilder* builder) {
  const PlyFormat format = header.format;
  const std::vector<PlyElement>& elements = header.elements;
  const size_t header_end = header.header_end;
  const size_t vertex_index = header.vertex_index;
  const PlyElement& vertex = elements[vertex_index];
  auto emit = [&](auto describe) { EmitVertex(layout, vertex, values, builder, describe); };
  const bool file_le = format == PlyFormat::kBinaryLe;
  const bool swap = file_le != internal::HostIsLittleEndian();
  size_t pos = header_end;
  auto need = [&](size_t bytes, const std::string& what) {
    if (pos + bytes > data.size()) {
      throw InputError::AtByte(path, pos, what, "end of file",
                               std::to_string(bytes) + " more bytes (truncated file?)");
    }
  };
  // `count` records of `stride` bytes, compared by division (a damaged count could wrap).
  auto need_records = [&](uint64_t count, size_t stride, const std::string& what) {
    if (stride > 0 && count > (data.size() - pos) / stride) {
      throw InputError::AtByte(path, pos, what, "end of file",
                               std::to_string(count) + " records of " + std::to_string(stride) +
                                   " bytes (truncated file, or a wrong count in the header?)");
    }
  };
  for (size_t e = 0; e < elements.size(); ++e) {
    const PlyElement& element = elements[e];
    // Fixed-size fast path check.
    bool fixed = true;
    size_t stride = 0;
    for (const PlyProperty& p : element.properties) {
      if (p.is_list) fixed = false;
      stride += internal::ScalarSize(p.type);
    }
    if (fixed) need_records(element.count, stride, element.name + " element");
    if (e != vertex_index && fixed) {
      pos += static_cast<size_t>(stride * element.count);
      continue;
    }
    for (uint64_t i = 0; i < element.count; ++i) {
      const size_t item_start = pos;
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& prop = element.properties[p];
        if (prop.is_list) {
          need(internal::ScalarSize(prop.count_type), prop.name + " count");
          const double count = internal::ReadScalar(data.data() + pos, prop.count_type, swap);
          if (count < 0) {
            throw InputError::AtByte(path, pos, prop.name + " count", std::to_string(count),
                                     "a non-negative count");
          }
          pos += internal::ScalarSize(prop.count_type);
          const size_t bytes = static_cast<size_t>(count) * internal::ScalarSize(prop.type);
          need(bytes, prop.name);
          pos += bytes;
          continue;
        }
        need(internal::ScalarSize(prop.type), prop.name);
        values[p] = internal::ReadScalar(data.data() + pos, prop.type, swap);
        pos += internal::ScalarSize(prop.type);
      }
      if (e == vertex_index) {
        emit([&] { return path + " (byte " + std::to_string(item_start) + ")"; });
      }
    }
  }
  if (pos != data.size()) {
    throw InputError::AtByte(path, pos, "end of file", std::to_string(data.size() - pos) + " more bytes",
                             "nothing after the " + std::to_string(elements.back().count) + " items of element '" +
                                 elements.back().name + "' (element counts in the header too small?)");
  }
}

}  // namespace

PointCloud ReadPly(const std::string& path) { return ReadPly(path, {}); }

PointCloud ReadPly(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  const std::string data = ReadWholeFile(path);
  const PlyHeader header = ParsePlyHeader(path, data);
  const PlyFormat format = header.format;
  const size_t header_end = header.header_end;
  const PlyElement& vertex = header.elements[header.vertex_index];
  const VertexLayout layout = RequireXyz(path, vertex);
  // The header's vertex count reserves memory only as far as the data can hold the records,
  // not up to CloudBuilder's cap (2^26 points, 4 GB with all fields, for a 500-byte file that
  // declares 2^35 vertices): a vertex takes at least 2 bytes per ASCII value ("0 "), and at
  // least the scalar's (or a list's count's) size per binary value.
  size_t min_vertex_bytes = 0;
  for (const PlyProperty& p : vertex.properties) {
    min_vertex_bytes += format == PlyFormat::kAscii ? 2 : internal::ScalarSize(p.is_list ? p.count_type : p.type);
  }
  const uint64_t vertices_that_fit = (data.size() - header_end) / std::max<size_t>(1, min_vertex_bytes);
  CloudBuilder builder = MakeBuilder(path, options, layout, std::min<uint64_t>(vertex.count, vertices_that_fit));
  std::vector<double> values(vertex.properties.size());
  if (format == PlyFormat::kAscii) {
    ReadPlyAsciiBody(path, data, header, layout, values, &builder);
    return builder.Finish("ply-ascii", stats);
  }
  ReadPlyBinaryBody(path, data, header, layout, values, &builder);
  return builder.Finish(format == PlyFormat::kBinaryLe ? "ply-binary-le" : "ply-binary-be", stats);
}

namespace {

// Fails unless the file holds `element.count` records of `stride` bytes from byte `pos` on,
// compared by division (a damaged count could wrap around).
void RequireRecords(const std::string& path, const PlyElement& element, size_t stride, uint64_t pos,
                    uint64_t file_size) {
  if (stride > 0 && element.count > (file_size - std::min(pos, file_size)) / stride) {
    throw InputError::AtByte(path, pos, element.name + " element", "end of file",
                             std::to_string(element.count) + " records of " + std::to_string(stride) +
                                 " bytes (truncated file, or a wrong count in the header?)");
  }
}

// Reads past the records of the elements after the vertices of a binary PLY streamed from
// `in` (at byte `pos`): they must all be in the file, and nothing after them.
void SkipElementsAfterVertices(const std::string& path, const PlyHeader& header, bool swap, uint64_t file_size,
                               uint64_t pos, std::istream& in) {
  for (size_t e = header.vertex_index + 1; e < header.elements.size(); ++e) {
    const PlyElement& element = header.elements[e];
    size_t stride = 0;
    bool fixed = true;
    for (const PlyProperty& p : element.properties) {
      fixed = fixed && !p.is_list;
      stride += internal::ScalarSize(p.type);
    }
    if (fixed) {
      RequireRecords(path, element, stride, pos, file_size);
      pos += stride * element.count;
      in.seekg(static_cast<std::streamoff>(pos));
      continue;
    }
    for (uint64_t i = 0; i < element.count; ++i) {
      for (const PlyProperty& p : element.properties) {
        const size_t count_size = internal::ScalarSize(p.is_list ? p.count_type : p.type);
        if (count_size > file_size - pos) {
          throw InputError::AtByte(path, pos, element.name + " element", "end of file",
                                   std::to_string(element.count) + " items (truncated file, or a wrong count in the header?)");
        }
        if (!p.is_list) {
          in.ignore(static_cast<std::streamsize>(count_size));
          pos += count_size;
          continue;
        }
        char buffer[8];
        in.read(buffer, static_cast<std::streamsize>(count_size));
        const double count = internal::ReadScalar(buffer, p.count_type, swap);
        if (count < 0) {
          throw InputError::AtByte(path, pos, p.name + " count", std::to_string(count), "a non-negative count");
        }
        pos += count_size;
        const uint64_t bytes = static_cast<uint64_t>(count) * internal::ScalarSize(p.type);
        if (bytes > file_size - pos) {
          throw InputError::AtByte(path, pos, p.name, "end of file", std::to_string(bytes) + " more bytes (truncated file?)");
        }
        in.ignore(static_cast<std::streamsize>(bytes));
        pos += bytes;
      }
    }
  }
  if (pos != file_size) {
    throw InputError::AtByte(path, pos, "end of file", std::to_string(file_size - pos) + " more bytes",
                             "nothing after the " + std::to_string(header.elements.back().count) + " items of element '" +
                                 header.elements.back().name + "' (element counts in the header too small?)");
  }
}

}  // namespace

namespace internal {

bool StreamBinaryPly(const std::string& path, size_t chunk_points, const ChunkConsumer& consume,
                     const ReadOptions& options, ReadStats* stats) {
  RequireRegularFile(path);
  std::error_code ec;
  const uint64_t file_size = std::filesystem::file_size(path, ec);
  std::ifstream in(path, std::ios::binary);
  if (ec || !in) return false;  // the whole-file reader names the error
  // The header, line by line up to end_header (bounded: a header is a few hundred bytes). A
  // header this bound cuts short is left to the whole-file reader.
  constexpr size_t kMaxHeaderBytes = size_t{1} << 20;
  std::string header_text, line;
  bool at_end_header = false;
  while (header_text.size() < kMaxHeaderBytes && std::getline(in, line)) {
    header_text += line;
    header_text += '\n';
    at_end_header = line == "end_header" || line == "end_header\r";
    if (at_end_header) break;
  }
  if (!in || (!at_end_header && header_text.size() >= kMaxHeaderBytes)) return false;
  const PlyHeader header = ParsePlyHeader(path, header_text);
  if (header.format == PlyFormat::kAscii) return false;
  const bool swap = (header.format == PlyFormat::kBinaryLe) != HostIsLittleEndian();
  // The data start where ParsePlyHeader says, as in the whole-file reader, not at tellg().
  // That is -1 once getline has met the end of the file (a file ending on "end_header"
  // without a newline), and past the data's start when the end_header line is not exactly
  // "end_header" ("end_header " or "end_header x": the loop reads on). header_text holds the
  // file's bytes up to there, plus a '\n' that its last line may lack in the file.
  size_t pos = static_cast<size_t>(std::min<uint64_t>(header.header_end, file_size));
  in.clear();
  // Elements before the vertices must have fixed-size records to be skipped.
  for (size_t e = 0; e <= header.vertex_index; ++e) {
    size_t stride = 0;
    for (const PlyProperty& p : header.elements[e].properties) {
      if (p.is_list) return false;
      stride += ScalarSize(p.type);
    }
    if (e == header.vertex_index) break;
    RequireRecords(path, header.elements[e], stride, pos, file_size);
    pos += stride * header.elements[e].count;
  }
  const PlyElement& vertex = header.elements[header.vertex_index];
  const VertexLayout layout = RequireXyz(path, vertex);
  size_t stride = 0;
  std::vector<size_t> offset;
  for (const PlyProperty& p : vertex.properties) {
    offset.push_back(stride);
    stride += ScalarSize(p.type);
  }
  in.seekg(static_cast<std::streamoff>(pos));
  chunk_points = std::max<size_t>(1, chunk_points);
  std::vector<char> buffer;
  std::vector<double> values(vertex.properties.size());
  size_t read = 0, skipped = 0;
  for (uint64_t first = 0; first < vertex.count; first += chunk_points) {
    const size_t count = static_cast<size_t>(std::min<uint64_t>(chunk_points, vertex.count - first));
    buffer.resize(count * stride);
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    if (static_cast<size_t>(in.gcount()) != buffer.size()) {
      throw InputError::AtByte(path, pos + static_cast<size_t>(std::max<std::streamsize>(0, in.gcount())), vertex.name + " element",
                               "end of file", std::to_string(buffer.size()) + " bytes for points " + std::to_string(first) +
                                                  "–" + std::to_string(first + count - 1) + " (truncated file?)");
    }
    CloudBuilder builder = MakeBuilder(path, options, layout, count);
    builder.SetFirstIndex(static_cast<size_t>(first));
    for (size_t i = 0; i < count; ++i) {
      const char* record = buffer.data() + i * stride;
      for (size_t p = 0; p < values.size(); ++p) values[p] = ReadScalar(record + offset[p], vertex.properties[p].type, swap);
      const size_t at = pos + i * stride;
      EmitVertex(layout, vertex, values, &builder, [&] { return path + " (byte " + std::to_string(at) + ")"; });
    }
    ReadStats chunk_stats;
    const PointCloud chunk = builder.Finish("", &chunk_stats);
    read += chunk_stats.num_read;
    skipped += chunk_stats.num_skipped;
    pos += buffer.size();
    consume(chunk, static_cast<size_t>(first), static_cast<size_t>(vertex.count));
  }
  SkipElementsAfterVertices(path, header, swap, file_size, pos, in);
  if (stats != nullptr) {
    stats->format = header.format == PlyFormat::kBinaryLe ? "ply-binary-le" : "ply-binary-be";
    stats->num_read = read;
    stats->num_skipped = skipped;
  }
  return true;
}

}  // namespace internal

}  // namespace mmba::io
