#include "mmba/io_survey/gsi.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kFootM = 0.3048;  // international foot

bool AllDigits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

/// The data as an integer (digits only, leading zeros allowed, at most 16 of them).
bool Integer(const std::string& digits, double* value) {
  if (!AllDigits(digits) || digits.size() > 16) return false;
  double v = 0;
  for (char c : digits) v = v * 10 + (c - '0');
  *value = v;
  return true;
}

struct LineWords {
  std::vector<GsiWord> words;
  bool gsi16 = false;
};

/// Splits one line into its words; throws InputError on a malformed or truncated word.
LineWords SplitLine(const std::string& file, int line, std::string text) {
  LineWords out;
  size_t pos = 0;
  if (!text.empty() && text[0] == '*') {
    out.gsi16 = true;
    pos = 1;
  }
  const size_t data_len = out.gsi16 ? 16 : 8;
  while (pos < text.size()) {
    if (text[pos] == ' ') {  // separators (some writers put more than one)
      ++pos;
      continue;
    }
    const std::string rest = text.substr(pos, 7 + data_len);
    const std::string field = "word " + std::to_string(out.words.size() + 1);
    if (rest.size() < 7 + data_len) {
      throw InputError(file, line, field, rest,
                       "a complete " + std::string(out.gsi16 ? "GSI-16" : "GSI-8") + " word of " +
                           std::to_string(7 + data_len) +
                           " characters (WI, 4 information characters, sign, data): the line or "
                           "file is truncated");
    }
    GsiWord w;
    const std::string wi = rest.substr(0, 2);
    double wi_value = 0;
    if (!Integer(wi, &wi_value) || wi_value < 11 || wi_value > 89 || wi[1] == '0') {
      throw InputError(file, line, field + " word index", wi,
                       "a GSI word index 11..89 (11 point, 21 Hz, 22 V, 31 slope distance, "
                       "32 horizontal distance, 33 height difference, 41-49 code block, 51 "
                       "ppm/mm, 71-79 remarks, 81-88 coordinates and heights)");
    }
    w.wi = static_cast<int>(wi_value);
    w.info = rest.substr(2, 4);
    w.unit = rest[5];
    w.sign = rest[6];
    if (w.sign != '+' && w.sign != '-') {
      throw InputError(file, line, field + " sign (position 7)", rest, "'+' or '-'");
    }
    w.data = rest.substr(7);
    pos += 7 + data_len;
    if (pos < text.size() && text[pos] != ' ') {
      throw InputError(file, line, field, text.substr(pos - 7 - data_len, 8 + data_len),
                       "a word of " + std::to_string(7 + data_len) +
                           " characters followed by a blank");
    }
    out.words.push_back(std::move(w));
  }
  return out;
}

/// State carried from line to line.
struct Reader {
  std::string file;
  survey::FieldBook book;
  std::optional<double> default_reflector_m;  // code block 3

  [[noreturn]] void Fail(int line, const GsiWord& w, const std::string& expected) const {
    throw InputError(file, line, "WI " + std::to_string(w.wi), w.sign + w.data, expected);
  }

  double Length(int line, const GsiWord& w) const {
    double m = 0;
    std::string problem;
    if (!GsiLengthM(w.data, w.unit, &m, &problem)) Fail(line, w, problem);
    return w.sign == '-' ? -m : m;
  }

  double Angle(int line, const GsiWord& w) const {
    double rad = 0;
    std::string problem;
    if (!GsiAngleRad(w.data, w.unit, &rad, &problem)) Fail(line, w, problem);
    return w.sign == '-' ? -rad : rad;
  }

  void CodeBlock(int line, const std::vector<GsiWord>& words);
  void StationRecord(int line, const std::vector<GsiWord>& words, const std::string& id);
  void Measurement(int line, const std::vector<GsiWord>& words, const std::string& id);
  /// The coordinates in words easting_wi, +1, +2 (81-83 of a coordinate record, 84-86 of a
  /// station record) as a known point, when the record has any.
  void Coordinates(int line, const std::vector<GsiWord>& words, const std::string& id, int easting_wi);
  void Line(int line, const std::vector<GsiWord>& words);
};

const GsiWord* FindWord(const std::vector<GsiWord>& words, int wi) {
  for (const GsiWord& w : words) {
    if (w.wi == wi) return &w;
  }
  return nullptr;
}

void Reader::CodeBlock(int line, const std::vector<GsiWord>& words) {
  const GsiWord& code_word = words.front();
  const std::string code = code_word.Text();
  if (code == "2" || code == "21") {
    survey::Setup setup;
    setup.line = line;
    const GsiWord* id = FindWord(words, 42);
    if (id == nullptr || id->Missing() || id->Text() == "0") {
      Fail(line, code_word, "a station code block with the station id in WI 42");
    }
    setup.station = id->Text();
    if (const GsiWord* h = FindWord(words, 43); h != nullptr && !h->Missing()) {
      setup.instrument_height_m = Length(line, *h);
      setup.has_instrument_height = true;
    }
    default_reflector_m.reset();
    if (const GsiWord* t = FindWord(words, 44); t != nullptr && !t->Missing()) {
      default_reflector_m = Length(line, *t);
    }
    book.setups.push_back(std::move(setup));
  } else if (code == "3") {
    if (const GsiWord* t = FindWord(words, 42); t != nullptr && !t->Missing()) {
      const double h = Length(line, *t);
      default_reflector_m = h;
      if (h == 0) default_reflector_m.reset();
    }
  }
  // Other codes (point codes, dates, levelling) carry no observation.
}

