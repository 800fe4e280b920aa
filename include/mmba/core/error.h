#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace mmba {

/// Bad user input: a file, a line or byte offset in it, the field, the value found and what
/// was expected. `main` catches it, prints `what()` on one line and exits with code 2.
///
/// what() reads, e.g.:
///   `model/cameras.txt:4: field 'model': found 'PINHOL', expected one of SIMPLE_PINHOLE, ...`
/// what() is one line safe to print on a terminal: control characters (escape sequences, '\n'
/// too) and bytes that are not UTF-8 are written as \t, \r, \n or \xHH, and the field and the
/// value found are cut to 100 bytes (the length is said).
class InputError : public std::runtime_error {
 public:
  /// Error at a text line (1-based). `line` <= 0 omits the line.
  InputError(const std::string& file, int64_t line, const std::string& field,
             const std::string& found, const std::string& expected);

  /// Error at a byte offset of a binary file.
  static InputError AtByte(const std::string& file, uint64_t byte_offset,
                           const std::string& field, const std::string& found,
                           const std::string& expected);

  /// Error about a whole file or an option (no line), free text after the location.
  static InputError Message(const std::string& where, const std::string& message);

  const std::string& file() const { return file_; }

 private:
  InputError(const std::string& message, std::string file);
  std::string file_;
};

/// A readable cloud holding a point with a NaN/Inf coordinate (or normal, intensity, time):
/// an InputError (exit 2) wherever it is not caught, but the file itself is readable, so
/// register-cloud reports it as a failed registration (status "failed") with the reason.
class NonFiniteInput : public InputError {
 public:
  explicit NonFiniteInput(const InputError& error) : InputError(error) {}
};

/// Exit codes of the `mmba` binary.
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,       ///< unexpected internal error
  kExitInputError = 2,    ///< bad input (InputError)
  kExitNotConverged = 3,  ///< adjustment/registration failed or degenerate
};

}  // namespace mmba
