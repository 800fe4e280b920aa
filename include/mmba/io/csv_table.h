// Comma-separated tables with a header row (GNSS files, image measurements, pose lists), in
// RFC 4180 form as spreadsheets write them: a field in double quotes may hold commas, line
// breaks and doubled quotes; CRLF or LF line ends; a UTF-8 byte order mark. Lines starting
// with '#' and blank lines are skipped; unquoted cells are trimmed. Every error names the
// file, line and column.
#pragma once

#include <map>
#include <string_view>
#include <string>
#include <vector>

namespace mmba::io {

/// One record of a comma-separated text: the line it starts on and its fields.
struct CsvRecord {
  int line = 0;
  std::vector<std::string> cells;
};

/// Splits `text` into RFC 4180 records. Fields are separated by ','; a field in double quotes
/// may hold ',', line breaks (CRLF inside becomes LF) and '""' for '"'; blanks around a field
/// are dropped outside the quotes. Records end at LF, CRLF or CR; a UTF-8 byte order mark
/// before the first record is dropped. Blank lines and lines whose first non-blank character
/// is `comment` are skipped; with `trailing_comments`, an unquoted `comment` character also
/// ends the record (the rest of the line is a comment). Throws InputError(file, line, ...)
/// for a quote that is never closed (the line where it opens), text after a closing quote,
/// and a record longer than kMaxLineBytes.
std::vector<CsvRecord> SplitCsvRecords(std::string_view text, const std::string& file,
                                       char comment = '#', bool trailing_comments = false);

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
