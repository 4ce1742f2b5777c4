// The steady time that timeouts, backoffs and pacing read, and the waits they make: the real
// clock, or a manual one a test moves.
#pragma once

#include <chrono>
#include <mutex>
#include <vector>

namespace gaugeloop {

// Steady time (never set back) and sleeping on it. Code with timers takes a Clock& and
// defaults to real_clock(); a test passes a ManualClock, so every timeout and backoff runs at
// once and exactly, with no real sleeping and no assertion on wall-clock time.
class Clock {
 public:
  using duration = std::chrono::steady_clock::duration;
  using time_point = std::chrono::steady_clock::time_point;

  virtual ~Clock() = default;
  virtual time_point now() = 0;
  // Return once `d` has passed, or `t` has been reached; at once when it already has. The
  // real clock may overrun by the scheduler's slack.
  virtual void sleep_for(duration d) = 0;
  virtual void sleep_until(time_point t) = 0;
};

// std::chrono::steady_clock and std::this_thread. One object for the whole process, stateless
// and thread-safe.
Clock& real_clock();

// Time that moves only when told: advance(), set_tick(), or a sleep, which moves it to the
// end of the sleep at once and records how long it was. Starts at the steady clock's epoch
// (time_point{}) unless given a start. Thread-safe.
class ManualClock final : public Clock {
 public:
  ManualClock() = default;
  explicit ManualClock(time_point start) : now_(start) {}

  // The current time; with a tick set, time first moves on by the tick, so a loop that only
  // reads the clock still sees time pass.
  time_point now() override;
  void sleep_for(duration d) override;
  void sleep_until(time_point t) override;

  void advance(duration d);
  void set_tick(duration tick);
  // The sleeps asked for, in order (a sleep_until as the time it had left; 0 when past).
  std::vector<duration> sleeps() const;

 private:
  mutable std::mutex mutex_;
  time_point now_{};
  duration tick_{};
  std::vector<duration> sleeps_;
};

}  // namespace gaugeloop
