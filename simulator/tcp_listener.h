// The listening TCP socket both simulators serve from (the gauge amplifier, the PLC).
#pragma once

#include <string>

#include "core/result.h"

namespace gaugeloop {

struct TcpListener {
  int fd = -1;
  int port = 0;  // the port bound: the one asked for, or the one the system picked for 0
};

// Binds and listens on host:port (IPv4; port 0: any free one), close-on-exec, SO_REUSEADDR.
// `who` names the server in messages ("simulator", "PLC simulator"). Errors: kInvalidInput
// for a host that is not an IPv4 address, kIo when the port cannot be bound or read back.
Result<TcpListener> listen_tcp(const std::string& host, int port, const std::string& who);

}  // namespace gaugeloop
