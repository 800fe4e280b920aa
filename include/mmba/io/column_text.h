// Text files of columns named by the project file (`columns: [id, image, x, y]`): image
// measurements and control points of a photogrammetric network, as DBAT, PhotoModeler and
// Australis export them. '#' starts a comment line; fields are separated by commas or blanks
// (spaces, tabs); a field in double quotes may hold either (RFC 4180, "" for a quote).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace mmba::io {

/// One data line split into fields. Comma-separated when the line holds a comma outside quotes
/// (empty fields kept: "1,,2" is three fields), else blank-separated. Throws InputError
/// naming `file`:`line` for an unterminated quote.
std::vector<std::string> SplitColumnLine(std::string_view text, const std::string& file, int64_t line);

/// Calls `row(line_number, fields)` for every line of `path` that is not blank or a comment.
void ForEachColumnLine(const std::string& path,
                       const std::function<void(int64_t, const std::vector<std::string>&)>& row);

/// One line's fields and their names (the `columns` list) with located, strict conversions:
/// every failure throws InputError("file:line: field 'NAME': found 'V', expected ...").
class ColumnRow {
 public:
  ColumnRow(const std::string& file, int64_t line, const std::vector<std::string>* fields,
            const std::vector<std::string>* names)
      : file_(file), line_(line), fields_(fields), names_(names) {}
  /// Field of column `index`; an InputError when the line is shorter ("a value for NAME").
  const std::string& Text(size_t index) const;
  /// Whether the line has a non-empty field at `index`.
  bool Has(size_t index) const { return index < fields_->size() && !(*fields_)[index].empty(); }
  /// A finite number.
  double Number(size_t index) const;
  [[noreturn]] void Fail(size_t index, const std::string& found, const std::string& expected) const;
  int64_t line() const { return line_; }

 private:
  const std::string& file_;
  int64_t line_;
  const std::vector<std::string>* fields_;
  const std::vector<std::string>* names_;
};

/// Index of column `name` in `columns`, or -1.
int ColumnIndex(const std::vector<std::string>& columns, const std::string& name);

/// Checks a `columns` list against the allowed names (`ignored`: label, skip, _ may repeat;
/// others at most once) and the required ones. `file`, `line` and `field`
/// ("sensors[0].measurements[1].columns") locate the InputError.
void CheckColumnNames(const std::vector<std::string>& columns, const std::vector<std::string>& allowed,
                      const std::vector<std::string>& required, const std::string& file, int64_t line,
                      const std::string& field);

}  // namespace mmba::io
