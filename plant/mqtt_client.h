// A small owner of one libmosquitto connection (Debian's libmosquitto, MQTT 3.1.1), driven by
// the thread that owns it: no thread of libmosquitto's own. The outbox sender runs the network
// between its reads and writes of the database, so the broker's acknowledgements arrive on the
// thread that holds the database connection (one RunStore per thread), without a queue
// between two threads, and a notify() wakes it at once (run_for polls a wake-up descriptor
// beside the socket). docs/plant.md, "Messages to the broker".
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/result.h"

struct mosquitto;

namespace gaugeloop {

struct MqttConnectOptions {
  std::string host;
  int port = 1883;
  std::string client_id;  // not empty
  // false: the broker keeps this client's QoS 1 state across reconnects.
  bool clean_session = false;
  int keepalive_s = 30;
  std::string username;  // empty: no login
  std::string password;
  std::filesystem::path ca_file;  // set: TLS, the broker's certificate checked against it
  std::filesystem::path cert_file;
  std::filesystem::path key_file;
  // The last will: published by the broker (QoS 1) when the connection ends without a
  // DISCONNECT. Empty topic: none.
  std::string will_topic;
  std::string will_payload;
  bool will_retain = true;
};

class MqttClient {
 public:
  // Starts the TCP (and TLS) connection without waiting for it, CONNECT queued behind it; the
  // connection, the handshake and the broker's answer (CONNACK) come through run_for:
  // connected() turns true, or failed() says why (a broker that does not answer within
  // keepalive_s is a lost connection). kIo naming the broker's address and the reason when the
  // connection cannot even be started (a host name that does not resolve); kInvalidInput for
  // options libmosquitto refuses (a TLS file it cannot read).
  static Result<std::unique_ptr<MqttClient>> connect(const MqttConnectOptions& options);
  // Closes the connection without a DISCONNECT (the broker publishes the last will), unless
  // disconnect() was called.
  ~MqttClient();
  MqttClient(const MqttClient&) = delete;
  MqttClient& operator=(const MqttClient&) = delete;

  // Publishes at QoS 1; returns the message id the acknowledgement will name. kIo when the
  // connection is lost.
  Result<int> publish(const std::string& topic, const std::string& payload, bool retain);

  // Runs the network until there is nothing more to do now and at most `timeout`, returning
  // early when `wake_fd` (>= 0) becomes readable (it is not read). Returns whether wake_fd
  // was readable.
  bool run_for(std::chrono::milliseconds timeout, int wake_fd = -1);

  bool connected() const { return connected_; }
  // Set when the broker refused the connection or it was lost; the client is done then.
  bool failed() const { return !failure_.empty(); }
  const std::string& failure() const { return failure_; }
  // The message ids the broker acknowledged (PUBACK) since the last call.
  std::vector<int> take_acknowledged();
  // Nothing waits to be written to the socket.
  bool idle() const;

  // A clean end: DISCONNECT sent (no last will), the connection closed.
  void disconnect();

  const std::string& address() const { return address_; }

 private:
  MqttClient() = default;
  static void on_connect(struct mosquitto*, void* self, int rc);
  static void on_disconnect(struct mosquitto*, void* self, int rc);
  static void on_publish(struct mosquitto*, void* self, int mid);
  static void on_log(struct mosquitto*, void* self, int level, const char* line);
  // libmosquitto's reason for `rc`, with what its log said last (OpenSSL's reason for a TLS
  // failure: "certificate verify failed").
  std::string reason_of(int rc) const;
  void fail(std::string why);

  struct mosquitto* mosq_ = nullptr;
  std::string address_;  // "host:port", for messages
  bool connected_ = false;
  bool tls_ = false;            // with a CA file: the connection is TLS
  bool tcp_connected_ = false;  // the socket was writable once: the TCP connection is made
  bool disconnected_ = false;   // by disconnect()
  std::string failure_;
  std::vector<int> acknowledged_;
  std::string last_log_error_;  // libmosquitto's last error log line
};

}  // namespace gaugeloop
