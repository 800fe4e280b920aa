// Shared helpers, the extension dispatch and the XYZ text reader.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace internal {

size_t ScalarSize(ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
    case ScalarType::kUInt8: return 1;
    case ScalarType::kInt16:
    case ScalarType::kUInt16: return 2;
    case ScalarType::kInt32:
    case ScalarType::kUInt32:
    case ScalarType::kFloat32: return 4;
    case ScalarType::kFloat64: return 8;
  }
  return 0;
}

double ReadScalar(const char* data, ScalarType type, bool swap) {
  char buffer[8];
  const size_t n = ScalarSize(type);
  std::memcpy(buffer, data, n);
  if (swap) std::reverse(buffer, buffer + n);
  switch (type) {
    case ScalarType::kInt8: { int8_t v; std::memcpy(&v, buffer, 1); return v; }
    case ScalarType::kUInt8: { uint8_t v; std::memcpy(&v, buffer, 1); return v; }
    case ScalarType::kInt16: { int16_t v; std::memcpy(&v, buffer, 2); return v; }
    case ScalarType::kUInt16: { uint16_t v; std::memcpy(&v, buffer, 2); return v; }
    case ScalarType::kInt32: { int32_t v; std::memcpy(&v, buffer, 4); return v; }
    case ScalarType::kUInt32: { uint32_t v; std::memcpy(&v, buffer, 4); return v; }
    case ScalarType::kFloat32: { float v; std::memcpy(&v, buffer, 4); return v; }
    case ScalarType::kFloat64: { double v; std::memcpy(&v, buffer, 8); return v; }
  }
  return 0.0;
}

CloudBuilder::CloudBuilder(const std::string& file, const ReadOptions& options,
                           bool normals, bool intensity, bool colors, size_t reserve, bool time)
    : file_(file),
      options_(options),
      has_normals_(normals),
      has_intensity_(intensity),
      has_colors_(colors),
      has_time_(time) {
  // Do not trust a header's count for the reservation beyond a sane size.
  reserve = std::min<size_t>(reserve, size_t{1} << 26);
  cloud_.points.reserve(reserve);
  if (normals) cloud_.normals.reserve(reserve);
  if (intensity) cloud_.intensity.reserve(reserve);
  if (colors) cloud_.colors.reserve(reserve);
  if (time) cloud_.time.reserve(reserve);
}

PointCloud CloudBuilder::Finish(const std::string& format, ReadStats* stats) {
  if (stats != nullptr) {
    stats->format = format;
    stats->num_read = cloud_.points.size();
    stats->num_skipped = skipped_;
  }
  return std::move(cloud_);
}

std::string ToLower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace internal


PointCloud WithoutMarked(const PointCloud& cloud, const std::vector<char>& marked) {
  PointCloud out;
  const auto keep = [&](const auto& in, auto* kept) {
    if (in.empty()) return;
    kept->reserve(in.size());
    for (size_t i = 0; i < in.size(); ++i) {
      if (!marked[i]) kept->push_back(in[i]);
    }
  };
  keep(cloud.points, &out.points);
  keep(cloud.normals, &out.normals);
  keep(cloud.intensity, &out.intensity);
  keep(cloud.colors, &out.colors);
  keep(cloud.time, &out.time);
  keep(cloud.ring, &out.ring);
  return out;
}

using internal::CloudBuilder;
using internal::ToLower;
using internal::NonFiniteText;

namespace {
// Six unnamed XYZ columns are a normal when the last three are a unit vector to within this.
constexpr double kGuessedNormalTolerance = 0.01;
}  // namespace

PointCloud ReadPointCloud(const std::string& path) { return ReadPointCloud(path, {}); }

