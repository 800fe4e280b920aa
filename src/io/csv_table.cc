#include "mmba/io/csv_table.h"

#include <cmath>

#include "mmba/core/error.h"
#include "mmba/core/utf8.h"
#include "mmba/io/text_reader.h"

namespace mmba::io {
namespace {

std::string Trim(std::string_view s) {
  size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return std::string(s.substr(a, b - a));
}

std::vector<std::string> Split(std::string_view line) {
  std::vector<std::string> cells;
  size_t start = 0;
  for (size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == ',') {
      cells.push_back(Trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return cells;
}

}  // namespace

CsvTable CsvTable::Read(const std::string& path, const std::vector<std::string>& required) {
  CsvTable table;
  table.path_ = path;
  const std::string text = ReadWholeFile(path);
  LineCursor cursor(text, path);
  std::string_view line;
  bool have_header = false;
  size_t header_size = 0;
  while (cursor.Next(&line)) {
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const int line_number = static_cast<int>(cursor.line_number());
    std::vector<std::string> cells = Split(trimmed);
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
