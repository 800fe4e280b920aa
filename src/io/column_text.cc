#include "mmba/io/column_text.h"

#include <algorithm>
#include <set>

#include "mmba/core/error.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t'; }

/// Whether a comma occurs outside double quotes.
bool HasUnquotedComma(std::string_view text) {
  bool quoted = false;
  for (char c : text) {
    if (c == '"') quoted = !quoted;
    if (c == ',' && !quoted) return true;
  }
  return false;
}

}  // namespace

std::vector<std::string> SplitColumnLine(std::string_view text, const std::string& file, int64_t line) {
  const bool commas = HasUnquotedComma(text);
  std::vector<std::string> fields;
  size_t i = 0;
  while (true) {
    while (i < text.size() && IsBlank(text[i])) ++i;
    if (!commas && i == text.size()) break;
    std::string field;
    if (i < text.size() && text[i] == '"') {  // RFC 4180: "" inside quotes is one quote
      size_t j = i + 1;
      for (;; ++j) {
        if (j >= text.size()) throw InputError(file, line, "quoted field", std::string(text.substr(i)), "a closing \"");
        if (text[j] == '"' && j + 1 < text.size() && text[j + 1] == '"') {
          field += '"';
          ++j;
        } else if (text[j] == '"') {
          break;
        } else {
          field += text[j];
        }
      }
      i = j + 1;
      while (i < text.size() && IsBlank(text[i])) ++i;
    } else {
      const size_t start = i;
      while (i < text.size() && !(commas ? text[i] == ',' : IsBlank(text[i]))) ++i;
      size_t end = i;
      while (end > start && IsBlank(text[end - 1])) --end;
      field = std::string(text.substr(start, end - start));
    }
    fields.push_back(std::move(field));
    if (commas) {
      if (i >= text.size()) break;
      if (text[i] != ',') throw InputError(file, line, "field " + std::to_string(fields.size()), std::string(text.substr(i)), "a comma after a quoted field");
      ++i;
    }
  }
  return fields;
}

void ForEachColumnLine(const std::string& path,
                       const std::function<void(int64_t, const std::vector<std::string>&)>& row) {
  const std::string text = ReadWholeFile(path);
  LineCursor cursor(text, path);
  std::string_view line;
  while (cursor.Next(&line)) {
    size_t a = 0;
    while (a < line.size() && IsBlank(line[a])) ++a;
    if (a == line.size() || line[a] == '#') continue;
    const int64_t number = cursor.line_number();
    row(number, SplitColumnLine(line.substr(a), path, number));
  }
}

const std::string& ColumnRow::Text(size_t index) const {
  if (index >= fields_->size()) {
    throw InputError(file_, line_, (*names_)[index], std::to_string(fields_->size()) + " fields",
                     "a value for column " + std::to_string(index + 1) + " (" + (*names_)[index] + ")");
  }
  return (*fields_)[index];
}

double ColumnRow::Number(size_t index) const {
  const std::string& text = Text(index);
  double value = 0.0;
  if (!ParseDouble(text, &value)) Fail(index, text.empty() ? "an empty field" : text, "a finite number");
  return value;
}

void ColumnRow::Fail(size_t index, const std::string& found, const std::string& expected) const {
  throw InputError(file_, line_, (*names_)[index], found, expected);
}

int ColumnIndex(const std::vector<std::string>& columns, const std::string& name) {
  const auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
}

void CheckColumnNames(const std::vector<std::string>& columns, const std::vector<std::string>& allowed,
                      const std::vector<std::string>& required, const std::string& file, int64_t line,
                      const std::string& field) {
  std::string names;
  for (const std::string& a : allowed) names += a + ", ";
  names += "label, skip, _ (ignored)";
  std::set<std::string> seen;
  for (const std::string& c : columns) {
    if (c == "label" || c == "skip" || c == "_") continue;
    if (std::find(allowed.begin(), allowed.end(), c) == allowed.end()) {
      throw InputError(file, line, field, c + " (unknown column)", "one of " + names);
    }
    if (!seen.insert(c).second) {
      throw InputError(file, line, field, c + " twice", "each column once");
    }
  }
  for (const std::string& r : required) {
    if (!seen.count(r)) {
      throw InputError(file, line, field, "no column " + r, "a column named " + r);
    }
  }
}

}  // namespace mmba::io