PointCloud ReadPointCloud(const std::string& path, const ReadOptions& options,
                          ReadStats* stats) {
  const std::string ext = ToLower(std::filesystem::path(path).extension().string());
  if (ext == ".ply") return ReadPly(path, options, stats);
  if (ext == ".pcd") return ReadPcd(path, options, stats);
  if (ext == ".las") return ReadLas(path, options, stats);
  if (ext == ".bin") {
    // nuScenes names its sweeps NAME.pcd.bin (5 floats per point), KITTI NAME.bin (4).
    if (ToLower(std::filesystem::path(path).stem().extension().string()) == ".pcd") {
      return ReadNuScenesBin(path, options, stats);
    }
    return ReadKittiBin(path, options, stats);
  }
  if (ext == ".xyz" || ext == ".txt" || ext == ".csv" || ext == ".pts") {
    return ReadXyz(path, options, stats);
  }
  if (ext == ".laz") {
    throw InputError(path, 0, "extension", ext,
                     "an uncompressed format (.las); decompress LAZ first (laszip/pdal)");
  }
  throw InputError(path, 0, "extension", ext.empty() ? "(none)" : ext,
                   "one of .ply .pcd .las .bin .pcd.bin .xyz .txt .csv .pts");
}

void StreamPointCloud(const std::string& path, size_t chunk_points, const ChunkConsumer& consume,
                      const ReadOptions& options, ReadStats* stats) {
  chunk_points = std::max<size_t>(1, chunk_points);
  if (ToLower(std::filesystem::path(path).extension().string()) == ".ply" &&
      internal::StreamBinaryPly(path, chunk_points, consume, options, stats)) {
    return;
  }
  const PointCloud cloud = ReadPointCloud(path, options, stats);
  PointCloud chunk;
  for (size_t first = 0; first < cloud.size(); first += chunk_points) {
    const size_t end = std::min(cloud.size(), first + chunk_points);
    const auto slice = [&](const auto& v, auto* out) {
      if (v.empty()) {
        out->clear();
      } else {
        out->assign(v.begin() + static_cast<std::ptrdiff_t>(first), v.begin() + static_cast<std::ptrdiff_t>(end));
      }
    };
    slice(cloud.points, &chunk.points);
    slice(cloud.normals, &chunk.normals);
    slice(cloud.intensity, &chunk.intensity);
    slice(cloud.colors, &chunk.colors);
    slice(cloud.time, &chunk.time);
    slice(cloud.ring, &chunk.ring);
    consume(chunk, first, cloud.size());
  }
}

// ---------------------------------------------------------------------------------------
// XYZ text.

namespace {

enum class Column { kX, kY, kZ, kNx, kNy, kNz, kIntensity, kR, kG, kB, kIgnore };

Column ColumnFromName(const std::string& raw) {
  std::string name = ToLower(raw);
  while (!name.empty() && (name[0] == '/' || name[0] == '#')) name.erase(0, 1);
  // Spreadsheets quote their headers: "X","Y","Z".
  if (name.size() >= 2 && (name.front() == '"' || name.front() == '\'') && name.back() == name.front()) {
    name = name.substr(1, name.size() - 2);
  }
  // A unit written onto the name: "X[m]".
  if (const size_t bracket = name.find_first_of("[("); bracket != std::string::npos && bracket > 0) {
    name.erase(bracket);
  }
  // A surveyor's grid coordinates name the axes easting, northing, height.
  if (name == "x" || name == "//x" || name == "e" || name == "east" || name == "easting") return Column::kX;
  if (name == "y" || name == "n" || name == "north" || name == "northing") return Column::kY;
  if (name == "z" || name == "h" || name == "height" || name == "elevation" || name == "elev") return Column::kZ;
  if (name == "nx" || name == "normal_x") return Column::kNx;
  if (name == "ny" || name == "normal_y") return Column::kNy;
  if (name == "nz" || name == "normal_z") return Column::kNz;
  if (name == "intensity" || name == "i" || name == "scalar_intensity" ||
      name == "reflectance" || name == "scalar_reflectance" || name == "remission") {
    return Column::kIntensity;
  }
  if (name == "r" || name == "red") return Column::kR;
  if (name == "g" || name == "green") return Column::kG;
  if (name == "b" || name == "blue") return Column::kB;
  return Column::kIgnore;
}

bool IsComment(std::string_view line) {
  size_t i = 0;
  while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
  if (i == line.size()) return true;  // blank
  return line[i] == '#' || line.substr(i, 2) == "//";
}

// How a text cloud separates its values, found from the first line holding a ',' or a ';'.
// A ',' is either a separator ("1.5,2.5,3.5") or a decimal comma, as spreadsheets in most of
// Europe write numbers: "1000,11;2002,27;120,81" (';' separates) or "1000,11 2002,27 120,81".
// Reading a decimal comma as a separator would silently turn each point into six other
// numbers (x y z r g b), so a line where ';' separates, or where blanks separate numbers that
// hold at most one ',' each and no '.', reads ',' as the decimal point.
class XyzSeparators {
 public:
  // The line with its separators as blanks and its decimal commas as points.
  std::string Normalise(std::string_view line, int64_t line_number) {
    if (dialect_ == Dialect::kUnknown) {
      dialect_ = Detect(line);
      decided_on_ = line_number;
    }
    std::string s(line);
    std::replace(s.begin(), s.end(), ';', ' ');
    std::replace(s.begin(), s.end(), ',', dialect_ == Dialect::kDecimalComma ? '.' : ' ');
    return s;
  }

