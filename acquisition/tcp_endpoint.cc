// Parsing, printing and resolving TCP endpoints of the gauge and the PLC.
#include "acquisition/tcp_endpoint.h"

#include <netdb.h>
#include <sys/socket.h>

#include <charconv>

namespace gaugeloop {

Result<TcpEndpoint> parse_tcp_endpoint(std::string_view text) {
  const auto bad = [&] {
    return make_error(ErrorCode::kInvalidInput, "`" + std::string(text) +
                                                    "`: expected HOST:PORT, e.g. 192.168.0.20:502, "
                                                    "gauge-amp.local:502 or [fd00::20]:502");
  };
  const size_t colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0) return bad();
  std::string_view host = text.substr(0, colon);
  if (host.front() == '[') {
    if (host.size() < 3 || host.back() != ']') return bad();
    host = host.substr(1, host.size() - 2);
  } else if (host.find(':') != std::string_view::npos) {
    return bad();  // an IPv6 address needs its brackets, or the port is ambiguous
  }
  const std::string_view port_text = text.substr(colon + 1);
  int port = 0;
  const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc() || end != port_text.data() + port_text.size() || port <= 0 || port > 65535) return bad();
  return TcpEndpoint{std::string(host), port};
}

std::string format_tcp_endpoint(const std::string& host, int port) {
  const bool ipv6 = host.find(':') != std::string::npos;
  return (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

Status resolve_tcp_host(const std::string& host, int port, std::string_view device) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_ADDRCONFIG;  // as libmodbus's modbus_new_tcp_pi connects
  addrinfo* found = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found);
  if (found != nullptr) ::freeaddrinfo(found);
  if (rc == 0) return {};
  const std::string why = rc == EAI_SYSTEM ? std::string("system error") : ::gai_strerror(rc);
  return make_error(rc == EAI_AGAIN ? ErrorCode::kGaugeUnreachable : ErrorCode::kInvalidInput,
                    "cannot resolve host '" + host + "': " + why + "; check the " + std::string(device) + "'s address");
}

}  // namespace gaugeloop
