// The one `mmba` binary; its subcommands live in apps/commands/ and register themselves.
#include "command.h"

int main(int argc, char** argv) { return mmba::app::RunMain(argc, argv); }
