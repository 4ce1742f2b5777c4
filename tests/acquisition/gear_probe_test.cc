// The gear flank probe over a real Modbus TCP socket on loopback, against the virtual machine's
// probe: the lead it reads is the virtual checker's to the register's 1 nm, and each fault of
// the probe cycle or the link is an error naming the point and the register, or is ridden out.
#include "acquisition/gear_probe.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "compensation/gear_coupling.h"
#include "core/gear_probe_registers.h"
#include "nc_out/stroke_program.h"
#include "simulator/gear_grinder.h"
#include "simulator/gear_probe_simulator.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

// The paper's gear (module 2.25, 71 teeth, helix 21.8 deg, face 24 mm) ground on machine seed 3
// from a stroke with SIM1 at 0: a lead of about 17 um.
GroundGear ground_gear(const testing::TempDir& dir) {
  GearPart part;
  std::vector<StrokeProgramPoint> points;
  for (double z = part.stroke.z_start_mm; z <= part.stroke.z_end_mm + 1e-9; z += part.stroke.spline_step_mm) {
    points.push_back({z, 0.0});
  }
  Result<std::string> text = render_stroke_program("GEAR", {}, points, 300.0, StrokeProgramFormat{});
  EXPECT_TRUE(text.ok()) << text.error().message;
  const std::filesystem::path file = dir.path() / "GEAR.SPF";
  std::ofstream(file, std::ios::binary) << *text;
  Result<GroundGear> gear = grind_gear(part, seeded_gear_machine(3), file.string());
  EXPECT_TRUE(gear.ok()) << gear.error().message;
  return std::move(*gear);
}

class GearProbeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<std::unique_ptr<GearProbeSimulator>> sim = GearProbeSimulator::start({});
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
    settings_.link.port = sim_->port();
    settings_.link.response_timeout = std::chrono::milliseconds(2000);
  }

  testing::TempDir dir_{"gear-probe"};
  std::unique_ptr<GearProbeSimulator> sim_;
  GearProbeSettings settings_;
};

TEST_F(GearProbeTest, TheLeadOverModbusIsTheCheckersToTheRegistersNanometre) {
  const GroundGear gear = ground_gear(dir_);
  sim_->load_gear(gear, 7);
  GearProbe probe(settings_);
  ASSERT_TRUE(probe.connect().ok());
  std::vector<double> heights;
  for (int i = 0; i <= 48; ++i) heights.push_back(-12.0 + 0.5 * i);
  Result<std::vector<LeadTrace>> probed = probe.measure_lead({1, 40}, heights);
  ASSERT_TRUE(probed.ok()) << probed.error().message;
  const std::vector<LeadTrace> checked = measure_lead(gear, {1, 40}, 0.5, 7);
  ASSERT_EQ(probed->size(), 4u);
  ASSERT_EQ(checked.size(), 4u);
  double largest = 0.0;
  for (std::size_t t = 0; t < 4; ++t) {
    EXPECT_EQ((*probed)[t].gap, checked[t].gap);
    EXPECT_EQ((*probed)[t].flank, checked[t].flank);
    ASSERT_EQ((*probed)[t].z_mm.size(), 49u);
    for (std::size_t i = 0; i < 49; ++i) {
      EXPECT_NEAR((*probed)[t].z_mm[i], checked[t].z_mm[i], 1e-9);
      // Each point rounded to the register's 1 nm (0.5 nm at most), and the trace's mean taken
      // out of rounded and unrounded values alike (0.5 nm at most): 1 nm.
      EXPECT_NEAR((*probed)[t].deviation_um[i], checked[t].deviation_um[i], 1e-3);
      largest = std::max(largest, std::abs(checked[t].deviation_um[i]));
    }
  }
  EXPECT_GT(largest, 5.0) << "the lead read is the gear's, not zeros";
  EXPECT_EQ(probe.points_measured(), 4 * 49);
  EXPECT_EQ(sim_->points_answered(), 4 * 49);
}

// The machine keeps its answer word between gaugeloop's sessions: a new session's first point
// must not take the last session's answer for its own.
TEST_F(GearProbeTest, ANewSessionNeverTakesTheLastSessionsAnswer) {
  sim_->load_gear(ground_gear(dir_), 1);
  {
    GearProbe first(settings_);
    Result<ProbedPoint> p = first.measure_point(1, Flank::kLeft, 0.0);
    ASSERT_TRUE(p.ok()) << p.error().message;
  }
  GearProbe second(settings_);
  Result<ProbedPoint> q = second.measure_point(1, Flank::kLeft, 5.0);
  ASSERT_TRUE(q.ok()) << q.error().message;
  EXPECT_NEAR(q->z_mm, 5.0, 1e-9);
  EXPECT_EQ(sim_->points_answered(), 2);
}

