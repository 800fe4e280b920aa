#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mmba::io {

/// Throws InputError naming the file unless `path` is an existing regular file (or a link to
/// one): a folder, a FIFO, a device or a socket is refused before it is opened, as opening a
/// FIFO blocks and a device such as /dev/zero never ends.
void RequireRegularFile(const std::string& path);

/// Reads a whole regular file into memory (RequireRegularFile first). Throws InputError naming
/// the file when it is missing, not a regular file or unreadable.
std::string ReadWholeFile(const std::string& path);

/// Longest line (bytes, without the newline) a LineCursor accepts unless told otherwise:
/// far above any line of the formats read here, and a bound on what one line can cost.
constexpr size_t kMaxLineBytes = size_t{1} << 20;

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
  /// A token that becomes a name or an id in mmba's outputs: valid UTF-8, else InputError
  /// ("... found invalid UTF-8 at byte N of the value").
  const std::string& Name(size_t i, const std::string& field) const;
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
  /// `file` names the text in errors; a line longer than `max_line_bytes` is an InputError
  /// (file:line, its length and the limit).
  explicit LineCursor(std::string_view text, std::string file = "(text)",
                      size_t max_line_bytes = kMaxLineBytes)
      : text_(text),
        file_(std::move(file)),
        max_line_bytes_(max_line_bytes),
        pos_(text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0) {}
  /// Next line (without the newline and a trailing '\r'); false at the end.
  bool Next(std::string_view* line);
  int64_t line_number() const { return line_number_; }

 private:
  std::string_view text_;
  std::string file_;
  size_t max_line_bytes_;
  size_t pos_;
  int64_t line_number_ = 0;
};

/// Strict conversions used by the readers; return false when `token` is not entirely a
/// number of the kind (finite for doubles).
bool ParseDouble(std::string_view token, double* value);
bool ParseInt(std::string_view token, int64_t* value);

}  // namespace mmba::io
