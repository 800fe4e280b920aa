#include "mmba/io/dbat_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

#include <pugixml.hpp>

#include "mmba/core/error.h"
#include "mmba/io/colmap_model.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

/// Reads one <camera> element; each element's text is kept with its line for messages.
class CameraElement {
 public:
  CameraElement(std::string path, const std::string& text, const pugi::xml_node& camera)
      : path_(std::move(path)), text_(text), camera_(camera) {
    for (const pugi::xml_node& child : camera.children()) {
      if (child.type() != pugi::node_element) continue;
      const std::string name = child.name();
      static const char* const kKnown[] = {"id", "name", "unit", "calibrated", "sensor", "image",
                                           "aspect", "focal", "model", "nK", "nP", "cc", "pp",
                                           "skew", "K", "P", "calibration_info"};
      if (std::find(std::begin(kKnown), std::end(kKnown), name) == std::end(kKnown)) {
        Fail(child, "an element of a DBAT camera (id, name, unit, sensor, image, aspect, focal, model, "
                    "nK, nP, cc, pp, skew, K, P, calibrated, calibration_info)", "<" + name + ">");
      }
    }
  }

  bool Has(const char* name) const { return static_cast<bool>(camera_.child(name)); }
  std::string Text(const char* name) const {
    std::string t = camera_.child(name).child_value();
    t.erase(0, t.find_first_not_of(" \t\r\n"));
    t.erase(t.find_last_not_of(" \t\r\n") + 1);
    return t;
  }

  /// Comma-separated numbers; "auto" (where `allow_auto`) is NaN.
  std::vector<double> List(const char* name, bool allow_auto = false) const {
    std::vector<double> values;
    std::stringstream list(Text(name));
    std::string item;
    while (std::getline(list, item, ',')) {
      item.erase(0, item.find_first_not_of(" \t\r\n"));
      item.erase(item.find_last_not_of(" \t\r\n") + 1);
      if (allow_auto && item == "auto") {
        values.push_back(std::nan(""));
        continue;
      }
      char* end = nullptr;
      const double v = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0' || !std::isfinite(v)) {
        Fail(camera_.child(name), "comma-separated numbers", Text(name));
      }
      values.push_back(v);
    }
    return values;
  }

  /// Exactly `count` numbers.
  std::vector<double> Numbers(const char* name, size_t count, bool allow_auto = false) const {
    const std::vector<double> values = List(name, allow_auto);
    if (values.size() != count) Fail(camera_.child(name), std::to_string(count) + " comma-separated numbers", Text(name));
    return values;
  }

  [[noreturn]] void Fail(const pugi::xml_node& node, const std::string& expected, const std::string& found) const {
    const size_t offset = static_cast<size_t>(std::max<ptrdiff_t>(0, node.offset_debug()));
    const int64_t line = 1 + std::count(text_.begin(), text_.begin() + std::min(offset, text_.size()), '\n');
    throw InputError(path_, line, std::string("camera.") + node.name(), found, expected);
  }
  [[noreturn]] void FailMissing(const char* name) const {
    Fail(camera_, std::string("the element <") + name + ">", "nothing");
  }
  const pugi::xml_node& node() const { return camera_; }

 private:
  std::string path_;
  const std::string& text_;
  pugi::xml_node camera_;
};

/// The <camera> element of the file; InputError unless exactly one.
pugi::xml_node SingleCamera(const std::string& path, const std::string& text, const pugi::xml_document& doc) {
  const pugi::xml_node cameras = doc.child("document").child("cameras");
  std::vector<pugi::xml_node> found;
  for (const pugi::xml_node& c : cameras.children("camera")) found.push_back(c);
  if (found.size() != 1) {
    const int64_t line = cameras ? 1 + std::count(text.begin(), text.begin() + std::min<size_t>(cameras.offset_debug(), text.size()), '\n') : 0;
    throw InputError(path, line, "document.cameras.camera", std::to_string(found.size()) + " cameras",
                     "one <camera> inside <document><cameras>");
  }
  return found.front();
}

}  // namespace

