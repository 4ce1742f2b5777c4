// The service's own sync into the plant's central history ([plant.central], docs/plant.md
// "The service syncs itself"): a thread that runs sync_to_central on the service's run
// database every interval and right after each run, with its own connections to the file
// and to PostgreSQL. A server that is down or refuses costs nothing but time: the records
// stay in the file, and the next sync that gets through copies them, in order, once.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <thread>

#include "plant/central_sync.h"

namespace gaugeloop {

// What /api/health and /metrics show of the sync.
struct CentralSyncerStatus {
  std::string url;  // as shown: any password replaced by "***"
  std::string started_utc;
  std::string last_attempt_utc;  // empty: none yet
  std::string last_success_utc;  // empty: none yet
  std::string last_error;        // of the last failed sync; empty after a sync that got through
  int consecutive_failures = 0;
  std::int64_t syncs_ok = 0;      // by this process
  std::int64_t syncs_failed = 0;  // by this process
  // Records this process copied (those found there already by UUID not counted).
  std::int64_t runs_copied = 0;
  std::int64_t pushes_copied = 0;
  std::int64_t events_copied = 0;
  std::int64_t last_run_id = 0;  // the local id of the last run the central history has from this file
  bool caught_up = false;        // the last sync copied everything the file had then
};

class CentralSyncer {
 public:
  // Starts the thread; its first sync is at once. `machine` names the grinder in the central
  // history (the config's machine). `on_fault` as start_guarded_thread's.
  CentralSyncer(std::filesystem::path db_path, CentralSyncSettings settings, std::string machine,
                std::function<void(std::string_view, std::string_view)> on_fault = {});
  // Ends the thread after the batch in progress (a connection attempt in progress ends by
  // libpq's connect_timeout, 10 s unless the URL says otherwise). What is not copied yet is
  // copied by the next sync, of this service or of `gaugeloop plant sync`.
  ~CentralSyncer();
  CentralSyncer(const CentralSyncer&) = delete;
  CentralSyncer& operator=(const CentralSyncer&) = delete;

  // A run or a push was stored: sync soon. Ignored while the last sync failed (the retry
  // waits its turn, so a server that is down is not asked after every run). Any thread.
  void notify();

  CentralSyncerStatus status() const;
  // gaugeloop_central_sync_ok, gaugeloop_central_sync_failures_total,
  // gaugeloop_central_sync_last_success_timestamp_seconds, gaugeloop_central_sync_copied_total.
  std::string metrics() const;
  // The "central" object of /api/health; `degraded` true once syncs have failed for longer than
  // three intervals (or no sync got through in the three intervals since the start).
  nlohmann::json health() const;

 private:
  class Loop;
  std::unique_ptr<Loop> loop_;
  std::thread thread_;
};

}  // namespace gaugeloop
