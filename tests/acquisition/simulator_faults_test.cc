// Every fault the simulator injects, met by the poller over a real loopback link: latched
// runs, and live runs that fail by design (live runs that must complete are in
// live_link_test.cc, at a spindle speed a loaded machine keeps up with). Faults are scheduled
// in spindle revolutions after the first request, so they fall inside the run whatever the
// machine's speed. The simulated spindle turns 60 rpm at 4x time scale: a revolution takes
// 250 ms of wall time.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "acquisition/poller.h"
#include "core/lift_table.h"
#include "outage_faults.h"
#include "simulator/gauge_simulator.h"
#include "tests/support/intake_simulator.h"

namespace gaugeloop {
namespace {

class SimulatorFaultTest : public ::testing::Test {
 protected:
  // Starts a simulator with `fault` and measures one latched run through it.
  Result<MeasuredRun> measure_with(const char* fault_text,
                                   std::chrono::milliseconds response_timeout = std::chrono::milliseconds(100),
                                   const RegisterMap& map = RegisterMap{}, SamplingMode mode = SamplingMode::kLatched) {
    SimulatorSettings ss;
    ss.time_scale = 4.0;
    Result<FaultSpec> fault = parse_fault_spec(fault_text);
    EXPECT_TRUE(fault.ok()) << fault.error().message;
    ss.faults.push_back(*fault);
    auto sim = testing::start_intake_simulator(ss);
    EXPECT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
    ModbusSettings ms;
    ms.port = sim_->port();
    ms.response_timeout = response_timeout;
    ms.map = map;
    ModbusGauge gauge(ms);
    PollerSettings ps = poller_settings_;
    ps.mode = mode;
    ps.backoff_initial = std::chrono::milliseconds(10);
    ps.backoff_max = std::chrono::milliseconds(100);
    Poller poller(gauge, ps);
    return poller.measure();
  }

  // The revolutions read the lobe: 8.5 mm nose + 0.25 mm gauge offset, 0.25 mm base circle,
  // within 0.05 mm (the 15 um form error and 0.3 um noise are far inside).
  static void expect_lobe(const MeasuredRun& run) {
    ASSERT_EQ(run.revolutions.size(), 3u);
    for (const auto& rev : run.revolutions) {
      EXPECT_NEAR(rev.lift_mm[0], 8.75, 0.05);
      EXPECT_NEAR(rev.lift_mm[180], 0.25, 0.05);
    }
  }

  std::unique_ptr<GaugeSimulator> sim_;
  PollerSettings poller_settings_;
};

// An outage of up to a revolution costs the revolutions it touches, never the run: the link
// is waited out for 2 revolutions, the failure count restarts at every good reply, and the
// stale timer does not count the time the link was down. A whole revolution of refused
// connections or exception replies spans more than the 5 attempts of the backoff (10, 20,
// 40, 80 ms), and a freeze of a revolution more than one stale period (200 ms).
class OutageTest : public SimulatorFaultTest, public ::testing::WithParamInterface<const char*> {};

TEST_P(OutageTest, AnOutageOfUpToARevolutionIsAbsorbedInLatchedMode) {
  Result<MeasuredRun> run = measure_with(GetParam());
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->reconnects, 1);
  EXPECT_GE(run->discarded_revolutions, 1);
  expect_lobe(*run);
}

INSTANTIATE_TEST_SUITE_P(SimulatorFaults, OutageTest, ::testing::ValuesIn(testing::kOutagesUpToARevolution),
                         testing::fault_test_name);

// 45 revolutions at 250 ms take over 11 s, longer than the shortest run timeout (10 s): the
// timeout follows the speed seen (50 revolutions: 12.5 s).
TEST_F(SimulatorFaultTest, ARunLongerThanTheShortestTimeoutCompletes) {
  poller_settings_.revolutions = 45;
  Result<MeasuredRun> run = measure_with("drift@1000");  // a fault that never comes
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->revolutions.size(), 45u);
}

// A timeout set by hand is taken as set and says so; 300 ms cannot hold 3 revolutions of
// 250 ms, whatever the machine's load.
TEST_F(SimulatorFaultTest, ARunTimeoutSetByHandIsNamed) {
  poller_settings_.run_timeout = std::chrono::milliseconds(300);
  Result<MeasuredRun> run = measure_with("drift@1000");
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("run timed out after 300 ms (as set) during revolution"), std::string::npos)
      << run.error().message;
}

// A link that stays down is named as the link, not as a frozen amplifier.
TEST_F(SimulatorFaultTest, ALastingSilenceIsNamedAsTheLink) {
  Result<MeasuredRun> run = measure_with("silent@1.5");
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(run.error().message.find("stopped answering"), std::string::npos) << run.error().message;
  EXPECT_NE(run.error().message.find("no reply within 100 ms"), std::string::npos) << run.error().message;
  EXPECT_EQ(run.error().message.find("frozen"), std::string::npos) << run.error().message;
}

