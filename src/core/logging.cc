#include "mmba/core/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace mmba {
namespace {
Verbosity g_verbosity = Verbosity::kNormal;
}  // namespace

void SetVerbosity(Verbosity verbosity) {
  g_verbosity = verbosity;
  static bool sink_set = false;
  if (!sink_set) {
    spdlog::set_default_logger(spdlog::stderr_color_mt("mmba"));
    sink_set = true;
  }
  spdlog::set_pattern("[mmba %l] %v");
  switch (verbosity) {
    case Verbosity::kQuiet: spdlog::set_level(spdlog::level::err); break;
    case Verbosity::kNormal: spdlog::set_level(spdlog::level::info); break;
    case Verbosity::kVerbose: spdlog::set_level(spdlog::level::debug); break;
  }
}

Verbosity GetVerbosity() { return g_verbosity; }

}  // namespace mmba
