// The one `mmba` binary; its subcommands live in apps/commands/ and register themselves.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

#include "command.h"
#include "mmba/core/huge_pages.h"

namespace {

// The re-execution for huge-page malloc (core/huge_pages.h) starts the program a second
// time, about 0.08 s more (it loads its ~55 shared libraries again; 0.15–0.2 s when OpenCV's
// image codecs were linked, before src/codecs). It pays only with buffers of tens of MB. The
// commands whose data are exactly the files named on their command line skip it when those
// total less than this; every other command (projects, simulations, scene folders, lists of
// frames) keeps it.
constexpr std::uintmax_t kHugePageMinInputBytes = 16u << 20;

// True for `register-cloud`, and `register-mi` without a `--list` of frames, whose files
// named on the command line (each argument, or the value after '=') total less than
// kHugePageMinInputBytes.
bool SmallNamedInputs(int argc, char** argv) {
  if (argc < 2) return true;  // the help
  const std::string command = argv[1];
  if (command != "register-cloud" && command != "register-mi") return false;
  std::uintmax_t total = 0;
  for (int i = 2; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--list" || arg.rfind("--list=", 0) == 0) return false;
    if (const size_t eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      arg = arg.substr(eq + 1);
    }
    std::error_code ec;
    if (!std::filesystem::is_regular_file(arg, ec)) continue;
    const std::uintmax_t size = std::filesystem::file_size(arg, ec);
    if (!ec) total += size;
  }
  return total < kHugePageMinInputBytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (!SmallNamedInputs(argc, argv)) {
    mmba::ReexecWithHugePageMalloc(argv);  // once, before anything is allocated or printed
  }
  return mmba::app::RunMain(argc, argv);
}
