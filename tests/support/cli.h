// Running the real gaugeloop binary as a user would, and reading what it wrote.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace gaugeloop::testing {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// The gaugeloop binary of the build tree.
inline std::string gaugeloop_binary() { return std::string(GAUGELOOP_BINARY_DIR) + "/bin/gaugeloop"; }

// A shell command line, stderr with stdout; -1 if it did not exit normally.
inline CommandResult run_shell(const std::string& script) {
  CommandResult r;
  FILE* pipe = ::popen((script + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) r.output += buf;
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// `gaugeloop ARGS` from the build tree, through the shell; -1 if it did not exit normally.
inline CommandResult run_command(const std::string& args) { return run_shell(gaugeloop_binary() + " " + args); }

// The whole file, bytes as they are; empty if it cannot be read.
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace gaugeloop::testing
