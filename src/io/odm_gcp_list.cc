#include "mmba/io/odm_gcp_list.h"

#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <utility>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

std::vector<std::string> SplitBlanks(const std::string& text) {
  std::istringstream stream(text);
  std::vector<std::string> fields;
  for (std::string f; stream >> f;) fields.push_back(f);
  return fields;
}

std::string Trim(const std::string& text) {
  const size_t a = text.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  const size_t b = text.find_last_not_of(" \t\r\n");
  return text.substr(a, b - a + 1);
}

/// "WGS84 UTM 32N" -> EPSG:32632; anything else is handed to PROJ as written.
std::string CrsFromHeader(const std::string& header, const std::string& path, int64_t line) {
  static const std::regex utm(R"(^WGS84\s+UTM\s+(.*)$)", std::regex::icase);
  std::smatch m;
  if (!std::regex_match(header, m, utm)) return header;
  static const std::regex zone(R"(^([0-9]{1,2})\s*([NnSs])$)");
  std::smatch z;
  const std::string text = m[1].str();
  int number = 0;
  if (std::regex_match(text, z, zone)) number = std::stoi(z[1].str());
  if (number < 1 || number > 60) {
    throw InputError(path, line, "projection", header, "WGS84 UTM <zone 1-60><N|S>, e.g. WGS84 UTM 32N");
  }
  const bool north = z[2].str() == "N" || z[2].str() == "n";
  return "EPSG:" + std::to_string((north ? 32600 : 32700) + number);
}

double Number(const std::string& text, const std::string& path, int64_t line, const char* field) {
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(value)) throw InputError(path, line, field, text, "a finite number");
  return value;
}

/// Ids of unnamed points by their coordinates, as ODM groups them.
class PointIds {
 public:
  PointIds(const std::string& path) : path_(path) {}
  std::string Id(const std::string& name, const Eigen::Vector3d& geo, int64_t line) {
    if (name.empty()) {
      const auto key = std::make_tuple(geo.x(), geo.y(), geo.z());
      auto [it, inserted] = by_coords_.emplace(key, "");
      if (inserted) it->second = "gcp" + std::to_string(by_coords_.size());
      return it->second;
    }
    const auto [it, inserted] = by_name_.emplace(name, std::make_pair(geo, line));
    if (!inserted && it->second.first != geo) {
      std::ostringstream found;
      found.precision(12);
      found << name << " at " << geo.transpose() << " (line " << it->second.second << ": "
            << it->second.first.transpose() << ")";
      throw InputError(path_, line, "geo_x geo_y geo_z", found.str(), "the same coordinates on every line of a point");
    }
    return name;
  }

 private:
  const std::string& path_;
  std::map<std::tuple<double, double, double>, std::string> by_coords_;
  std::map<std::string, std::pair<Eigen::Vector3d, int64_t>> by_name_;
};

GcpObservation ReadRow(const std::vector<std::string>& f, const std::string& path, int64_t line, PointIds* ids) {
  if (f.size() < 6) {
    throw InputError(path, line, "line", std::to_string(f.size()) + " fields",
                     "geo_x geo_y geo_z im_x im_y image_name [gcp_name ...]");
  }
  static const char* names[5] = {"geo_x", "geo_y", "geo_z", "im_x", "im_y"};
  double v[5];
  for (int k = 0; k < 5; ++k) v[k] = Number(f[k], path, line, names[k]);
  for (int k = 3; k < 5; ++k) {
    if (v[k] < -0.5) throw InputError(path, line, names[k], f[k], "a pixel coordinate >= -0.5");
  }
  GcpObservation o;
  o.geo = {v[0], v[1], v[2]};
  o.xy_px = {v[3] + 0.5, v[4] + 0.5};
  o.image = f[5];
  o.line = line;
  o.point_id = ids->Id(f.size() > 6 ? f[6] : "", o.geo, line);
  return o;
}

}  // namespace

GcpList ReadOdmGcpList(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError::Message(path, "cannot open the file");
  GcpList list;
  list.file = path;
  PointIds ids(path);
  std::map<std::pair<std::string, std::string>, int64_t> measured;  // (point, image) -> line
  std::string text;
  for (int64_t line = 1; std::getline(in, text); ++line) {
    if (line == 1 && text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
    const std::string content = Trim(text.substr(0, text.find('#')));
    if (content.empty()) continue;
    if (list.crs.empty()) {
      list.crs = CrsFromHeader(content, path, line);
      list.crs_line = line;
      continue;
    }
    GcpObservation o = ReadRow(SplitBlanks(content), path, line, &ids);
    const auto [it, inserted] = measured.emplace(std::make_pair(o.point_id, o.image), line);
    if (!inserted) {
      throw InputError(path, line, "image_name", o.point_id + " in " + o.image + " (also on line " + std::to_string(it->second) + ")",
                       "each point once per image");
    }
    list.observations.push_back(std::move(o));
  }
  if (list.crs.empty()) throw InputError::Message(path, "no projection line (EPSG:nnnn, a PROJ string or WGS84 UTM <zone><N|S>)");
  if (list.observations.empty()) throw InputError::Message(path, "no ground control point line after the projection");
  return list;
}

}  // namespace mmba::io
