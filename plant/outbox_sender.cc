// The outbox sender's thread: read a batch, render, publish at QoS 1, delete on PUBACK;
// reconnect with a bounded backoff; wake on notify() or every poll interval.
#include "plant/outbox_sender.h"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
#include <map>
#include <optional>
#include <set>
#include <utility>

#include "core/guarded_thread.h"
#include "core/utc_time.h"
#include "plant/mqtt_client.h"
#include "plant/plant_messages.h"

namespace gaugeloop {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// Messages handed to the broker and not yet acknowledged, at most: enough to keep a broker on
// the plant network busy, few enough that a lost connection resends little.
constexpr std::size_t kMaxInFlight = 100;
// Rows read per look at the outbox.
constexpr int kBatch = 50;
// The network is looked at at least this often (keepalive pings).
constexpr milliseconds kMaxWait{1000};

milliseconds until(Clock::time_point t) {
  const auto d = std::chrono::duration_cast<milliseconds>(t - Clock::now());
  return std::max(milliseconds(0), d);
}

}  // namespace

class OutboxSender::Loop {
 public:
  Loop(std::filesystem::path db_path, MqttSettings settings, std::string machine)
      : db_path_(std::move(db_path)), settings_(std::move(settings)), machine_(std::move(machine)) {
    wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (settings_.client_id.empty()) settings_.client_id = "gaugeloop-" + machine_;
  }
  ~Loop() {
    if (wake_fd_ >= 0) ::close(wake_fd_);
  }

  void wake() {
    const std::uint64_t one = 1;
    if (wake_fd_ >= 0) [[maybe_unused]]
      const auto n = ::write(wake_fd_, &one, sizeof one);
  }

  void queue_state(std::string state, std::string detail) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      states_.emplace_back(std::move(state), std::move(detail));
    }
    wake();
  }

  void request_stop(bool clean) {
    clean_stop_ = clean;
    stopping_ = true;
    wake();
  }

  OutboxSenderStatus status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }

  void run();
  // After an exception ended run(): waits a while (or until stopped); false when stopping.
  bool pause_after_fault() {
    if (stopping_) return false;
    wait_for_wake(settings_.reconnect_max);
    return !stopping_;
  }

 private:
  // Drains the wake-up counter; true if it was set.
  bool drain_wake() {
    std::uint64_t n = 0;
    return wake_fd_ >= 0 && ::read(wake_fd_, &n, sizeof n) == static_cast<ssize_t>(sizeof n);
  }
  // Waits for a wake-up or `timeout`, without a connection to watch.
  void wait_for_wake(milliseconds timeout) {
    pollfd fd{wake_fd_, POLLIN, 0};
    ::poll(&fd, 1, static_cast<int>(timeout.count()));
  }

  void set_error(const std::string& e) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (status_.last_error == e) return;
      status_.last_error = e;
    }
    spdlog::warn("plant broker: {}", e);
  }
  template <typename F>
  void update(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    f(status_);
  }

  MqttConnectOptions options() const {
    MqttConnectOptions o;
    o.host = settings_.host;
    o.port = settings_.port;
    o.client_id = settings_.client_id;
    o.clean_session = false;
    o.keepalive_s = settings_.keepalive_s;
    o.username = settings_.username;
    o.password = settings_.password;
    o.ca_file = settings_.ca_file;
    o.cert_file = settings_.cert_file;
    o.key_file = settings_.key_file;
    o.will_topic = plant_topic(settings_.site, machine_, "state");
    o.will_payload = state_payload(machine_, "offline", "the connection to the broker ended without a goodbye");
    o.will_retain = true;
    return o;
  }

  void write_states(RunStore& store);
  bool fill(RunStore& store, MqttClient& client);
  void settle_acknowledged(RunStore& store, MqttClient& client);
  void refresh_counts(const RunStore& store);
  void finish(RunStore* store, std::unique_ptr<MqttClient> client);

  const std::filesystem::path db_path_;
  MqttSettings settings_;
  const std::string machine_;
  int wake_fd_ = -1;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> clean_stop_{true};

  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, std::string>> states_;  // guarded by mutex_
  OutboxSenderStatus status_;                                // guarded by mutex_

  // The sender's thread only.
  std::map<int, std::int64_t> in_flight_;  // message id -> outbox id (0: the online/offline state)
  std::set<std::int64_t> in_flight_ids_;
};

