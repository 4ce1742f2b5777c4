// The HTTP API's front door: one poll loop over every connection.
#include "service/http_front.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <list>
#include <map>
#include <string_view>
#include <thread>
#include <vector>

#include "core/guarded_thread.h"

namespace gaugeloop {
// Named, not anonymous: HttpFront::Impl holds its types, and the unity build shares the file
// with others.
namespace http_front_detail {

using Clock = std::chrono::steady_clock;

constexpr std::size_t kReadChunk = 16 * 1024;
// Bytes waiting for the server before the front stops reading the client (a body), and bytes
// of an answer the front holds for a slow client before it stops reading the server.
constexpr std::size_t kToServerBuffer = 256 * 1024;
constexpr std::size_t kToClientBuffer = 64 * 1024 * 1024;
// After its answer, a connection is read and dropped for a moment before it is closed, so the
// client sees the answer and not a reset for the body it was still sending.
constexpr std::chrono::milliseconds kLinger{2000};
constexpr std::size_t kLingerBytes = 1024 * 1024;

void set_nonblocking(int fd) { ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK); }

// An answer of the front's own: a JSON error as the API's (docs/http_api.md, "Errors"), and
// the connection closed after it. `message` holds no quote or backslash.
std::string own_answer(int status, const char* reason, const std::string& message) {
  const std::string body = "{\n  \"error\": \"" + message + "\"\n}\n";
  return "HTTP/1.1 " + std::to_string(status) + " " + reason +
         "\r\nContent-Type: application/json\r\nConnection: close\r\nContent-Length: " + std::to_string(body.size()) +
         "\r\n\r\n" + body;
}

std::string duration_text(std::chrono::milliseconds d) {
  return d.count() % 1000 == 0 ? std::to_string(d.count() / 1000) + " s" : std::to_string(d.count()) + " ms";
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Where a request's body ends, found as its bytes pass: a Content-Length, the last chunk of a
// chunked body and its trailer, none (no body), or not known (the server decides; the body
// deadline ends it).
class BodyEnd {
 public:
  enum class Kind { kNone, kLength, kChunked, kUnknown };

  void start(Kind kind, std::uint64_t length = 0) {
    kind_ = kind;
    remaining_ = length;
    done_ = kind == Kind::kNone || (kind == Kind::kLength && length == 0);
  }
  bool done() const { return done_; }

  void feed(std::string_view bytes) {
    while (!bytes.empty() && !done_) {
      switch (kind_) {
        case Kind::kNone:
          done_ = true;
          return;
        case Kind::kUnknown:
          return;
        case Kind::kLength: {
          const std::uint64_t n = std::min<std::uint64_t>(remaining_, bytes.size());
          remaining_ -= n;
          bytes.remove_prefix(static_cast<std::size_t>(n));
          done_ = remaining_ == 0;
          break;
        }
        case Kind::kChunked:
          bytes = feed_chunked(bytes);
          break;
      }
    }
  }

 private:
  enum class Chunk { kSize, kData, kDataEnd, kTrailer };

  // One step of the chunked framing; the bytes left.
  std::string_view feed_chunked(std::string_view bytes) {
    if (chunk_ == Chunk::kData) {
      const std::uint64_t n = std::min<std::uint64_t>(remaining_, bytes.size());
      remaining_ -= n;
      if (remaining_ == 0) chunk_ = Chunk::kDataEnd;
      return bytes.substr(static_cast<std::size_t>(n));
    }
    const std::size_t nl = bytes.find('\n');
    line_.append(bytes.substr(0, nl));
    if (line_.size() > 8 * 1024) {
      kind_ = Kind::kUnknown;  // not chunked as it says: the server refuses it
      return {};
    }
    if (nl == std::string_view::npos) return {};
    const std::string_view line = trim(line_);
    if (chunk_ == Chunk::kSize) {
      const std::uint64_t size = std::strtoull(std::string(line.substr(0, line.find(';'))).c_str(), nullptr, 16);
      chunk_ = size == 0 ? Chunk::kTrailer : Chunk::kData;
      remaining_ = size;
    } else if (chunk_ == Chunk::kDataEnd) {
      chunk_ = Chunk::kSize;
    } else if (line.empty()) {
      done_ = true;  // the trailer's end
    }
    line_.clear();
    return bytes.substr(nl + 1);
  }

  Kind kind_ = Kind::kNone;
  std::uint64_t remaining_ = 0;
  bool done_ = true;
  Chunk chunk_ = Chunk::kSize;
  std::string line_;
};

struct Connection {
  enum class Phase { kHead, kConnecting, kRelay, kAnswering, kLingering };
  int client = -1;
  int server = -1;
  std::string address;
  Phase phase = Phase::kHead;
  std::string head;  // what came while the head was read
  std::string to_server;
  std::size_t to_server_sent = 0;
  std::string to_client;
  std::size_t to_client_sent = 0;
  BodyEnd body;
  bool server_done = false;  // the server closed: its answer is whole
  Clock::time_point deadline;
  Clock::time_point last_progress;
  std::size_t lingered = 0;
  bool closed = false;
};

// The head of `c` so far against the limits: empty when it may go on, else the answer.
std::string check_head(const std::string& head, const HttpFrontLimits& limits) {
  std::size_t start = 0;
  bool first = true;
  for (;;) {
    const std::size_t nl = head.find('\n', start);
    const std::size_t length = (nl == std::string::npos ? head.size() : nl) - start;
    if (length > limits.max_line_bytes) {
      const std::string kb = std::to_string(limits.max_line_bytes / 1024);
      return first ? own_answer(414, "URI Too Long",
                                "the request line is longer than " + kb + " KiB; the API's paths and queries are short")
                   : own_answer(431, "Request Header Fields Too Large", "a header line is longer than " + kb + " KiB");
    }
    if (nl == std::string::npos) break;
    first = false;
    start = nl + 1;
  }
  if (head.size() > limits.max_head_bytes) {
    return own_answer(431, "Request Header Fields Too Large",
                      "the request's head is larger than " + std::to_string(limits.max_head_bytes / 1024) + " KiB");
  }
  return {};
}

// The head as the server gets it: the client's lines but Connection, Keep-Alive,
// Proxy-Connection and X-Forwarded-For, then `Connection: close` and the client's address;
// and where the body ends.
std::string head_for_server(std::string_view head, const std::string& address, BodyEnd& body) {
  std::string out;
  bool first = true;
  bool chunked = false;
  bool has_length = false;
  std::uint64_t length = 0;
  while (!head.empty()) {
    const std::size_t nl = head.find('\n');
    const std::string_view line = head.substr(0, nl == std::string_view::npos ? head.size() : nl + 1);
    head.remove_prefix(line.size());
    const std::string_view bare = trim(line.substr(0, line.find('\n')));
    if (bare.empty()) break;
    if (first) {
      first = false;
      out.append(bare).append("\r\n");
      continue;
    }
    const std::size_t colon = bare.find(':');
    const std::string name = lower(trim(bare.substr(0, colon)));
    const std::string_view value = colon == std::string_view::npos ? std::string_view() : trim(bare.substr(colon + 1));
    if (name == "connection" || name == "keep-alive" || name == "proxy-connection" || name == "x-forwarded-for") {
      continue;
    }
    if (name == "transfer-encoding") chunked = lower(value).find("chunked") != std::string::npos;
    if (name == "content-length") {
      has_length = true;
      length = std::strtoull(std::string(value).c_str(), nullptr, 10);
    }
    out.append(bare).append("\r\n");
  }
  out += "Connection: close\r\nX-Forwarded-For: " + address + "\r\n\r\n";
  if (chunked && has_length) {
    body.start(BodyEnd::Kind::kUnknown);  // the server refuses it
  } else if (chunked) {
    body.start(BodyEnd::Kind::kChunked);
  } else if (has_length) {
    body.start(BodyEnd::Kind::kLength, length);
  } else {
    body.start(BodyEnd::Kind::kNone);
  }
  return out;
}

// The end of a head in `bytes`: just past its empty line, or npos.
std::size_t head_end(const std::string& bytes) {
  const std::size_t crlf = bytes.find("\r\n\r\n");
  const std::size_t lf = bytes.find("\n\n");
  if (crlf == std::string::npos && lf == std::string::npos) return std::string::npos;
  if (lf == std::string::npos || (crlf != std::string::npos && crlf < lf)) return crlf + 4;
  return lf + 2;
}

}  // namespace http_front_detail

struct HttpFront::Impl {
  using Clock = http_front_detail::Clock;
  using Connection = http_front_detail::Connection;
  using BodyEnd = http_front_detail::BodyEnd;
  HttpFrontLimits limits;
  int listener = -1;
  int wake = -1;
  int port = 0;
  int backend_port = 0;
  std::thread thread;
  std::atomic<bool> stopping{false};
  std::atomic<bool> running{false};
  std::list<Connection> connections;
  std::map<std::string, int> per_address;
  Clock::time_point accept_paused_until{};

