#include "mmba/io/csv_table.h"

#include <cmath>

#include "mmba/core/error.h"
#include "mmba/core/utf8.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t'; }
bool IsLineEnd(char c) { return c == '\n' || c == '\r'; }

/// Splits RFC 4180 text record by record; `line_` is the line of the current position.
class CsvSplitter {
 public:
  CsvSplitter(std::string_view text, const std::string& file, char comment, bool trailing_comments)
      : text_(text), file_(file), comment_(comment), trailing_(trailing_comments) {
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = 3;
  }

  std::vector<CsvRecord> Records() {
    std::vector<CsvRecord> records;
    while (pos_ < text_.size()) {
      if (SkipBlankOrCommentLine()) continue;
      CsvRecord record;
      record.line = line_;
      const size_t start = pos_;
      while (true) {
        record.cells.push_back(Field());
        if (pos_ - start > kMaxLineBytes) {
          throw InputError(file_, record.line, "record", "more than " + std::to_string(kMaxLineBytes) + " bytes",
                           "a shorter record (a quote left open?)");
        }
        if (pos_ < text_.size() && text_[pos_] == ',') {
          ++pos_;
          continue;
        }
        if (trailing_ && pos_ < text_.size() && text_[pos_] == comment_) SkipToLineEnd();
        EndLine();
        break;
      }
      records.push_back(std::move(record));
    }
    return records;
  }

 private:
  /// Skips a blank line or one whose first non-blank character is the comment character.
  bool SkipBlankOrCommentLine() {
    size_t j = pos_;
    while (j < text_.size() && IsBlank(text_[j])) ++j;
    if (j < text_.size() && !IsLineEnd(text_[j]) && text_[j] != comment_) return false;
    pos_ = j;
    SkipToLineEnd();
    EndLine();
    return true;
  }

  void SkipToLineEnd() {
    while (pos_ < text_.size() && !IsLineEnd(text_[pos_])) ++pos_;
  }

  /// Consumes LF, CRLF or CR (nothing at the end of the text).
  void EndLine() {
    if (pos_ >= text_.size()) return;
    if (text_[pos_] == '\r') {
      ++pos_;
      if (pos_ < text_.size() && text_[pos_] == '\n') ++pos_;
    } else if (text_[pos_] == '\n') {
      ++pos_;
    }
    ++line_;
  }

  std::string Field() {
    while (pos_ < text_.size() && IsBlank(text_[pos_])) ++pos_;
    if (pos_ < text_.size() && text_[pos_] == '"') return QuotedField();
    const size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != ',' && !IsLineEnd(text_[pos_]) &&
           !(trailing_ && text_[pos_] == comment_)) {
      ++pos_;
    }
    size_t end = pos_;
    while (end > start && IsBlank(text_[end - 1])) --end;
    return std::string(text_.substr(start, end - start));
  }

  std::string QuotedField() {
    const int open_line = line_;
    ++pos_;
    std::string value;
    while (true) {
      if (pos_ >= text_.size()) {
        throw InputError(file_, open_line, "quoted field", "no closing quote before the end of the file",
                         "a field ending in '\"' (a quote inside a field is written '\"\"')");
      }
      const char c = text_[pos_];
      if (c == '"') {
        if (pos_ + 1 < text_.size() && text_[pos_ + 1] == '"') {
          value += '"';
          pos_ += 2;
          continue;
        }
        ++pos_;
        break;
      }
      if (c == '\r' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '\n') {
        value += '\n';
        pos_ += 2;
        ++line_;
        continue;
      }
      if (IsLineEnd(c)) ++line_;
      value += c;
      ++pos_;
    }
    while (pos_ < text_.size() && IsBlank(text_[pos_])) ++pos_;
    if (pos_ < text_.size() && text_[pos_] != ',' && !IsLineEnd(text_[pos_]) &&
        !(trailing_ && text_[pos_] == comment_)) {
      size_t end = pos_;
      while (end < text_.size() && end < pos_ + 10 && !IsLineEnd(text_[end])) ++end;
      throw InputError(file_, line_, "quoted field",
                       "'" + std::string(text_.substr(pos_, end - pos_)) + "' after the closing quote",
                       "a comma or the end of the line after a closing quote");
    }
    return value;
  }

  std::string_view text_;
  const std::string& file_;
  char comment_;
  bool trailing_;
  size_t pos_ = 0;
  int line_ = 1;
};

}  // namespace

std::vector<CsvRecord> SplitCsvRecords(std::string_view text, const std::string& file, char comment,
                                       bool trailing_comments) {
  return CsvSplitter(text, file, comment, trailing_comments).Records();
}

CsvTable CsvTable::Read(const std::string& path, const std::vector<std::string>& required) {
  CsvTable table;
  table.path_ = path;
  const std::string text = ReadWholeFile(path);
  bool have_header = false;
  size_t header_size = 0;
  for (CsvRecord& record : SplitCsvRecords(text, path)) {
    const int line_number = record.line;
    std::vector<std::string>& cells = record.cells;
    // Cells become ids and names in the outputs: text is checked here, where the line is known.
    for (size_t i = 0; i < cells.size(); ++i) {
      if (const size_t bad = InvalidUtf8Offset(cells[i]); bad != std::string::npos) {
        const std::string column = have_header ? (i < header_size ? table.header_[i] : "column " + std::to_string(i + 1))
                                               : "header cell " + std::to_string(i + 1);
        throw InputError(path, line_number, column, "invalid UTF-8 at byte " + std::to_string(bad) + " of the cell",
                         "UTF-8 text");
      }
    }
    if (!have_header) {
      for (size_t i = 0; i < cells.size(); ++i) table.columns_[cells[i]] = i;
      for (const std::string& column : required) {
        if (!table.columns_.count(column)) {
          // The header is not quoted back: the file may not be a table at all (any file can
          // be named here), and the required names say what is missing.
          std::string needed;
          for (const std::string& name : required) needed += (needed.empty() ? "" : ", ") + name;
          throw InputError(path, line_number, "header",
                           std::to_string(cells.size()) + (cells.size() == 1 ? " cell" : " cells") +
                               ", none named " + column,
                           "a header line naming the columns " + needed);
        }
      }
      table.header_ = cells;
      header_size = cells.size();
      have_header = true;
      continue;
    }
    if (cells.size() != header_size) {
      throw InputError(path, line_number, "row", std::to_string(cells.size()) + " cells",
                       std::to_string(header_size) + " cells as in the header");
    }
    table.rows_.push_back({line_number, std::move(cells)});
  }
  if (!have_header) throw InputError::Message(path, "no header row (the file has no data)");
  return table;
}

const std::string& CsvTable::String(const Row& row, const std::string& column) const {
  const auto it = columns_.find(column);
  if (it == columns_.end()) Fail(row, column, "no such column", "a column named " + column);
  return row.cells[it->second];
}

double CsvTable::Double(const Row& row, const std::string& column) const {
  const std::string& cell = String(row, column);
  double value = 0.0;
  if (!ParseDouble(cell, &value) || !std::isfinite(value)) {
    Fail(row, column, cell.empty() ? "an empty cell" : cell, "a finite number");
  }
  return value;
}

double CsvTable::Double(const Row& row, const std::string& column, double empty_value) const {
  if (!Has(column) || String(row, column).empty()) return empty_value;
  return Double(row, column);
}

void CsvTable::Fail(const Row& row, const std::string& column, const std::string& found,
                    const std::string& expected) const {
  throw InputError(path_, row.line, column, found, expected);
}

}  // namespace mmba::io
