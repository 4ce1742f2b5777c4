// The virtual grinder's machine error model, term by term, on the sample intake lobe.
#include "simulator/virtual_grinder.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "compensation/work_speed.h"
#include "simulator/gauge_simulator.h"
#include "tests/support/intake_simulator.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

// A model with every term off; each test turns on the one it is about.
MachineErrorModel no_errors() {
  MachineErrorModel m = vibration_only(MachineErrorModel{});
  m.vibration_rms_um = 0.0;
  return m;
}

class VirtualGrinderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<LiftTable> design = testing::intake_table();
    ASSERT_TRUE(design.ok()) << design.error().message;
    design_ = *design;
    Result<CommandedPath> path = commanded_path_from_design(part_, design_);
    ASSERT_TRUE(path.ok()) << path.error().message;
    path_ = *path;
    Result<PeriodicSpline> lift = PeriodicSpline::fit(design_.angle_deg, design_.lift_mm);
    ASSERT_TRUE(lift.ok());
    Result<DegreeTable> reading = flat_probe_reading(*lift, part_);
    ASSERT_TRUE(reading.ok());
    design_reading_ = *reading;
  }

  TrueLiftError grind(const MachineErrorModel& m, int part_index = 0) {
    Result<GroundPart> g = grind_part(part_, path_, m, part_index);
    EXPECT_TRUE(g.ok()) << g.error().message;
    if (!g) return {};
    last_ = *g;
    return true_lift_error(g->reading_mm, design_reading_);
  }

  static int worst_degree(const TrueLiftError& e) {
    int worst = 0;
    for (int d = 0; d < 360; ++d) {
      if (std::abs(e.error_um[static_cast<size_t>(d)]) > std::abs(e.error_um[static_cast<size_t>(worst)])) worst = d;
    }
    return worst;
  }

  Part part_ = testing::intake_part();
  LiftTable design_;
  CommandedPath path_;
  DegreeTable design_reading_{};
  GroundPart last_;
};

// Tolerance 0.01 um: the envelope round trip (the cam-grinding kinematics) is exact to ~1e-6 um; the
// spline through the 0.1 deg path rows adds well under 0.01 um on this lobe.
TEST_F(VirtualGrinderTest, PerfectMachineGrindsTheDesign) {
  const TrueLiftError e = grind(no_errors());
  EXPECT_LT(e.max_abs_um, 0.01);
}

// The default model is the seed's uncompensated machine: about 16 um, mostly servo lag.
TEST_F(VirtualGrinderTest, DefaultModelGivesAbout16Um) {
  const TrueLiftError e = grind(MachineErrorModel{});
  EXPECT_GT(e.max_abs_um, 14.0);
  EXPECT_LT(e.max_abs_um, 18.0);
}

// Servo lag follows the acceleration where velocity is fed forward: largest where X reverses,
// at the nose (cam 0), doubling when the bandwidth drops by sqrt 2 and growing with the
// square of the work speed.
TEST_F(VirtualGrinderTest, ServoLagIsLargestWhereXReversesAndScalesWithTheAcceleration) {
  MachineErrorModel m = no_errors();
  m.servo_bandwidth_hz = MachineErrorModel{}.servo_bandwidth_hz;
  const TrueLiftError nominal = grind(m);
  const double servo_um = last_.largest_servo_error_um;
  const int worst = worst_degree(nominal);
  EXPECT_TRUE(worst <= 20 || worst >= 340) << "largest error at cam " << worst;
  EXPECT_GT(nominal.max_abs_um, 10.0);

  m.servo_bandwidth_hz /= std::sqrt(2.0);
  grind(m);
  EXPECT_NEAR(last_.largest_servo_error_um / servo_um, 2.0, 0.2);  // 1 / w^2 at low frequency

  m.servo_bandwidth_hz = MachineErrorModel{}.servo_bandwidth_hz;
  m.work_speed_rpm = 30.0;
  grind(m);
  EXPECT_NEAR(last_.largest_servo_error_um / servo_um, 0.25, 0.05);  // acceleration ~ speed^2
}

// Geometric error repeats with C: the followed path is the commanded one plus the two
// harmonics, exactly, wherever C is.
TEST_F(VirtualGrinderTest, GeometricErrorRepeatsWithC) {
  MachineErrorModel m = no_errors();
  m.geometric_once_um = 2.0;
  m.geometric_once_phase_deg = 0.0;
  m.geometric_twice_um = 1.0;
  m.geometric_twice_phase_deg = 90.0;
  grind(m);
  for (int k : {0, 450, 900, 2000}) {
    const double c = k * 0.1 * std::numbers::pi / 180.0;
    const double expected_um = 2.0 * std::cos(c) + 1.0 * std::cos(2.0 * c + std::numbers::pi / 2.0);
    EXPECT_NEAR((last_.followed_x_mm[static_cast<size_t>(k)] - path_.x_mm[static_cast<size_t>(k)]) * 1000.0,
                expected_um, 1e-9)
        << "C " << k * 0.1;
  }
}

