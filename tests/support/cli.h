// Running the real gaugeloop binary as a user would, and reading what it wrote.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

#include "tests/support/text.h"

namespace gaugeloop::testing {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// The gaugeloop binary of the build tree.
inline std::string gaugeloop_binary() { return std::string(GAUGELOOP_BINARY_DIR) + "/bin/gaugeloop"; }

// A shell command line, stderr with stdout unless `stderr_to` (a shell redirection target,
// such as /dev/null) says otherwise; -1 if it did not exit normally.
inline CommandResult run_shell(const std::string& script, const std::string& stderr_to = "&1") {
  CommandResult r;
  FILE* pipe = ::popen((script + " 2>" + stderr_to).c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) r.output += buf;
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// `gaugeloop ARGS` from the build tree, through the shell; -1 if it did not exit normally.
inline CommandResult run_command(const std::string& args) { return run_shell(gaugeloop_binary() + " " + args); }

// As run_command, stdout alone (stderr discarded): for output a test parses.
inline CommandResult run_command_stdout(const std::string& args) {
  return run_shell(gaugeloop_binary() + " " + args, "/dev/null");
}

}  // namespace gaugeloop::testing
