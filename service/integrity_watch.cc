// The run database's full integrity check on a thread beside the service.
#include "service/integrity_watch.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <ctime>
#include <system_error>
#include <utility>

#include "core/atomic_file.h"
#include "core/utc_time.h"
#include "storage/db_maintenance.h"

namespace gaugeloop {

std::filesystem::path clean_shutdown_marker(const std::filesystem::path& db_path) {
  return std::filesystem::path(db_path.string() + ".clean-shutdown");
}

bool take_clean_shutdown_marker(const std::filesystem::path& db_path) {
  std::error_code ec;
  const bool removed = std::filesystem::remove(clean_shutdown_marker(db_path), ec);
  if (ec)
    spdlog::warn("the clean-shutdown marker {} could not be removed: {}", clean_shutdown_marker(db_path).string(),
                 ec.message());
  return removed;
}

void leave_clean_shutdown_marker(const std::filesystem::path& db_path) {
  if (Status s = write_file_atomically(clean_shutdown_marker(db_path), "stopped cleanly at " + utc_now() + "\n"); !s) {
    spdlog::warn("the clean-shutdown marker could not be written ({}); the next start checks the database whole",
                 s.error().message);
  }
}

IntegrityWatch::IntegrityWatch(Settings settings, std::function<void(const std::string&)> on_damaged,
                               ThreadFault on_fault)
    : settings_(std::move(settings)), on_damaged_(std::move(on_damaged)) {
  thread_ = start_guarded_thread(
      "database integrity", [this] { loop(); }, std::move(on_fault));
}

IntegrityWatch::~IntegrityWatch() { stop(); }

void IntegrityWatch::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  cancel_.cancel();
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool IntegrityWatch::wait_for_first_check(std::chrono::milliseconds within) {
  std::unique_lock<std::mutex> lock(mutex_);
  return wake_.wait_for(lock, within, [this] { return checks_ > 0 || stopping_; }) && checks_ > 0;
}

void IntegrityWatch::loop() {
  auto due = std::chrono::steady_clock::now() + (settings_.check_now ? std::chrono::seconds(0) : settings_.interval);
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      const auto wait = std::chrono::duration_cast<std::chrono::seconds>(due - std::chrono::steady_clock::now());
      next_check_utc_ = format_utc(std::time(nullptr) + static_cast<std::time_t>(std::max<long long>(0, wait.count())));
      if (wake_.wait_until(lock, due, [this] { return stopping_; })) return;
      state_ = "checking";
    }
    const auto started = std::chrono::steady_clock::now();
    Result<IntegrityReport> report = check_database_file(settings_.db_path, IntegrityCheck::kFull, cancel_);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::string damaged;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return;  // cancelled: no verdict
      ++checks_;
      last_check_utc_ = utc_now();
      last_duration_s_ = seconds;
      if (!report) {
        state_ = "failed";
        problem_ = report.error().message;
      } else if (!report->sound()) {
        state_ = "damaged";
        problem_ = damaged_database(settings_.db_path, report->problems).message;
        damaged = problem_;
      } else {
        state_ = "sound";
        problem_.clear();
      }
    }
    wake_.notify_all();
    if (!report) {
      spdlog::error("the database's integrity check failed after {:.1f} s: {}", seconds, report.error().message);
    } else if (!damaged.empty()) {
      spdlog::error("{}", damaged);
      if (on_damaged_) on_damaged_(damaged);
    } else {
      spdlog::info("database {} checked whole in {:.1f} s: sound", settings_.db_path.string(), seconds);
    }
    due = std::chrono::steady_clock::now() + settings_.interval;
  }
}

nlohmann::json IntegrityWatch::health() const {
  std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json out{{"state", state_}, {"checks", checks_}, {"next_check_utc", next_check_utc_}};
  out["last_check_utc"] = last_check_utc_.empty() ? nlohmann::json(nullptr) : nlohmann::json(last_check_utc_);
  out["last_duration_s"] = checks_ > 0 ? nlohmann::json(last_duration_s_) : nlohmann::json(nullptr);
  out["problem"] = problem_.empty() ? nlohmann::json(nullptr) : nlohmann::json(problem_);
  return out;
}

std::string IntegrityWatch::metrics() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string m;
  m += "# HELP gaugeloop_database_integrity_checks_total Full integrity checks of the run database ended.\n";
  m += "# TYPE gaugeloop_database_integrity_checks_total counter\n";
  m += "gaugeloop_database_integrity_checks_total " + std::to_string(checks_) + "\n";
  if (checks_ > 0) {
    m += "# HELP gaugeloop_database_integrity_sound 1 if the last full check found the run database sound.\n";
    m += "# TYPE gaugeloop_database_integrity_sound gauge\n";
    m += "gaugeloop_database_integrity_sound " + std::string(state_ == "sound" ? "1" : "0") + "\n";
    m += "# HELP gaugeloop_database_integrity_last_check_seconds How long the last full check took.\n";
    m += "# TYPE gaugeloop_database_integrity_last_check_seconds gauge\n";
    m += "gaugeloop_database_integrity_last_check_seconds " + std::to_string(last_duration_s_) + "\n";
  }
  return m;
}

}  // namespace gaugeloop
