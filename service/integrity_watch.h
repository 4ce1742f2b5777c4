// The run database checked whole beside the service, not before it: the service starts in a
// moment at any size (a header and schema check only, check_database_header) and a thread of
// its own runs the full integrity check (PRAGMA integrity_check and foreign_key_check) at once
// when the service last stopped without saying so (a crash, a power cut: the clean-shutdown
// marker is missing), and every `interval` after. Its state is in /api/health ("database" ->
// "integrity") and /metrics. docs/service.md, "The database's integrity".
#pragma once

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "core/guarded_thread.h"
#include "storage/db_maintenance.h"

namespace gaugeloop {

// The marker a clean stop leaves beside the database (<db>.clean-shutdown): written after the
// last write of the service, taken away at start. Absent at start: the last stop was not clean.
std::filesystem::path clean_shutdown_marker(const std::filesystem::path& db_path);
// Takes the marker away; true if it was there. Any failure to remove it is logged.
bool take_clean_shutdown_marker(const std::filesystem::path& db_path);
// Writes the marker (atomically); logged, not fatal, when it cannot be written.
void leave_clean_shutdown_marker(const std::filesystem::path& db_path);

class IntegrityWatch {
 public:
  struct Settings {
    std::filesystem::path db_path;
    bool check_now = true;                     // false: the first check after `interval`
    std::chrono::seconds interval{24 * 3600};  // between checks
  };
  // `on_damaged` is called on the watch's thread with the message (damaged_database's) once a
  // check finds the file damaged; `on_fault` as for any guarded thread.
  IntegrityWatch(Settings settings, std::function<void(const std::string&)> on_damaged, ThreadFault on_fault);
  ~IntegrityWatch();  // stop()
  IntegrityWatch(const IntegrityWatch&) = delete;
  IntegrityWatch& operator=(const IntegrityWatch&) = delete;

  // Cancels a check in progress (SQLite interrupted where it is, within a few pages) and joins.
  // Idempotent.
  void stop();
  // Until the first check has ended. For tests and for a caller that must know. Any thread.
  bool wait_for_first_check(std::chrono::milliseconds within);

  // {"state": "waiting" | "checking" | "sound" | "damaged" | "failed", "last_check_utc",
  //  "last_duration_s", "problem" (damaged or failed), "checks", "next_check_utc"}. Any thread.
  nlohmann::json health() const;
  // Prometheus lines: gaugeloop_database_integrity_sound (1, 0; absent before the first check),
  // gaugeloop_database_integrity_checks_total, gaugeloop_database_integrity_last_check_seconds.
  std::string metrics() const;

 private:
  void loop();

  const Settings settings_;
  const std::function<void(const std::string&)> on_damaged_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;          // guarded by mutex_
  std::string state_ = "waiting";  // guarded by mutex_
  std::string last_check_utc_, next_check_utc_, problem_;
  double last_duration_s_ = 0.0;
  long long checks_ = 0;
  CheckCancel cancel_;  // cancelled by stop()
  std::thread thread_;
};

}  // namespace gaugeloop
