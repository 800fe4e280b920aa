// Typed access to the report JSON and number formatting of report.html (html_internal.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "report/html_internal.h"

namespace mmba::report::internal {

std::string Describe(const json& value) {
  std::string text = value.dump(-1, ' ', false, json::error_handler_t::replace);
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return std::string(value.type_name()) + " " + text;
}

[[noreturn]] void Fail(const std::string& path, const std::string& found,
                       const std::string& expected) {
  throw std::invalid_argument("report JSON: field '" + path + "': found " + found + ", expected " +
                              expected);
}

std::string Join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string Index(const std::string& path, size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

// A present, non-null member (nullptr when absent or null).
const json* Member(const json& object, const std::string& key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return nullptr;
  return &*it;
}

std::optional<std::string> OptString(const json& object, const std::string& key,
                                     const std::string& path) {
  const json* v = Member(object, key);
  if (v == nullptr) return std::nullopt;
  if (!v->is_string()) Fail(Join(path, key), Describe(*v), "a string");
  return v->get<std::string>();
}

std::string ReqString(const json& object, const std::string& key, const std::string& path) {
  const auto value = OptString(object, key, path);
  if (!value) Fail(Join(path, key), "nothing (missing)", "a string");
  return *value;
}

// A number; NaN when absent or null (JSON has no NaN: writers emit null).
double Num(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v == nullptr) return NAN;
  if (!v->is_number()) Fail(Join(path, key), Describe(*v), "a number or null");
  return v->get<double>();
}

std::optional<bool> OptBool(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v == nullptr) return std::nullopt;
  if (!v->is_boolean()) Fail(Join(path, key), Describe(*v), "true or false");
  return v->get<bool>();
}

const json* OptObject(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v != nullptr && !v->is_object()) Fail(Join(path, key), Describe(*v), "an object");
  return v;
}

const json* OptArray(const json& object, const std::string& key, const std::string& path) {
  const json* v = Member(object, key);
  if (v != nullptr && !v->is_array()) Fail(Join(path, key), Describe(*v), "an array");
  return v;
}

const json& ElementObject(const json& array, size_t i, const std::string& path) {
  const json& v = array[i];
  if (!v.is_object()) Fail(Index(path, i), Describe(v), "an object");
  return v;
}

// An array of 3 numbers (null = NaN); nullopt when absent.
std::optional<std::array<double, 3>> OptVec3(const json& object, const std::string& key,
                                             const std::string& path) {
  const json* v = OptArray(object, key, path);
  if (v == nullptr) return std::nullopt;
  const std::string field = Join(path, key);
  if (v->size() != 3) Fail(field, Describe(*v), "an array of 3 numbers [E, N, U]");
  std::array<double, 3> out{};
  for (size_t i = 0; i < 3; ++i) {
    const json& e = (*v)[i];
    if (e.is_null()) {
      out[i] = NAN;
    } else if (e.is_number()) {
      out[i] = e.get<double>();
    } else {
      Fail(Index(field, i), Describe(e), "a number or null");
    }
  }
  return out;
}

std::vector<double> NumberArray(const json& object, const std::string& key, const std::string& path) {
  std::vector<double> out;
  const json* v = OptArray(object, key, path);
  if (v == nullptr) return out;
  out.reserve(v->size());
  for (size_t i = 0; i < v->size(); ++i) {
    const json& e = (*v)[i];
    if (e.is_null()) {
      out.push_back(NAN);
    } else if (e.is_number()) {
      out.push_back(e.get<double>());
    } else {
      Fail(Index(Join(path, key), i), Describe(e), "a number or null");
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Formatting.

std::string Esc(const std::string& s) { return HtmlEscape(s); }

// A count with thin spaces between thousands ("35 966"); "—" when not finite.
std::string Count(double value) {
  if (!std::isfinite(value)) return kDash;
  if (std::abs(value - std::round(value)) > 1e-9) return FormatFixed(value, 1);
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.0f", std::abs(value));
  std::string digits = buffer, out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += "\xE2\x80\xAF";  // narrow no-break space
    out += digits[i];
  }
  return (value < 0 ? "-" : "") + out;
}

// Significant digits ("%.Ng"), "—" when not finite.
std::string Sig(double value, int digits) {
  if (!std::isfinite(value)) return kDash;
  char buffer[48];
  std::snprintf(buffer, sizeof(buffer), "%.*g", digits, value);
  return buffer;
}

std::string Mm(double metres, int decimals) { return FormatFixed(metres * 1000.0, decimals); }

std::string Td(const std::string& content) { return "<td class=\"num\">" + content + "</td>"; }
std::string TdText(const std::string& escaped) { return "<td>" + escaped + "</td>"; }

// ---------------------------------------------------------------------------------------
// Statistics helpers.

// Regularised lower incomplete gamma P(a, x) by its series (Abramowitz & Stegun 6.5.29);
// used for the χ tail P(|w| > t) = 1 − P(k/2, t²/2) at t = 3 with small k.
namespace {
double LowerRegularizedGamma(double a, double x) {
  if (x <= 0.0) return 0.0;
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 500; ++n) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * 1e-15) break;
  }
  return std::min(1.0, sum * std::exp(-x + a * std::log(x) - std::lgamma(a)));
}

}  // namespace

// P(norm of k whitened components > t); k = 1 is the two-sided normal tail.
double ChiTail(double t, int k) { return 1.0 - LowerRegularizedGamma(0.5 * k, 0.5 * t * t); }


double Norm3(const std::array<double, 3>& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

}  // namespace mmba::report::internal
