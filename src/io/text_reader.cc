#include "mmba/io/text_reader.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <sys/stat.h>

#include "mmba/core/error.h"
#include "mmba/core/utf8.h"

namespace mmba::io {
namespace {

// What a file that is not a regular file is, for the message.
const char* KindOfFile(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

void RequireRegularFile(const std::string& path) {
  // stat() follows links and does not open the file (opening a FIFO would wait for a writer).
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) throw InputError::Message(path, "file not found");
    throw InputError::Message(path, std::string("cannot read the file's status: ") + std::strerror(errno));
  }
  if (!S_ISREG(status.st_mode)) {
    throw InputError::Message(path, std::string("is ") + KindOfFile(status.st_mode) + ", expected a regular file");
  }
}

std::string ReadWholeFile(const std::string& path) {
  RequireRegularFile(path);
  std::error_code ec;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError::Message(path, "cannot open file for reading");
  // Read straight into the string when the size is known (one copy, not two).
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (!ec) {
    std::string data(static_cast<size_t>(size), '\0');
    in.read(data.data(), static_cast<std::streamsize>(data.size()));
    if (in.gcount() == static_cast<std::streamsize>(data.size()) && in.peek() == EOF) return data;
    in.clear();
    in.seekg(0);
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

bool ParseDouble(std::string_view token, double* value) {
  // std::from_chars: correctly rounded like strtod, but in place and independent of the
  // locale's decimal point. A leading '+' is allowed, as strtod allows it.
  if (token.empty()) return false;
  const char* begin = token.data();
  const char* end = token.data() + token.size();
  if (*begin == '+') ++begin;
  if (begin == end || *begin == '+' || (*begin == '-' && begin != token.data())) return false;
  double v = 0.0;
  const auto result = std::from_chars(begin, end, v);
  if (result.ec != std::errc() || result.ptr != end || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool ParseInt(std::string_view token, int64_t* value) {
  if (token.empty()) return false;
  const char* begin = token.data();
  if (*begin == '+') ++begin;
  const auto result = std::from_chars(begin, token.data() + token.size(), *value);
  return result.ec == std::errc() && result.ptr == token.data() + token.size();
}

TokenLine::TokenLine(std::string file, int64_t line_number, std::string_view text)
    : file_(std::move(file)), line_number_(line_number) {
  size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    size_t j = i;
    while (j < text.size() && !std::isspace(static_cast<unsigned char>(text[j]))) ++j;
    if (j > i) tokens_.emplace_back(text.substr(i, j - i));
    i = j;
  }
}

void TokenLine::Fail(const std::string& field, const std::string& found,
                     const std::string& expected) const {
  throw InputError(file_, line_number_, field, found, expected);
}

void TokenLine::ExpectCount(size_t count, const std::string& what) const {
  if (tokens_.size() != count) {
    Fail(what, std::to_string(tokens_.size()) + " values",
         std::to_string(count) + " values");
  }
}

void TokenLine::ExpectAtLeast(size_t count, const std::string& what) const {
  if (tokens_.size() < count) {
    Fail(what, std::to_string(tokens_.size()) + " values",
         "at least " + std::to_string(count) + " values");
  }
}

const std::string& TokenLine::Str(size_t i, const std::string& field) const {
  if (i >= tokens_.size()) Fail(field, "end of line", "a value");
  return tokens_[i];
}

const std::string& TokenLine::Name(size_t i, const std::string& field) const {
  const std::string& token = Str(i, field);
  if (const size_t bad = InvalidUtf8Offset(token); bad != std::string::npos) {
    Fail(field, "invalid UTF-8 at byte " + std::to_string(bad) + " of the value", "UTF-8 text");
  }
  return token;
}

double TokenLine::Double(size_t i, const std::string& field) const {
  double v = 0.0;
  if (!ParseDouble(Str(i, field), &v)) Fail(field, tokens_[i], "a finite number");
  return v;
}

int64_t TokenLine::Int(size_t i, const std::string& field) const {
  int64_t v = 0;
  if (!ParseInt(Str(i, field), &v)) Fail(field, tokens_[i], "an integer");
  return v;
}

uint64_t TokenLine::UInt(size_t i, const std::string& field) const {
  int64_t v = 0;
  if (!ParseInt(Str(i, field), &v) || v < 0) {
    Fail(field, tokens_[i], "a non-negative integer");
  }
  return static_cast<uint64_t>(v);
}

bool LineCursor::Next(std::string_view* line) {
  if (pos_ >= text_.size()) return false;
  size_t end = text_.find('\n', pos_);
  if (end == std::string_view::npos) end = text_.size();
  std::string_view l = text_.substr(pos_, end - pos_);
  if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
  *line = l;
  pos_ = end + 1;
  ++line_number_;
  if (l.size() > max_line_bytes_) {
    throw InputError(file_, line_number_, "line", std::to_string(l.size()) + " bytes",
                     "at most " + std::to_string(max_line_bytes_) + " bytes per line (not a text file of this format?)");
  }
  return true;
}

}  // namespace mmba::io
