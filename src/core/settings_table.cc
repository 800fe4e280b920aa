#include "mmba/core/settings_table.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace mmba {
namespace {

std::string Printed(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string Joined(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
}


}  // namespace

std::string SettingRange::Text() const {
  if (!text.empty()) return text;
  const bool no_lo = std::isinf(lo) && lo < 0, no_hi = std::isinf(hi) && hi > 0;
  if (no_lo && no_hi) return "";
  if (no_hi) return (lo_open ? "> " : ">= ") + Printed(lo);
  if (no_lo) return (hi_open ? "< " : "<= ") + Printed(hi);
  return (lo_open ? "(" : "[") + Printed(lo) + ", " + Printed(hi) + (hi_open ? ")" : "]");
}

std::string SettingSpec::KindText() const {
  switch (kind) {
    case SettingKind::kNumber:
      return "number";
    case SettingKind::kInteger:
      return "integer";
    case SettingKind::kBool:
      return "true|false";
    case SettingKind::kChoice:
      return "choice";
  }
  return "";
}

std::string SettingSpec::RangeText() const {
  if (kind == SettingKind::kBool) return "true|false";
  if (kind == SettingKind::kChoice) return Joined(choices, "|");
  return range.Text();
}

namespace {

// "a number > 0", "an integer [1, 6]", "a finite number" (the article and kind, then the range).
std::string Expected(const SettingSpec& spec, bool finite) {
  const std::string range = spec.range.Text();
  std::string what = spec.kind == SettingKind::kInteger ? "an integer" : finite ? "a finite number" : "a number";
  return range.empty() ? what : what + " " + range;
}

}  // namespace

bool SettingSpec::Parse(const std::string& text, SettingValue* value, std::string* problem) const {
  if (kind == SettingKind::kBool) {
    if (text != "true" && text != "false" && text != "1" && text != "0") {
      *problem = "found '" + text + "', expected true or false";
      return false;
    }
    value->flag = text == "true" || text == "1";
    return true;
  }
  if (kind == SettingKind::kChoice) {
    if (std::find(choices.begin(), choices.end(), text) == choices.end()) {
      *problem = "found '" + text + "', expected " + Joined(choices, ", ");
      return false;
    }
    value->choice = text;
    return true;
  }
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  const bool number = !text.empty() && end == text.c_str() + text.size();
  const bool finite = number && std::isfinite(v);
  const bool whole = finite && (kind != SettingKind::kInteger || (v == std::floor(v) && std::abs(v) < 1e9));
  if (!whole || !range.Contains(v)) {
    *problem = "found '" + text + "', expected " + Expected(*this, number && !finite);
    return false;
  }
  value->number = v;
  return true;
}

bool SettingSpec::Accepts(const SettingValue& value, std::string* problem) const {
  if (kind == SettingKind::kBool) return true;
  if (kind == SettingKind::kChoice) {
    if (std::find(choices.begin(), choices.end(), value.choice) != choices.end()) return true;
    *problem = "found '" + value.choice + "', expected " + Joined(choices, ", ");
    return false;
  }
  if (std::isfinite(value.number) && range.Contains(value.number)) return true;
  *problem = "found " + Printed(value.number) + ", expected " + Expected(*this, !std::isfinite(value.number));
  return false;
}

std::string SettingSpec::Format(const SettingValue& value) const {
  switch (kind) {
    case SettingKind::kBool:
      return value.flag ? "true" : "false";
    case SettingKind::kChoice:
      return value.choice;
    default:
      return Printed(value.number);
  }
}

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string ClosestSettingName(const std::string& name, const std::vector<std::string>& names) {
  std::string closest;
  size_t best = std::max<size_t>(2, name.size() / 2) + 1;  // farther than this is no hint
  for (const std::string& candidate : names) {
    const size_t d = EditDistance(name, candidate);
    if (d < best) best = d, closest = candidate;
  }
  return closest;
}

bool SplitSetting(const std::string& setting, std::string* name, std::string* value, std::string* problem) {
  const size_t eq = setting.find('=');
  if (eq == std::string::npos) {
    *problem = "found '" + setting + "', expected NAME=VALUE";
    return false;
  }
  *name = setting.substr(0, eq);
  *value = setting.substr(eq + 1);
  return true;
}

}  // namespace mmba
