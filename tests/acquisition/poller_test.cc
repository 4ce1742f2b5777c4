// Poller against a scripted gauge: binning, whole-revolution rejection and link faults.
#include "acquisition/poller.h"

#include <gtest/gtest.h>
#include <sys/prctl.h>

#include "acquisition/run_watches.h"
#include "scripted_gauge.h"

namespace gaugeloop {
namespace {

using testing::Fault;
using testing::ScriptedGauge;

PollerSettings fast_settings(SamplingMode mode = SamplingMode::kLive) {
  PollerSettings s;
  s.mode = mode;
  // The scripted spindle advances per request, not with the clock: no waiting helps it.
  s.backoff_initial = std::chrono::milliseconds(0);
  s.backoff_max = std::chrono::milliseconds(0);
  s.latch_idle_wait = std::chrono::microseconds(0);
  s.latch_max_wait = std::chrono::milliseconds(0);
  return s;
}

// Cubic interpolation of a sine of amplitude 0.5 mm between polls 0.3 deg apart errs by about
// h^4/24 * A * (pi/180)^4 = 0.3^4 / 24 * 0.5 * 9.3e-8 = 1.6e-11 mm; linear interpolation
// would err by up to A * (h in rad)^2 / 8 = 1.7e-6 mm, so this bound also checks the cubic.
constexpr double kInterpolationTolMm = 1e-9;

// Every degree of every revolution is the gauge's lift at that angle of that revolution (so
// values come from their own revolution), to the cubic's tolerance.
void expect_true_lift(const MeasuredRun& run, const ScriptedGauge& g) {
  for (const auto& rev : run.revolutions) {
    for (int d = 0; d < 360; ++d) {
      ASSERT_NEAR(rev.lift_mm[d], g.lift_mm(static_cast<double>(rev.revolution) * 360.0 + d), kInterpolationTolMm)
          << "revolution " << rev.revolution << " degree " << d;
    }
  }
}

TEST(Poller, CollectsCompleteRevolutionsFromTheNextBoundary) {
  ScriptedGauge g;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  EXPECT_EQ(run->discarded_revolutions, 0);
  for (size_t i = 0; i < 3; ++i) {
    const auto& rev = run->revolutions[i];
    EXPECT_EQ(rev.revolution, static_cast<std::int64_t>(i) + 1) << "starts at the boundary after the first poll";
    for (int d = 0; d < 360; ++d) {
      EXPECT_NEAR(rev.lift_mm[d], g.lift_mm(static_cast<double>(rev.revolution) * 360.0 + d), kInterpolationTolMm)
          << "degree " << d;
    }
  }
}

// A run narrows the thread's timer slack for its pacing sleeps and gives the thread its own
// back after: the service's worker thread goes on to other work.
TEST(Poller, GivesTheThreadItsTimerSlackBack) {
  constexpr unsigned long kOwnSlackNs = 77000;
  ASSERT_EQ(::prctl(PR_SET_TIMERSLACK, kOwnSlackNs, 0UL, 0UL, 0UL), 0);
  ScriptedGauge g;
  Poller p(g, fast_settings());
  ASSERT_TRUE(p.measure().ok());
  EXPECT_EQ(::prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL), static_cast<int>(kOwnSlackNs));
}

TEST(Poller, UnwrapsTheRevolutionCounterAcrossItsWrap) {
  ScriptedGauge g;
  g.revolution_base = 65534;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->revolutions[0].revolution, 65535);
  EXPECT_EQ(run->revolutions[2].revolution, 65537);
}

// Amplifiers that update the revolution count on their own cycle move it a little after the
// angle wraps: up to 5 degrees late it is the same wrap, not the encoder running backwards.
TEST(Poller, ARevolutionCounterLaggingTheWrapIsTheSameWrap) {
  ScriptedGauge g;
  g.revolution_lag_deg = 4.5;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 0);
  EXPECT_EQ(run->revolutions[0].revolution, 1);
  expect_true_lift(*run, g);
}

// Beyond the stated tolerance the counter is believed: the angle went back a revolution.
TEST(Poller, ARevolutionCounterLaggingFartherIsNotExplainedAway) {
  ScriptedGauge g;
  g.revolution_lag_deg = 8.0;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_NE(run.error().message.find("encoder angle went backwards"), std::string::npos) << run.error().message;
}

