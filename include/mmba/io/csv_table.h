// Comma-separated tables with a header row (GNSS files, image measurements, pose lists).
// Lines starting with '#' and blank lines are skipped; cells are trimmed. Every error names
// the file, line and column.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace mmba::io {

class CsvTable {
 public:
  struct Row {
    int line = 0;
    std::vector<std::string> cells;
  };

  /// Reads `path`; the first non-comment line is the header and must name every column of
  /// `required` (other columns are allowed). Every row must have as many cells as the header,
  /// and every cell must be UTF-8 text.
  static CsvTable Read(const std::string& path, const std::vector<std::string>& required);

  bool Has(const std::string& column) const { return columns_.count(column) > 0; }
  const std::string& String(const Row& row, const std::string& column) const;
  /// The cell as a finite number; `empty_value` is returned for an empty cell when given
  /// (else an empty cell is an error).
  double Double(const Row& row, const std::string& column) const;
  double Double(const Row& row, const std::string& column, double empty_value) const;
  [[noreturn]] void Fail(const Row& row, const std::string& column, const std::string& found,
                         const std::string& expected) const;

  const std::vector<Row>& rows() const { return rows_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::map<std::string, size_t> columns_;
  std::vector<std::string> header_;  ///< column names in file order
  std::vector<Row> rows_;
};

}  // namespace mmba::io