  ~Impl() { close_all(); }

  // After the thread ended: nothing listens, every connection is closed.
  void close_all() {
    for (Connection& c : connections) close_connection(c);
    connections.clear();
    if (listener >= 0) ::close(listener);
    if (wake >= 0) ::close(wake);
    listener = wake = -1;
  }

  void close_connection(Connection& c) {
    if (c.closed) return;
    c.closed = true;
    if (c.client >= 0) ::close(c.client);
    if (c.server >= 0) ::close(c.server);
    c.client = c.server = -1;
    if (auto it = per_address.find(c.address); it != per_address.end() && --it->second <= 0) per_address.erase(it);
  }

  // Our own answer, then the lingering close.
  void answer(Connection& c, std::string text) {
    if (c.server >= 0) {
      ::close(c.server);
      c.server = -1;
    }
    c.to_client = std::move(text);
    c.to_client_sent = 0;
    c.phase = Connection::Phase::kAnswering;
    c.deadline = Clock::now() + limits.body_timeout;
  }

  void accept_all() {
    for (;;) {
      sockaddr_storage from{};
      socklen_t size = sizeof from;
      const int fd = ::accept4(listener, reinterpret_cast<sockaddr*>(&from), &size, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        // Out of file descriptors or memory: the pending connection stays in the backlog, and
        // the listener is left alone for a moment instead of waking the loop at once again.
        if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
          accept_paused_until = Clock::now() + std::chrono::milliseconds(100);
        }
        return;
      }
      char host[NI_MAXHOST] = "?";
      ::getnameinfo(reinterpret_cast<sockaddr*>(&from), size, host, sizeof host, nullptr, 0, NI_NUMERICHOST);
      const std::string address = host;
      const int from_address = per_address.count(address) ? per_address[address] : 0;
      if (static_cast<int>(connections.size()) >= limits.max_total || from_address >= limits.max_per_address) {
        const bool one = from_address >= limits.max_per_address;
        const std::string text = http_front_detail::own_answer(
            503, "Service Unavailable",
            one ? "too many connections from " + address + " (" + std::to_string(limits.max_per_address) +
                      "); close some and try again"
                : "too many connections (" + std::to_string(limits.max_total) + "); try again in a moment");
        (void)::send(fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
        ::close(fd);
        continue;
      }
      Connection& c = connections.emplace_back();
      c.client = fd;
      c.address = address;
      ++per_address[address];
      c.deadline = Clock::now() + limits.head_timeout;
      c.last_progress = Clock::now();
    }
  }

