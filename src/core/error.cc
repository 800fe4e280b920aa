#include "mmba/core/error.h"

#include <utility>

namespace mmba {
namespace {

std::string Location(const std::string& file, int64_t line) {
  if (line <= 0) return file;
  return file + ":" + std::to_string(line);
}

std::string Body(const std::string& field, const std::string& found,
                 const std::string& expected) {
  return "field '" + field + "': found '" + found + "', expected " + expected;
}

}  // namespace

InputError::InputError(const std::string& file, int64_t line, const std::string& field,
                       const std::string& found, const std::string& expected)
    : InputError(Location(file, line) + ": " + Body(field, found, expected), file) {}

InputError::InputError(std::string message, std::string file)
    : std::runtime_error(std::move(message)), file_(std::move(file)) {}

InputError InputError::AtByte(const std::string& file, uint64_t byte_offset,
                              const std::string& field, const std::string& found,
                              const std::string& expected) {
  return InputError(file + " (byte " + std::to_string(byte_offset) + "): " +
                        Body(field, found, expected),
                    file);
}

InputError InputError::Message(const std::string& where, const std::string& message) {
  return InputError(where + ": " + message, where);
}

}  // namespace mmba
