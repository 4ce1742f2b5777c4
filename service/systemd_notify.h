// Telling systemd how the service is doing (sd_notify(3)): started, reloading, stopping, a
// status line for `systemctl status`, and the watchdog, fed only while the PLC trigger polls
// and the HTTP server accepts. Not started by systemd (NOTIFY_SOCKET unset: a shell, a test),
// every call is a no-op. docs/service.md.
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "config/service_config.h"

namespace gaugeloop {

class HttpApi;
class PlcTrigger;

// Sends `state` (KEY=VALUE lines, sd_notify(3)) to systemd. False when not started by systemd
// or the send failed; nothing else to do about either. Any thread.
bool notify_systemd(const std::string& state);

// READY=1 with a STATUS= line naming what serves requests: after start, and after each SIGHUP
// whether the file was taken or refused (the service runs on either way).
void notify_started(const HttpApi* http, const PlcTrigger* plc);
// RELOADING=1 (with the MONOTONIC_USEC newer systemd asks for), until the next notify_started.
void notify_reloading();
// STOPPING=1: systemd waits for the exit (TimeoutStopSec) instead of the watchdog.
void notify_stopping();

// The watchdog's question before each feed: empty while alive, otherwise why not, in words for
// the log ("the HTTP server no longer accepts connections"). Called on the watchdog's thread.
using LivenessCheck = std::function<std::string()>;

// How long the PLC trigger may go without beginning a poll and still count as alive: three
// poll intervals, or one interval plus three reply timeouts (a PLC that does not answer holds
// a connect, a read and a write that long), and never less than a second.
std::chrono::milliseconds plc_alive_within(const PlcSettings& plc);

// Alive: the HTTP server accepts (when there is one) and the PLC trigger began a poll within
// plc_alive_within(*plc_settings) (when there is one). `http` and `plc` must outlive the check.
LivenessCheck service_liveness(const HttpApi* http, const PlcTrigger* plc,
                               const std::optional<PlcSettings>& plc_settings);

// Feeds a watchdog ("WATCHDOG=1") every period while the liveness check answers alive. It
// stops feeding while the check answers why not, and says so once (log and STATUS=); once
// alive again it feeds again and says so. systemd restarts the service when no feed arrived
// within WatchdogSec.
class Watchdog {
 public:
  using Send = std::function<void(const std::string&)>;

  // Not started: start() runs it on a thread, tick() runs one round on the caller's.
  Watchdog(std::chrono::microseconds period, LivenessCheck alive, Send send);
  ~Watchdog();  // stops
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  // The watchdog systemd asks for (WatchdogSec=: WATCHDOG_USEC, and WATCHDOG_PID naming this
  // process if set), fed through sd_notify every half interval on a thread of its own;
  // nullptr when systemd asks for none.
  static std::unique_ptr<Watchdog> start_for_systemd(LivenessCheck alive);

  // One round: asks the check and feeds when alive. Returns whether it fed.
  bool tick();
  // A thread that waits a period, then ticks, until stop(). The first tick comes a period
  // after the start, so the PLC trigger has polled by then.
  void start();
  void stop();  // idempotent; joins the thread

 private:
  const std::chrono::microseconds period_;
  const LivenessCheck alive_;
  const Send send_;
  bool starving_ = false;  // the last tick did not feed; tick()'s caller's thread only
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;  // guarded by mutex_
  std::thread thread_;
};

// Watchdog::start_for_systemd with service_liveness.
std::unique_ptr<Watchdog> start_service_watchdog(const HttpApi* http, const PlcTrigger* plc,
                                                 const std::optional<PlcSettings>& plc_settings);

}  // namespace gaugeloop