TEST_F(GearProbeTest, AStalledProbeCycleTimesOutNamingThePointAndTheAnswerRegister) {
  sim_->load_gear(ground_gear(dir_), 1);
  settings_.base_address = 0;
  settings_.point_timeout = std::chrono::milliseconds(500);
  ManualClock clock;
  clock.set_tick(std::chrono::milliseconds(1));  // each look at the clock is a millisecond later
  GearProbe probe(settings_, clock);
  ASSERT_TRUE(probe.measure_point(1, Flank::kLeft, 0.0).ok());
  sim_->set_stalled(true);
  Result<ProbedPoint> p = probe.measure_point(20, Flank::kRight, 3.5);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(p.error().message.find("gap 20, right flank, Z 3.5000 mm within 500 ms"), std::string::npos)
      << p.error().message;
  EXPECT_NE(p.error().message.find("register 5 (answer sequence) holds 1 where 2 was asked"), std::string::npos)
      << p.error().message;
  // The cycle answers again: the next point is measured, not taken for the stalled one.
  sim_->set_stalled(false);
  Result<ProbedPoint> next = probe.measure_point(20, Flank::kRight, 4.0);
  ASSERT_TRUE(next.ok()) << next.error().message;
  EXPECT_NEAR(next->z_mm, 4.0, 1e-9);
}

TEST_F(GearProbeTest, AStatusBitIsAnErrorNamingItAndThePoint) {
  GearProbe probe(settings_);
  // No gear on the machine yet: the probe reports a fault.
  Result<ProbedPoint> empty = probe.measure_point(1, Flank::kLeft, 0.0);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code, ErrorCode::kIncompleteRun);
  EXPECT_NE(empty.error().message.find("probe fault (register 6)"), std::string::npos) << empty.error().message;
  sim_->load_gear(ground_gear(dir_), 1);
  sim_->set_status(gear_probe_registers::kNoContact);
  Result<ProbedPoint> no_contact = probe.measure_point(2, Flank::kRight, -1.25);
  ASSERT_FALSE(no_contact.ok());
  EXPECT_NE(no_contact.error().message.find("could not measure gap 2, right flank, Z -1.2500 mm: no contact"),
            std::string::npos)
      << no_contact.error().message;
  sim_->set_status(0);
  // A gap the gear does not have, a height off the face: out of reach.
  Result<ProbedPoint> gap = probe.measure_point(72, Flank::kLeft, 0.0);
  ASSERT_FALSE(gap.ok());
  EXPECT_NE(gap.error().message.find("out of reach"), std::string::npos) << gap.error().message;
  Result<ProbedPoint> high = probe.measure_point(1, Flank::kLeft, 12.5);
  ASSERT_FALSE(high.ok());
  EXPECT_NE(high.error().message.find("out of reach"), std::string::npos) << high.error().message;
  EXPECT_TRUE(probe.measure_point(1, Flank::kLeft, 12.0).ok());
}

TEST_F(GearProbeTest, ALinkLostBetweenPointsIsOpenedAgainAndTheLeadCompletes) {
  sim_->load_gear(ground_gear(dir_), 1);
  GearProbe probe(settings_);
  ASSERT_TRUE(probe.measure_point(1, Flank::kLeft, 0.0).ok());
  sim_->drop_connections();  // returns once the server has closed the link
  Result<std::vector<LeadTrace>> lead = probe.measure_lead({1}, {-1.0, 0.0, 1.0});
  ASSERT_TRUE(lead.ok()) << lead.error().message;
  EXPECT_EQ(lead->size(), 2u);
  EXPECT_EQ(probe.reconnects(), 1);
}

TEST_F(GearProbeTest, NoMachineAndBadRequestsAreRefusedClearly) {
  const int port = sim_->port();
  sim_->stop();
  GearProbeSettings nobody = settings_;
  nobody.link.port = port;
  nobody.reconnects = 0;
  GearProbe probe(nobody);
  Result<ProbedPoint> p = probe.measure_point(1, Flank::kLeft, 0.0);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_NE(p.error().message.find("gear probe"), std::string::npos) << p.error().message;
  Result<ProbedPoint> gap0 = probe.measure_point(0, Flank::kLeft, 0.0);
  ASSERT_FALSE(gap0.ok());
  EXPECT_EQ(gap0.error().code, ErrorCode::kInvalidInput);
  Result<std::vector<LeadTrace>> down = probe.measure_lead({1}, {1.0, 0.0, -1.0});
  ASSERT_FALSE(down.ok());
  EXPECT_NE(down.error().message.find("must increase"), std::string::npos) << down.error().message;
}

}  // namespace
}  // namespace gaugeloop
