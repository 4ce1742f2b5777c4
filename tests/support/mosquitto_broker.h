// A real mosquitto broker for the plant tests: `mosquitto -c <conf>` on 127.0.0.1 and a free
// port, with its persistence in a directory of the test's, stopped (SIGTERM, then waited for)
// at the end. It can be stopped and started again on the same port and directory, as a broker
// restart is. No fixed ports, nothing beyond loopback.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/free_port.h"
#include "tests/support/wait_until.h"

namespace gaugeloop::testing {

// Whether something accepts TCP connections on 127.0.0.1:port now.
inline bool accepts_connections(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

class MosquittoBroker {
 public:
  // Starts a broker keeping its state in `dir` (created). Check started(). With
  // `password_file` (made with mosquitto_passwd), only its users may connect; `listener_conf`
  // adds lines to the listener (e.g. TLS: cafile, certfile, keyfile).
  explicit MosquittoBroker(std::filesystem::path dir, std::filesystem::path password_file = {},
                           std::string listener_conf = {})
      : dir_(std::move(dir)), password_file_(std::move(password_file)), listener_conf_(std::move(listener_conf)) {
    std::filesystem::create_directories(dir_);
    for (int attempt = 0; attempt < 5 && !running(); ++attempt) {
      port_ = free_loopback_port();
      start();
    }
  }
  ~MosquittoBroker() {
    stop();
    release_port();
  }
  MosquittoBroker(const MosquittoBroker&) = delete;
  MosquittoBroker& operator=(const MosquittoBroker&) = delete;

  bool started() const { return running(); }
  int port() const { return port_; }
  const std::filesystem::path& dir() const { return dir_; }

  // SIGTERM (mosquitto saves its persistence), then waits for the process. The port stays
  // held until the broker starts again (see hold_port).
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGCONT);  // a paused broker would never act on SIGTERM
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
    hold_port();
  }
  // SIGSTOP / SIGCONT: a broker that hangs, its socket still open; the kernel takes the
  // client's bytes and nothing answers.
  bool pause() { return pid_ > 0 && ::kill(pid_, SIGSTOP) == 0; }
  bool resume() { return pid_ > 0 && ::kill(pid_, SIGCONT) == 0; }
  // SIGKILL: a broker that dies without saving.
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
    hold_port();
  }
  // Again on the same port and directory; true once it accepts connections.
  bool restart() {
    stop();
    // The port was ours a moment ago; another process may take it meanwhile, rarely: retry.
    for (int attempt = 0; attempt < 50 && !running(); ++attempt) start();
    return running();
  }

  static std::filesystem::path binary() {
    for (const char* p : {"/usr/sbin/mosquitto", "/usr/bin/mosquitto", "/usr/local/sbin/mosquitto"}) {
      if (std::filesystem::exists(p)) return p;
    }
    return "mosquitto";
  }

 private:
  bool running() const { return pid_ > 0; }

  // While the broker is down its port stays ours: bound, not listening, so a client is refused
  // as by no broker, and no broker of another test running beside this one (ctest -j) can take
  // the port and answer our client in its place.
  void hold_port() {
    release_port();
    hold_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (hold_fd_ < 0) return;
    const int one = 1;
    ::setsockopt(hold_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port_));
    if (::bind(hold_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) release_port();  // best effort
  }
  void release_port() {
    if (hold_fd_ >= 0) ::close(hold_fd_);
    hold_fd_ = -1;
  }

  void start() {
    release_port();
    const std::filesystem::path conf = dir_ / "mosquitto.conf";
    {
      std::ofstream c(conf);
      c << "listener " << port_ << " 127.0.0.1\n"
        << listener_conf_ << "allow_anonymous " << (password_file_.empty() ? "true" : "false") << "\n"
        << "persistence true\n"
        << "persistence_location " << dir_.string() << "/\n"
        << "log_dest file " << (dir_ / "mosquitto.log").string() << "\n"
        << "log_type all\n"
        // A subscriber that falls behind a backlog sent at once must not lose messages to the
        // broker's per-client queue (1000 by default): the tests count every one.
        << "max_queued_messages 0\n";
      // As root, mosquitto would change to the user `mosquitto`, who cannot write our directory.
      if (::geteuid() == 0) c << "user root\n";
      if (!password_file_.empty()) c << "password_file " << password_file_.string() << "\n";
    }
    const std::string bin = binary().string();
    const std::string conf_path = conf.string();
    const std::string out_path = (dir_ / "mosquitto.out").string();
    pid_ = ::fork();
    if (pid_ == 0) {
      // Its own lines (e.g. "should not be run as root") to a file, not the test's output.
      const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      if (out >= 0) {
        ::dup2(out, STDOUT_FILENO);
        ::dup2(out, STDERR_FILENO);
      }
      ::execl(bin.c_str(), bin.c_str(), "-c", conf_path.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Up to 30 s for it to accept; it failing to bind (port taken) ends the process.
    const bool up = wait_until([this] {
      if (::waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        return true;
      }
      return accepts_connections(port_);
    });
    if (!up && pid_ > 0) kill();
  }

  std::filesystem::path dir_;
  std::filesystem::path password_file_;
  std::string listener_conf_;
  int port_ = 0;
  pid_t pid_ = -1;
  int hold_fd_ = -1;  // the port, bound while the broker is down
};

struct Received {
  std::string topic;
  nlohmann::json payload;
  bool retained = false;
};

// A subscriber of its own (libmosquitto with its network thread), independent of the sender.
// With `persistent`, the broker keeps its QoS 1 messages while it is disconnected (a broker
// restart), as a plant consumer's session does.
class Subscriber {
 public:
  Subscriber(int port, std::string filter, bool persistent = false, std::string id = {}) : filter_(std::move(filter)) {
    mosquitto_lib_init();
    if (id.empty()) id = "test-subscriber-" + std::to_string(++count());
    mosq_ = mosquitto_new(id.c_str(), !persistent, this);
    mosquitto_connect_callback_set(mosq_, [](struct mosquitto* m, void* self, int rc) {
      if (rc == 0) mosquitto_subscribe(m, nullptr, static_cast<Subscriber*>(self)->filter_.c_str(), 1);
    });
    mosquitto_subscribe_callback_set(mosq_, [](struct mosquitto*, void* self, int, int, const int*) {
      auto* s = static_cast<Subscriber*>(self);
      std::lock_guard<std::mutex> lock(s->mutex_);
      ++s->subscribed_;
    });
    mosquitto_message_callback_set(mosq_, [](struct mosquitto*, void* self, const mosquitto_message* m) {
      auto* s = static_cast<Subscriber*>(self);
      const std::string text(static_cast<const char*>(m->payload), static_cast<std::size_t>(m->payloadlen));
      std::lock_guard<std::mutex> lock(s->mutex_);
      s->messages_.push_back({m->topic, nlohmann::json::parse(text, nullptr, false), m->retain});
    });
    mosquitto_reconnect_delay_set(mosq_, 1, 1, false);
    EXPECT_EQ(mosquitto_connect(mosq_, "127.0.0.1", port, 10), MOSQ_ERR_SUCCESS);
    EXPECT_EQ(mosquitto_loop_start(mosq_), MOSQ_ERR_SUCCESS);
    EXPECT_TRUE(wait_until([this] { return subscriptions() > 0; })) << "no SUBACK from the broker";
  }
  ~Subscriber() {
    mosquitto_disconnect(mosq_);
    // Not forced: a cancelled network thread could hold a libmosquitto mutex that destroy then
    // frees (ThreadSanitizer: destroy of a locked mutex). After the DISCONNECT it ends itself.
    mosquitto_loop_stop(mosq_, false);
    mosquitto_destroy(mosq_);
  }

  std::vector<Received> messages() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  int subscriptions() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return subscribed_;
  }
  // The messages on topics ending in `kind`.
  std::vector<Received> of(const std::string& kind) const {
    std::vector<Received> out;
    for (const Received& r : messages()) {
      if (r.topic.size() >= kind.size() && r.topic.compare(r.topic.size() - kind.size(), kind.size(), kind) == 0) {
        out.push_back(r);
      }
    }
    return out;
  }

 private:
  static int& count() {
    static int n = 0;
    return n;
  }
  std::string filter_;
  struct mosquitto* mosq_ = nullptr;
  mutable std::mutex mutex_;
  std::vector<Received> messages_;
  int subscribed_ = 0;
};

}  // namespace gaugeloop::testing
