// `gaugeloop serve --config F` as a child process of a test, with the HTTP port it printed.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace gaugeloop::testing {

// stdout read line by line, stderr to a file; killed (SIGKILL) at the end unless waited for.
// `env`: NAME=VALUE entries the child sees before (so instead of) this process's environment.
class ServiceProcess {
 public:
  ServiceProcess(const std::filesystem::path& config, const std::filesystem::path& log,
                 std::vector<std::string> env = {}) {
    // Everything the child needs, made before the fork.
    const std::string bin = std::string(GAUGELOOP_BINARY_DIR) + "/bin/gaugeloop";
    const std::string config_path = config.string();
    const std::string log_path = log.string();
    std::vector<char*> envp;
    for (std::string& e : env) envp.push_back(e.data());
    for (char** e = environ; *e != nullptr; ++e) envp.push_back(*e);
    envp.push_back(nullptr);
    int out[2];
    if (::pipe(out) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      // Only async-signal-safe calls between fork and exec: the parent has other threads.
      ::dup2(out[1], STDOUT_FILENO);
      const int err = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (err >= 0) ::dup2(err, STDERR_FILENO);
      ::close(out[0]);
      ::execle(bin.c_str(), bin.c_str(), "serve", "--config", config_path.c_str(), static_cast<char*>(nullptr),
               envp.data());
      ::_exit(127);
    }
    ::close(out[1]);
    stdout_ = ::fdopen(out[0], "r");
  }
  ~ServiceProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (stdout_ != nullptr) std::fclose(stdout_);
  }
  ServiceProcess(const ServiceProcess&) = delete;
  ServiceProcess& operator=(const ServiceProcess&) = delete;

  // The HTTP port from the "listening on http://HOST:PORT" (or https) line; 0 if the process ended first.
  int port() {
    char line[512];
    while (stdout_ != nullptr && std::fgets(line, sizeof line, stdout_) != nullptr) {
      int port = 0;
      if (std::sscanf(line, "listening on http://127.0.0.1:%d", &port) == 1 ||
          std::sscanf(line, "listening on https://127.0.0.1:%d", &port) == 1) {
        return port;
      }
    }
    return 0;
  }
  pid_t pid() const { return pid_; }
  void signal(int sig) const { ::kill(pid_, sig); }
  // Exit status, or -1 if killed by a signal.
  int wait() {
    int status = 0;
    ::waitpid(pid_, &status, 0);
    exited_ = true;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  std::FILE* stdout_ = nullptr;
  bool exited_ = false;
};

}  // namespace gaugeloop::testing
