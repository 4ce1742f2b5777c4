// Store and forward from the run database's outbox to the plant's broker (docs/plant.md, "The
// outbox"): a thread of its own, with its own connection to the database, publishes each
// waiting message at QoS 1 and deletes it when the broker acknowledges it. Nothing is lost
// while the broker is down: messages wait in the database (bounded) until acknowledged, and
// what a stop or a crash left unacknowledged is sent again by the next sender, with the same
// message_uuid, which the consumer drops if it had it.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "core/result.h"
#include "plant/mqtt_settings.h"
#include "storage/run_store.h"

namespace gaugeloop {

// What /metrics and /api/health show of the sender.
struct OutboxSenderStatus {
  bool connected = false;           // the broker accepted our connection and it holds
  std::int64_t published = 0;       // messages handed to the broker by this sender
  std::int64_t acknowledged = 0;    // of those, acknowledged and deleted
  std::int64_t skipped = 0;         // rows whose run or push is gone, deleted unsent
  std::int64_t reconnects = 0;      // connections lost or refused
  std::string last_error;           // the last failure; empty: none yet
  std::string connected_since_utc;  // empty while not connected
  OutboxCounts outbox;              // as last read from the database
};

// How long a stop waits for the offline state to be acknowledged before it disconnects.
inline constexpr std::chrono::seconds kSenderStopLimit{3};

class OutboxSender {
 public:
  // Starts the thread: it opens its own RunStore on `db_path` and connects to the broker of
  // `settings` (site and machine checked by the config reader) as `machine`, with the last
  // will {"state":"offline",...} on gaugeloop/<site>/<machine>/state. `on_fault` as
  // start_guarded_thread's (empty: a line on stderr).
  OutboxSender(std::filesystem::path db_path, MqttSettings settings, std::string machine,
               std::function<void(std::string_view, std::string_view)> on_fault = {});
  // Stops within a bounded time: the state messages queued so far are written, the retained
  // offline state published (waiting kSenderStopLimit at most for the broker), then a clean
  // DISCONNECT. Messages not acknowledged stay in the outbox for the next start.
  ~OutboxSender();
  OutboxSender(const OutboxSender&) = delete;
  OutboxSender& operator=(const OutboxSender&) = delete;

  // Something was queued (a run, a push, a state): look at the outbox now. Any thread.
  void notify();
  // Queues a state message (state_payload) in the outbox, written by the sender's thread with
  // its own connection, so the caller never waits for the database. Any thread.
  void queue_state(std::string state, std::string detail = {});

  // Ends the thread as a crash would: no offline state, no DISCONNECT, so the broker
  // publishes the last will. For tests of the will; the destructor then does nothing more.
  void stop_abruptly();

  OutboxSenderStatus status() const;
  // The Prometheus lines: gaugeloop_outbox_depth, gaugeloop_outbox_sent_total,
  // gaugeloop_outbox_dropped_total, gaugeloop_mqtt_connected, ...
  std::string metrics() const;
  // The "outbox" object of /api/health; `degraded` true while messages older than
  // `stale_after` wait and the broker is not connected.
  nlohmann::json health(std::chrono::seconds stale_after = std::chrono::minutes(5)) const;

 private:
  class Loop;
  void stop(bool clean);

  std::unique_ptr<Loop> loop_;
  std::thread thread_;
};

}  // namespace gaugeloop
