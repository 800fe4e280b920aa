#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mmba::io {

/// Reads a whole file into memory. Throws InputError naming the file when it is missing or
/// unreadable.
std::string ReadWholeFile(const std::string& path);

/// One whitespace-separated line of a text file, with strict, located conversions: every
/// failure throws InputError("file:line: field 'F': found 'V', expected ...").
class TokenLine {
 public:
  TokenLine(std::string file, int64_t line_number, std::string_view text);

  size_t size() const { return tokens_.size(); }
  int64_t line_number() const { return line_number_; }
  const std::string& file() const { return file_; }

  /// Throws unless the line has exactly (or at least) `count` tokens; `what` names the record.
  void ExpectCount(size_t count, const std::string& what) const;
  void ExpectAtLeast(size_t count, const std::string& what) const;

  const std::string& Str(size_t i, const std::string& field) const;
  /// A finite double (NaN and Inf rejected).
  double Double(size_t i, const std::string& field) const;
  /// A signed integer.
  int64_t Int(size_t i, const std::string& field) const;
  /// A non-negative integer.
  uint64_t UInt(size_t i, const std::string& field) const;

  /// Throws the standard located error for this line.
  [[noreturn]] void Fail(const std::string& field, const std::string& found,
                         const std::string& expected) const;

 private:
  std::string file_;
  int64_t line_number_;
  std::vector<std::string> tokens_;
};

/// Iterates the lines of a text buffer, numbering them from 1. A UTF-8 byte-order mark before
/// the first line (as some Windows programs write one) is not part of that line.
class LineCursor {
 public:
  explicit LineCursor(std::string_view text)
      : text_(text), pos_(text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0) {}
  /// Next line (without the newline and a trailing '\r'); false at the end.
  bool Next(std::string_view* line);
  int64_t line_number() const { return line_number_; }

 private:
  std::string_view text_;
  size_t pos_;
  int64_t line_number_ = 0;
};

/// Strict conversions used by the readers; return false when `token` is not entirely a
/// number of the kind (finite for doubles).
bool ParseDouble(std::string_view token, double* value);
bool ParseInt(std::string_view token, int64_t* value);

}  // namespace mmba::io
