// What every libFuzzer harness of tests/fuzz shares: the fuzzer's bytes written as files in a
// folder private to the process (the readers take paths), and the rule that an InputError is
// the expected end of bad input while anything else — another exception, a crash, a hang, a
// leak, a sanitizer report — is a finding (docs/fuzzing.md).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "mmba/core/error.h"

namespace mmba::fuzz {

/// Separates the files of a harness that reads several (a COLMAP model folder, KITTI's raw
/// calibration pair): the input "A<kSplit>B<kSplit>C" holds the files A, B and C.
inline constexpr std::string_view kSplit = "\n%%MMBA-SPLIT%%\n";

/// The folder of this process's input files ($TMPDIR or /tmp, "mmba-fuzz-<pid>"), created on
/// first use and removed when the process exits normally.
inline const std::filesystem::path& WorkDir() {
  // Never destroyed, so that the exit handler below can still read it.
  static const std::filesystem::path* const dir = [] {
    const char* tmp = std::getenv("TMPDIR");
    auto* path = new std::filesystem::path(
        std::filesystem::path(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") /
        ("mmba-fuzz-" + std::to_string(::getpid())));
    std::filesystem::create_directories(*path);
    return path;
  }();
  static const bool cleanup_registered = [] {
    return std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(WorkDir(), ec);
    }) == 0;
  }();
  (void)cleanup_registered;
  return *dir;
}

/// Writes `bytes` to WorkDir()/`name` (parent folders created, the file replaced); returns
/// its path.
inline std::string WriteInput(const std::string& name, std::string_view bytes) {
  const std::filesystem::path path = WorkDir() / name;
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
  return path.string();
}

inline std::string WriteInput(const std::string& name, const uint8_t* data, size_t size) {
  return WriteInput(name, std::string_view(reinterpret_cast<const char*>(data), size));
}

/// Removes WorkDir()/`name` if it exists (a file the input does not provide).
inline void RemoveInput(const std::string& name) {
  std::error_code ec;
  std::filesystem::remove(WorkDir() / name, ec);
}

/// The input cut at each kSplit, at most `max_parts` parts (the last keeps any further
/// separators).
inline std::vector<std::string_view> SplitInput(const uint8_t* data, size_t size,
                                                size_t max_parts) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  std::vector<std::string_view> parts;
  while (parts.size() + 1 < max_parts) {
    const size_t at = rest.find(kSplit);
    if (at == std::string_view::npos) break;
    parts.push_back(rest.substr(0, at));
    rest.remove_prefix(at + kSplit.size());
  }
  parts.push_back(rest);
  return parts;
}

/// Writes the parts of the input as the files `names` (in order); the files without a part
/// are removed, so that a short input also exercises the "missing file" errors.
inline void WriteParts(const uint8_t* data, size_t size, const std::vector<std::string>& names) {
  const std::vector<std::string_view> parts = SplitInput(data, size, names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    if (i < parts.size()) {
      WriteInput(names[i], parts[i]);
    } else {
      RemoveInput(names[i]);
    }
  }
}

/// Runs `read`: an InputError (or a subclass) is the documented answer to bad input and is
/// swallowed (printed to stderr when MMBA_FUZZ_VERBOSE is set, to check what the seeds
/// reach); any other exception leaves the harness, and libFuzzer reports the abort of the
/// uncaught exception (with its type and what()) as a crash.
template <typename Read>
void ExpectOnlyInputError(Read&& read) {
  static const bool verbose = std::getenv("MMBA_FUZZ_VERBOSE") != nullptr;
  try {
    read();
    if (verbose) std::fprintf(stderr, "read: ok\n");
  } catch (const InputError& error) {
    if (verbose) std::fprintf(stderr, "read: InputError: %s\n", error.what());
  }
}

}  // namespace mmba::fuzz
