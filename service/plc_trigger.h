// The PLC trigger: the handshake block polled on a thread of its own, each PLC request run as
// one measuring cycle of the service on a worker thread, each step logged once and kept as an
// event. docs/service.md, "The PLC handshake".
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>

#include "config/service_config.h"
#include "core/part_temperature.h"
#include "service/plc_handshake.h"
#include "service/service.h"

namespace gaugeloop {

// The outcome the PLC is told for a run (or a refusal to start one). `stored_run`: the run's
// id if it was stored, which a failure after that (the push) still reports.
PlcCycleOutcome plc_outcome(const Result<JobReport>& report, std::optional<std::int64_t> stored_run);

// The serial number and operator a PLC request carries (words 13-36), as the run keeps them:
// decode_plc_text's text, checked by check_run_identity like the CLI's options. Empty: not
// given. kInvalidInput naming the word, its holding register (`base_address` + word) and the
// byte at fault otherwise.
struct PlcIdentity {
  std::string serial;
  std::string operator_name;
};
Result<PlcIdentity> plc_identity(const PlcRequestWords& request, int base_address);

// The part temperature a PLC request carries (word 37), as the run keeps it: empty when not
// given. kInvalidInput naming the word, its holding register (`base_address` + 37) and the value
// when it is out of range (decode_plc_part_temperature).
Result<std::optional<PartTemperature>> plc_part_temperature(const PlcRequestWords& request, int base_address);

// Runs a PLC request's cycle on a worker thread, so the handshake keeps polling (and the
// heartbeat counting) while the lobe is measured. Used by the PLC trigger's thread only.
class ServiceCycleRunner final : public PlcCycleRunner {
 public:
  // `base_address`: the block's first holding register ([plc] base_address), for messages.
  explicit ServiceCycleRunner(Service& service, int base_address = 0)
      : service_(service), base_address_(base_address) {}
  ~ServiceCycleRunner() override;

  // While the service stops: kNotNow at once, whatever the PLC asks for. Then at once: an
  // unknown part or lobe (kUnknownPart), serial number or operator words that are not text
  // (kBadIdentity, plc_identity), a part temperature out of range (kBadPartTemperature,
  // plc_part_temperature), another run in progress (kNotNow).
  std::optional<PlcCycleOutcome> start(const PlcRequestWords& request) override;
  std::optional<PlcCycleOutcome> poll() override;

 private:
  void finish(PlcCycleOutcome outcome);

  Service& service_;
  const int base_address_;
  std::thread worker_;
  std::mutex mutex_;
  bool finished_ = false;                   // guarded by mutex_
  std::optional<PlcCycleOutcome> outcome_;  // guarded by mutex_
};

// Polls the handshake block every poll interval on a thread of its own. Its events go to the
// service's event queue (Service::record_event): a busy database never holds a poll.
// stop() returns once no cycle is in progress and its outcome is in the PLC's registers (or
// the link is down and cannot carry it), and, when the service is stopping
// (Service::set_stopping, to be called first), once no run of the service is in progress,
// whoever started it (HTTP, PLC). Until then it polls on: the heartbeat counts and every
// request is answered at once with fault, result code 7 (kNotNow), "the service is stopping".
// An exception in a poll is recorded (Service::record_thread_fault) and the trigger polls on
// after one interval.
class PlcTrigger {
 public:
  // `plc`: the PLC's registers; by default a Modbus link built from `settings`.
  PlcTrigger(Service& service, PlcSettings settings, std::unique_ptr<PlcRegisters> plc = nullptr);
  ~PlcTrigger();

  void start();
  void stop();  // idempotent

  std::string address() const { return link_->address(); }
  // True while the trigger thread polls: its last poll began within `within` (for the
  // watchdog). Any thread.
  bool alive(std::chrono::steady_clock::duration within) const;
  nlohmann::json status() const;  // for /api/health
  std::string metrics() const;    // Prometheus lines

 private:
  void loop();
  void report(PlcEvent e);
  std::string request_text() const;
  std::string part_name() const;
  bool wait_poll_interval();  // false once stop() was called

  Service& service_;
  const PlcSettings settings_;
  std::unique_ptr<PlcRegisters> link_;  // the trigger thread's only
  ServiceCycleRunner runner_;
  PlcHandshake handshake_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;       // guarded by mutex_
  bool link_down_ = false;  // trigger thread only
  std::atomic<bool> connected_{false};
  std::atomic<int> state_{0};
  std::atomic<long long> requests_{0};
  std::atomic<std::chrono::steady_clock::rep> last_poll_{0};  // steady_clock ticks; 0: never polled
};

}  // namespace gaugeloop
