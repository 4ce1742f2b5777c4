// The PLC handshake as a state machine over the handshake registers (core/plc_registers.h):
// request -> ack, busy -> the cycle -> done or fault with a result code -> the PLC clears the
// request -> the service clears ack, done and fault. docs/service.md has the timing diagram.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "acquisition/plc_link.h"
#include "core/clock.h"
#include "core/plc_registers.h"
#include "core/result.h"

namespace gaugeloop {

// What one cycle came to, as the PLC is told.
struct PlcCycleOutcome {
  PlcResultCode code = PlcResultCode::kOtherFault;
  std::uint32_t run_id = 0;         // 0: no run stored
  std::uint16_t table_version = 0;  // 0: no table pushed
  std::string message;              // for the log: what happened, or what failed
};

// Runs the measurement cycle a PLC request asks for, off the handshake's thread, so the
// heartbeat goes on while a lobe is measured.
class PlcCycleRunner {
 public:
  virtual ~PlcCycleRunner() = default;
  // Starts a cycle for the PLC's words (part and lobe numbers, the table that ground the part,
  // serial number and operator) and returns at once: nullopt when it runs, or the outcome at
  // once when no run is started (unknown part or lobe, serial number or operator not text,
  // another run in progress, the service stopping).
  virtual std::optional<PlcCycleOutcome> start(const PlcRequestWords& request) = 0;
  // The outcome once the cycle started last has ended; nullopt while it runs. Called until it
  // returns a value, once per poll.
  virtual std::optional<PlcCycleOutcome> poll() = 0;
};

// The handshake's states. The link's state (connected or not) is apart: a cycle goes on, and
// its outcome waits, while the link is down.
//
//   kIdle --request rises (seen low before)--> kBusy        ack=1 busy=1; the cycle starts
//   kIdle --request rises, no run started----> kDone        ack=1 fault=1, result code
//   kBusy --the cycle ends-------------------> kDone        busy=0, done=1 or fault=1, result, run id
//   kDone --request low----------------------> kIdle        ack=done=fault=0
//
// A request counts on its rising edge only: a request held high after done, or already high
// when the service starts, is not a new one; the PLC clears it first. A request cleared while
// busy does not stop the run (it stores whole); done or fault is raised when it ends and
// cleared at the next poll. Every poll increments the heartbeat word.
enum class PlcState { kIdle, kBusy, kDone };
std::string_view plc_state_name(PlcState state);  // "idle", "busy", "done"

// What a step did, for the log and the event table.
enum class PlcEvent {
  kConnected,        // the link came up (first time or again)
  kConnectFailed,    // a connection attempt failed; the next one after the backoff
  kLinkLost,         // a read or a write failed; the link is closed, reconnecting
  kRequestAccepted,  // kIdle -> kBusy
  kRequestRefused,   // kIdle -> kDone with a fault, no run started (unknown part, not now)
  kCycleEnded,       // kBusy -> kDone
  kOutcomeWritten,   // done or fault is in the PLC's registers now
  kCleared,          // kDone -> kIdle
  kClearedEarly,     // the PLC cleared the request while busy
};
std::string_view plc_event_name(PlcEvent event);

struct PlcHandshakeSettings {
  std::chrono::milliseconds reconnect_min{100};   // first retry after a lost link
  std::chrono::milliseconds reconnect_max{5000};  // backoff doubles up to this
};

// Not thread-safe: one thread calls step() once per poll interval. `plc`, `runner` and `clock`
// must outlive the handshake. `clock` times the reconnect backoff (step() never sleeps).
class PlcHandshake {
 public:
  PlcHandshake(PlcRegisters& plc, PlcCycleRunner& runner, PlcHandshakeSettings settings = {},
               Clock& clock = real_clock());

  // One poll: collect a finished cycle, (re)connect if due, read the PLC's words, move the
  // state on, write the service's words. Never throws; link errors are events, and the link
  // is retried with a backoff (reconnect_min doubling to reconnect_max).
  std::vector<PlcEvent> step();

  PlcState state() const { return state_; }
  bool connected() const { return plc_.connected(); }
  // The PLC words of the request taken last (valid from kRequestAccepted/kRequestRefused on).
  const PlcRequestWords& request() const { return request_; }
  // The outcome of the last cycle (valid in kDone, and kept in kIdle until the next request).
  const std::optional<PlcCycleOutcome>& outcome() const { return outcome_; }
  // What was written to the PLC last (or is to be written once the link is back).
  const PlcServiceWords& service_words() const { return words_; }
  // The error of the last failed connect, read or write.
  const std::string& last_link_error() const { return last_link_error_; }
  // True when the outcome of the last cycle is in the PLC's registers (or no cycle ran).
  bool outcome_delivered() const { return delivered_; }

 private:
  void link_failed(const Error& e, std::vector<PlcEvent>& events);

  PlcRegisters& plc_;
  PlcCycleRunner& runner_;
  PlcHandshakeSettings settings_;
  Clock& clock_;
  PlcState state_ = PlcState::kIdle;
  bool armed_ = false;  // the request was seen low since the start or the last outcome
  bool cleared_early_ = false;
  bool delivered_ = true;
  PlcRequestWords request_;
  std::optional<PlcCycleOutcome> outcome_;
  PlcServiceWords words_;
  Clock::time_point next_connect_{};
  std::chrono::milliseconds backoff_{0};
  std::string last_link_error_;
};

}  // namespace gaugeloop