  // How the file was read, for an error on a line that does not fit: "" when commas separate.
  std::string DecimalCommaNote() const {
    return dialect_ == Dialect::kDecimalComma
               ? " (read with ',' as the decimal comma and ';' or blanks between values, as line " +
                     std::to_string(decided_on_) + " writes them)"
               : "";
  }

 private:
  enum class Dialect { kUnknown, kCommaSeparates, kDecimalComma };

  static Dialect Detect(std::string_view line) {
    if (line.find(';') != std::string_view::npos) return Dialect::kDecimalComma;
    if (line.find(',') == std::string_view::npos) return Dialect::kUnknown;
    std::istringstream in{std::string(line)};
    std::string token;
    int tokens = 0;
    bool decimal = true;  // every blank-separated value a number with at most one ',' inside
    while (in >> token) {
      ++tokens;
      std::string point = token;
      std::replace(point.begin(), point.end(), ',', '.');
      double v;
      decimal = decimal && std::count(token.begin(), token.end(), ',') <= 1 &&
                token.find('.') == std::string::npos && ParseDouble(point, &v);
    }
    return tokens >= 2 && decimal ? Dialect::kDecimalComma : Dialect::kCommaSeparates;
  }

  Dialect dialect_ = Dialect::kUnknown;
  int64_t decided_on_ = 0;
};

// A header line described without quoting it (it may be the first line of any file named as
// a cloud): how many names it holds and which of x, y, z they are.
std::string DescribeHeader(const std::vector<Column>& columns) {
  std::string named;
  for (const auto& [column, name] : {std::pair{Column::kX, "x"}, std::pair{Column::kY, "y"}, std::pair{Column::kZ, "z"}}) {
    if (std::find(columns.begin(), columns.end(), column) != columns.end()) named += (named.empty() ? "" : ", ") + std::string(name);
  }
  return std::to_string(columns.size()) + " column names, " +
         (named.empty() ? std::string("none of them x, y or z") : "of x, y and z only " + named);
}

// Refuses a text cloud holding a NUL byte: such a file is binary (or damaged), not an empty cloud.
void CheckNoNul(const std::string& path, const std::string& text) {
  if (const size_t nul = text.find('\0'); nul != std::string::npos) {
    const int64_t line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(nul), '\n');
    throw InputError(path, line, "character", "a NUL byte (binary data)",
                     "text: x y z [...] per line (a binary cloud needs its extension: .ply, .pcd, .las, .bin)");
  }
}

// What the lines before the first point say: the columns a header names (empty: none), the
// header's line, and the first point's line (number, normalised text; number 0: no point).
struct XyzPreamble {
  std::vector<Column> columns;
  int64_t header_line = 0;
  std::pair<int64_t, std::string> first_point{0, std::string()};
};

