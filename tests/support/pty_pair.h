// A pseudo-terminal pair made by socat, for Modbus RTU tests and benchmarks.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <regex>
#include <string>
#include <vector>

namespace gaugeloop::testing {

// `socat -d -d pty,raw,echo=0 pty,raw,echo=0`: a connected pair of pseudo-terminals. socat
// reports each end on stderr ("PTY is /dev/pts/N") before it starts moving data, so reading
// those two lines is the synchronisation.
class PtyPair {
 public:
  PtyPair() {
    int err[2];
    if (::pipe(err) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(err[1], 2);
      ::close(err[0]);
      ::execlp("socat", "socat", "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(err[1]);
    FILE* f = ::fdopen(err[0], "r");
    const std::regex pty(R"(PTY is (\S+))");
    char line[256];
    while (f != nullptr && ends_.size() < 2 && std::fgets(line, sizeof line, f) != nullptr) {
      std::cmatch m;
      if (std::regex_search(line, m, pty)) ends_.push_back(m[1]);
    }
    stderr_ = f;  // kept open: socat must not get SIGPIPE on its later messages
  }
  ~PtyPair() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
    if (stderr_ != nullptr) std::fclose(stderr_);
  }
  bool ok() const { return ends_.size() == 2; }
  const std::string& gauge_end() const { return ends_[0]; }
  const std::string& simulator_end() const { return ends_[1]; }

 private:
  pid_t pid_ = -1;
  FILE* stderr_ = nullptr;
  std::vector<std::string> ends_;
};

}  // namespace gaugeloop::testing