void Reader::StationRecord(int line, const std::vector<GsiWord>& words, const std::string& id) {
  survey::Setup setup;
  setup.line = line;
  setup.station = id;
  if (const GsiWord* h = FindWord(words, 88); h != nullptr && !h->Missing()) {
    setup.instrument_height_m = Length(line, *h);
    setup.has_instrument_height = true;
  }
  Coordinates(line, words, id, 84);
  default_reflector_m.reset();
  book.setups.push_back(std::move(setup));
}

void Reader::Measurement(int line, const std::vector<GsiWord>& words, const std::string& id) {
  if (book.setups.empty()) {
    throw InputError(file, line, "WI 11", id,
                     "a station record before the first measurement (code block WI 41 = 2 "
                     "or 21 with WI 42/43, or WI 11 with WI 84-86/88)");
  }
  survey::Setup& setup = book.setups.back();
  survey::RawObservation o;
  o.target = id;
  o.line = line;
  for (const GsiWord& w : words) {
    if (w.Missing()) continue;
    switch (w.wi) {
      case 21: o.hz_rad = Angle(line, w); o.has_hz = true; break;
      case 22: o.v_rad = Angle(line, w); o.has_v = true; break;
      case 31: o.slope_m = Length(line, w); o.has_slope = o.slope_m > 0; break;
      case 32: o.horizontal_m = Length(line, w); o.has_horizontal = o.horizontal_m > 0; break;
      case 33: o.height_diff_m = Length(line, w); o.has_height_diff = true; break;
      case 87: o.reflector_height_m = Length(line, w); o.has_reflector_height = true; break;
      case 71: o.code = w.Text(); break;
      case 51: {
        // sign ppm (4 or 8 digits) sign prism constant [mm] (3 or 7 digits)
        const size_t inner = w.data.find_first_of("+-");
        double ppm = 0, mm = 0;
        if (inner == std::string::npos || !Integer(w.data.substr(0, inner), &ppm) ||
            !Integer(w.data.substr(inner + 1), &mm)) {
          Fail(line, w, "ppm and prism constant as sign, digits, sign, digits");
        }
        o.ppm = w.sign == '-' ? -ppm : ppm;
        o.prism_constant_mm = w.data[inner] == '-' ? -mm : mm;
        o.has_ppm_prism = true;
        break;
      }
      default: break;
    }
  }
  if (o.has_hz && (o.hz_rad < 0 || o.hz_rad >= 2 * kPi)) {
    Fail(line, *FindWord(words, 21), "a horizontal circle reading in [0, 400) gon");
  }
  if (o.has_v && !(o.v_rad > 0 && o.v_rad < 2 * kPi)) {
    Fail(line, *FindWord(words, 22), "a vertical circle reading in (0, 400) gon");
  }
  if (!o.has_reflector_height) {
    // The instrument keeps the reflector height until it is changed: the code block's, else
    // the set-up's last one.
    if (default_reflector_m) {
      o.reflector_height_m = *default_reflector_m;
      o.has_reflector_height = true;
    } else if (!setup.observations.empty() && setup.observations.back().has_reflector_height) {
      o.reflector_height_m = setup.observations.back().reflector_height_m;
      o.has_reflector_height = true;
    }
  }
  setup.observations.push_back(std::move(o));
}

void Reader::Coordinates(int line, const std::vector<GsiWord>& words, const std::string& id, int easting_wi) {
  survey::KnownPoint p;
  p.id = id;
  p.file = file;
  p.line = line;
  const GsiWord* e = FindWord(words, easting_wi);
  const GsiWord* n = FindWord(words, easting_wi + 1);
  const GsiWord* z = FindWord(words, easting_wi + 2);
  if ((e == nullptr) != (n == nullptr)) {
    throw InputError(file, line, "WI " + std::to_string(e ? easting_wi + 1 : easting_wi), "missing",
                     "both easting (" + std::to_string(easting_wi) + ") and northing (" +
                         std::to_string(easting_wi + 1) + "), or neither");
  }
  if (e && !e->Missing() && !n->Missing()) {
    p.en_h.x() = Length(line, *e);
    p.en_h.y() = Length(line, *n);
    p.has_xy = true;
  }
  if (z && !z->Missing()) {
    p.en_h.z() = Length(line, *z);
    p.has_z = true;
  }
  if (p.has_xy || p.has_z) book.points.push_back(p);
}

