// The HTTP API's front door (docs/http_api.md, "Connection limits"): one thread that accepts
// every connection, reads each request's head under limits, and only then hands the request to
// the API's server on loopback. A client that sends its head slowly, or a head without end,
// costs the front a socket and at most a head's bytes, never one of the server's worker
// threads: /api/health and /metrics keep answering while hundreds of such clients hold on.
//
// The API's server (cpp-httplib) gives each accepted connection a worker thread of a small
// pool until the whole head is read, with no bound on a header line's length: the front is
// where those bounds live. Plain HTTP only; with HTTPS the server takes connections itself.
//
// Per connection, in order:
//  - caps: at most `max_per_address` connections from one address and `max_total` in all;
//    beyond them the connection is answered 503 and closed at once;
//  - the head within `head_timeout` of the connection (408 after it), its request line at most
//    `max_line_bytes` (414), each header line at most `max_line_bytes` and the head at most
//    `max_head_bytes` (431): answered and closed without reading further;
//  - then a connection to the server, the head passed on with `Connection: close` (one request
//    a connection: the next one goes through these limits again) and `X-Forwarded-For`, and the
//    bytes relayed both ways: the body (the server applies its own limits to it) within
//    `body_timeout` of the head, the answer buffered by the front so a slow reader holds no
//    worker either.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>

#include "core/result.h"

namespace gaugeloop {

struct HttpFrontLimits {
  std::chrono::milliseconds head_timeout{10'000};
  std::chrono::milliseconds body_timeout{30'000};
  // A connection whose answer makes no progress (nothing from the server, nothing taken by the
  // client) for this long is closed.
  std::chrono::milliseconds idle_timeout{300'000};
  std::size_t max_line_bytes = 8 * 1024;
  std::size_t max_head_bytes = 64 * 1024;
  int max_per_address = 32;
  int max_total = 256;
};

class HttpFront {
 public:
  // Listens on host:port (0: any free port) and passes each request on to
  // 127.0.0.1:backend_port. kIo naming the address when it cannot listen there.
  static Result<std::unique_ptr<HttpFront>> start(const std::string& host, int port, int backend_port,
                                                  HttpFrontLimits limits);
  HttpFront(const HttpFront&) = delete;
  HttpFront& operator=(const HttpFront&) = delete;
  ~HttpFront();  // stop()

  int port() const;
  bool alive() const;  // the front's thread runs
  // Stops accepting and closes every connection. Idempotent.
  void stop();

 private:
  struct Impl;
  explicit HttpFront(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gaugeloop
