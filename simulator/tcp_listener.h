// The listening TCP socket both simulators serve from (the gauge amplifier, the PLC), and the
// clients they serve on it.
#pragma once

#include <modbus/modbus.h>

#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

struct TcpListener {
  int fd = -1;
  int port = 0;  // the port bound: the one asked for, or the one the system picked for 0
};

// Binds and listens on host:port (an IPv4 or IPv6 address; port 0: any free one),
// close-on-exec, SO_REUSEADDR. `who` names the server in messages ("simulator", "PLC
// simulator"). Errors: kInvalidInput for a host that is not an IPv4 or IPv6 address, kIo
// when the port cannot be bound or read back.
Result<TcpListener> listen_tcp(const std::string& host, int port, const std::string& who);

// The Modbus TCP clients of one server thread, served a poll round at a time. Owns their
// sockets (closed on destruction).
class ModbusTcpClients {
 public:
  ModbusTcpClients() = default;
  ~ModbusTcpClients() { close_all(); }
  ModbusTcpClients(const ModbusTcpClients&) = delete;
  ModbusTcpClients& operator=(const ModbusTcpClients&) = delete;

  void close_all();

  enum class Round { kServed, kWoken, kFailed };
  // A request received on `ctx` (its socket set to the client's): the query and its length.
  // Returns false to drop that client's connection (the request is then left unanswered).
  using OnRequest = std::function<bool(const std::uint8_t* query, int length)>;

  // Waits up to timeout_ms (-1: no limit) for `wake_fd`, a new client on `listen_fd` (< 0: not
  // listening) or a request; accepts the new client and hands each request to `on_request`.
  // A client that goes away or sends garbage is closed. kWoken: wake_fd is readable (left
  // unread) and nothing else was done; kFailed: poll failed.
  Round serve_round(modbus_t* ctx, int wake_fd, int listen_fd, int timeout_ms, const OnRequest& on_request);

 private:
  std::vector<int> clients_;
  std::vector<std::uint8_t> query_ = std::vector<std::uint8_t>(MODBUS_TCP_MAX_ADU_LENGTH);
};

// The framing context (TCP on host:port, IPv4 or IPv6; its sockets are the listener's), a
// mapping of `words` holding registers from `base_address` and the wake eventfd of a server
// that serves holding registers (the PLC, the gear probe). Each handle is set as it is made, so
// that shut_down_modbus_server releases what an error left. `who` names the server in messages.
// Errors: kInvalidInput for a base address that leaves no room for the words or an unusable host,
// kInternal when the mapping cannot be allocated, kIo when the eventfd cannot be made.
Status open_holding_register_server(const std::string& host, int port, int base_address, int words,
                                    const std::string& who, modbus_t*& ctx, modbus_mapping_t*& mapping, int& wake_fd);

// The one teardown of a simulator's server: `before_wake` (e.g. setting a stop flag), a wake
// of the serving thread through its eventfd, the thread joined; then the listening socket and
// the eventfd closed, the context freed (a serial one closes its line first; a TCP one's
// sockets are the clients' and closed already) and the register mapping freed. Each handle is
// reset, so a second call does nothing.
void shut_down_modbus_server(std::thread& thread, int& wake_fd, int& listen_fd, modbus_t*& ctx,
                             modbus_mapping_t*& mapping, bool serial, const std::function<void()>& before_wake = {});

}  // namespace gaugeloop
