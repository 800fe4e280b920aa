// Strict reading of YAML configuration files (project files, scene files): every key known,
// every value typed, and an error names the file, line, dotted key, value and expectation.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace mmba::io {

class YamlReader {
 public:
  using Handler = std::function<void(const YAML::Node& value, const std::string& field)>;

  explicit YamlReader(std::string path) : path_(std::move(path)) {}

  /// Loads the file; a missing file, one that is not a regular file (RequireRegularFile) or a
  /// YAML syntax error is an InputError.
  YAML::Node Load(const std::string& what) const;

  /// Reads the keys of `node` (a mapping) through `handlers`; any other key, a key given twice
  /// (YAML leaves its meaning open; yaml-cpp would keep both) or a key that is not UTF-8 text
  /// is an error.
  /// `field` names the mapping in messages ("" for the root, "sensors[2]", …).
  void Map(const YAML::Node& node, const std::string& field,
           const std::map<std::string, Handler>& handlers) const;
  /// Fails naming `field` + "." + each key of `required` absent from `node`.
  void Require(const YAML::Node& node, const std::string& field,
               const std::vector<std::string>& required) const;

  double Number(const YAML::Node& node, const std::string& field) const;
  /// A number in (lo, hi] — `unit` is added to the message ("m", "px").
  double Positive(const YAML::Node& node, const std::string& field, double hi,
                  const std::string& unit) const;
  int Integer(const YAML::Node& node, const std::string& field) const;
  bool Bool(const YAML::Node& node, const std::string& field) const;
  /// A scalar that is valid UTF-8 (a name or a path that reaches the outputs).
  std::string String(const YAML::Node& node, const std::string& field) const;
  std::vector<std::string> StringList(const YAML::Node& node, const std::string& field) const;
  std::vector<double> NumberList(const YAML::Node& node, const std::string& field) const;

  [[noreturn]] void Fail(const YAML::Node& node, const std::string& field,
                         const std::string& expected, const std::string& found) const;

  const std::string& path() const { return path_; }
  static std::string Kind(const YAML::Node& node);
  static std::string Text(const YAML::Node& node);

 private:
  std::string path_;
};

}  // namespace mmba::io
