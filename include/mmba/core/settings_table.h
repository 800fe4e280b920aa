#pragma once

// The named settings of an options struct, as `--set NAME=VALUE` reaches them: each setting's
// name, kind (number, integer, true|false, choice), accepted values, one-line description and
// default. The table sets a setting from text with a message that names what is wrong, lists
// every setting for a command's help, and checks a whole options struct against the ranges
// (the struct's Check() uses it), so the ranges are written once.

#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace mmba {

enum class SettingKind { kNumber, kInteger, kBool, kChoice };

/// The values a number or integer setting accepts: lo <= v <= hi, an end excluded when it is
/// open. `text`, when set, replaces the generated description of the range (e.g. "0..1/3").
struct SettingRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  std::string text;

  static SettingRange Any() { return {}; }
  static SettingRange AtLeast(double lo) { return {lo, Inf(), false, true, {}}; }  ///< >= lo
  static SettingRange Above(double lo) { return {lo, Inf(), true, true, {}}; }     ///< > lo
  static SettingRange Closed(double lo, double hi) { return {lo, hi, false, false, {}}; }  ///< [lo, hi]
  static SettingRange LeftOpen(double lo, double hi) { return {lo, hi, true, false, {}}; }  ///< (lo, hi]
  static SettingRange RightOpen(double lo, double hi) { return {lo, hi, false, true, {}}; }  ///< [lo, hi)
  static SettingRange Open(double lo, double hi) { return {lo, hi, true, true, {}}; }  ///< (lo, hi)
  /// The same range described as `description` in messages and help.
  SettingRange Described(std::string description) const {
    SettingRange r = *this;
    r.text = std::move(description);
    return r;
  }
  bool Contains(double v) const {
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  /// "> 0", ">= 1", "[0, 1]", "(0, 1]", or `text`; empty for Any().
  std::string Text() const;

 private:
  static double Inf() { return std::numeric_limits<double>::infinity(); }
};

/// One setting as a command's help lists it.
struct SettingInfo {
  std::string name;
  std::string kind;         ///< "number", "integer", "true|false" or "choice"
  std::string range;        ///< the accepted values, e.g. "> 0", "0..1/3", "none|parzen|bspline"
  std::string description;  ///< one line
  std::string default_value;
};

/// What a setting holds, whatever its kind (number and integer in `number`).
struct SettingValue {
  double number = 0;
  bool flag = false;
  std::string choice;
};

/// A setting without its options struct: what it accepts and how it reads and prints.
struct SettingSpec {
  std::string name;
  SettingKind kind = SettingKind::kNumber;
  SettingRange range;                ///< number and integer
  std::vector<std::string> choices;  ///< choice
  std::string description;

  /// "number", "integer", "true|false" or "choice".
  std::string KindText() const;
  /// The range's text; "true|false" and "a|b|c" for a switch and a choice.
  std::string RangeText() const;
  /// Reads `text` as this setting's value: a finite number within the range (an integer a
  /// whole one, |v| < 1e9), true/false/1/0, or one of the choices. Returns false with
  /// `problem` ("found '0', expected a number > 0") otherwise.
  bool Parse(const std::string& text, SettingValue* value, std::string* problem) const;
  /// Whether `value` is acceptable; false with `problem` ("found 7, expected an integer
  /// [1, 6]") otherwise.
  bool Accepts(const SettingValue& value, std::string* problem) const;
  /// The value as help shows it and Parse reads it back.
  std::string Format(const SettingValue& value) const;
};

/// Levenshtein distance of two strings (insertions, deletions, substitutions; each costs 1).
size_t EditDistance(const std::string& a, const std::string& b);

/// The name among `names` closest to `name` by edit distance, or "" when none is near.
std::string ClosestSettingName(const std::string& name, const std::vector<std::string>& names);

/// Splits "NAME=VALUE"; false with `problem` ("found 'x', expected NAME=VALUE") without '='.
bool SplitSetting(const std::string& setting, std::string* name, std::string* value, std::string* problem);

/// A field of Options that a setting reads and writes: a member, a member of a member, or a
/// pair of functions (a derived field, e.g. one number spread over a vector).
template <typename Options, typename T>
struct SettingField {
  std::function<T(const Options&)> get;
  std::function<void(Options*, T)> set;

  SettingField(std::function<T(const Options&)> getter, std::function<void(Options*, T)> setter)
      : get(std::move(getter)), set(std::move(setter)) {}
  SettingField(T Options::*member)  // NOLINT(google-explicit-constructor): a member is a field
      : get([member](const Options& o) { return o.*member; }),
        set([member](Options* o, T v) { o->*member = v; }) {}
  template <typename Sub>
  SettingField(Sub Options::*sub, T Sub::*member)
      : get([sub, member](const Options& o) { return (o.*sub).*member; }),
        set([sub, member](Options* o, T v) { (o->*sub).*member = v; }) {}
};

/// The settings table of one options struct. Built once (a function-local static) by a chain
/// of Number/Integer/Flag/Choice calls in the order help lists them.
template <typename Options>
class SettingsTable {
 public:
  /// `help_hint` ends the message of an unknown name, e.g. "mmba register-cloud --help lists them".
  explicit SettingsTable(std::string help_hint) : help_hint_(std::move(help_hint)) {}

