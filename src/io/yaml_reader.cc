#include "mmba/io/yaml_reader.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "mmba/core/error.h"
#include "mmba/core/utf8.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {

YAML::Node YamlReader::Load(const std::string& what) const {
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) throw InputError::Message(path_, what + " not found");
  const std::string text = ReadWholeFile(path_);
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path_, e.mark.line + 1, "YAML", e.msg, "valid YAML");
  }
}

void YamlReader::Map(const YAML::Node& node, const std::string& field,
                     const std::map<std::string, Handler>& handlers) const {
  if (!node.IsMap()) Fail(node, field.empty() ? "(file)" : field, "a mapping", "a " + Kind(node));
  std::map<std::string, int> seen_on_line;  // key → its (1-based) line
  for (const auto& item : node) {
    const std::string key = String(item.first, field.empty() ? "(key)" : field + ".(key)");
    const std::string sub = field.empty() ? key : field + "." + key;
    const int line = item.first.Mark().line + 1;
    if (const auto [earlier, first] = seen_on_line.emplace(key, line); !first) {
      Fail(item.first, sub, "each key once", "the key a second time (first on line " + std::to_string(earlier->second) + ")");
    }
    const auto it = handlers.find(key);
    if (it == handlers.end()) {
      std::string known;
      for (const auto& [name, fn] : handlers) known += (known.empty() ? "" : ", ") + name;
      Fail(item.first, sub, "one of " + known, key + " (unknown key)");
    }
    it->second(item.second, sub);
  }
}

void YamlReader::Require(const YAML::Node& node, const std::string& field,
                         const std::vector<std::string>& required) const {
  for (const std::string& key : required) {
    if (!node[key]) Fail(node, field.empty() ? key : field + "." + key, "the key to be present", "nothing");
  }
}

double YamlReader::Number(const YAML::Node& node, const std::string& field) const {
  double value = 0.0;
  try {
    if (!node.IsScalar()) throw YAML::Exception(node.Mark(), "");
    value = node.as<double>();
  } catch (const YAML::Exception&) {
    Fail(node, field, "a number", Text(node));
  }
  if (!std::isfinite(value)) Fail(node, field, "a finite number", Text(node));
  return value;
}

double YamlReader::Positive(const YAML::Node& node, const std::string& field, double hi,
                            const std::string& unit) const {
  const double value = Number(node, field);
  if (!(value > 0.0 && value <= hi)) {
    std::ostringstream expected;
    expected << "a value in (0, " << hi << "] " << unit;
    Fail(node, field, expected.str(), Text(node));
  }
  return value;
}

int YamlReader::Integer(const YAML::Node& node, const std::string& field) const {
  try {
    if (!node.IsScalar()) throw YAML::Exception(node.Mark(), "");
    return node.as<int>();
  } catch (const YAML::Exception&) {
    Fail(node, field, "an integer", Text(node));
  }
}

bool YamlReader::Bool(const YAML::Node& node, const std::string& field) const {
  try {
    if (!node.IsScalar()) throw YAML::Exception(node.Mark(), "");
    return node.as<bool>();
  } catch (const YAML::Exception&) {
    Fail(node, field, "true or false", Text(node));
  }
}

std::string YamlReader::String(const YAML::Node& node, const std::string& field) const {
  if (!node.IsScalar()) Fail(node, field, "a string", "a " + Kind(node));
  const std::string& text = node.Scalar();
  if (const size_t bad = InvalidUtf8Offset(text); bad != std::string::npos) {
    Fail(node, field, "UTF-8 text", "invalid UTF-8 at byte " + std::to_string(bad) + " of the value");
  }
  return text;
}

std::vector<std::string> YamlReader::StringList(const YAML::Node& node,
                                                const std::string& field) const {
  if (!node.IsSequence()) Fail(node, field, "a list", "a " + Kind(node));
  std::vector<std::string> out;
  for (size_t i = 0; i < node.size(); ++i) {
    out.push_back(String(node[i], field + "[" + std::to_string(i) + "]"));
  }
  return out;
}

std::vector<double> YamlReader::NumberList(const YAML::Node& node, const std::string& field) const {
  if (!node.IsSequence()) Fail(node, field, "a list of numbers", "a " + Kind(node));
  std::vector<double> out;
  for (size_t i = 0; i < node.size(); ++i) {
    out.push_back(Number(node[i], field + "[" + std::to_string(i) + "]"));
  }
  return out;
}

void YamlReader::Fail(const YAML::Node& node, const std::string& field, const std::string& expected,
                      const std::string& found) const {
  throw InputError(path_, node.Mark().line >= 0 ? node.Mark().line + 1 : 0, field, found, expected);
}

std::string YamlReader::Kind(const YAML::Node& node) {
  return node.IsMap() ? "mapping" : node.IsSequence() ? "sequence" : node.IsNull() ? "null" : "scalar";
}

std::string YamlReader::Text(const YAML::Node& node) {
  return node.IsScalar() ? node.Scalar() : Kind(node);
}

}  // namespace mmba::io
