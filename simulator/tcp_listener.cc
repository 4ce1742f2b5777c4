// The listening TCP socket both simulators serve from, and their clients.
#include "simulator/tcp_listener.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>

namespace gaugeloop {

Result<TcpListener> listen_tcp(const std::string& host, int port, const std::string& who) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICHOST | AI_NUMERICSERV | AI_PASSIVE;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found) != 0 || found == nullptr) {
    if (found != nullptr) ::freeaddrinfo(found);
    return make_error(ErrorCode::kInvalidInput,
                      who + " address " + host + " is not an IPv4 or IPv6 address (e.g. 127.0.0.1 or ::1)");
  }
  const int fd = ::socket(found->ai_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const int yes = 1;
  if (fd >= 0) ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  const bool bound = fd >= 0 && ::bind(fd, found->ai_addr, found->ai_addrlen) == 0 && ::listen(fd, 16) == 0;
  const int bind_err = errno;
  ::freeaddrinfo(found);
  if (!bound) {
    if (fd >= 0) ::close(fd);
    return make_error(ErrorCode::kIo, who + " cannot listen on " + host + ":" + std::to_string(port) + ": " +
                                          std::strerror(bind_err) + "; choose another port or 0 for any free one");
  }
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const int err = errno;
    ::close(fd);
    return make_error(ErrorCode::kIo, who + " cannot read its port back: " + std::strerror(err));
  }
  const std::uint16_t bound_port = addr.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port
                                                              : reinterpret_cast<sockaddr_in*>(&addr)->sin_port;
  return TcpListener{fd, ntohs(bound_port)};
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

Status open_holding_register_server(const std::string& host, int port, int base_address, int words,
                                    const std::string& who, modbus_t*& ctx, modbus_mapping_t*& mapping, int& wake_fd) {
  if (base_address < 0 || base_address > 65536 - words) {
    return make_error(ErrorCode::kInvalidInput, who + " base_address " + std::to_string(base_address) +
                                                    " leaves no room for the " + std::to_string(words) +
                                                    "-word block; use 0 to " + std::to_string(65536 - words));
  }
  // Framing only (the sockets are the listener's); the protocol-independent backend: IPv4 or IPv6.
  ctx = modbus_new_tcp_pi(host.c_str(), std::to_string(port).c_str());
  if (ctx == nullptr) {
    return make_error(ErrorCode::kInvalidInput, who + " address " + host + " is not usable: " + modbus_strerror(errno));
  }
  mapping = modbus_mapping_new_start_address(0, 0, 0, 0, static_cast<unsigned int>(base_address),
                                             static_cast<unsigned int>(words), 0, 0);
  if (mapping == nullptr) return make_error(ErrorCode::kInternal, "cannot allocate the " + who + "'s registers");
  wake_fd = ::eventfd(0, EFD_CLOEXEC);
  if (wake_fd < 0) return make_error(ErrorCode::kIo, std::string("eventfd: ") + std::strerror(errno));
  return {};
}

void shut_down_modbus_server(std::thread& thread, int& wake_fd, int& listen_fd, modbus_t*& ctx,
                             modbus_mapping_t*& mapping, bool serial, const std::function<void()>& before_wake) {
  if (thread.joinable()) {
    if (before_wake) before_wake();
    const std::uint64_t one = 1;
    [[maybe_unused]] auto w = ::write(wake_fd, &one, sizeof one);
    thread.join();
  }
  for (int* fd : {&listen_fd, &wake_fd}) {
    if (*fd >= 0) {
      ::close(*fd);
      *fd = -1;
    }
  }
  if (ctx != nullptr) {
    if (serial) {
      modbus_close(ctx);  // the serial line is libmodbus's own
    } else {
      modbus_set_socket(ctx, -1);  // the sockets are closed already; keep modbus_free from closing one again
    }
    modbus_free(ctx);
    ctx = nullptr;
  }
  if (mapping != nullptr) {
    modbus_mapping_free(mapping);
    mapping = nullptr;
  }
}

}  // namespace gaugeloop