// A CloudCompare-style "//X,Y,Z,R,G,B" comment naming the columns: true when `line` is one
// (≥ 3 names, the first not a number), with its columns added to `preamble`.
bool ReadCommentHeader(const std::string& path, std::string_view line, int64_t line_number,
                       XyzSeparators* separators, XyzPreamble* preamble) {
  std::string_view t = line;
  while (!t.empty() && std::isspace(static_cast<unsigned char>(t[0]))) t.remove_prefix(1);
  if (t.substr(0, 2) != "//" || t.size() <= 2) return false;
  TokenLine names(path, line_number, separators->Normalise(t.substr(2), line_number));
  double v;
  if (names.size() < 3 || ParseDouble(names.Str(0, "name"), &v)) return false;
  for (size_t i = 0; i < names.size(); ++i) preamble->columns.push_back(ColumnFromName(names.Str(i, "name")));
  preamble->header_line = line_number;
  return true;
}

// Reads up to the first point: comments, a header naming the columns ("//X,Y,Z" or a first
// line of names, units such as "[m]" skipped) or a PTS point count.
XyzPreamble ReadPreamble(const std::string& path, LineCursor* cursor, XyzSeparators* separators) {
  XyzPreamble preamble;
  std::string_view line;
  bool first_content = true;
  while (cursor->Next(&line)) {
    const bool comment = IsComment(line);
    const std::string s = comment ? std::string() : separators->Normalise(line, cursor->line_number());
    if (comment) {
      if (first_content && ReadCommentHeader(path, line, cursor->line_number(), separators, &preamble)) {
        first_content = false;
      }
      continue;
    }
    TokenLine tokens(path, cursor->line_number(), s);
    double v;
    if (first_content && !ParseDouble(tokens.Str(0, "x"), &v)) {
      for (size_t i = 0; i < tokens.size(); ++i) {
        const std::string& name = tokens.Str(i, "name");
        if (i > 0 && (name.front() == '[' || name.front() == '(')) continue;  // "X [m]": a unit
        preamble.columns.push_back(ColumnFromName(name));
      }
      preamble.header_line = cursor->line_number();
      first_content = false;
      continue;
    }
    if (first_content && tokens.size() == 1) {  // PTS point count
      tokens.UInt(0, "point count");
      first_content = false;
      continue;
    }
    preamble.first_point = {cursor->line_number(), s};
    break;
  }
  return preamble;
}

// Six unnamed columns: x y z and, in columns 4–6, integer colours 0..255, else a unit normal,
// else colours 0..1 (as CloudCompare can write them); anything else is not guessed.
std::vector<Column> GuessSixColumns(const TokenLine& first, bool* guessed_normals, bool* colors_0_1) {
  bool rgb = true, unit_rgb = true;
  double length2 = 0.0;
  for (size_t i = 3; i < 6; ++i) {
    int64_t c;
    if (!ParseInt(first.Str(i, "value"), &c) || c < 0 || c > 255) rgb = false;
    const double v = first.Double(i, "value");
    length2 += v * v;
    if (!(v >= 0.0 && v <= 1.0)) unit_rgb = false;
  }
  const bool normal = std::abs(std::sqrt(length2) - 1.0) <= kGuessedNormalTolerance;
  std::vector<Column> columns = {Column::kX, Column::kY, Column::kZ};
  if (rgb) {
    columns.insert(columns.end(), {Column::kR, Column::kG, Column::kB});
  } else if (normal) {
    columns.insert(columns.end(), {Column::kNx, Column::kNy, Column::kNz});
    *guessed_normals = true;
  } else if (unit_rgb) {
    columns.insert(columns.end(), {Column::kR, Column::kG, Column::kB});
    *colors_0_1 = true;
  } else {
    first.Fail("columns 4-6", first.Str(3, "value") + " " + first.Str(4, "value") + " " +
                                  first.Str(5, "value"),
               "colours 0..255 or 0..1, or a unit normal (or a first line naming the "
               "columns)");
  }
  return columns;
}