void OutboxSender::Loop::write_states(RunStore& store) {
  std::vector<std::pair<std::string, std::string>> states;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    states.swap(states_);
  }
  for (const auto& [state, detail] : states) {
    Result<std::int64_t> id = store.enqueue_state(state_payload(machine_, state, detail));
    if (!id) set_error("state \"" + state + "\" not queued: " + id.error().message);
  }
}

void OutboxSender::Loop::settle_acknowledged(RunStore& store, MqttClient& client) {
  std::vector<std::int64_t> ids;
  for (int mid : client.take_acknowledged()) {
    const auto it = in_flight_.find(mid);
    if (it == in_flight_.end()) continue;
    if (it->second != 0) ids.push_back(it->second);
    in_flight_ids_.erase(it->second);
    in_flight_.erase(it);
  }
  if (ids.empty()) return;
  // If this fails (the database locked beyond its busy timeout), the rows stay and are sent
  // again: a repeat the consumer drops by message_uuid, never a loss.
  if (Status s = store.outbox_delivered(ids); !s) {
    set_error("acknowledged messages not marked sent (they will be sent again): " + s.error().message);
    return;
  }
  update([&](OutboxSenderStatus& st) { st.acknowledged += static_cast<std::int64_t>(ids.size()); });
}

// Publishes waiting rows not yet in flight. True when more may be waiting and there is room.
bool OutboxSender::Loop::fill(RunStore& store, MqttClient& client) {
  if (in_flight_ids_.size() >= kMaxInFlight) return false;
  const int limit = static_cast<int>(in_flight_ids_.size()) + kBatch;
  Result<std::vector<OutboxMessage>> batch = store.outbox_batch(limit);
  if (!batch) {
    set_error("cannot read the outbox: " + batch.error().message);
    return false;
  }
  std::vector<std::int64_t> skipped;
  std::int64_t published = 0;
  bool room = true;
  for (const OutboxMessage& m : *batch) {
    if (in_flight_ids_.count(m.id) != 0) continue;
    if (in_flight_ids_.size() >= kMaxInFlight) {
      room = false;
      break;
    }
    Result<std::optional<PlantMessage>> message = render_message(store, m, settings_.site, machine_);
    if (!message && message.error().code == ErrorCode::kStorage) {
      set_error("cannot read outbox message " + std::to_string(m.id) + ": " + message.error().message);
      room = false;
      break;
    }
    if (!message || !message->has_value()) {
      spdlog::warn("plant broker: outbox message {} ({}, run {}) skipped unsent: {}", m.id, m.topic, m.run_id,
                   message ? "its record is no longer in the database" : message.error().message);
      skipped.push_back(m.id);
      continue;
    }
    Result<int> mid = client.publish((*message)->topic, (*message)->payload, (*message)->retain);
    if (!mid) {
      if (mid.error().code != ErrorCode::kIo) {  // this message cannot be sent (too large)
        spdlog::warn("plant broker: outbox message {} skipped unsent: {}", m.id, mid.error().message);
        skipped.push_back(m.id);
        continue;
      }
      room = false;  // the connection is gone: the loop reconnects
      break;
    }
    in_flight_[*mid] = m.id;
    in_flight_ids_.insert(m.id);
    ++published;
  }
  if (!skipped.empty()) {
    if (Status s = store.outbox_delivered(skipped, RunStore::OutboxOutcome::kSkipped); !s)
      set_error("cannot delete skipped messages: " + s.error().message);
  }
  update([&](OutboxSenderStatus& st) {
    st.published += published;
    st.skipped += static_cast<std::int64_t>(skipped.size());
  });
  return room && static_cast<int>(batch->size()) == limit;
}

