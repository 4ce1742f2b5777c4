// The link to one gauge amplifier for the length of a run: connect, back off, give up.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <string_view>

#include "acquisition/gauge_client.h"
#include "core/clock.h"
#include "core/result.h"

namespace gaugeloop {

// The link's states. Transitions (every other pair is impossible):
//
//   Disconnected --ensure, connect ok-------------------> Connected
//   Disconnected --ensure, connect fails, attempts left--> BackingOff
//   BackingOff   --ensure: sleep backoff, connect ok-----> Connected     (a reconnect)
//   BackingOff   --ensure: connect fails, not spent------> BackingOff    (backoff doubles)
//   Connected    --succeeded-----------------------------> Connected     (failures and backoff reset)
//   Connected    --failed, not spent---------------------> BackingOff    (link closed: late replies flushed)
//   any          --failure, attempts and patience spent--> Failed        (terminal: every call returns the error)
//
// "Attempts" counts consecutive failures, of connects and of requests alike; a successful
// request resets it. The backoff starts at backoff_initial and doubles up to backoff_max.
// Once the link has been up, it also waits out `patience` (set_patience) from the first
// failure of an outage before it gives up: the poller sets it to what its spare revolutions
// can absorb, so a short outage costs revolutions, not the run, whatever the spindle speed.
enum class LinkState { kDisconnected, kConnected, kBackingOff, kFailed };

std::string_view link_state_name(LinkState state);

struct LinkPolicy {
  int max_attempts = 5;
  std::chrono::milliseconds backoff_initial{20};
  std::chrono::milliseconds backoff_max{500};
};

// Not thread-safe: one per run, on the poller's thread. `clock` times the outage and sleeps
// the backoff; it must outlive the link.
class GaugeLink {
 public:
  GaugeLink(GaugeClient& gauge, LinkPolicy policy, Clock& clock = real_clock())
      : gauge_(gauge), policy_(policy), clock_(clock), backoff_(policy.backoff_initial) {}

  // Makes sure the link is up before a request. An error: the attempts are spent (Failed).
  // `where_now` says where the run is, for the message ("during revolution 2 of 3").
  Status ensure(std::string_view where_now);
  // Records a failed request or a stale gauge. An error: the attempts are spent (Failed);
  // its message says the gauge stopped answering and that nothing was stored.
  Status failed(const Error& e, std::string_view where_now);
  // Records a good request (any reply that is not an error): the outage, if any, is over.
  void succeeded();
  // The shortest outage given up on once the link has been up; 0 (the default): none.
  void set_patience(Clock::duration patience) { patience_ = patience; }

  LinkState state() const { return state_; }
  int reconnects() const { return reconnects_; }
  // Called on every change of state, for tests and logs.
  void set_on_transition(std::function<void(LinkState from, LinkState to)> callback) {
    on_transition_ = std::move(callback);
  }

 private:
  void move_to(LinkState next);
  // Counts one more failure; true when the attempts and the patience are both spent.
  bool spent();
  Status give_up(const Error& e, std::string_view where_now);

  GaugeClient& gauge_;
  LinkPolicy policy_;
  Clock& clock_;
  std::chrono::milliseconds backoff_;
  LinkState state_ = LinkState::kDisconnected;
  int failures_ = 0;
  Clock::time_point outage_since_{};  // first failure of the current outage
  Clock::duration patience_{};
  int reconnects_ = 0;
  bool ever_connected_ = false;
  Error failure_;  // kept once Failed
  std::function<void(LinkState, LinkState)> on_transition_;
};

}  // namespace gaugeloop
