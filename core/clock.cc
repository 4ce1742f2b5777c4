// The real clock, and the manual one tests move.
#include "core/clock.h"

#include <thread>

namespace gaugeloop {
namespace {

class RealClock final : public Clock {
 public:
  time_point now() override { return std::chrono::steady_clock::now(); }
  void sleep_for(duration d) override { std::this_thread::sleep_for(d); }
  void sleep_until(time_point t) override { std::this_thread::sleep_until(t); }
};

}  // namespace

Clock& real_clock() {
  static RealClock clock;
  return clock;
}

ManualClock::time_point ManualClock::now() {
  std::lock_guard lock(mutex_);
  now_ += tick_;
  return now_;
}

void ManualClock::sleep_for(duration d) {
  std::lock_guard lock(mutex_);
  const duration slept = d > duration::zero() ? d : duration::zero();
  sleeps_.push_back(slept);
  now_ += slept;
}

void ManualClock::sleep_until(time_point t) {
  std::lock_guard lock(mutex_);
  const duration slept = t > now_ ? t - now_ : duration::zero();
  sleeps_.push_back(slept);
  now_ += slept;
}

void ManualClock::advance(duration d) {
  std::lock_guard lock(mutex_);
  now_ += d;
}

void ManualClock::set_tick(duration tick) {
  std::lock_guard lock(mutex_);
  tick_ = tick;
}

std::vector<ManualClock::duration> ManualClock::sleeps() const {
  std::lock_guard lock(mutex_);
  return sleeps_;
}

}  // namespace gaugeloop
