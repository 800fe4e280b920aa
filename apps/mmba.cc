// The one `mmba` binary; its subcommands live in apps/commands/ and register themselves.
#include "command.h"
#include "mmba/core/huge_pages.h"

int main(int argc, char** argv) {
  mmba::ReexecWithHugePageMalloc(argv);  // once, before anything is allocated or printed
  return mmba::app::RunMain(argc, argv);
}
