#include "command.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <vector>

#include "arguments.h"
#include "mmba/core/logging.h"
#include "mmba/core/version.h"

namespace mmba::app {
namespace {

std::vector<std::pair<int, CommandSetup>>& Registry() {
  static std::vector<std::pair<int, CommandSetup>> registry;
  return registry;
}

}  // namespace

void AddCommonOptions(CLI::App* sub, CommonOptions* common) {
  sub->add_flag("-q,--quiet", common->quiet, "Print only errors and the final summary");
  sub->add_flag("-v,--verbose", common->verbose, "Print debugging detail");
}

namespace {

// Throws unless the file `path` can be created or replaced: an existing path must be a regular
// file, the nearest existing ancestor a folder in which an entry can be created (probed by
// creating and removing one: permission bits say nothing for root or for /proc).
void CheckOutputPath(const FileArg& arg) {
  namespace fs = std::filesystem;
  if (arg.path.empty()) return;
  const auto fail = [&](const std::string& why) {
    throw InputError::Message(arg.option, "cannot write '" + arg.path + "': " + why + "; expected a file to write");
  };
  std::error_code ec;
  const fs::path path = fs::absolute(arg.path, ec).lexically_normal();
  if (ec) fail(ec.message());
  const fs::file_status status = fs::status(path, ec);
  if (fs::exists(status)) {
    if (fs::is_directory(status)) fail("it is an existing folder");
    // A device (/dev/null), pipe or socket: the output is written beside it and renamed over
    // it (never half-written), which would replace the device or pipe by a plain file.
    if (!fs::is_regular_file(status)) fail("it is a device, pipe or socket, not a regular file");
  }
  // The nearest existing ancestor.
  fs::path existing = path.parent_path();
  while (!existing.empty() && !fs::exists(existing, ec) && existing != existing.root_path()) {
    existing = existing.parent_path();
  }
  if (!fs::is_directory(existing, ec)) {
    fail("'" + existing.string() + "' is a file, not a folder");
  }
  // A probe entry: a file where the output's folder exists, else a folder (what
  // AtomicFileSet's create_directories will do there).
  const std::string probe = (existing / (".mmba-write-check-" + std::to_string(getpid()))).string();
  if (existing == path.parent_path()) {
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
    if (fd < 0) fail("cannot create a file in '" + existing.string() + "' (" + std::strerror(errno) + ")");
    ::close(fd);
    ::unlink(probe.c_str());
  } else {
    if (::mkdir(probe.c_str(), 0700) != 0) {
      fail("cannot create a folder in '" + existing.string() + "' (" + std::strerror(errno) + ")");
    }
    ::rmdir(probe.c_str());
  }
}

}  // namespace

void CheckOutputFiles(const std::vector<FileArg>& outputs) {
  for (const FileArg& out : outputs) CheckOutputPath(out);
}

std::vector<NamedPath> AsNamedPaths(const std::vector<FileArg>& inputs) {
  std::vector<NamedPath> named;
  for (const FileArg& input : inputs) named.push_back({input.option, input.path});
  return named;
}

void RefuseToOverwriteInputs(const std::vector<FileArg>& outputs, const std::vector<FileArg>& inputs) {
  namespace fs = std::filesystem;
  // Existing files compare by identity (links, "./a" and "a"); an output not written yet
  // compares with the other outputs by its normalised absolute path.
  const auto same = [](const std::string& a, const std::string& b) {
    std::error_code ec_a, ec_b;
    if (fs::exists(a, ec_a) && fs::exists(b, ec_b)) {
      std::error_code ec;
      return fs::equivalent(a, b, ec) && !ec;
    }
    return fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
  };
  for (size_t i = 0; i < outputs.size(); ++i) {
    const FileArg& out = outputs[i];
    if (out.path.empty()) continue;
    for (const FileArg& in : inputs) {
      if (!in.path.empty() && same(out.path, in.path)) {
        throw InputError::Message(out.option, "'" + out.path + "' is the input " + in.option +
                                                  "; mmba never overwrites its inputs, give another file");
      }
    }
    for (size_t j = 0; j < i; ++j) {
      if (!outputs[j].path.empty() && same(out.path, outputs[j].path)) {
        throw InputError::Message(out.option, "'" + out.path + "' is also given as " + outputs[j].option +
                                                  "; give each output its own file");
      }
    }
  }
  CheckOutputFiles(outputs);
}

namespace {

// Every option of `sub` that takes a value refuses one that is an option name: "--output
// --help" is a forgotten value, not a folder named "--help". A value starting with "--", or
// one of the subcommand's short names (-h, -q, -v), is such a name; a negative number ("-2")
// or "x=-1" is a value. Flags take no value and are left alone.
void RefuseOptionNamesAsValues(CLI::App* sub) {
  std::vector<std::string> short_names;
  for (const CLI::Option* option : sub->get_options()) {
    for (const std::string& s : option->get_snames()) short_names.push_back("-" + s);
  }
  const CLI::Validator not_an_option_name(
      [short_names](std::string& value) -> std::string {
        const bool name = value.rfind("--", 0) == 0 ||
                          std::find(short_names.begin(), short_names.end(), value) != short_names.end();
        return name ? "needs a value, found the option name '" + value + "'" : std::string();
      },
      "");
  for (CLI::Option* option : sub->get_options()) {
    if (option->get_type_size_max() > 0) option->check(not_an_option_name);
  }
}

}  // namespace

bool RegisterCommand(int order, CommandSetup setup) {
  Registry().emplace_back(order, std::move(setup));
  return true;
}

int RunMain(int argc, char** argv) {
  CLI::App app{
      "mmba: multi-modal photogrammetric bundle adjustment for survey-grade work.\n"
      "Exit codes: 0 ok, 2 bad input, 3 adjustment/registration failed or did not converge,\n"
      "1 internal error (a bug: please report it with the input)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", VersionLine());
  CommonOptions common;
  auto& registry = Registry();
  std::stable_sort(registry.begin(), registry.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::pair<CLI::App*, std::function<int()>>> commands;
  for (auto& [order, setup] : registry) {
    const size_t before = app.get_subcommands({}).size();
    std::function<int()> run = setup(app, &common);
    const auto subs = app.get_subcommands({});
    if (subs.size() > before) {
      RefuseOptionNamesAsValues(subs.back());
      commands.emplace_back(subs.back(), std::move(run));
    }
  }
  if (const std::string unknown = UnknownArgument(app, argc, argv); !unknown.empty()) {
    std::cerr << "mmba: error: " << unknown << std::endl;
    return kExitInputError;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    // CLI11 returns 0 for --help/--version; any real option error is bad input.
    return code == 0 ? kExitOk : kExitInputError;
  }
  SetVerbosity(common.quiet ? Verbosity::kQuiet
                            : (common.verbose ? Verbosity::kVerbose : Verbosity::kNormal));
  // Whether the allocator runs on huge pages (core/huge_pages.h; mmba.cc re-executes for it).
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  spdlog::debug("memory: GLIBC_TUNABLES={}", tunables != nullptr ? tunables : "(not set)");
  try {
    for (auto& [sub, run] : commands) {
      if (sub->parsed()) return run();
    }
  } catch (const InputError& e) {
    std::cerr << "mmba: error: " << e.what() << std::endl;
    return kExitInputError;
  } catch (const CommandFailed& e) {
    std::cerr << "mmba: failed: " << e.what() << std::endl;
    return kExitNotConverged;
  } catch (const std::exception& e) {
    std::cerr << "mmba: internal error: " << e.what() << std::endl;
    return kExitFailure;
  }
  return kExitFailure;
}

}  // namespace mmba::app
