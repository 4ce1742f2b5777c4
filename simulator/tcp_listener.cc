// The listening TCP socket both simulators serve from, and their clients.
#include "simulator/tcp_listener.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>

namespace gaugeloop {

Result<TcpListener> listen_tcp(const std::string& host, int port, const std::string& who) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
    return make_error(ErrorCode::kInvalidInput, who + " address " + host + " is not an IPv4 address");
  }
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const int yes = 1;
  if (fd >= 0) ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd, 16) != 0) {
    const int err = errno;
    if (fd >= 0) ::close(fd);
    return make_error(ErrorCode::kIo, who + " cannot listen on " + host + ":" + std::to_string(port) + ": " +
                                          std::strerror(err) + "; choose another port or 0 for any free one");
  }
  socklen_t len = sizeof addr;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const int err = errno;
    ::close(fd);
    return make_error(ErrorCode::kIo, who + " cannot read its port back: " + std::strerror(err));
  }
  return TcpListener{fd, ntohs(addr.sin_port)};
}

void ModbusTcpClients::close_all() {
  for (int c : clients_) ::close(c);
  clients_.clear();
}

ModbusTcpClients::Round ModbusTcpClients::serve_round(modbus_t* ctx, int wake_fd, int listen_fd, int timeout_ms,
                                                      const OnRequest& on_request) {
  std::vector<pollfd> fds;
  fds.push_back({wake_fd, POLLIN, 0});
  if (listen_fd >= 0) fds.push_back({listen_fd, POLLIN, 0});
  const size_t first_client = fds.size();
  for (int c : clients_) fds.push_back({c, POLLIN, 0});
  if (::poll(fds.data(), fds.size(), timeout_ms) < 0) return errno == EINTR ? Round::kServed : Round::kFailed;
  if (fds[0].revents != 0) return Round::kWoken;
  if (listen_fd >= 0 && (fds[1].revents & POLLIN)) {
    const int c = ::accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
    if (c >= 0) clients_.push_back(c);
  }
  std::vector<int> closed;
  for (size_t i = first_client; i < fds.size(); ++i) {
    if (fds[i].revents == 0) continue;
    const int fd = fds[i].fd;
    modbus_set_socket(ctx, fd);
    const int rc = modbus_receive(ctx, query_.data());
    if (rc < 0 || (rc > 0 && !on_request(query_.data(), rc))) closed.push_back(fd);  // gone, garbage or dropped
  }
  for (int fd : closed) {
    ::close(fd);
    clients_.erase(std::remove(clients_.begin(), clients_.end(), fd), clients_.end());
  }
  return Round::kServed;
}

}  // namespace gaugeloop