// The columns of a cloud without a header, from the first point's value count.
std::vector<Column> GuessColumns(const TokenLine& first, bool* guessed_normals, bool* colors_0_1) {
  switch (first.size()) {
    case 3: return {Column::kX, Column::kY, Column::kZ};
    case 4: return {Column::kX, Column::kY, Column::kZ, Column::kIntensity};
    case 6: return GuessSixColumns(first, guessed_normals, colors_0_1);
    case 7:
      return {Column::kX, Column::kY, Column::kZ, Column::kIntensity, Column::kR, Column::kG, Column::kB};
    case 9:
      return {Column::kX, Column::kY, Column::kZ, Column::kR, Column::kG,
              Column::kB, Column::kNx, Column::kNy, Column::kNz};
    default:
      first.Fail("column count", std::to_string(first.size()),
                 "3 (x y z), 4 (+intensity), 6 (+rgb or +normal), 7 (+intensity rgb), "
                 "9 (+rgb normal), or a first line naming the columns");
  }
}

// Reads the points of a text cloud, one line each, into a CloudBuilder.
class XyzLineParser {
 public:
  // `columns` name every value of a line; guessed_normals: six unnamed columns read as a
  // normal from the first line (line first_line), which every line must then hold;
  // colors_0_1: colours in 0..1.
  XyzLineParser(const std::vector<Column>& columns, bool guessed_normals, bool colors_0_1, int64_t first_line)
      : columns_(columns), guessed_normals_(guessed_normals), colors_0_1_(colors_0_1), first_line_(first_line) {
    std::fill(index_, index_ + 10, -1);
    for (size_t i = 0; i < columns.size(); ++i) {
      if (columns[i] != Column::kIgnore && index_[static_cast<int>(columns[i])] < 0) {
        index_[static_cast<int>(columns[i])] = static_cast<int>(i);
      }
    }
    normals_ = Has(Column::kNx) && Has(Column::kNy) && Has(Column::kNz);
    colors_ = Has(Column::kR) && Has(Column::kG) && Has(Column::kB);
    intensity_ = Has(Column::kIntensity);
  }

  bool Has(Column c) const { return index_[static_cast<int>(c)] >= 0; }
  bool normals() const { return normals_; }
  bool colors() const { return colors_; }
  bool intensity() const { return intensity_; }

  void Parse(const std::string& path, const TokenLine& t, CloudBuilder* builder) const {
    t.ExpectCount(columns_.size(), "point");
    double xyz[3], n[3] = {0, 0, 0};
    uint8_t rgb[3] = {0, 0, 0};
    float inten = 0.0f;
    const char* names[3] = {"x", "y", "z"};
    const char* nnames[3] = {"nx", "ny", "nz"};
    for (int k = 0; k < 3; ++k) xyz[k] = Value(t, index_[static_cast<int>(Column::kX) + k], names[k]);
    if (normals_) {
      for (int k = 0; k < 3; ++k) n[k] = Value(t, index_[static_cast<int>(Column::kNx) + k], nnames[k]);
      CheckGuessedNormal(t, n);
    }
    if (intensity_) inten = static_cast<float>(Value(t, index_[static_cast<int>(Column::kIntensity)], "intensity"));
    if (colors_) ParseColours(t, rgb);
    builder->Add(xyz, normals_ ? n : nullptr, inten, rgb, [&] {
      return path + ":" + std::to_string(t.line_number());
    });
  }

 private:
  // Non-finite values: ParseDouble refuses "nan"/"inf", so check the text ourselves to give
  // the finiteness error (or skip) instead of a parse error.
  static double Value(const TokenLine& t, int i, const char* field) {
    double v;
    if (NonFiniteText(t.Str(i, field), &v)) return v;
    return t.Double(i, field);
  }

