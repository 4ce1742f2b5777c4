// The service's sync thread: wait for the interval or a run, sync a few batches at a time
// (so a stop is heard between them), back off after a failure.
#include "plant/central_syncer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <condition_variable>
#include <ctime>
#include <mutex>
#include <optional>
#include <utility>

#include "core/guarded_thread.h"
#include "core/utc_time.h"
#include "plant/central_history.h"

namespace gaugeloop {

namespace {

using Clock = std::chrono::steady_clock;

// Batches per call of sync_to_central: between calls the thread looks whether it must stop.
constexpr int kBatchesPerCall = 5;

}  // namespace

class CentralSyncer::Loop {
 public:
  Loop(std::filesystem::path db_path, CentralSyncSettings settings, std::string machine)
      : db_path_(std::move(db_path)), settings_(std::move(settings)), machine_(std::move(machine)) {
    const Result<CentralUrl> url = parse_central_url(settings_.url);
    status_.url = url ? url->shown : settings_.url;
    status_.started_utc = utc_now();
  }

  void wake() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      woken_ = true;
    }
    changed_.notify_all();
  }

  void request_stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    changed_.notify_all();
  }

  CentralSyncerStatus status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }

  const CentralSyncSettings& settings() const { return settings_; }

  void run() {
    Clock::time_point next = Clock::now();
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        // A run wakes the thread only while syncs get through; after a failure the retry waits.
        changed_.wait_until(lock, next, [this] { return stopping_ || (woken_ && status_.consecutive_failures == 0); });
        if (stopping_) return;
        woken_ = false;
      }
      const bool ok = sync_once();
      next = Clock::now() +
             (ok ? std::chrono::duration_cast<std::chrono::milliseconds>(settings_.interval) : retry_wait());
    }
  }

  // After an exception ended run(): waits a while (or until stopped); false when stopping.
  bool pause_after_fault() {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, settings_.interval, [this] { return stopping_; });
    return !stopping_;
  }

 private:
  bool stopping() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stopping_;
  }

  // The wait after the n-th failure in a row: retry_min doubled n - 1 times, at most the interval.
  std::chrono::milliseconds retry_wait() const {
    const int failures = status().consecutive_failures;
    std::chrono::milliseconds wait = settings_.retry_min;
    for (int i = 1; i < failures && wait < settings_.interval; ++i) wait *= 2;
    return std::min<std::chrono::milliseconds>(wait, settings_.interval);
  }

  // One sync until caught up (or stopping); true when it got through.
  bool sync_once() {
    const std::string attempt_utc = utc_now();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      status_.last_attempt_utc = attempt_utc;
    }
    if (!store_) {
      Result<RunStore> opened = RunStore::open(db_path_);
      if (!opened) return failed(opened.error().message);
      store_.emplace(std::move(*opened));
    }
    CentralSyncOptions options;
    options.batch_size = settings_.batch_size;
    options.programs = settings_.programs;
    options.per_degree = settings_.per_degree;
    options.max_batches = kBatchesPerCall;
    for (;;) {
      Result<CentralSyncCounts> counts = sync_to_central(*store_, settings_.url, machine_, options);
      if (!counts) {
        // Whatever failed, the next sync starts afresh: the file is opened again (cheap), and
        // every call connects to the server anyway.
        store_.reset();
        return failed(counts.error().message);
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        status_.runs_copied += counts->runs.inserted;
        status_.pushes_copied += counts->pushes.inserted;
        status_.events_copied += counts->events.inserted;
        status_.last_run_id = counts->runs.last_local_id;
        status_.caught_up = counts->caught_up;
      }
      if (counts->caught_up || stopping()) break;
    }
    bool recovered = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      recovered = status_.consecutive_failures > 0;
      status_.last_success_utc = utc_now();
      status_.last_error.clear();
      status_.consecutive_failures = 0;
      ++status_.syncs_ok;
    }
    if (recovered) spdlog::info("central history: sync got through again ({})", status_.url);
    return true;
  }

  bool failed(const std::string& message) {
    bool repeated = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      repeated = status_.last_error == message;
      status_.last_error = message;
      ++status_.consecutive_failures;
      ++status_.syncs_failed;
    }
    // Once per distinct reason, not once per retry.
    if (!repeated) spdlog::warn("central history: sync failed, the records wait in the file: {}", message);
    return false;
  }

  const std::filesystem::path db_path_;
  const CentralSyncSettings settings_;
  const std::string machine_;
  std::optional<RunStore> store_;  // the sync thread's own connection to the file

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool stopping_ = false;  // guarded by mutex_
  bool woken_ = false;     // guarded by mutex_
  CentralSyncerStatus status_;
};

