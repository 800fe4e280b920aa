#pragma once

// Checks of the command line before CLI11 parses it, so that a mistyped command or option is
// named first, with the closest valid name, instead of a consequence of it ("A subcommand is
// required", "--input is required").

#include <string>

#include <CLI/CLI.hpp>

namespace mmba::app {

/// Empty when argv names a known subcommand of `app` (or only --help/--version) and every
/// option word of it ("--name", "--name=value", "-x") is one of that subcommand's options;
/// else one line for the user: "unknown command 'adjsut'; did you mean 'adjust'? (...)".
std::string UnknownArgument(const CLI::App& app, int argc, char** argv);

}  // namespace mmba::app