TEST(Poller, RevolutionWithAGapIsDiscardedWholeAndReplaced) {
  ScriptedGauge g;
  g.faults[1700] = Fault::kSkip;  // in revolution 2: 1700 reads * 0.3 deg = 510 deg
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
  ASSERT_EQ(run->revolutions.size(), 3u);
  EXPECT_EQ(run->revolutions[0].revolution, 2) << "revolution 1 had the gap";
  expect_true_lift(*run, g);
}

TEST(Poller, OverRangeDiscardsTheRevolution) {
  ScriptedGauge g;
  g.faults[1500] = Fault::kOverRange;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
  EXPECT_EQ(run->revolutions[0].revolution, 2);
}

TEST(Poller, EncoderJumpingBackDiscardsTheRevolution) {
  ScriptedGauge g;
  g.faults[1500] = Fault::kAngleBack;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
}

TEST(Poller, RepeatedSampleIsNotTakenAsNew) {
  ScriptedGauge g;
  g.step_deg = 0.4;  // a repeat leaves 0.8 deg between new samples: within the 1 deg limit
  for (int i = 100; i < 2000; i += 7) g.faults[i] = Fault::kRepeat;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 0);
  expect_true_lift(*run, g);
}

TEST(Poller, ANewSampleAtAnUnchangedAngleIsHarmless) {
  ScriptedGauge g;
  for (int i = 100; i < 4000; i += 5) g.faults[i] = Fault::kStall;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 0);
  expect_true_lift(*run, g);
}

// Polls 0.05 deg apart and, 500 deg in (revolution 1), one gap of `gap_deg` between two polls.
ScriptedGauge crowded_with_one_gap(double gap_deg) {
  ScriptedGauge g;
  g.step_deg = 0.05;
  g.skip_deg = gap_deg - g.step_deg;
  g.u_deg = 0.01;
  g.faults[10000] = Fault::kSkip;
  return g;
}

// Polls 0.05 deg apart, then one 0.8 deg gap (a poll stalled): too long for a straight line
// (0.5 deg), and its immediate neighbours are too close to carry a cubic without amplifying
// noise. The cubic reaches for the nearest polls at least a third of the gap beyond either
// end (0.3 deg here), so the degree in the gap is filled, to the cubic's tolerance, and no
// revolution is lost. (Live TCP on this project's VM: a 4 ms stall at 30 rpm is 0.72 deg.)
TEST(Poller, ALongGapBetweenCrowdedPollsTakesWellSpacedNeighbours) {
  ScriptedGauge g = crowded_with_one_gap(0.8);
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 0);
  ASSERT_EQ(run->revolutions[0].revolution, 1);
  expect_true_lift(*run, g);
}

// The same gap just over the limit (1.05 deg against max_interpolation_gap_deg 1): nobody
// sampled near the degree in it, so it stays missing and its revolution is replaced.
TEST(Poller, AGapOverTheLimitIsLeftMissing) {
  ScriptedGauge g = crowded_with_one_gap(1.05);
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
  EXPECT_EQ(run->revolutions[0].revolution, 2);
}

TEST(Poller, ReconnectsAfterATimeoutAndDropsThatRevolution) {
  ScriptedGauge g;
  g.faults[1500] = Fault::kTimeout;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->reconnects, 1);
  EXPECT_EQ(g.connects, 2);
  EXPECT_EQ(run->discarded_revolutions, 1);
  EXPECT_EQ(run->revolutions.size(), 3u);
}

TEST(Poller, GaugeThatStopsAnsweringFailsWithoutSamples) {
  ScriptedGauge g;
  g.faults[1500] = Fault::kTimeout;
  g.dead_after_faults = true;
  PollerSettings s = fast_settings();
  s.max_attempts = 4;
  s.patience_revolutions = 0;  // the scripted spindle turns per request, not with the clock
  Poller p(g, s);
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(run.error().message.find("stopped answering during revolution"), std::string::npos) << run.error().message;
  EXPECT_NE(run.error().message.find("4 attempts"), std::string::npos) << run.error().message;
  EXPECT_EQ(g.reads, 1500 + 3) << "gives up after max_attempts consecutive failures";
}

TEST(Poller, UnreachableGaugeFailsAfterTheConfiguredAttempts) {
  ScriptedGauge g;
  g.fail_connects = 100;
  PollerSettings s = fast_settings();
  s.max_attempts = 3;
  Poller p(g, s);
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_EQ(g.connects, 3);
  EXPECT_EQ(g.reads, 0);
}

TEST(Poller, RecoversWhenTheGaugeComesBackBeforeTheAttemptsRunOut) {
  ScriptedGauge g;
  g.fail_connects = 2;
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(g.connects, 3);
}