sensors::Camera ReadDbatCamera(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(text.data(), text.size());
  if (!parsed) {
    const int64_t line = 1 + std::count(text.begin(), text.begin() + std::min<size_t>(parsed.offset, text.size()), '\n');
    throw InputError(path, line, "xml", parsed.description(), "a well-formed DBAT camera XML file");
  }
  const CameraElement e(path, text, SingleCamera(path, text, doc));
  for (const char* required : {"sensor", "image", "model"}) {
    if (!e.Has(required)) e.FailMissing(required);
  }
  if (e.Has("unit") && e.Text("unit") != "mm") e.Fail(e.node().child("unit"), "mm", e.Text("unit"));
  const std::vector<double> image = e.Numbers("image", 2);
  for (double side : image) {
    if (!(side >= 1 && side <= static_cast<double>(kMaxImageSidePx)) || side != std::floor(side)) {
      e.Fail(e.node().child("image"), "two whole numbers of pixels", e.Text("image"));
    }
  }
  const std::vector<double> model = e.Numbers("model", 1);
  if (model[0] != 2 && model[0] != 3) {
    e.Fail(e.node().child("model"), "DBAT lens distortion model 2 or 3 (backward, affinity before the correction)", e.Text("model"));
  }
  std::vector<double> sensor = e.Numbers("sensor", 2, true);
  if (!(sensor[1] > 0)) e.Fail(e.node().child("sensor"), "a positive format height (mm)", e.Text("sensor"));
  double aspect = 1.0;
  if (e.Has("aspect") && e.Text("aspect") == "auto") {
    if (std::isnan(sensor[0])) e.Fail(e.node().child("aspect"), "a number when the sensor width is auto", "auto");
    aspect = (sensor[0] / image[0]) / (sensor[1] / image[1]);
  } else if (e.Has("aspect")) {
    aspect = e.Numbers("aspect", 1)[0];
  }
  if (std::isnan(sensor[0])) sensor[0] = aspect * sensor[1] * image[0] / image[1];
  if (!(sensor[0] > 0) || !(aspect > 0)) e.Fail(e.node().child("sensor"), "a positive format width (mm)", e.Text("sensor"));
  const double skew = e.Has("skew") ? e.Numbers("skew", 1)[0] : 0.0;
  if (model[0] == 2 && (aspect != 1.0 || skew != 0.0)) {
    e.Fail(e.node().child("model"), "model 3 for a camera with aspect or skew (model 2 has neither)", e.Text("model"));
  }
  const double focal = e.Has("focal") ? e.Numbers("focal", 1)[0] : std::nan("");
  double cc = focal;
  if (e.Has("cc") && e.Text("cc") != "focal") cc = e.Numbers("cc", 1)[0];
  if (!(cc > 0)) e.Fail(e.Has("cc") ? e.node().child("cc") : e.node(), "a positive camera constant <cc> or <focal> (mm)", e.Has("cc") ? e.Text("cc") : "nothing");
  std::vector<double> pp = {sensor[0] / 2, sensor[1] / 2};
  if (e.Has("pp") && e.Text("pp") != "default") pp = e.Numbers("pp", 2);
  const std::vector<double> k = e.Has("K") ? e.List("K") : std::vector<double>{};
  const std::vector<double> p = e.Has("P") ? e.List("P") : std::vector<double>{};
  if (k.size() > 3) e.Fail(e.node().child("K"), "at most 3 radial coefficients K1, K2, K3", e.Text("K"));
  if (p.size() > 2) e.Fail(e.node().child("P"), "at most 2 decentering coefficients P1, P2", e.Text("P"));

  sensors::Camera camera;
  camera.model_id = sensors::CameraModelId::kPhotogrammetric;
  camera.width = static_cast<uint64_t>(image[0]);
  camera.height = static_cast<uint64_t>(image[1]);
  const double b1 = 1.0 - aspect;
  const double pitch_mm = sensor[1] / image[1];
  camera.params = {cc, pp[0], pp[1], 0, 0, 0, 0, 0, b1, skew, sensor[0] / (image[0] * (1.0 + b1)), pitch_mm};
  for (size_t i = 0; i < k.size(); ++i) camera.params[3 + i] = k[i];
  for (size_t i = 0; i < p.size(); ++i) camera.params[6 + i] = p[i];
  return camera;
}

}  // namespace mmba::io
