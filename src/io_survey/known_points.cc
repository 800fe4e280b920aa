#include "mmba/io_survey/known_points.h"

#include <cmath>
#include <map>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"
#include "mmba/io_survey/gsi.h"

namespace mmba::io {
namespace {

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

std::vector<std::string> SplitComma(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string f;
  while (std::getline(in, f, ',')) fields.push_back(Trim(f));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

bool ParseNumber(const std::string& text, double* v) {
  if (text.empty()) return false;
  std::istringstream in(text);
  in >> *v;
  return in && in.eof() && std::isfinite(*v);
}

std::vector<survey::KnownPoint> ParseCsv(const std::string& text, const std::string& file) {
  std::vector<survey::KnownPoint> points;
  std::istringstream in(text);
  std::string line_text;
  int line = 0;
  bool first = true;
  while (std::getline(in, line_text)) {
    ++line;
    const std::string t = Trim(line_text.substr(0, line_text.find('#')));
    if (t.empty()) continue;
    const std::vector<std::string> f = SplitComma(t);
    double e = 0, n = 0, h = 0;
    if (first && (f.size() < 2 || !ParseNumber(f[1], &e))) {
      first = false;
      continue;  // header
    }
    first = false;
    if (f.size() < 3 || f.size() > 4) {
      throw InputError(file, line, "fields", t, "id,east,north[,height]");
    }
    if (f[0].empty()) throw InputError(file, line, "id", "", "a point id");
    if (!ParseNumber(f[1], &e)) throw InputError(file, line, "east", f[1], "a number [m]");
    if (!ParseNumber(f[2], &n)) throw InputError(file, line, "north", f[2], "a number [m]");
    survey::KnownPoint p;
    p.id = f[0];
    p.file = file;
    p.line = line;
    p.en_h.head<2>() << e, n;
    p.has_xy = true;
    if (f.size() == 4 && !f[3].empty()) {
      if (!ParseNumber(f[3], &h)) throw InputError(file, line, "height", f[3], "a number [m] or nothing");
      p.en_h.z() = h;
      p.has_z = true;
    }
    points.push_back(p);
  }
  return points;
}

}  // namespace

std::vector<survey::KnownPoint> ReadKnownPoints(const std::string& path) {
  const bool gsi = IsGsiPath(path);
  const std::vector<survey::KnownPoint> read = gsi ? ReadGsi(path).points : ParseCsv(ReadWholeFile(path), path);
  if (read.empty()) {
    throw InputError::Message(path, "no coordinates (expected GSI WI 81-83 records or id,east,north[,height] lines)");
  }
  // A GSI job records a point again when it is measured again: the first record counts.
  std::vector<survey::KnownPoint> points;
  std::map<std::string, int> seen;
  for (const survey::KnownPoint& p : read) {
    auto [it, inserted] = seen.emplace(p.id, p.line);
    if (inserted) {
      points.push_back(p);
    } else if (!gsi) {
      throw InputError(path, p.line, "id", p.id,
                       "each point once (also at line " + std::to_string(it->second) + ")");
    }
  }
  return points;
}

}  // namespace mmba::io
