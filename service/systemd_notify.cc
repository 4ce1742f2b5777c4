// sd_notify(3) and the watchdog: see systemd_notify.h.
#include "service/systemd_notify.h"

#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>
#include <time.h>

#include <algorithm>
#include <cstdint>

#include "core/guarded_thread.h"
#include "service/http_api.h"
#include "service/plc_trigger.h"

namespace gaugeloop {

bool notify_systemd(const std::string& state) { return sd_notify(0, state.c_str()) > 0; }

void notify_started(const HttpApi* http, const PlcTrigger* plc) {
  std::string serving;
  if (http) serving += "HTTP API on port " + std::to_string(http->port());
  if (plc) serving += (serving.empty() ? "" : ", ") + std::string("PLC trigger at ") + plc->address();
  notify_systemd("READY=1\nSTATUS=waiting for requests: " + (serving.empty() ? "no HTTP API, no PLC" : serving));
}

void notify_reloading() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  const std::int64_t usec = static_cast<std::int64_t>(now.tv_sec) * 1000000 + now.tv_nsec / 1000;
  notify_systemd("RELOADING=1\nMONOTONIC_USEC=" + std::to_string(usec) + "\nSTATUS=reloading the configuration");
}

void notify_stopping() { notify_systemd("STOPPING=1\nSTATUS=stopping: letting the run in progress finish"); }

std::chrono::milliseconds plc_alive_within(const PlcSettings& plc) {
  const std::chrono::milliseconds timeout = plc.link.link.response_timeout;
  return std::max({3 * plc.poll_interval, plc.poll_interval + 3 * timeout, std::chrono::milliseconds{1000}});
}

LivenessCheck service_liveness(const HttpApi* http, const PlcTrigger* plc,
                               const std::optional<PlcSettings>& plc_settings) {
  const std::chrono::milliseconds within =
      plc_settings ? plc_alive_within(*plc_settings) : std::chrono::milliseconds{0};
  return [http, plc, within]() -> std::string {
    if (http && !http->alive()) return "the HTTP server no longer accepts connections";
    if (plc && !plc->alive(within)) {
      return "the PLC trigger has not begun a poll for more than " + std::to_string(within.count()) + " ms";
    }
    return "";
  };
}

Watchdog::Watchdog(std::chrono::microseconds period, LivenessCheck alive, Send send)
    : period_(period), alive_(std::move(alive)), send_(std::move(send)) {}

Watchdog::~Watchdog() { stop(); }

std::unique_ptr<Watchdog> Watchdog::start_for_systemd(LivenessCheck alive) {
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) <= 0 || usec == 0) return nullptr;
  // Half the interval, as sd_watchdog_enabled(3) advises: one late feed is not yet a restart.
  auto watchdog = std::make_unique<Watchdog>(std::chrono::microseconds(static_cast<std::int64_t>(usec / 2)),
                                             std::move(alive), [](const std::string& s) { notify_systemd(s); });
  spdlog::info("systemd watchdog: {} s; fed every {} ms while the PLC trigger polls and the HTTP server accepts",
               static_cast<double>(usec) / 1e6, usec / 2000);
  watchdog->start();
  return watchdog;
}

bool Watchdog::tick() {
  const std::string why_not = alive_();
  if (!why_not.empty()) {
    if (!starving_) {
      spdlog::error("watchdog not fed: {}; systemd restarts the service unless it recovers", why_not);
      send_("STATUS=watchdog not fed: " + why_not);
    }
    starving_ = true;
    return false;
  }
  if (starving_) {
    spdlog::warn("watchdog fed again: the service is alive");
    send_("STATUS=waiting for requests (watchdog fed again)");
  }
  starving_ = false;
  send_("WATCHDOG=1");
  return true;
}

void Watchdog::start() {
  thread_ = start_guarded_thread(
      "watchdog",
      [this] {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!wake_.wait_for(lock, period_, [this] { return stop_; })) {
          lock.unlock();
          tick();
          lock.lock();
        }
      },
      // A watchdog thread that died feeds no more: systemd restarts the service, as it should.
      [](std::string_view name, std::string_view what) {
        spdlog::critical("{} thread failed: {}; the watchdog is no longer fed", name, what);
      });
}

void Watchdog::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::unique_ptr<Watchdog> start_service_watchdog(const HttpApi* http, const PlcTrigger* plc,
                                                 const std::optional<PlcSettings>& plc_settings) {
  return Watchdog::start_for_systemd(service_liveness(http, plc, plc_settings));
}

}  // namespace gaugeloop