// Drift grows part by part, most where X is largest.
TEST_F(VirtualGrinderTest, DriftGrowsWithEveryPart) {
  MachineErrorModel m = no_errors();
  m.drift_um_per_part = 0.2;
  const auto nose = static_cast<size_t>(std::max_element(path_.x_mm.begin(), path_.x_mm.end()) - path_.x_mm.begin());
  grind(m, 0);
  EXPECT_NEAR(last_.followed_x_mm[nose] - path_.x_mm[nose], 0.0, 1e-12);
  grind(m, 10);
  EXPECT_NEAR((last_.followed_x_mm[nose] - path_.x_mm[nose]) * 1000.0, 2.0, 1e-9);
}

// Vibration: the RMS asked for on the ground lift (tolerance 0.05 um: the envelope and the
// 1 deg sampling of the reading change it slightly), a new pattern every part, the same one
// for the same part and seed.
TEST_F(VirtualGrinderTest, VibrationHasItsRmsAndIsNewEveryPart) {
  MachineErrorModel m = vibration_only(MachineErrorModel{});
  const TrueLiftError a = grind(m, 3);
  const TrueLiftError again = grind(m, 3);
  const TrueLiftError b = grind(m, 4);
  EXPECT_NEAR(a.rms_um, 0.5, 0.05);
  EXPECT_EQ(a.error_um, again.error_um);
  EXPECT_NE(a.error_um, b.error_um);
  m.seed = 99;
  EXPECT_NE(grind(m, 3).error_um, a.error_um);
}

TEST_F(VirtualGrinderTest, BadModelIsRefusedNamingTheTerm) {
  MachineErrorModel m;
  m.servo_damping = 0.0;
  Result<GroundPart> g = grind_part(part_, path_, m, 0);
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(g.error().message.find("servo_damping"), std::string::npos) << g.error().message;
  m = MachineErrorModel{};
  m.vibration_min_harmonic = 200;
  m.vibration_max_harmonic = 100;
  Status s = validate(m);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("vibration harmonics 200..100"), std::string::npos) << s.error().message;
}

// A constant program is the constant speed: the same part to well under a nanometre, every
// term on, at the default speed and another.
TEST_F(VirtualGrinderTest, AConstantSpeedProgramGrindsTheSamePartAsThatSpeed) {
  for (double rpm : {60.0, 90.0}) {
    MachineErrorModel constant;
    constant.work_speed_rpm = rpm;
    Result<GroundPart> a = grind_part(part_, path_, constant, 2);
    MachineErrorModel programmed = constant;
    programmed.work_speed_rpm = 5.0;  // not used under a program
    programmed.speed_program = WorkSpeedProgram{1.0, std::vector<double>(360, rpm)};
    Result<GroundPart> b = grind_part(part_, path_, programmed, 2);
    ASSERT_TRUE(a.ok() && b.ok());
    double worst_mm = 0.0;
    for (size_t k = 0; k < a->followed_x_mm.size(); ++k) {
      worst_mm = std::max(worst_mm, std::abs(a->followed_x_mm[k] - b->followed_x_mm[k]));
    }
    EXPECT_LT(worst_mm, 1e-9) << rpm << " rpm";
    EXPECT_NEAR(a->largest_servo_error_um, b->largest_servo_error_um, 1e-6);
  }
}

