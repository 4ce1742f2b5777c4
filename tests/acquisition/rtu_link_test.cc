// Modbus RTU: the poller and the simulator on the two ends of a pseudo-terminal pair made
// by socat, the simulator holding each reply back for its line time at 115200 baud.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "acquisition/poller.h"
#include "core/lift_table.h"
#include "simulator/gauge_simulator.h"
#include "tests/support/intake_simulator.h"
#include "tests/support/pty_pair.h"

namespace gaugeloop {
namespace {

using testing::PtyPair;

std::unique_ptr<GaugeSimulator> start_rtu_sim(const std::string& device, double rpm) {
  SimulatorSettings ss;
  ss.rtu_device = device;
  ss.unit_id = 7;
  ss.speed_rpm = rpm;
  auto sim = testing::start_intake_simulator(ss);
  EXPECT_TRUE(sim.ok()) << sim.error().message;
  return sim.ok() ? std::move(*sim) : nullptr;
}

ModbusSettings rtu_settings(const std::string& device, int unit_id) {
  ModbusSettings ms;
  ms.transport = ModbusTransport::kRtu;
  ms.device = device;
  ms.baud = 115200;
  ms.unit_id = unit_id;
  // A loaded machine (tests run twice the cores at a time, a build beside them) can hold the
  // simulator's thread or socat for tens of milliseconds: the margin is a second, not the
  // 100 ms a quiet line needs (both tests failed once at 100 ms under such load).
  ms.response_timeout = std::chrono::milliseconds(1000);
  return ms;
}

// As above: a stall of the simulator under load is not a frozen amplifier, and the run may
// take longer than on a quiet machine.
PollerSettings loaded_machine_poller() {
  PollerSettings ps;
  ps.stale_after = std::chrono::milliseconds(1000);
  ps.run_timeout = std::chrono::milliseconds(60000);
  return ps;
}

TEST(RtuLink, LatchedRunOverAPtyPair) {
  PtyPair pty;
  ASSERT_TRUE(pty.ok()) << "socat did not make a pty pair (socat: scripts/install-deps.sh)";
  auto sim = start_rtu_sim(pty.simulator_end(), 60.0);
  ASSERT_NE(sim, nullptr);
  ModbusGauge gauge(rtu_settings(pty.gauge_end(), 7));
  EXPECT_NE(gauge.address().find("rtu:" + pty.gauge_end() + "@115200"), std::string::npos) << gauge.address();
  Poller poller(gauge, loaded_machine_poller());
  Result<MeasuredRun> run = poller.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  // The lobe plus the 0.25 mm gauge offset (see SimulatorLink tests).
  for (const auto& rev : run->revolutions) {
    EXPECT_NEAR(rev.lift_mm[0], 8.75, 0.05);
    EXPECT_NEAR(rev.lift_mm[180], 0.25, 0.05);
  }
}

// Compact latch entries over the bus: 2 registers a degree instead of 4.
TEST(RtuLink, CompactLatchedRunOverAPtyPair) {
  PtyPair pty;
  ASSERT_TRUE(pty.ok()) << "socat did not make a pty pair (socat: scripts/install-deps.sh)";
  auto sim = start_rtu_sim(pty.simulator_end(), 60.0);
  ASSERT_NE(sim, nullptr);
  ModbusSettings ms = rtu_settings(pty.gauge_end(), 7);
  ms.map = testing::compact_simulator_map();
  ModbusGauge gauge(ms);
  Poller poller(gauge, loaded_machine_poller());
  Result<MeasuredRun> run = poller.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->revolutions.size(), 3u);
  EXPECT_EQ(run->discarded_revolutions, 0);
  for (const auto& rev : run->revolutions) {
    for (int d = 0; d < 360; ++d) ASSERT_NEAR(rev.lift_mm[d], sim->true_lift_mm(d) + 0.25, 0.002) << "degree " << d;
  }
}

TEST(RtuLink, WrongUnitIdTimesOut) {
  PtyPair pty;
  ASSERT_TRUE(pty.ok()) << "socat did not make a pty pair";
  auto sim = start_rtu_sim(pty.simulator_end(), 60.0);
  ASSERT_NE(sim, nullptr);
  ModbusGauge gauge(rtu_settings(pty.gauge_end(), 3));  // the simulator answers to unit 7 only
  ASSERT_TRUE(gauge.connect().ok());
  Result<GaugeSnapshot> s = gauge.read_snapshot();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(s.error().message.find("unit 3"), std::string::npos) << s.error().message;
}

TEST(RtuLink, MissingSerialDeviceIsUnreachable) {
  ModbusGauge gauge(rtu_settings("/dev/nonexistent-gauge", 1));
  Status s = gauge.connect();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_NE(s.error().message.find("/dev/nonexistent-gauge"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace gaugeloop