  SettingsTable& Number(const char* name, SettingField<Options, double> field, SettingRange range,
                        const char* description) {
    return Add(Spec(name, SettingKind::kNumber, std::move(range), {}, description),
               [get = field.get](const Options& o) { return NumberValue(get(o)); },
               [set = field.set](Options* o, const SettingValue& v) { set(o, v.number); });
  }
  SettingsTable& Integer(const char* name, SettingField<Options, int> field, SettingRange range,
                         const char* description) {
    return Add(Spec(name, SettingKind::kInteger, std::move(range), {}, description),
               [get = field.get](const Options& o) { return NumberValue(get(o)); },
               [set = field.set](Options* o, const SettingValue& v) { set(o, static_cast<int>(v.number)); });
  }
  SettingsTable& Flag(const char* name, SettingField<Options, bool> field, const char* description) {
    return Add(Spec(name, SettingKind::kBool, SettingRange::Any(), {}, description),
               [get = field.get](const Options& o) {
                 SettingValue v;
                 v.flag = get(o);
                 return v;
               },
               [set = field.set](Options* o, const SettingValue& v) { set(o, v.flag); });
  }
  SettingsTable& Choice(const char* name, SettingField<Options, std::string> field, std::vector<std::string> choices,
                        const char* description) {
    return Add(Spec(name, SettingKind::kChoice, SettingRange::Any(), std::move(choices), description),
               [get = field.get](const Options& o) {
                 SettingValue v;
                 v.choice = get(o);
                 return v;
               },
               [set = field.set](Options* o, const SettingValue& v) { set(o, v.choice); });
  }

  /// Sets `name` to `value` (text as the command line gives it). Returns false with `problem`
  /// when the name is unknown ("unknown setting 'x' (closest: 'y'; HINT)") or the value is not
  /// of its kind or outside its range ("found 'x', expected a number > 0"; the setting's name
  /// is not repeated); `options` is then unchanged.
  bool Set(const std::string& name, const std::string& value, Options* options, std::string* problem) const {
    const Entry* entry = Find(name);
    if (entry == nullptr) {
      *problem = UnknownProblem(name);
      return false;
    }
    SettingValue parsed;
    if (!entry->spec.Parse(value, &parsed, problem)) return false;
    entry->set(options, parsed);
    return true;
  }

  /// Set for each "NAME=VALUE" of `settings`, in order (`--set`). Returns false at the first
  /// one that is malformed or refused, with `problem` naming it ("NAME: found …"). `names`,
  /// when given, receives the name of each setting set.
  bool Apply(const std::vector<std::string>& settings, Options* options, std::string* problem,
             std::vector<std::string>* names = nullptr) const {
    for (const std::string& setting : settings) {
      std::string name, value;
      if (!SplitSetting(setting, &name, &value, problem)) return false;
      if (!Set(name, value, options, problem)) {
        if (Find(name) != nullptr) *problem = name + ": " + *problem;
        return false;
      }
      if (names != nullptr) names->push_back(name);
    }
    return true;
  }

  /// Whether every setting of `options` is within its range (and a choice one of its
  /// choices); false with `problem` naming the first that is not ("bins: found 2, expected an
  /// integer [4, 1024]").
  bool Check(const Options& options, std::string* problem) const {
    for (const Entry& entry : entries_) {
      if (!entry.spec.Accepts(entry.get(options), problem)) {
        *problem = entry.spec.name + ": " + *problem;
        return false;
      }
    }
    return true;
  }

  /// Every setting with its value in `defaults`, in the table's order.
  std::vector<SettingInfo> List(const Options& defaults = Options()) const {
    std::vector<SettingInfo> out;
    for (const Entry& entry : entries_) {
      out.push_back({entry.spec.name, entry.spec.KindText(), entry.spec.RangeText(), entry.spec.description,
                     entry.spec.Format(entry.get(defaults))});
    }
    return out;
  }

  /// A help footer: `title`, then one line per setting, "  name = default (range): description".
  std::string Footer(const std::string& title, const Options& defaults = Options()) const {
    std::string footer = title + "\n";
    for (const SettingInfo& s : List(defaults)) {
      footer += "  " + s.name + " = " + s.default_value + " (" + s.range + "): " + s.description + "\n";
    }
    return footer;
  }

  bool Has(const std::string& name) const { return Find(name) != nullptr; }

  /// The value of `name` in `options` as help prints it ("" for an unknown name).
  std::string Value(const std::string& name, const Options& options) const {
    const Entry* entry = Find(name);
    return entry == nullptr ? std::string() : entry->spec.Format(entry->get(options));
  }

 private:
  struct Entry {
    SettingSpec spec;
    std::function<SettingValue(const Options&)> get;
    std::function<void(Options*, const SettingValue&)> set;
  };

  static SettingSpec Spec(const char* name, SettingKind kind, SettingRange range, std::vector<std::string> choices,
                          const char* description) {
    SettingSpec spec;
    spec.name = name;
    spec.kind = kind;
    spec.range = std::move(range);
    spec.choices = std::move(choices);
    spec.description = description;
    return spec;
  }

  static SettingValue NumberValue(double number) {
    SettingValue v;
    v.number = number;
    return v;
  }

  SettingsTable& Add(SettingSpec spec, std::function<SettingValue(const Options&)> get,
                     std::function<void(Options*, const SettingValue&)> set) {
    entries_.push_back({std::move(spec), std::move(get), std::move(set)});
    return *this;
  }

  const Entry* Find(const std::string& name) const {
    for (const Entry& entry : entries_) {
      if (entry.spec.name == name) return &entry;
    }
    return nullptr;
  }

  std::string UnknownProblem(const std::string& name) const {
    std::vector<std::string> names;
    for (const Entry& entry : entries_) names.push_back(entry.spec.name);
    const std::string closest = ClosestSettingName(name, names);
    return "unknown setting '" + name + "' (" + (closest.empty() ? "" : "closest: '" + closest + "'; ") +
           help_hint_ + ")";
  }

  std::string help_hint_;
  std::vector<Entry> entries_;
};

}  // namespace mmba
