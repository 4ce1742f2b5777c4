// The timers of one run, shared by the poller's two collectors: its time budget, the spindle's
// rate and the freeze watch. Internal to acquisition/.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "acquisition/poller.h"
#include "core/clock.h"

namespace gaugeloop {

// A run's budget of time, from the spindle speed seen so far: the run timeout, and how long
// an outage or a frozen amplifier is waited out before the run fails.
class RunBudget {
 public:
  RunBudget(const PollerSettings& s, Clock::time_point start) : s_(s), start_(start) {}

  // Spindle speed from the poller's own view (latch rate, angle rate); <= 0: unknown. The
  // budget keeps the slowest speed seen: a rate measured across a stall of the poller (a
  // loaded machine taking it off the CPU between a reading and its time) reads fast, and a
  // budget that believed it would time the run out while the spindle still turns. A budget
  // too long only makes a failing run fail later.
  void saw_speed(double rev_per_s) {
    if (rev_per_s > 0.0 && (rev_per_s_ <= 0.0 || rev_per_s < rev_per_s_)) rev_per_s_ = rev_per_s;
  }
  // One revolution at the speed seen; zero while unknown.
  Clock::duration revolution() const;
  // How long an outage or a freeze is waited out (PollerSettings::patience_revolutions).
  Clock::duration patience() const { return s_.patience_revolutions * revolution(); }
  Clock::duration run_timeout() const { return run_timeout_at(s_, rev_per_s_ * 60.0); }
  bool timed_out(Clock::time_point now) const { return now - start_ > run_timeout(); }
  // "run timed out after 10000 ms (the spindle speed was never seen)".
  std::string timeout_text() const;

 private:
  const PollerSettings& s_;
  Clock::time_point start_;
  double rev_per_s_ = 0.0;
};

// The spindle's rate over a long baseline: the progress (latch marks, unwrapped degrees)
// since the first observation after the last restart. Restarted at every gap (an outage, a
// freeze), so a gap never slows it; per-poll ratios of tiny, quantised steps would read
// several times the true rate. Only progress of kMinProgress or more counts, so an encoder
// dithering on a stopped spindle never makes the rate (and with it the patience and the
// run timeout) creep towards zero.
class RateWatch {
 public:
  static constexpr double kMinProgress = 10.0;  // degrees, or latch marks

  explicit RateWatch(Clock::duration baseline) : baseline_(baseline) {}
  void restart() { origin_.reset(); }
  // Progress at `now`, counting up. True when the rate was updated.
  bool observe(Clock::time_point now, double progress);
  double per_s() const { return per_s_; }  // 0 until known

 private:
  Clock::duration baseline_;
  std::optional<std::pair<Clock::time_point, double>> origin_;
  double per_s_ = 0.0;
};

// Whether the gauge stands still while the link answers: no progress (a new latch entry; a
// new sample and half a degree of angle in live mode) for stale_after. Time with the link
// down does not count: the timer restarts at the first good exchange after a failure, so an
// outage is never taken for a freeze. Each stale period found restarts the timer; the freeze
// is given up on after max_attempts periods in a row and the budget's patience.
class FreezeWatch {
 public:
  FreezeWatch(const PollerSettings& s, Clock::time_point now) : s_(s), since_(now) {}

  void progressed(Clock::time_point now) {
    since_ = now;
    periods_ = 0;
    outage_ = false;
  }
  void link_failed() { outage_ = true; }
  void answered(Clock::time_point now) {
    if (!outage_) return;
    since_ = now;
    outage_ = false;
  }
  // True when a new stale period has passed; counts it and restarts the timer.
  bool stale(Clock::time_point now);
  // Where the stale period now running began (the last progress, answer after an outage, or
  // stale period).
  Clock::time_point period_began() const { return since_; }
  std::chrono::milliseconds frozen_for() const { return periods_ * s_.stale_after; }
  bool exhausted(const RunBudget& budget) const {
    return periods_ >= s_.max_attempts && frozen_for() >= budget.patience();
  }

 private:
  const PollerSettings& s_;
  Clock::time_point since_;
  int periods_ = 0;
  bool outage_ = false;
};

}  // namespace gaugeloop