TEST(Poller, TooSlowAPollRateLeavesDegreesMissingAndNamesThem) {
  ScriptedGauge g;
  g.step_deg = 1.5;  // polls further apart than max_interpolation_gap_deg (1 deg): never invent degrees
  Poller p(g, fast_settings());
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("only 0 of 3 revolutions"), std::string::npos) << run.error().message;
  EXPECT_NE(run.error().message.find("missing degrees 0-359"), std::string::npos) << run.error().message;
}

TEST(Poller, RefusesFewerThanThreeRevolutions) {
  ScriptedGauge g;
  PollerSettings s = fast_settings();
  s.revolutions = 2;
  Poller p(g, s);
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(g.reads, 0);
}

TEST(Poller, ReportsEachCompletedRevolution) {
  ScriptedGauge g;
  Poller p(g, fast_settings());
  std::vector<int> seen;
  p.set_on_revolution([&](int n) { seen.push_back(n); });
  ASSERT_TRUE(p.measure().ok());
  EXPECT_EQ(seen, (std::vector<int>{1, 2, 3}));
}

// Latched mode: each entry is the reading at its degree, so values must match exactly.

TEST(LatchedPoller, DrainsWholeRevolutionsFromDegreeZero) {
  ScriptedGauge g;
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  EXPECT_EQ(run->discarded_revolutions, 0);
  for (size_t i = 1; i < 3; ++i) EXPECT_GT(run->revolutions[i].revolution, run->revolutions[i - 1].revolution);
  // Marks 0..259 precede the first degree 0 (mark k is degree (k + 100) % 360), so
  // revolution n holds marks 260 + 360 n + d. Values match exactly: nothing is interpolated.
  for (size_t n = 0; n < 3; ++n) {
    for (int d = 0; d < 360; ++d) {
      ASSERT_EQ(run->revolutions[n].lift_mm[d], g.latched_mm(260 + 360 * n + static_cast<std::uint64_t>(d)))
          << "revolution " << n << " degree " << d;
    }
  }
  EXPECT_LT(g.latch_count, 1000000u) << "the 32-bit latch count wrapped during the run";
}

TEST(LatchedPoller, BufferOverrunDiscardsTheRevolution) {
  ScriptedGauge g;
  g.latch_faults[130] = Fault::kSkip;  // 130 * 7 = 910 marks in: the second revolution
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
  EXPECT_EQ(run->revolutions.size(), 3u);
}

TEST(LatchedPoller, DegreeJumpDiscardsTheRevolution) {
  ScriptedGauge g;
  g.latch_faults[80] = Fault::kAngleBack;
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
}

TEST(LatchedPoller, OverRangeDiscardsTheRevolution) {
  ScriptedGauge g;
  g.latch_faults[80] = Fault::kOverRange;
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 1);
}

TEST(LatchedPoller, ReconnectsAfterATimeout) {
  ScriptedGauge g;
  g.latch_faults[80] = Fault::kTimeout;
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->reconnects, 1);
  EXPECT_EQ(run->discarded_revolutions, 1);
}

TEST(LatchedPoller, GaugeThatStopsAnsweringFails) {
  ScriptedGauge g;
  g.latch_faults[130] = Fault::kTimeout;
  g.latch_dead_after_faults = true;
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(run.error().message.find("stopped answering during revolution 2 of 3"), std::string::npos)
      << run.error().message;
}

TEST(LatchedPoller, TooManyBadRevolutionsFailsNamingTheLast) {
  ScriptedGauge g;
  for (int k = 60; k < 2000; k += 40) g.latch_faults[k] = Fault::kOverRange;  // every revolution
  Poller p(g, fast_settings(SamplingMode::kLatched));
  Result<MeasuredRun> run = p.measure();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("over-range"), std::string::npos) << run.error().message;
}

// On a manual clock that moves 1 ms at every reading, a run that cannot finish in its
// timeout fails at the first check past it; no time passes but the clock's own ticks.
TEST(RunTimeout, ARunLongerThanItsTimeoutFailsNamingIt) {
  for (SamplingMode mode : {SamplingMode::kLive, SamplingMode::kLatched}) {
    SCOPED_TRACE(sampling_mode_name(mode));
    ScriptedGauge g;
    g.step_deg = 0.05;     // live: 7200 polls a revolution, half a degree well within stale_after
    g.marks_per_poll = 1;  // latched: one mark a poll
    PollerSettings s = fast_settings(mode);
    s.run_timeout = std::chrono::milliseconds(1000);
    ManualClock clock;
    clock.set_tick(std::chrono::milliseconds(1));
    Poller p(g, s, clock);
    Result<MeasuredRun> run = p.measure();
    ASSERT_FALSE(run.ok());
    EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
    EXPECT_NE(run.error().message.find("run timed out after 1000 ms (as set) during revolution 1 of 3"),
              std::string::npos)
        << run.error().message;
    const Clock::duration ended = clock.now() - Clock::time_point{};
    EXPECT_GT(ended, std::chrono::milliseconds(1000));
    EXPECT_LT(ended, std::chrono::milliseconds(1020));
    for (Clock::duration slept : clock.sleeps()) EXPECT_EQ(slept, Clock::duration::zero());
  }
}