// Under a program the servo acts in time: slowing the lobe to hold 2000 mm/min there lags
// less than the constant speed of the base circle, and a base circle twice as fast costs
// nothing at the nose, where the lag is largest, since X barely moves on the base circle.
TEST_F(VirtualGrinderTest, TheServoErrorFollowsTheSpeedProgram) {
  Result<PeriodicSpline> lift = PeriodicSpline::fit(design_.angle_deg, design_.lift_mm);
  ASSERT_TRUE(lift.ok());
  Result<MachinePath> machine = compute_machine_path(*lift, part_, 1.0);
  ASSERT_TRUE(machine.ok());
  MachineErrorModel m = no_errors();
  m.servo_bandwidth_hz = MachineErrorModel{}.servo_bandwidth_hz;
  grind(m);
  const double constant_um = last_.largest_servo_error_um;
  const TrueLiftError constant_part = true_lift_error(last_.reading_mm, design_reading_);

  WorkSpeedSettings s;
  Result<WorkSpeedPlan> plan = plan_work_speed(*machine, part_, s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  m.speed_program = plan->program;
  const TrueLiftError slow_part = grind(m);
  const double slow_um = last_.largest_servo_error_um;

  s.base_speed_rpm = 120.0;
  plan = plan_work_speed(*machine, part_, s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  m.speed_program = plan->program;
  const TrueLiftError fast_base_part = grind(m);
  const double fast_base_um = last_.largest_servo_error_um;
  std::printf(
      "servo error %.2f um at 60 rpm, %.2f um under the program, %.2f um with a 120 rpm base circle; "
      "parts %.2f, %.2f, %.2f um\n",
      constant_um, slow_um, fast_base_um, constant_part.max_abs_um, slow_part.max_abs_um, fast_base_part.max_abs_um);
  // The largest lag is at the nose, where the program turns at about 50 rpm: (50 / 60)^2 = 0.69.
  EXPECT_LT(slow_um, 0.8 * constant_um);
  EXPECT_LT(slow_part.max_abs_um, 0.8 * constant_part.max_abs_um);
  EXPECT_LT(fast_base_part.max_abs_um, 1.05 * slow_part.max_abs_um);
}

TEST_F(VirtualGrinderTest, ABadSpeedProgramIsRefused) {
  MachineErrorModel m;
  m.speed_program = WorkSpeedProgram{1.0, std::vector<double>(359, 60.0)};
  EXPECT_NE(validate(m).error().message.find("359 speeds"), std::string::npos);
  m.speed_program = WorkSpeedProgram{1.0, std::vector<double>(360, 60.0)};
  m.speed_program->speed_rpm[90] = 0.0;
  Status s = validate(m);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("at C 90"), std::string::npos) << s.error().message;
}

TEST_F(VirtualGrinderTest, TableInForceMustBeReadable) {
  const testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  Result<CommandedPath> missing = commanded_path_from_program(dir / "NONE.SPF");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_NE(missing.error().message.find("NONE.SPF"), std::string::npos);
  const std::filesystem::path bad = dir / "BAD.SPF";
  std::ofstream(bad) << "CTABDEF(X,C,1,1)\nG1 C0 X0\nC120 Y3\nCTABEND\n";
  Result<CommandedPath> parsed = commanded_path_from_program(bad);
  ASSERT_FALSE(parsed.ok());
  EXPECT_NE(parsed.error().message.find("BAD.SPF"), std::string::npos) << parsed.error().message;
}

// The gauge simulator serves the ground lobe: its form error is the ground lobe's against the
// design; a reading that is not a number is refused, naming the cam degree.
TEST_F(VirtualGrinderTest, GaugeSimulatorServesTheGroundLobe) {
  MachineErrorModel m = no_errors();
  m.geometric_once_um = 3.0;
  grind(m);
  SimulatorSettings s;
  s.ground_reading_mm = last_.reading_mm;
  Result<std::unique_ptr<GaugeSimulator>> sim = GaugeSimulator::start(part_, design_, s);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  for (int d : {0, 90, 180, 270}) {
    const auto i = static_cast<size_t>(d);
    EXPECT_NEAR((*sim)->true_lift_mm(d), last_.reading_mm[i], 1e-12) << d;
    EXPECT_NEAR((*sim)->lobe_error_um(d), (last_.reading_mm[i] - design_reading_[i]) * 1000.0, 1e-9) << d;
  }
  EXPECT_GT(std::abs((*sim)->lobe_error_um(180)), 1.0);  // the runout shows on the base circle
  // The next part on the machine: the gauge reads it from now on.
  const DegreeTable first = last_.reading_mm;
  m.geometric_once_um = 0.0;
  grind(m);
  ASSERT_TRUE((*sim)->load_ground_part(last_.reading_mm).ok());
  EXPECT_NEAR((*sim)->lobe_error_um(180), 0.0, 0.01);
  EXPECT_NE((*sim)->true_lift_mm(180), first[180]);
  DegreeTable bad_part = last_.reading_mm;
  bad_part[42] = std::numeric_limits<double>::infinity();
  const Status refused = (*sim)->load_ground_part(bad_part);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("cam degree 42"), std::string::npos) << refused.error().message;
  EXPECT_NEAR((*sim)->lobe_error_um(180), 0.0, 0.01);  // the part on the machine stays
  (*sim)->stop();

  (*s.ground_reading_mm)[17] = std::nan("");
  Result<std::unique_ptr<GaugeSimulator>> bad = GaugeSimulator::start(part_, design_, s);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(bad.error().message.find("cam degree 17"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace gaugeloop