// An amplifier that stands still while the link answers fails the run as a freeze, after
// 5 stale periods and 2 revolutions, well before the run timeout (at least 10 s); `what`
// says what stood still.
void expect_freeze_named(const Result<MeasuredRun>& run, const char* what) {
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(run.error().message.find("stood still during revolution"), std::string::npos) << run.error().message;
  EXPECT_NE(run.error().message.find(what), std::string::npos) << run.error().message;
}

TEST_F(SimulatorFaultTest, ALastingFreezeFailsTheRunNamingItInLatchedMode) {
  expect_freeze_named(measure_with("frozen@1.5"), "latch count stayed at");
}

// Live mode: the next poll after a reconnect meets the same sample number and is no new
// sample, so the freeze is found as in latched mode.
TEST_F(SimulatorFaultTest, ALastingFreezeFailsTheRunNamingItInLiveMode) {
  expect_freeze_named(measure_with("frozen@1.5", std::chrono::milliseconds(100), RegisterMap{}, SamplingMode::kLive),
                      "sample number stayed at");
}

// The spindle stops for good (speed drift of -100 %) while the amplifier keeps sampling:
// latched, the latch count stands; live, the angle does.
TEST_F(SimulatorFaultTest, AStoppedSpindleFailsTheRunNamingItInBothModes) {
  expect_freeze_named(measure_with("drift@1.5:-100"), "latch count stayed at");
  expect_freeze_named(
      measure_with("drift@1.5:-100", std::chrono::milliseconds(100), RegisterMap{}, SamplingMode::kLive),
      "angle stayed at");
}

// A status that stays bad is named, with its degrees, in live mode too.
TEST_F(SimulatorFaultTest, ALastingBadStatusIsNamedInLiveMode) {
  Result<MeasuredRun> run =
      measure_with("under-range@0.5", std::chrono::milliseconds(100), RegisterMap{}, SamplingMode::kLive);
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("gauge status under-range at degrees 0-359"), std::string::npos)
      << run.error().message;
}

// An amplifier whose status word is 0 when all is well and has a bit for each fault of its
// own (the simulator's register 9), described by an ok value and the bits' names.
TEST_F(SimulatorFaultTest, AStatusWordWithAnOkValueIsNamedByItsBits) {
  RegisterMap map;
  map.status.address = sim_registers::kStatusCode;
  map.masks.ok_value = 0;
  map.masks.bit_names[0] = "lever over-range";
  map.masks.bit_names[3] = "amplifier not ready";
  map.latch.present = false;
  Result<MeasuredRun> run = measure_with("over-range@0.5", std::chrono::milliseconds(100), map, SamplingMode::kLive);
  ASSERT_FALSE(run.ok());
  EXPECT_NE(run.error().message.find("gauge status lever over-range at degrees"), std::string::npos)
      << run.error().message;
}

TEST_F(SimulatorFaultTest, ConnectionDroppedMidRunReconnects) {
  Result<MeasuredRun> run = measure_with("drop@1.5");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->reconnects, 1);
  EXPECT_GE(run->discarded_revolutions, 1);
  expect_lobe(*run);
}

TEST_F(SimulatorFaultTest, PermanentExceptionFailsNamingIt) {
  Result<MeasuredRun> run = measure_with("exception@1.5:4");
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kGaugeProtocol);
  EXPECT_NE(run.error().message.find("stopped answering"), std::string::npos) << run.error().message;
  EXPECT_NE(run.error().message.find("failure"), std::string::npos)
      << "exception 4, server failure: " << run.error().message;
}

// A reply 300 ms late on a 100 ms timeout. Unflushed, it would be taken as the answer to
// the next request and every value after it would be one request stale; the values below
// show it was not.
TEST_F(SimulatorFaultTest, LateReplyIsFlushedNotMistakenForTheNext) {
  Result<MeasuredRun> run = measure_with("late@1.5:300");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->reconnects, 1);
  expect_lobe(*run);
  for (int d = 0; d < 360; ++d) {
    ASSERT_NEAR(run->revolutions[2].lift_mm[d], run->revolutions[0].lift_mm[d], 0.0021) << "degree " << d;
  }
}

TEST_F(SimulatorFaultTest, FrozenAmplifierIsDetectedAndItsRevolutionDropped) {
  Result<MeasuredRun> run = measure_with("frozen@1.5+1.5");  // 375 ms: longer than stale_after (200 ms)
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->reconnects, 1) << "a latch count that stands still is a fault: the link is reset";
  EXPECT_GE(run->discarded_revolutions, 1);
  expect_lobe(*run);
}

TEST_F(SimulatorFaultTest, OverRangeDiscardsTheRevolutionItTouches) {
  Result<MeasuredRun> run = measure_with("over-range@1.5+0.2");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->discarded_revolutions, 1);
  EXPECT_EQ(run->reconnects, 0);
  expect_lobe(*run);
}

TEST_F(SimulatorFaultTest, ProbeMissingDiscardsTheRevolutionItTouches) {
  Result<MeasuredRun> run = measure_with("probe-missing@1.5+0.2");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->discarded_revolutions, 1);
  expect_lobe(*run);
}

TEST_F(SimulatorFaultTest, UnderRangeForGoodFailsTheRunNamingIt) {
  Result<MeasuredRun> run = measure_with("under-range@0.5");
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("gauge status under-range at degrees 0-359"), std::string::npos)
      << run.error().message;
}

