// Requests no HTTP client library would send, written to a loopback port byte for byte.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstdint>
#include <string>

namespace gaugeloop::testing {

// Sends `bytes` as they are to 127.0.0.1:`port` and returns the answer: its head and a body
// of Content-Length bytes (the service may keep the connection open for the next request).
inline std::string raw_http(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return "";
  const timeval guard{60, 0};  // a service that never answers fails the test instead of hanging it
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &guard, sizeof guard);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string answer;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
      ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size())) {
    char buf[4096];
    for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) {
      answer.append(buf, static_cast<size_t>(n));
      const size_t head_end = answer.find("\r\n\r\n");
      if (head_end == std::string::npos) continue;
      const size_t length_at = answer.find("Content-Length: ");
      const size_t length = length_at < head_end ? std::stoul(answer.substr(length_at + 16)) : 0;
      if (answer.size() >= head_end + 4 + length) break;
    }
  }
  ::close(fd);
  return answer;
}

}  // namespace gaugeloop::testing