void Reader::Line(int line, const std::vector<GsiWord>& words) {
  if (words.front().wi == 41) {
    CodeBlock(line, words);
    return;
  }
  const GsiWord* id_word = FindWord(words, 11);
  auto has = [&](std::initializer_list<int> wis) {
    return std::any_of(wis.begin(), wis.end(), [&](int wi) {
      const GsiWord* w = FindWord(words, wi);
      return w != nullptr && !w->Missing();
    });
  };
  const bool measured = has({21, 22, 31, 32, 33});
  const bool station = has({84, 85, 86, 88});
  const bool coordinates = has({81, 82, 83});
  if (!measured && !station && !coordinates) return;  // codes, remarks, headers
  if (id_word == nullptr || id_word->Text().empty() || id_word->Missing()) {
    throw InputError(file, line, "WI 11", "missing",
                     "a point number (WI 11) on a line with measurements or coordinates");
  }
  const std::string id = id_word->Text();
  if (measured) {
    Measurement(line, words, id);
  } else if (station) {
    StationRecord(line, words, id);
  } else {
    Coordinates(line, words, id, 81);
  }
}

}  // namespace

std::string GsiWord::Text() const {
  const size_t first = data.find_first_not_of('0');
  if (first == std::string::npos) return "0";
  std::string t = data.substr(first);
  while (!t.empty() && t.back() == ' ') t.pop_back();
  return t;
}

bool GsiWord::Missing() const { return data.find("--") != std::string::npos; }

bool GsiAngleRad(const std::string& digits, char unit, double* rad, std::string* problem) {
  double n = 0;
  if (!Integer(digits, &n)) {
    *problem = "digits of an angle";
    return false;
  }
  switch (unit) {
    case '2': *rad = n * 1e-5 * kPi / 200.0; return true;
    case '3': *rad = n * 1e-5 * kPi / 180.0; return true;
    case '4': {
      const double degrees = std::floor(n / 1e5);
      const double rest = n - degrees * 1e5;  // MMSSs
      const double minutes = std::floor(rest / 1e3);
      const double seconds = (rest - minutes * 1e3) / 10.0;
      if (minutes >= 60 || seconds >= 60) {
        *problem = "DDD.MMSSs with minutes and seconds below 60 (unit 4)";
        return false;
      }
      *rad = (degrees + minutes / 60.0 + seconds / 3600.0) * kPi / 180.0;
      return true;
    }
    case '5': *rad = n * 1e-4 * kPi / 3200.0; return true;
    default:
      *problem = std::string("an angle unit (position 6) 2 gon, 3 degrees, 4 DMS or 5 mil, found '") +
                 unit + "'";
      return false;
  }
}

bool GsiLengthM(const std::string& digits, char unit, double* metres, std::string* problem) {
  if (unit == '.' && digits.find('.') != std::string::npos) {
    std::string t = digits.substr(digits.find_first_not_of('0') == std::string::npos
                                      ? 0
                                      : digits.find_first_not_of('0'));
    std::istringstream in(t);
    double v = 0;
    if (!(in >> v) || !in.eof()) {
      *problem = "a length in metres";
      return false;
    }
    *metres = v;
    return true;
  }
  double n = 0;
  if (!Integer(digits, &n)) {
    *problem = "digits of a length";
    return false;
  }
  switch (unit) {
    case '.':
    case '0': *metres = n * 1e-3; return true;
    case '1': *metres = n * 1e-3 * kFootM; return true;
    case '6': *metres = n * 1e-4; return true;
    case '7': *metres = n * 1e-4 * kFootM; return true;
    case '8': *metres = n * 1e-5; return true;
    default:
      *problem = std::string("a length unit (position 6) 0, 1, 6, 7 or 8, found '") + unit + "'";
      return false;
  }
}

bool IsGsiPath(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".gsi";
}

survey::FieldBook ParseGsi(const std::string& text, const std::string& file) {
  Reader reader;
  reader.file = file;
  reader.book.source = file;
  bool any8 = false, any16 = false;
  std::istringstream in(text);
  std::string line_text;
  int line = 0;
  while (std::getline(in, line_text)) {
    ++line;
    while (!line_text.empty() && (line_text.back() == '\r' || line_text.back() == ' ' ||
                                  line_text.back() == '\x1a')) {
      line_text.pop_back();
    }
    if (line_text.empty() || line_text[0] == '!' || line_text[0] == '\x03') continue;
    const LineWords words = SplitLine(file, line, line_text);
    if (words.words.empty()) continue;
    (words.gsi16 ? any16 : any8) = true;
    reader.Line(line, words.words);
  }
  if (!any8 && !any16) {
    throw InputError::Message(file, "no GSI records (expected lines of GSI-8 or GSI-16 words)");
  }
  reader.book.format = any8 && any16 ? "GSI-8/16" : (any16 ? "GSI-16" : "GSI-8");
  return std::move(reader.book);
}

survey::FieldBook ReadGsi(const std::string& path) { return ParseGsi(ReadWholeFile(path), path); }

}  // namespace mmba::io
