// The broker the outbox sender delivers to: the service's [plant.mqtt] (docs/service.md,
// docs/plant.md "Messages to the broker").
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>

namespace gaugeloop {

struct MqttSettings {
  std::string host;  // the broker's name or address; required
  int port = 1883;   // 8883 is usual with TLS
  // The plant's site: the second level of every topic (gaugeloop/<site>/<machine>/...).
  std::string site;
  // The client id the broker keeps this grinder's session under; empty: gaugeloop-<machine>.
  std::string client_id;
  std::string username;  // empty: no login
  std::string password;  // read from [plant.mqtt] password_file by the config reader
  // TLS: the CA that signed the broker's certificate (set: TLS on); a client certificate and
  // key when the broker asks for one (both or neither).
  std::filesystem::path ca_file;
  std::filesystem::path cert_file;
  std::filesystem::path key_file;
  int keepalive_s = 30;             // MQTT keepalive: the broker declares us gone after 1.5 times it
  std::int64_t max_depth = 100000;  // the outbox bound: past it the oldest message is dropped
  // Not in the config file: how the sender paces itself (tests make them short).
  std::chrono::milliseconds reconnect_min{500};    // the first wait after a failed connection
  std::chrono::milliseconds reconnect_max{30000};  // the wait doubles up to this
  std::chrono::milliseconds poll_interval{2000};   // rows written by other processes (the CLI)
};

}  // namespace gaugeloop