CentralSyncer::CentralSyncer(std::filesystem::path db_path, CentralSyncSettings settings, std::string machine,
                             std::function<void(std::string_view, std::string_view)> on_fault)
    : loop_(std::make_unique<Loop>(std::move(db_path), std::move(settings), std::move(machine))) {
  // As the outbox sender: an exception that ends a pass is told and the sync starts again after
  // a pause; the records are in the file, so nothing is lost.
  thread_ = std::thread([l = loop_.get(), fault = std::move(on_fault)] {
    while (!run_guarded(
        "central sync", [l] { l->run(); }, fault)) {
      if (!l->pause_after_fault()) break;
    }
  });
}

CentralSyncer::~CentralSyncer() {
  if (!thread_.joinable()) return;
  loop_->request_stop();
  thread_.join();
}

void CentralSyncer::notify() { loop_->wake(); }

CentralSyncerStatus CentralSyncer::status() const { return loop_->status(); }

std::string CentralSyncer::metrics() const {
  const CentralSyncerStatus s = status();
  std::string m;
  const auto head = [&m](const char* name, const char* type, const char* help) {
    m += std::string("# HELP ") + name + " " + help + "\n";
    m += std::string("# TYPE ") + name + " " + type + "\n";
  };
  head("gaugeloop_central_sync_ok", "gauge", "1 while the last sync into the central history got through.");
  m += "gaugeloop_central_sync_ok " + std::string(s.syncs_ok > 0 && s.consecutive_failures == 0 ? "1" : "0") + "\n";
  head("gaugeloop_central_sync_failures_total", "counter", "Syncs into the central history that failed.");
  m += "gaugeloop_central_sync_failures_total " + std::to_string(s.syncs_failed) + "\n";
  head("gaugeloop_central_sync_last_success_timestamp_seconds", "gauge",
       "When the last sync into the central history got through (Unix time; 0: not yet).");
  const std::optional<std::time_t> at = epoch_of_utc(s.last_success_utc);
  m += "gaugeloop_central_sync_last_success_timestamp_seconds " + std::to_string(at ? *at : 0) + "\n";
  head("gaugeloop_central_sync_copied_total", "counter", "Records this process copied into the central history.");
  m += "gaugeloop_central_sync_copied_total{table=\"runs\"} " + std::to_string(s.runs_copied) + "\n";
  m += "gaugeloop_central_sync_copied_total{table=\"nc_pushes\"} " + std::to_string(s.pushes_copied) + "\n";
  m += "gaugeloop_central_sync_copied_total{table=\"events\"} " + std::to_string(s.events_copied) + "\n";
  return m;
}

nlohmann::json CentralSyncer::health() const {
  const CentralSyncerStatus s = status();
  const auto text_or_null = [](const std::string& t) {
    return t.empty() ? nlohmann::json(nullptr) : nlohmann::json(t);
  };
  const std::int64_t interval_s = loop_->settings().interval.count();
  // Since the last success, or since the start when there was none.
  const std::optional<std::time_t> since =
      epoch_of_utc(s.last_success_utc.empty() ? s.started_utc : s.last_success_utc);
  const bool degraded =
      s.consecutive_failures > 0 && since && std::time(nullptr) - *since > 3 * std::max<std::int64_t>(interval_s, 1);
  return {{"url", s.url},
          {"interval_s", interval_s},
          {"last_attempt_utc", text_or_null(s.last_attempt_utc)},
          {"last_success_utc", text_or_null(s.last_success_utc)},
          {"last_error", text_or_null(s.last_error)},
          {"consecutive_failures", s.consecutive_failures},
          {"runs_copied", s.runs_copied},
          {"pushes_copied", s.pushes_copied},
          {"events_copied", s.events_copied},
          {"last_run_id", s.last_run_id},
          {"caught_up", s.caught_up},
          {"degraded", degraded}};
}

}  // namespace gaugeloop
