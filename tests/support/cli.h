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

// `gaugeloop ARGS` from the build tree, through the shell; -1 if it did not exit normally.
inline CommandResult run_command(const std::string& args) {
  const std::string cmd = std::string(GAUGELOOP_BINARY_DIR) + "/bin/gaugeloop " + args + " 2>&1";
  CommandResult r;
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) r.output += buf;
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The whole file, bytes as they are; empty if it cannot be read.
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace gaugeloop::testing
