#pragma once

// The subcommand registry of the one `mmba` binary. Every apps/commands/<name>.cc defines
// its options and a run function and registers itself with MMBA_REGISTER_COMMAND; main()
// parses, sets the verbosity and runs the chosen command. Commands stay thin: they parse
// options, call library code, write files and print a short summary.

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mmba/core/error.h"
#include "mmba/core/output_folder.h"

namespace mmba::app {

/// A result that is not a success: an adjustment or registration that failed, did not
/// converge or is degenerate. main() prints the message and exits with kExitNotConverged (3).
class CommandFailed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Options every command has.
struct CommonOptions {
  bool quiet = false;
  bool verbose = false;
};

/// Adds --quiet / --verbose to a subcommand.
void AddCommonOptions(CLI::App* sub, CommonOptions* common);

/// A command: `setup` adds the subcommand and its options to the app and returns the run
/// function (called only when that subcommand was given; returns the exit code).
using CommandSetup = std::function<std::function<int()>(CLI::App& app, CommonOptions* common)>;

/// Registers a command; `order` sorts the help listing. Returns true (for static init).
bool RegisterCommand(int order, CommandSetup setup);

/// Called by main().
int RunMain(int argc, char** argv);

/// A file a command reads or writes, named by its option (e.g. {"--target", "scan.ply"}).
struct FileArg {
  std::string option;
  std::string path;
};

/// mmba never overwrites its inputs: throws InputError (exit 2) naming the option when an
/// output is the same file as an input (an existing file, however the path is spelled) or as
/// another output, or when an output file cannot be written (CheckOutputFiles). Call before
/// any work. Empty paths are skipped.
void RefuseToOverwriteInputs(const std::vector<FileArg>& outputs, const std::vector<FileArg>& inputs);

/// Output files must be writable where they are named, checked before any work: throws
/// InputError (exit 2) naming the option, the path and what was expected when a path is an
/// existing folder, when a part of its folder path is an existing file, or when nothing can be
/// created in its nearest existing folder (read-only, /proc, no permission). Missing folders
/// are fine (AtomicFileSet creates them). The check creates and removes one probe entry in
/// that folder and leaves nothing behind. Empty paths are skipped. RefuseToOverwriteInputs
/// calls it for its outputs.
void CheckOutputFiles(const std::vector<FileArg>& outputs);

/// The inputs as core/output_folder.h names them: an output folder (a command writing several
/// files into one: adjust, ba, simulate, survey, register-eval, register-mi --probe) is an
/// OutputFolder, checked against these before any work.
std::vector<NamedPath> AsNamedPaths(const std::vector<FileArg>& inputs);

}  // namespace mmba::app

#define MMBA_REGISTER_COMMAND_CONCAT2(a, b) a##b
#define MMBA_REGISTER_COMMAND_CONCAT(a, b) MMBA_REGISTER_COMMAND_CONCAT2(a, b)
/// In a command's .cc file: MMBA_REGISTER_COMMAND(10, SetupBaCommand);
#define MMBA_REGISTER_COMMAND(order, setup)                                               \
  static const bool MMBA_REGISTER_COMMAND_CONCAT(mmba_command_registered_, __LINE__) =   \
      ::mmba::app::RegisterCommand(order, setup)
