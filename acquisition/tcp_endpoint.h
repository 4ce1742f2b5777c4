// Where a Modbus TCP device is: a host name, an IPv4 or an IPv6 address, and a port.
#pragma once

#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

struct TcpEndpoint {
  std::string host;  // a name ("gauge-amp.local", "localhost"), "192.168.0.20" or "::1"
  int port = 0;
};

// Parses "HOST:PORT", an IPv6 address in brackets: "localhost:1502", "[::1]:1502".
// Errors: kInvalidInput saying what is expected.
Result<TcpEndpoint> parse_tcp_endpoint(std::string_view text);

// "HOST:PORT", with brackets around an IPv6 address, for messages.
std::string format_tcp_endpoint(const std::string& host, int port);

// Resolves `host` as libmodbus's modbus_new_tcp_pi connects to it (getaddrinfo, any
// family, addresses this machine can use), so a bad name is found before any run.
// Errors: kInvalidInput "cannot resolve host 'x': <resolver's reason>; check the <device>'s
// address" for a name that does not exist; kGaugeUnreachable when the resolver could not
// answer now (try again).
Status resolve_tcp_host(const std::string& host, int port, std::string_view device);

}  // namespace gaugeloop