// The encoder loses 30 degrees: the revolution it happens in is discarded, and later ones
// are taken as they come, labelled by the jumped encoder: degree d then reads the lobe at
// d - 30 (the analysis reports such a shift as a phase error).
TEST_F(SimulatorFaultTest, AngleJumpDiscardsThatRevolution) {
  Result<MeasuredRun> run = measure_with("jump@1.5:30");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->discarded_revolutions, 1);
  const auto& last = run->revolutions.back();
  EXPECT_NEAR(last.lift_mm[30], sim_->true_lift_mm(0.0) + 0.25, 0.002);
}

// Latched samples are taken per degree, whatever the speed: drift costs nothing.
TEST_F(SimulatorFaultTest, SpeedDriftLeavesLatchedRunsWhole) {
  Result<MeasuredRun> run = measure_with("drift@0.5+5:10");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 0);
  expect_lobe(*run);
}

// Compact latch entries (the reading alone, the degree implied by the latch count): the
// same faults, caught without a degree or status word in the entries.
class CompactLatchFaultTest : public SimulatorFaultTest {
 protected:
  Result<MeasuredRun> measure_compact(const char* fault_text) {
    return measure_with(fault_text, std::chrono::milliseconds(100), testing::compact_simulator_map());
  }
};

// No fault at all: each degree holds the lobe at that degree, so the degrees implied by the
// count are the machine's (a shift of one degree would be off by up to 0.1 mm on the flanks).
TEST_F(CompactLatchFaultTest, CleanRunReadsEachDegreeWhereItIs) {
  Result<MeasuredRun> run = measure_compact("drift@100");  // a fault that never comes
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->discarded_revolutions, 0);
  expect_lobe(*run);
  for (const auto& rev : run->revolutions) {
    for (int d = 0; d < 360; ++d) {
      ASSERT_NEAR(rev.lift_mm[d], sim_->true_lift_mm(d) + 0.25, 0.002) << "degree " << d;
    }
  }
}

TEST_F(CompactLatchFaultTest, OverRangeIsCaughtByTheFaultMarkCounter) {
  Result<MeasuredRun> run = measure_compact("over-range@1.5+0.2");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->discarded_revolutions, 1);
  EXPECT_EQ(run->reconnects, 0);
  expect_lobe(*run);
}

TEST_F(CompactLatchFaultTest, ProbeMissingForGoodFailsTheRunNamingIt) {
  Result<MeasuredRun> run = measure_compact("probe-missing@0.5");
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(run.error().message.find("probe missing between degrees"), std::string::npos) << run.error().message;
}

// 100 ms: shorter than stale_after, so the poller does not reconnect; on recovery the count
// jumps over ring slots still holding readings of 2.8 revolutions ago. Nothing in a compact
// entry shows that; the fault mark counter counts them as lost.
TEST_F(CompactLatchFaultTest, ABriefFreezeLeavesNoOldReadingInARun) {
  Result<MeasuredRun> run = measure_compact("frozen@1.5+0.4");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_GE(run->discarded_revolutions, 1);
  expect_lobe(*run);
  for (const auto& rev : run->revolutions) {
    for (int d = 0; d < 360; ++d) {
      ASSERT_NEAR(rev.lift_mm[d], sim_->true_lift_mm(d) + 0.25, 0.002)
          << "revolution " << rev.revolution << " degree " << d;
    }
  }
}

TEST_F(CompactLatchFaultTest, ConnectionDroppedMidRunReconnects) {
  Result<MeasuredRun> run = measure_compact("drop@1.5");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->reconnects, 1);
  EXPECT_GE(run->discarded_revolutions, 1);
  expect_lobe(*run);
}

// The encoder has jumped before the run: the count (marks from the index) and the angle
// disagree by 30 degrees, so the count cannot be trusted to give the degree. Refused.
TEST_F(CompactLatchFaultTest, ACountOutOfStepWithTheEncoderIsRefused) {
  Result<MeasuredRun> run = measure_compact("jump@0:30");
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(run.error().message.find("zeroed at the encoder's index pulse"), std::string::npos) << run.error().message;
}

TEST(FaultSpec, ParsesTheTextForm) {
  auto f = parse_fault_spec("over-range@1.5+0.25");
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->kind, FaultKind::kOverRange);
  EXPECT_DOUBLE_EQ(f->start_rev, 1.5);
  EXPECT_DOUBLE_EQ(f->duration_rev, 0.25);
  f = parse_fault_spec("late@2:300");
  ASSERT_TRUE(f.ok());
  EXPECT_DOUBLE_EQ(f->param, 300.0);
  EXPECT_LT(f->duration_rev, 0.0);
  for (const char* bad : {"overrange@1", "silent", "drop@1+2", "silent@-1", "silent@1+0", "late@1:x"}) {
    auto b = parse_fault_spec(bad);
    ASSERT_FALSE(b.ok()) << bad;
    EXPECT_NE(b.error().message.find("KIND@START"), std::string::npos) << b.error().message;
  }
}

}  // namespace
}  // namespace gaugeloop
