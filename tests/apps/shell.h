#pragma once

// Runs a shell command for the end-to-end tests of the `mmba` binary and returns its exit code
// and its stdout and stderr together.

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace mmba::test {

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

inline RunResult RunShell(const std::string& command) {
  RunResult run;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

}  // namespace mmba::test