  void start_server(Connection& c, std::size_t end) {
    c.to_server = http_front_detail::head_for_server(std::string_view(c.head).substr(0, end), c.address, c.body);
    const std::string_view rest = std::string_view(c.head).substr(end);
    c.body.feed(rest);
    c.to_server.append(rest);
    c.head.clear();
    c.head.shrink_to_fit();
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<std::uint16_t>(backend_port));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd < 0 || (::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0 && errno != EINPROGRESS)) {
      if (fd >= 0) ::close(fd);
      answer(c, http_front_detail::own_answer(502, "Bad Gateway",
                                              "the API's server does not take the request; see the service's log"));
      return;
    }
    c.server = fd;
    c.phase = Connection::Phase::kConnecting;
    c.deadline = Clock::now() + limits.body_timeout;
  }

  // Reads what the client sent while its head is read.
  void read_head(Connection& c) {
    char buf[http_front_detail::kReadChunk];
    const ssize_t n = ::recv(c.client, buf, sizeof buf, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return close_connection(c);
    if (n < 0) return;
    c.head.append(buf, static_cast<std::size_t>(n));
    const std::size_t end = http_front_detail::head_end(c.head);
    const std::string refused =
        http_front_detail::check_head(end == std::string::npos ? c.head : c.head.substr(0, end), limits);
    if (!refused.empty()) return answer(c, refused);
    if (end != std::string::npos) start_server(c, end);
  }

  void relay(Connection& c, short client_events, short server_events) {
    char buf[http_front_detail::kReadChunk];
    const Clock::time_point now = Clock::now();
    if (c.phase == Connection::Phase::kConnecting && (server_events & (POLLOUT | POLLERR | POLLHUP)) != 0) {
      int error = 0;
      socklen_t size = sizeof error;
      ::getsockopt(c.server, SOL_SOCKET, SO_ERROR, &error, &size);
      if (error != 0) {
        return answer(c,
                      http_front_detail::own_answer(502, "Bad Gateway", "the API's server does not take the request"));
      }
      c.phase = Connection::Phase::kRelay;
    }
    if (c.phase != Connection::Phase::kRelay) return;
    if ((client_events & (POLLIN | POLLHUP | POLLERR)) != 0 && !c.body.done()) {
      const ssize_t n = ::recv(c.client, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return close_connection(c);
      if (n > 0) {
        c.body.feed(std::string_view(buf, static_cast<std::size_t>(n)));
        c.to_server.append(buf, static_cast<std::size_t>(n));
        c.last_progress = now;
      }
    }
    if ((server_events & POLLOUT) != 0 && c.to_server_sent < c.to_server.size()) {
      const ssize_t n =
          ::send(c.server, c.to_server.data() + c.to_server_sent, c.to_server.size() - c.to_server_sent, MSG_NOSIGNAL);
      if (n > 0) {
        c.to_server_sent += static_cast<std::size_t>(n);
        if (c.to_server_sent == c.to_server.size()) {
          c.to_server.clear();
          c.to_server_sent = 0;
        }
      }
      // A server that stopped reading (it answered before the body): its answer still comes.
    }
    if ((server_events & (POLLIN | POLLHUP | POLLERR)) != 0 && !c.server_done) {
      const ssize_t n = ::recv(c.server, buf, sizeof buf, 0);
      if (n > 0) {
        c.to_client.append(buf, static_cast<std::size_t>(n));
        c.last_progress = now;
      } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
        c.server_done = true;
        ::close(c.server);
        c.server = -1;
      }
    }
    write_client(c, client_events);
    if (c.server_done && c.to_client_sent == c.to_client.size()) linger(c);
  }

  void write_client(Connection& c, short client_events) {
    if ((client_events & POLLOUT) == 0 || c.to_client_sent >= c.to_client.size()) return;
    const ssize_t n =
        ::send(c.client, c.to_client.data() + c.to_client_sent, c.to_client.size() - c.to_client_sent, MSG_NOSIGNAL);
    if (n < 0 && errno != EAGAIN && errno != EINTR) return close_connection(c);
    if (n > 0) {
      c.to_client_sent += static_cast<std::size_t>(n);
      c.last_progress = Clock::now();
      if (c.to_client_sent == c.to_client.size()) {
        c.to_client.clear();
        c.to_client_sent = 0;
      }
    }
  }

  void linger(Connection& c) {
    ::shutdown(c.client, SHUT_WR);
    c.phase = Connection::Phase::kLingering;
    c.deadline = Clock::now() + http_front_detail::kLinger;
  }

  void drain(Connection& c) {
    char buf[http_front_detail::kReadChunk];
    const ssize_t n = ::recv(c.client, buf, sizeof buf, 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return close_connection(c);
    if (n > 0) c.lingered += static_cast<std::size_t>(n);
    if (c.lingered > http_front_detail::kLingerBytes) close_connection(c);
  }

  void on_deadlines() {
    const Clock::time_point now = Clock::now();
    for (Connection& c : connections) {
      if (c.closed) continue;
      switch (c.phase) {
        case Connection::Phase::kHead:
          if (now >= c.deadline) {
            answer(c, http_front_detail::own_answer(408, "Request Timeout",
                                                    "the request's head did not come whole within " +
                                                        http_front_detail::duration_text(limits.head_timeout)));
          }
          break;
        case Connection::Phase::kConnecting:
        case Connection::Phase::kRelay:
          if ((!c.body.done() && now >= c.deadline) || now - c.last_progress >= limits.idle_timeout) {
            close_connection(c);
          }
          break;
        case Connection::Phase::kAnswering:
        case Connection::Phase::kLingering:
          if (now >= c.deadline) close_connection(c);
          break;
      }
    }
  }

  // When `c` must be looked at again without an event: its deadline while it applies, else when
  // it would have been idle too long.
  Clock::time_point next_deadline(const Connection& c) const {
    const bool relaying = c.phase == Connection::Phase::kConnecting || c.phase == Connection::Phase::kRelay;
    if (relaying && c.body.done()) return c.last_progress + limits.idle_timeout;
    if (relaying) return std::min(c.deadline, c.last_progress + limits.idle_timeout);
    return c.deadline;
  }

  int poll_timeout_ms() const {
    Clock::time_point next = Clock::now() + std::chrono::seconds(1);
    for (const Connection& c : connections) next = std::min(next, next_deadline(c));
    // A listener at rest listens again when its rest ends, not at the next second's tick.
    if (accept_paused_until > Clock::now()) next = std::min(next, accept_paused_until);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now()).count();
    return static_cast<int>(std::clamp<long long>(ms + 1, 1, 1000));
  }

  void loop() {
    std::vector<pollfd> fds;
    std::vector<Connection*> of;
    while (!stopping) {
      fds.clear();
      of.clear();
      fds.push_back({wake, POLLIN, 0});
      fds.push_back({listener, static_cast<short>(Clock::now() >= accept_paused_until ? POLLIN : 0), 0});
      for (Connection& c : connections) {
        short client = 0;
        short server = 0;
        switch (c.phase) {
          case Connection::Phase::kHead:
          case Connection::Phase::kLingering:
            client = POLLIN;
            break;
          case Connection::Phase::kAnswering:
            client = POLLOUT;
            break;
          case Connection::Phase::kConnecting:
            server = POLLOUT;
            break;
          case Connection::Phase::kRelay:
            if (!c.body.done() && c.to_server.size() - c.to_server_sent < http_front_detail::kToServerBuffer)
              client |= POLLIN;
            if (c.to_client_sent < c.to_client.size()) client |= POLLOUT;
            if (c.to_server_sent < c.to_server.size()) server |= POLLOUT;
            if (!c.server_done && c.to_client.size() - c.to_client_sent < http_front_detail::kToClientBuffer)
              server |= POLLIN;
            break;
        }
        fds.push_back({c.client, client, 0});
        fds.push_back({c.server, server, 0});  // -1: ignored by poll
        of.push_back(&c);
      }
      const int ready = ::poll(fds.data(), fds.size(), poll_timeout_ms());
      if (ready < 0 && errno != EINTR) {
        spdlog::error("http front: poll failed: {}", std::strerror(errno));
        return;
      }
      if (stopping) return;
      if ((fds[1].revents & POLLIN) != 0) accept_all();
      for (std::size_t i = 0; i < of.size(); ++i) {
        Connection& c = *of[i];
        const short client = fds[2 + 2 * i].revents;
        const short server = fds[3 + 2 * i].revents;
        if (c.closed || (client == 0 && server == 0)) continue;
        switch (c.phase) {
          case Connection::Phase::kHead:
            read_head(c);
            break;
          case Connection::Phase::kConnecting:
          case Connection::Phase::kRelay:
            relay(c, client, server);
            break;
          case Connection::Phase::kAnswering:
            write_client(c, client);
            if (!c.closed && c.to_client_sent == 0 && c.to_client.empty()) linger(c);
            break;
          case Connection::Phase::kLingering:
            drain(c);
            break;
        }
      }
      on_deadlines();
      connections.remove_if([](const Connection& c) { return c.closed; });
    }
  }
};