// Live mode, on a manual clock: the spindle stops in revolution 1 while the amplifier goes on
// sampling once every four polls (three polls in four read the sample before again), so the
// poll that meets the end of the patience is most likely one of the same sample number. The
// run still names the spindle, which stood while the amplifier sampled; an amplifier that
// stands as well is named as the amplifier.
TEST(Poller, AStoppedSpindleIsNamedWhicheverPollMeetsTheEndOfThePatience) {
  for (const int sample_every : {4, 0}) {
    SCOPED_TRACE("a new sample every " + std::to_string(sample_every) + " polls (0: none)");
    ScriptedGauge g;
    g.stand_from_read = 1500;  // 450 deg in: revolution 1
    g.sample_every = sample_every;
    ManualClock clock;
    clock.set_tick(std::chrono::milliseconds(1));
    Poller p(g, fast_settings(), clock);
    Result<MeasuredRun> run = p.measure();
    ASSERT_FALSE(run.ok());
    EXPECT_EQ(run.error().code, ErrorCode::kGaugeTimeout) << run.error().message;
    EXPECT_NE(run.error().message.find("stood still during revolution 1"), std::string::npos) << run.error().message;
    const std::string named = sample_every > 0 ? "its angle stayed at" : "its sample number stayed at";
    EXPECT_NE(run.error().message.find(named), std::string::npos) << run.error().message;
  }
}

// (revolutions + spares + 2) revolutions at the speed, at least 10 s; or as set.
TEST(RunTimeout, FollowsTheSpeedAndTheRevolutions) {
  PollerSettings s;  // 3 revolutions, 3 spares: 8 revolutions
  EXPECT_EQ(run_timeout_at(s, 3.0), std::chrono::milliseconds(160000)) << "20 s a revolution";
  EXPECT_EQ(run_timeout_at(s, 600.0), kRunTimeoutFloor);
  EXPECT_EQ(run_timeout_at(s, 0.0), kRunTimeoutFloor) << "speed not seen yet";
  s.revolutions = 70;
  EXPECT_EQ(run_timeout_at(s, 60.0), std::chrono::milliseconds(75000));
  s.run_timeout = std::chrono::milliseconds(5000);
  EXPECT_EQ(run_timeout_at(s, 3.0), std::chrono::milliseconds(5000)) << "set by the user";
}

// A rate read across a stall of the poller reads fast: the budget keeps the slowest speed seen,
// so such a reading never cuts the run (or the patience) short.
TEST(RunTimeout, KeepsTheSlowestSpeedSeen) {
  PollerSettings s;  // 8 revolutions
  RunBudget budget(s, Clock::time_point{});
  EXPECT_EQ(budget.run_timeout(), kRunTimeoutFloor) << "speed not seen yet";
  budget.saw_speed(0.25);  // 15 rpm: 4 s a revolution
  EXPECT_EQ(budget.run_timeout(), std::chrono::milliseconds(32000));
  budget.saw_speed(1.25);  // a reading five times too fast
  EXPECT_EQ(budget.run_timeout(), std::chrono::milliseconds(32000));
  EXPECT_EQ(budget.revolution(), std::chrono::seconds(4));
  budget.saw_speed(0.0);  // unknown: ignored
  EXPECT_EQ(budget.run_timeout(), std::chrono::milliseconds(32000));
  budget.saw_speed(0.125);  // slower still: taken
  EXPECT_EQ(budget.run_timeout(), std::chrono::milliseconds(64000));
}

TEST(DegreeRanges, FormatsRuns) {
  EXPECT_EQ(format_degree_ranges({}), "none");
  EXPECT_EQ(format_degree_ranges({3}), "3");
  EXPECT_EQ(format_degree_ranges({1, 2, 3, 7, 9, 10}), "1-3, 7, 9-10");
}

}  // namespace
}  // namespace gaugeloop