void OutboxSender::Loop::refresh_counts(const RunStore& store) {
  Result<OutboxCounts> counts = store.outbox_counts();
  if (!counts) {
    set_error("cannot read the outbox counts: " + counts.error().message);
    return;
  }
  update([&](OutboxSenderStatus& st) { st.outbox = *counts; });
}

void OutboxSender::Loop::run() {
  std::optional<RunStore> store;
  std::unique_ptr<MqttClient> client;
  milliseconds backoff = settings_.reconnect_min;
  Clock::time_point next_attempt = Clock::now();
  Clock::time_point next_poll = Clock::now();
  bool work_due = true;
  const auto lost = [&](const std::string& why) {
    set_error(why);
    client.reset();
    in_flight_.clear();
    in_flight_ids_.clear();
    update([](OutboxSenderStatus& st) {
      st.connected = false;
      st.connected_since_utc.clear();
      ++st.reconnects;
    });
    next_attempt = Clock::now() + backoff;
    backoff = std::min(backoff * 2, settings_.reconnect_max);
  };
  while (!stopping_) {
    if (!store) {
      Result<RunStore> opened = RunStore::open(db_path_);
      if (!opened) {
        set_error("cannot open the run database: " + opened.error().message);
        wait_for_wake(settings_.reconnect_max);
        continue;
      }
      store.emplace(std::move(*opened));
    }
    write_states(*store);
    if (Clock::now() >= next_poll) {
      work_due = true;
      next_poll = Clock::now() + settings_.poll_interval;
      refresh_counts(*store);
    }
    if (!client) {
      if (Clock::now() >= next_attempt) {
        Result<std::unique_ptr<MqttClient>> made = MqttClient::connect(options());
        if (made) {
          client = std::move(*made);
        } else {
          lost(made.error().message);
        }
      }
      if (!client) {
        wait_for_wake(std::min(until(next_attempt), until(next_poll)));
        drain_wake();
        continue;
      }
    }
    const bool was_connected = client->connected();
    const milliseconds wait = work_due && client->connected() ? milliseconds(0) : std::min(until(next_poll), kMaxWait);
    if (client->run_for(wait, wake_fd_) && drain_wake()) work_due = true;
    if (client->failed()) {
      lost(client->failure());
      continue;
    }
    if (!was_connected && client->connected()) {
      backoff = settings_.reconnect_min;
      spdlog::info("plant broker {} connected as {}", client->address(), settings_.client_id);
      // The retained state says this grinder is reachable; the will turns it to offline.
      Result<int> mid =
          client->publish(plant_topic(settings_.site, machine_, "state"), state_payload(machine_, "online"), true);
      if (mid) in_flight_[*mid] = 0;
      update([](OutboxSenderStatus& st) {
        st.connected = true;
        st.connected_since_utc = utc_now();
      });
      work_due = true;
    }
    const std::size_t before = in_flight_.size();
    settle_acknowledged(*store, *client);
    if (in_flight_.size() != before) work_due = true;
    if (client->connected() && work_due) {
      work_due = fill(*store, *client);
      refresh_counts(*store);
    }
  }
  finish(store ? &*store : nullptr, std::move(client));
}

// The end: abrupt (the broker publishes the will), or clean: the state messages queued so far
// written, the offline state published and acknowledged (bounded), DISCONNECT.
void OutboxSender::Loop::finish(RunStore* store, std::unique_ptr<MqttClient> client) {
  if (!clean_stop_) return;  // `client` is destroyed without a DISCONNECT
  if (store != nullptr) write_states(*store);
  if (!client || !client->connected()) return;
  const Clock::time_point deadline = Clock::now() + kSenderStopLimit;
  if (store != nullptr) fill(*store, *client);  // the states just queued, if there is room
  Result<int> offline = client->publish(plant_topic(settings_.site, machine_, "state"),
                                        state_payload(machine_, "offline", "the service stopped"), true);
  if (!offline) return;
  bool acknowledged = false;
  while (!acknowledged && !client->failed() && Clock::now() < deadline) {
    client->run_for(std::min(until(deadline), kMaxWait));
    for (int mid : client->take_acknowledged()) {
      // Acknowledgements of outbox messages that arrive now are settled too.
      const auto it = in_flight_.find(mid);
      if (mid == *offline) acknowledged = true;
      if (it != in_flight_.end() && it->second != 0 && store != nullptr) {
        if (store->outbox_delivered({it->second})) update([](OutboxSenderStatus& st) { ++st.acknowledged; });
      }
    }
  }
  client->disconnect();
  update([](OutboxSenderStatus& st) { st.connected = false; });
}