Result<std::unique_ptr<HttpFront>> HttpFront::start(const std::string& host, int port, int backend_port,
                                                    HttpFrontLimits limits) {
  auto impl = std::make_unique<Impl>();
  impl->limits = limits;
  impl->backend_port = backend_port;
  auto cannot = [&](const std::string& why) {
    return make_error(ErrorCode::kIo, "cannot serve HTTP on " + host + ":" + std::to_string(port) + ": " + why +
                                          "; change [http] host or port");
  };
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0 || found == nullptr) {
    return cannot("the host is not an address of this machine");
  }
  std::string why = "the port is in use or the host is not an address of this machine";
  for (addrinfo* a = found; a != nullptr && impl->listener < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int yes = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, 512) == 0) {
      impl->listener = fd;
    } else {
      why = std::strerror(errno);
      ::close(fd);
    }
  }
  ::freeaddrinfo(found);
  if (impl->listener < 0) return cannot(why);
  sockaddr_storage bound{};
  socklen_t size = sizeof bound;
  ::getsockname(impl->listener, reinterpret_cast<sockaddr*>(&bound), &size);
  impl->port = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                                 : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  impl->wake = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (impl->wake < 0) return cannot(std::strerror(errno));
  Impl& s = *impl;
  s.running = true;
  s.thread = start_guarded_thread(
      "HTTP front",
      [&s] {
        s.loop();
        s.running = false;
      },
      [&s](std::string_view name, std::string_view what) {
        spdlog::error("the {} thread was ended by an exception: {}; the HTTP API no longer answers", name, what);
        s.running = false;
      });
  return std::unique_ptr<HttpFront>(new HttpFront(std::move(impl)));
}

HttpFront::HttpFront(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HttpFront::~HttpFront() { stop(); }

int HttpFront::port() const { return impl_->port; }

bool HttpFront::alive() const { return impl_->running; }

void HttpFront::stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  impl_->stopping = true;
  const std::uint64_t one = 1;
  (void)::write(impl_->wake, &one, sizeof one);
  impl_->thread.join();
  impl_->close_all();
}

}  // namespace gaugeloop
