#pragma once

#include <spdlog/spdlog.h>

namespace mmba {

/// Verbosity of the command-line tools: messages go to stderr, results to stdout/files.
enum class Verbosity { kQuiet, kNormal, kVerbose };

/// Sets the level of the default spdlog logger: quiet = errors only, normal = info,
/// verbose = debug. Also sets a compact "[mmba] message" pattern.
void SetVerbosity(Verbosity verbosity);
Verbosity GetVerbosity();

}  // namespace mmba
