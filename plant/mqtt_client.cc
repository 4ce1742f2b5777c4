// libmosquitto under an owner that drives its network itself (mosquitto_loop_read/write/misc
// around poll(2)), so that every callback runs on the owner's thread.
#include "plant/mqtt_client.h"

#include <mosquitto.h>
#include <poll.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <utility>

namespace gaugeloop {

namespace {

// mosquitto_lib_init once per process, before the first client; never cleaned up, as other
// clients (another sender, a test's subscriber) may live until the process ends.
void init_library() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

std::string reason(int rc) {
  if (rc == MOSQ_ERR_ERRNO) return std::strerror(errno);
  return mosquitto_strerror(rc);
}

}  // namespace

Result<std::unique_ptr<MqttClient>> MqttClient::connect(const MqttConnectOptions& o) {
  init_library();
  std::unique_ptr<MqttClient> c(new MqttClient());
  c->address_ = o.host + ":" + std::to_string(o.port);
  c->mosq_ = mosquitto_new(o.client_id.c_str(), o.clean_session, c.get());
  if (c->mosq_ == nullptr) {
    return make_error(ErrorCode::kInternal,
                      "cannot make an MQTT client for " + c->address_ + ": " + std::strerror(errno));
  }
  mosquitto_int_option(c->mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  mosquitto_connect_callback_set(c->mosq_, &MqttClient::on_connect);
  mosquitto_disconnect_callback_set(c->mosq_, &MqttClient::on_disconnect);
  mosquitto_publish_callback_set(c->mosq_, &MqttClient::on_publish);
  mosquitto_log_callback_set(c->mosq_, &MqttClient::on_log);
  if (!o.username.empty()) {
    const int rc =
        mosquitto_username_pw_set(c->mosq_, o.username.c_str(), o.password.empty() ? nullptr : o.password.c_str());
    if (rc != MOSQ_ERR_SUCCESS) {
      return make_error(ErrorCode::kInvalidInput, "MQTT username for " + c->address_ + " refused: " + reason(rc));
    }
  }
  if (!o.ca_file.empty()) {
    const std::string cert = o.cert_file.string();
    const std::string key = o.key_file.string();
    const int rc = mosquitto_tls_set(c->mosq_, o.ca_file.c_str(), nullptr, cert.empty() ? nullptr : cert.c_str(),
                                     key.empty() ? nullptr : key.c_str(), nullptr);
    if (rc != MOSQ_ERR_SUCCESS) {
      return make_error(ErrorCode::kInvalidInput, "TLS to the broker " + c->address_ + " refused (CA file " +
                                                      o.ca_file.string() + "): " + reason(rc));
    }
  }
  if (!o.will_topic.empty()) {
    const int rc = mosquitto_will_set(c->mosq_, o.will_topic.c_str(), static_cast<int>(o.will_payload.size()),
                                      o.will_payload.data(), 1, o.will_retain);
    if (rc != MOSQ_ERR_SUCCESS) {
      return make_error(ErrorCode::kInvalidInput, "the last will on " + o.will_topic + " refused: " + reason(rc));
    }
  }
  // Not blocking: the TCP connection (and TLS handshake) completes in run_for, so a broker that
  // never answers holds no thread; libmosquitto's keepalive check ends a connection that gets
  // no CONNACK within keepalive_s. Only a host name is resolved here (getaddrinfo): give the
  // broker's address to avoid even that.
  c->tls_ = !o.ca_file.empty();
  errno = 0;
  const int rc = mosquitto_connect_async(c->mosq_, o.host.c_str(), o.port, o.keepalive_s);
  if (rc != MOSQ_ERR_SUCCESS) {
    return make_error(ErrorCode::kIo, "cannot connect to the broker " + c->address_ + ": " + c->reason_of(rc));
  }
  return c;
}

MqttClient::~MqttClient() {
  // Without a DISCONNECT first, the broker sees the connection drop and publishes the will.
  if (mosq_ != nullptr) mosquitto_destroy(mosq_);
}

void MqttClient::on_connect(struct mosquitto*, void* self, int rc) {
  auto* c = static_cast<MqttClient*>(self);
  if (rc == 0) {
    c->connected_ = true;
  } else {
    c->fail("the broker " + c->address_ + " refused the connection: " + mosquitto_connack_string(rc));
  }
}

void MqttClient::on_disconnect(struct mosquitto*, void* self, int rc) {
  auto* c = static_cast<MqttClient*>(self);
  c->connected_ = false;
  if (!c->disconnected_) c->fail("the connection to the broker " + c->address_ + " was lost: " + c->reason_of(rc));
}

void MqttClient::on_log(struct mosquitto*, void* self, int level, const char* line) {
  if ((level & (MOSQ_LOG_ERR | MOSQ_LOG_WARNING)) != 0 && line != nullptr) {
    static_cast<MqttClient*>(self)->last_log_error_ = line;
  }
}

std::string MqttClient::reason_of(int rc) const {
  std::string r = reason(rc);
  if (rc == MOSQ_ERR_TLS && !last_log_error_.empty()) r += " (" + last_log_error_ + ")";
  return r;
}

void MqttClient::on_publish(struct mosquitto*, void* self, int mid) {
  static_cast<MqttClient*>(self)->acknowledged_.push_back(mid);
}

void MqttClient::fail(std::string why) {
  connected_ = false;
  if (failure_.empty()) failure_ = std::move(why);
}

Result<int> MqttClient::publish(const std::string& topic, const std::string& payload, bool retain) {
  if (failed()) return make_error(ErrorCode::kIo, failure_);
  int mid = 0;
  const int rc =
      mosquitto_publish(mosq_, &mid, topic.c_str(), static_cast<int>(payload.size()), payload.data(), 1, retain);
  if (rc == MOSQ_ERR_SUCCESS) return mid;
  if (rc == MOSQ_ERR_NO_CONN || rc == MOSQ_ERR_CONN_LOST || rc == MOSQ_ERR_ERRNO) {
    fail("publishing to the broker " + address_ + " failed: " + reason(rc));
    return make_error(ErrorCode::kIo, failure_);
  }
  return make_error(ErrorCode::kInvalidInput, "the broker " + address_ + " cannot take a message on " + topic + " (" +
                                                  std::to_string(payload.size()) + " bytes): " + reason(rc));
}

bool MqttClient::idle() const { return failed() || !mosquitto_want_write(mosq_); }

bool MqttClient::run_for(std::chrono::milliseconds timeout, int wake_fd) {
  if (failed()) return false;
  const int sock = mosquitto_socket(mosq_);
  if (sock < 0) {
    fail("the connection to the broker " + address_ + " is closed");
    return false;
  }
  // Until the TCP connection is made, it is writability that says so. After that, while a TLS
  // handshake runs, libmosquitto may still want to write (want_write stays set until its first
  // packet is written), but the handshake goes on when the broker answers: waiting for
  // writability then would wake at once, again and again.
  const bool handshaking = tls_ && tcp_connected_ && !connected_;
  const bool want_write = mosquitto_want_write(mosq_) && !handshaking;
  pollfd fds[2] = {{sock, static_cast<short>(POLLIN | (want_write ? POLLOUT : 0)), 0}, {wake_fd, POLLIN, 0}};
  const int n = ::poll(fds, wake_fd >= 0 ? 2 : 1, static_cast<int>(timeout.count()));
  bool woken = false;
  if (n > 0) {
    woken = wake_fd >= 0 && (fds[1].revents & POLLIN) != 0;
    const bool readable = (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) != 0;
    const bool writable = (fds[0].revents & POLLOUT) != 0;
    if (writable) tcp_connected_ = true;
    int rc = MOSQ_ERR_SUCCESS;
    // A TLS handshake is driven by mosquitto_loop_read alone (it calls SSL_connect while one is
    // under way): on the connection's first writability, and on every answer of the broker.
    // Then what waits to be written (CONNECT, once the handshake is done) is written.
    if (readable || (tls_ && !connected_ && writable)) rc = mosquitto_loop_read(mosq_, 1);
    if (rc == MOSQ_ERR_SUCCESS && (writable || (tls_ && !connected_ && readable))) {
      rc = mosquitto_loop_write(mosq_, 1);
    }
    if (rc != MOSQ_ERR_SUCCESS) {
      fail("the connection to the broker " + address_ + " was lost: " + reason_of(rc));
      return woken;
    }
  }
  // Keepalive pings and the broker's silence; a lost connection shows here too.
  if (const int rc = mosquitto_loop_misc(mosq_); rc != MOSQ_ERR_SUCCESS) {
    fail("the connection to the broker " + address_ + " was lost: " + reason(rc));
  }
  return woken;
}

std::vector<int> MqttClient::take_acknowledged() { return std::exchange(acknowledged_, {}); }

void MqttClient::disconnect() {
  if (mosq_ == nullptr || failed()) return;
  disconnected_ = true;
  mosquitto_disconnect(mosq_);
  connected_ = false;
}

}  // namespace gaugeloop
