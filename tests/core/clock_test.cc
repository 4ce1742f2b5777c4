// The real clock keeps steady time; the manual clock moves only when told, and a sleep on it
// returns at once, moving it to the end of the sleep.
#include "core/clock.h"

#include <gtest/gtest.h>

#include <vector>

namespace gaugeloop {
namespace {

using std::chrono::milliseconds;

TEST(RealClock, NeverGoesBackAndAZeroSleepReturns) {
  Clock& clock = real_clock();
  const Clock::time_point a = clock.now();
  clock.sleep_for(Clock::duration::zero());
  clock.sleep_until(a);  // already past
  EXPECT_GE(clock.now(), a);
  EXPECT_EQ(&clock, &real_clock()) << "one real clock for the process";
}

TEST(ManualClock, StandsStillUntilAdvanced) {
  ManualClock clock;
  EXPECT_EQ(clock.now(), Clock::time_point{});
  EXPECT_EQ(clock.now(), Clock::time_point{});
  clock.advance(milliseconds(250));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(250));
}

TEST(ManualClock, ASleepMovesTimeToItsEndAndIsRecorded) {
  ManualClock clock(Clock::time_point{} + milliseconds(1000));
  clock.sleep_for(milliseconds(20));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(1020));
  clock.sleep_until(Clock::time_point{} + milliseconds(1100));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(1100));
  clock.sleep_until(Clock::time_point{} + milliseconds(1050));  // already past: no time passes
  clock.sleep_for(milliseconds(-5));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(1100));
  EXPECT_EQ(clock.sleeps(), (std::vector<Clock::duration>{milliseconds(20), milliseconds(80), Clock::duration::zero(),
                                                          Clock::duration::zero()}));
}

TEST(ManualClock, ATickMovesTimeOnAtEveryRead) {
  ManualClock clock;
  clock.set_tick(milliseconds(3));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(3));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(6));
  clock.set_tick(Clock::duration::zero());
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(6));
}

}  // namespace
}  // namespace gaugeloop
