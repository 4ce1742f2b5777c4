// Requests no HTTP client library would send, written to a loopback port byte for byte.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace gaugeloop::testing {

// The bytes a request is made of, piece by piece: each call gives the next piece (valid until
// the next call), empty once all were given. Lets a test send more than it could hold.
using ByteSource = std::function<std::string_view()>;

struct RawExchange {
  std::string answer;     // the head and a body of Content-Length bytes, or what came before the end
  bool all_sent = false;  // false: the service closed the connection before taking every byte
};

// Sends what `next` gives to 127.0.0.1:`port` and reads the answer while sending, until it is
// whole (the service may keep the connection open for the next request) or the service ends
// the connection; with `until_closed`, sends and reads on until the service ends it. A service
// that answers before it has read all of the request and closes the connection (EPIPE or
// ECONNRESET on send) ends the sending, not the test.
inline RawExchange raw_exchange(int port, const ByteSource& next, bool until_closed = false) {
  RawExchange out;
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return out;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return out;
  }
  std::string& answer = out.answer;
  const auto whole = [&answer] {
    const std::size_t head_end = answer.find("\r\n\r\n");
    if (head_end == std::string::npos) return false;
    const std::size_t length_at = answer.find("Content-Length: ");
    const std::size_t length = length_at < head_end ? std::stoul(answer.substr(length_at + 16)) : 0;
    return answer.size() >= head_end + 4 + length;
  };
  std::string_view piece = next();
  bool sending = !piece.empty();
  out.all_sent = !sending;
  for (;;) {
    pollfd p{fd, static_cast<short>(POLLIN | (sending ? POLLOUT : 0)), 0};
    // A guard, not a clock: a service that never answers fails the test instead of hanging it.
    if (::poll(&p, 1, 60 * 1000) <= 0) break;
    if ((p.revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
      char buf[4096];
      const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        answer.append(buf, static_cast<std::size_t>(n));
        if (!until_closed && whole()) break;
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EINTR)) break;  // closed, or reset after the answer
    }
    if (sending && (p.revents & POLLOUT) != 0) {
      const ssize_t n = ::send(fd, piece.data(), piece.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0 && errno != EAGAIN && errno != EINTR) sending = false;  // closed by the service: read on
      if (n > 0) piece.remove_prefix(static_cast<std::size_t>(n));
      if (sending && piece.empty()) piece = next();
      if (sending && piece.empty()) {
        sending = false;
        out.all_sent = true;
      }
    }
  }
  ::close(fd);
  return out;
}

// raw_exchange of `bytes` as they are: the answer. For requests no HTTP client library would
// send.
inline std::string raw_http(int port, const std::string& bytes) {
  bool given = false;
  return raw_exchange(port,
                      [&]() -> std::string_view {
                        if (given) return {};
                        given = true;
                        return bytes;
                      })
      .answer;
}

}  // namespace gaugeloop::testing