OutboxSender::OutboxSender(std::filesystem::path db_path, MqttSettings settings, std::string machine,
                           std::function<void(std::string_view, std::string_view)> on_fault)
    : loop_(std::make_unique<Loop>(std::move(db_path), std::move(settings), std::move(machine))) {
  // An exception that ends a pass is told (on_fault) and the sender starts again after a
  // pause, with a new connection: the messages are in the database, so nothing is lost, and
  // a fault must not stop the deliveries for good.
  thread_ = std::thread([l = loop_.get(), fault = std::move(on_fault)] {
    while (!run_guarded(
        "outbox sender", [l] { l->run(); }, fault)) {
      if (!l->pause_after_fault()) break;
    }
  });
}

OutboxSender::~OutboxSender() { stop(true); }

void OutboxSender::stop(bool clean) {
  if (!thread_.joinable()) return;
  loop_->request_stop(clean);
  thread_.join();
}

void OutboxSender::stop_abruptly() { stop(false); }

void OutboxSender::notify() { loop_->wake(); }

void OutboxSender::queue_state(std::string state, std::string detail) {
  loop_->queue_state(std::move(state), std::move(detail));
}

OutboxSenderStatus OutboxSender::status() const { return loop_->status(); }

std::string OutboxSender::metrics() const {
  const OutboxSenderStatus s = status();
  std::string m;
  const auto series = [&m](const char* name, const char* type, const char* help, std::int64_t value) {
    m += std::string("# HELP ") + name + " " + help + "\n";
    m += std::string("# TYPE ") + name + " " + type + "\n";
    m += std::string(name) + " " + std::to_string(value) + "\n";
  };
  series("gaugeloop_outbox_depth", "gauge", "Plant messages waiting in the outbox for the broker.", s.outbox.depth);
  series("gaugeloop_outbox_sent_total", "counter", "Plant messages the broker acknowledged, ever.",
         s.outbox.sent_total);
  series("gaugeloop_outbox_dropped_total", "counter",
         "Plant messages dropped unsent (the outbox was full, or one could not be sent), ever.",
         s.outbox.dropped_total);
  series("gaugeloop_mqtt_connected", "gauge", "1 while the plant broker holds our connection.", s.connected ? 1 : 0);
  series("gaugeloop_mqtt_reconnects_total", "counter", "Connections to the plant broker lost or refused.",
         s.reconnects);
  series("gaugeloop_mqtt_published_total", "counter", "Plant messages handed to the broker by this process.",
         s.published);
  return m;
}

nlohmann::json OutboxSender::health(std::chrono::seconds stale_after) const {
  const OutboxSenderStatus s = status();
  bool stale = false;
  if (s.outbox.depth > 0 && !s.outbox.oldest_utc.empty()) {
    const std::optional<std::time_t> oldest = epoch_of_utc(s.outbox.oldest_utc);
    stale = oldest && std::time(nullptr) - *oldest > stale_after.count();
  }
  return {{"depth", s.outbox.depth},
          {"oldest_utc", s.outbox.oldest_utc.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.outbox.oldest_utc)},
          {"connected", s.connected},
          {"sent_total", s.outbox.sent_total},
          {"dropped_total", s.outbox.dropped_total},
          {"reconnects", s.reconnects},
          {"last_error", s.last_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.last_error)},
          {"degraded", stale && !s.connected}};
}

}  // namespace gaugeloop