  // Six unnamed columns taken for a normal from the first line: every line must hold one.
  void CheckGuessedNormal(const TokenLine& t, const double n[3]) const {
    const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (guessed_normals_ && !(std::abs(length - 1.0) <= kGuessedNormalTolerance)) {
      t.Fail("nx ny nz", "a vector of length " + std::to_string(length),
             "a unit normal, as on line " + std::to_string(first_line_) +
                 " (six unnamed columns are x y z nx ny nz when the first line's last three "
                 "are a unit vector; name the columns in a first line otherwise)");
    }
  }

  void ParseColours(const TokenLine& t, uint8_t rgb[3]) const {
    const char* cnames[3] = {"red", "green", "blue"};
    for (int k = 0; k < 3; ++k) {
      if (colors_0_1_) {
        const double c = t.Double(index_[static_cast<int>(Column::kR) + k], cnames[k]);
        if (!(c >= 0.0 && c <= 1.0)) {
          t.Fail(cnames[k], t.Str(index_[static_cast<int>(Column::kR) + k], cnames[k]),
                 "a colour in 0..1, as on line " + std::to_string(first_line_));
        }
        rgb[k] = static_cast<uint8_t>(std::lround(255.0 * c));
        continue;
      }
      const uint64_t c = t.UInt(index_[static_cast<int>(Column::kR) + k], cnames[k]);
      if (c > 255) t.Fail(cnames[k], std::to_string(c), "an integer in 0..255");
      rgb[k] = static_cast<uint8_t>(c);
    }
  }

  const std::vector<Column>& columns_;
  bool guessed_normals_, colors_0_1_;
  int64_t first_line_;
  int index_[10];
  bool normals_ = false, colors_ = false, intensity_ = false;
};

}  // namespace

PointCloud ReadXyz(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  const std::string text = ReadWholeFile(path);
  CheckNoNul(path, text);
  LineCursor cursor(text, path);
  XyzSeparators separators;
  XyzPreamble preamble = ReadPreamble(path, &cursor, &separators);
  std::vector<Column>& columns = preamble.columns;
  if (preamble.first_point.first == 0) {
    // A file without a point is an empty cloud, as a PLY with "element vertex 0" is: the
    // command that reads it says what it cannot do without points. A header that does not
    // name x, y and z is not a cloud's.
    const auto named = [&columns](Column c) { return std::find(columns.begin(), columns.end(), c) != columns.end(); };
    if (!columns.empty() && !(named(Column::kX) && named(Column::kY) && named(Column::kZ))) {
      throw InputError(path, preamble.header_line, "columns", DescribeHeader(columns) + " (and no point)",
                       "a header naming x, y and z, and lines of x y z ...");
    }
    return CloudBuilder(path, options, false, false, false, 0).Finish("xyz", stats);
  }
  TokenLine first(path, preamble.first_point.first, preamble.first_point.second);
  bool guessed_normals = false, colors_0_1 = false;
  if (columns.empty()) columns = GuessColumns(first, &guessed_normals, &colors_0_1);
  const XyzLineParser parser(columns, guessed_normals, colors_0_1, first.line_number());
  if (!parser.Has(Column::kX) || !parser.Has(Column::kY) || !parser.Has(Column::kZ)) {
    throw InputError(path, preamble.header_line, "columns", DescribeHeader(columns),
                     "columns named x, y and z (or e/easting, n/northing, h/height/elevation)");
  }
  CloudBuilder builder(path, options, parser.normals(), parser.intensity(), parser.colors(), text.size() / 24);
  parser.Parse(path, first, &builder);
  std::string_view line;
  while (cursor.Next(&line)) {
    if (IsComment(line)) continue;
    const TokenLine t(path, cursor.line_number(), separators.Normalise(line, cursor.line_number()));
    if (t.size() != columns.size() && !separators.DecimalCommaNote().empty()) {
      t.Fail("point", std::string(line.substr(0, 80)),
             std::to_string(columns.size()) + " values" + separators.DecimalCommaNote());
    }
    parser.Parse(path, t, &builder);
  }
  return builder.Finish("xyz", stats);
}

}  // namespace mmba::io
