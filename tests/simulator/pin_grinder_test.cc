// The virtual grinder for crankpins on the sample pin (R 45, r 25, rw 300): the ideal machine,
// the machine's errors on each slide, the gauge's reading, and the tables read back.
#include "simulator/pin_grinder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <string>

#include "compensation/pin_envelope.h"
#include "compensation/pin_kinematics.h"
#include "nc_out/curve_table.h"
#include "nc_out/sampled_path.h"
#include "nc_out/table_writer.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

// Both slides with every term off; each test turns on the ones it is about.
PinMachineErrorModel ideal_machine() {
  PinMachineErrorModel m = vibration_only(PinMachineErrorModel{});
  m.x.vibration_rms_um = 0.0;
  m.y.vibration_rms_um = 0.0;
  return m;
}

PinGeometry sample_pin(PinMode mode, double pin_angle_deg = 0.0) {
  PinGeometry pin;
  pin.mode = mode;
  pin.pin_angle_deg = pin_angle_deg;
  return pin;
}

PinCommandedPath design(const PinGeometry& pin) {
  Result<PinCommandedPath> path = pin_commanded_path_from_design(pin);
  EXPECT_TRUE(path) << path.error().message;
  return path ? *path : PinCommandedPath{};
}

GroundPin grind(const PinGeometry& pin, const PinMachineErrorModel& m, int part_index = 0) {
  Result<GroundPin> g = grind_pin(pin, design(pin), m, part_index);
  EXPECT_TRUE(g) << g.error().message;
  return g ? *g : GroundPin{};
}

double largest_abs_mm(const DegreeTable& t) {
  double worst = 0.0;
  for (double v : t) worst = std::max(worst, std::abs(v));
  return worst;
}

class PinGrinderBothModes : public ::testing::TestWithParam<std::tuple<PinMode, double>> {};

// The envelope's own accuracy on a 0.1 deg path is far below the 1e-4 mm.
TEST_P(PinGrinderBothModes, IdealMachineGrindsTheDesignPin) {
  const auto [mode, angle_deg] = GetParam();
  const PinGeometry pin = sample_pin(mode, angle_deg);
  const GroundPin g = grind(pin, ideal_machine());
  EXPECT_LE(largest_abs_mm(g.radius_error_mm), 1e-4);
  EXPECT_LE(largest_abs_mm(g.gauge_reading_mm), 1e-4);
  EXPECT_EQ(g.largest_servo_error_um, 0.0);
}

// The gauge at machine degree C reads the pin where gauge_psi_deg puts it, evaluated there.
TEST_P(PinGrinderBothModes, GaugeReadsTheRadiusErrorAtItsPinDegree) {
  const auto [mode, angle_deg] = GetParam();
  const PinGeometry pin = sample_pin(mode, angle_deg);
  const GroundPin g = grind(pin, PinMachineErrorModel{}, 2);
  ASSERT_EQ(g.followed_x_mm.size(), 3600u);
  for (int c : {0, 1, 45, 90, 137, 180, 271, 359}) {
    const double psi = gauge_psi_deg(pin, c);
    Result<std::vector<double>> direct =
        ground_pin_radius_error_at_mm(pin, 0.1, g.followed_x_mm, g.followed_y_mm, {psi});
    ASSERT_TRUE(direct) << direct.error().message;
    EXPECT_NEAR(g.gauge_reading_mm[static_cast<size_t>(c)], (*direct)[0], 1e-12) << "C " << c;
  }
  EXPECT_GT(largest_abs_mm(g.gauge_reading_mm), 1e-3);  // the machine's errors are in it
}

INSTANTIATE_TEST_SUITE_P(SamplePin, PinGrinderBothModes,
                         ::testing::Combine(::testing::Values(PinMode::kCX, PinMode::kCXY),
                                            ::testing::Values(0.0, 37.0)));

// X swings 2R = 90 mm per turn, so the servo lags tens of um at 60 rpm; it mostly follows the
// acceleration, so halving the speed takes it to about a quarter. What is left on the pin after
// the least-squares circle is several um (the lag is nearly a once-per-turn wave, which moves
// the circle rather than making the pin out of round).
TEST(PinGrinder, DefaultModelOnXGivesServoLagAndSeveralUmOfPinError) {
  const PinGeometry pin = sample_pin(PinMode::kCX);
  PinMachineErrorModel m;
  const GroundPin at60 = grind(pin, m);
  m.x.work_speed_rpm = 30.0;
  const GroundPin at30 = grind(pin, m);
  std::cout << "C-X servo error: " << at60.largest_servo_error_um << " um at 60 rpm, " << at30.largest_servo_error_um
            << " um at 30 rpm\n";
  EXPECT_GT(at60.largest_servo_error_um, 10.0);
  EXPECT_GT(at60.largest_servo_error_um / at30.largest_servo_error_um, 2.5);
  EXPECT_LT(at60.largest_servo_error_um / at30.largest_servo_error_um, 4.5);
  const TruePinError e = true_pin_error(at60.radius_error_mm);
  std::cout << "C-X default model at 60 rpm: largest " << e.max_abs_um << " um, rms " << e.rms_um << " um, roundness "
            << e.roundness_um << " um\n";
  EXPECT_GT(e.roundness_um, 2.0);
  EXPECT_GT(e.max_abs_um, e.roundness_um / 2.0);
}

// An error of Y moves the wheel along the pin's tangent in C-X-Y: the wheel centre's distance
// from the pin centre grows by dY^2 / (2 (r + rw)), no more to first order. The default model
// on Y (tens of um of servo lag: Y swings +-R per turn) with a large runout moves the pin by
// a few nm.
TEST(PinGrinder, ErrorsOnYAloneChangeTheRadiusOnlyToSecondOrder) {
  const PinGeometry pin = sample_pin(PinMode::kCXY, 37.0);
  PinMachineErrorModel m = ideal_machine();
  m.y = MachineErrorModel{};
  m.y.geometric_once_um = 40.0;
  const GroundPin g = grind(pin, m, 3);
  const PinCommandedPath commanded = design(pin);
  double dy_max_mm = 0.0;
  for (size_t k = 0; k < commanded.y_mm.size(); ++k) {
    dy_max_mm = std::max(dy_max_mm, std::abs(g.followed_y_mm[k] - commanded.y_mm[k]));
  }
  EXPECT_GT(dy_max_mm, 0.03);
  const double second_order_mm = dy_max_mm * dy_max_mm / (2.0 * (pin.pin_radius_mm + pin.wheel_radius_mm));
  const double worst_mm = largest_abs_mm(g.radius_error_mm);
  std::cout << "C-X-Y, errors on Y alone: largest dY " << dy_max_mm * 1000.0 << " um, radius error "
            << worst_mm * 1000.0 << " um, dY^2 / (2 (r + rw)) " << second_order_mm * 1000.0 << " um\n";
  // Margin 1.5 for the curvature of the followed path; 1e-7 mm for the envelope's own error.
  EXPECT_LE(worst_mm, 1.5 * second_order_mm + 1e-7);
  // The same errors on X would be first order: the pin's radius would move by dY itself.
  EXPECT_LT(worst_mm, dy_max_mm / 100.0);
}

// The floor: vibration alone, about its RMS on the pin (the normal leans from X by at most
// asin(R / (r + rw)), 8 deg, so the radius sees nearly all of it).
TEST(PinGrinder, VibrationOnlyGivesTheFloor) {
  const PinGeometry pin = sample_pin(PinMode::kCX);
  const PinMachineErrorModel full;
  const GroundPin floor = grind(pin, vibration_only(full));
  EXPECT_EQ(floor.largest_servo_error_um, 0.0);
  const TruePinError e = true_pin_error(floor.radius_error_mm);
  std::cout << "C-X vibration only: rms " << e.rms_um << " um, roundness " << e.roundness_um << " um\n";
  EXPECT_GT(e.rms_um, 0.6 * full.x.vibration_rms_um);
  EXPECT_LT(e.rms_um, 1.4 * full.x.vibration_rms_um);
  EXPECT_LT(e.roundness_um, true_pin_error(grind(pin, full).radius_error_mm).roundness_um);
}

TEST(PinGrinder, ABadModelIsRefusedNamingTheSlide) {
  PinMachineErrorModel m;
  m.y.servo_damping = 0.0;
  Status s = validate(m);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().message.rfind("Y slide: ", 0), 0u) << s.error().message;
  EXPECT_NE(s.error().message.find("servo_damping"), std::string::npos);
  Result<GroundPin> g = grind_pin(sample_pin(PinMode::kCXY), design(sample_pin(PinMode::kCXY)), m, 0);
  ASSERT_FALSE(g);
  EXPECT_EQ(g.error().code, ErrorCode::kInvalidInput);
  PinCommandedPath short_path = design(sample_pin(PinMode::kCX));
  short_path.x_mm.pop_back();
  EXPECT_FALSE(grind_pin(sample_pin(PinMode::kCX), short_path, PinMachineErrorModel{}, 0));
}

// The design path of one slide (Y when `y`), as nc_out's writers take it: 0.01 deg rows, the
// derivatives by central differences of the closed form (1e-3 deg apart: well inside what the
// writers need for their spline start and between-rows bound).
SampledPath sampled_design(const PinGeometry& pin, bool y) {
  auto at = [&](double c) {
    const PinPose p = design_pin_pose(pin, c);
    return y ? p.y_mm : p.x_mm;
  };
  const double h = 1e-3;
  SampledPath path;
  path.c_step_deg = 0.01;
  for (int k = 0; k < 36000; ++k) {
    const double c = k * path.c_step_deg;
    path.x_mm.push_back(at(c));
    path.dx_dc_mm_per_deg.push_back((at(c + h) - at(c - h)) / (2.0 * h));
    path.d2x_dc2_mm_per_deg2.push_back((at(c + h) - 2.0 * at(c) + at(c - h)) / (h * h));
  }
  return path;
}

// Writes the slide's table as the NC gets it. nc_out writes the following axis as X; a Y table
// is the same blocks with Y.
CurveTable write_program(const PinGeometry& pin, bool y, const std::filesystem::path& file) {
  Result<CurveTable> table = write_default_table(sampled_design(pin, y), TableChoiceSettings{});
  EXPECT_TRUE(table) << table.error().message;
  if (!table) return {};
  std::string blocks = render_table_blocks(table->points, table->interpolation);
  if (y) {
    for (size_t at = blocks.find(" X"); at != std::string::npos; at = blocks.find(" X", at)) blocks[at + 1] = 'Y';
  }
  std::ofstream(file) << "; pin table\nCTABDEF(" << (y ? "Y" : "X") << ",C,1,1)\n" << blocks << "\nCTABEND\n";
  return *table;
}

TEST(PinGrinder, CommandedPathFromTheProgramsIsTheDesignWithinTheTablesCommandError) {
  const testing::TempDir tmp;
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = sample_pin(mode, 37.0);
    const std::filesystem::path x_file = tmp.path() / "PIN_X.SPF";
    const std::filesystem::path y_file = tmp.path() / "PIN_Y.SPF";
    const CurveTable x_table = write_program(pin, false, x_file);
    const CurveTable y_table = write_program(pin, true, y_file);
    EXPECT_LE(x_table.error.max_abs_um, 0.5);
    EXPECT_LE(y_table.error.max_abs_um, 0.5);
    Result<PinCommandedPath> read = pin_commanded_path_from_programs(pin, x_file, y_file);
    ASSERT_TRUE(read) << read.error().message;
    const PinCommandedPath exact = design(pin);
    ASSERT_EQ(read->x_mm.size(), exact.x_mm.size());
    ASSERT_EQ(read->y_mm.size(), exact.y_mm.size());
    double x_worst_um = 0.0, y_worst_um = 0.0;
    for (size_t k = 0; k < exact.x_mm.size(); ++k) {
      x_worst_um = std::max(x_worst_um, std::abs(read->x_mm[k] - exact.x_mm[k]) * 1000.0);
      y_worst_um = std::max(y_worst_um, std::abs(read->y_mm[k] - exact.y_mm[k]) * 1000.0);
    }
    // The 0.1 deg rows are rows of the 0.01 deg path the command error is measured on; 1e-6 um
    // for the arithmetic.
    EXPECT_LE(x_worst_um, x_table.error.max_abs_um + 1e-6) << pin_mode_name(mode);
    EXPECT_GT(x_worst_um, 0.0);  // the table is an approximation: the comparison can fail
    if (mode == PinMode::kCXY) {
      EXPECT_LE(y_worst_um, y_table.error.max_abs_um + 1e-6);
      EXPECT_GT(y_worst_um, 0.0);
    } else {
      EXPECT_EQ(y_worst_um, 0.0);  // C-X: no Y slide, the Y program is not read
    }
  }
}

TEST(PinGrinder, AYTableWhereTheXTableIsExpectedIsRefused) {
  const testing::TempDir tmp;
  const PinGeometry pin = sample_pin(PinMode::kCXY);
  const std::filesystem::path x_file = tmp.path() / "PIN_X.SPF";
  const std::filesystem::path y_file = tmp.path() / "PIN_Y.SPF";
  write_program(pin, false, x_file);
  write_program(pin, true, y_file);
  Result<PinCommandedPath> swapped = pin_commanded_path_from_programs(pin, y_file, x_file);
  ASSERT_FALSE(swapped);
  EXPECT_EQ(swapped.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(swapped.error().message.find("PIN_Y.SPF"), std::string::npos) << swapped.error().message;
  Result<PinCommandedPath> x_twice = pin_commanded_path_from_programs(pin, x_file, x_file);
  ASSERT_FALSE(x_twice);
  EXPECT_NE(x_twice.error().message.find("table of X against C where the table of Y"), std::string::npos)
      << x_twice.error().message;
  Result<PinCommandedPath> missing = pin_commanded_path_from_programs(pin, x_file, tmp.path() / "NONE.SPF");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
}

TEST(PinGrinder, TruePinErrorTakesOutTheLeastSquaresCircle) {
  DegreeTable e{};
  for (int d = 0; d < 360; ++d) {
    const double a = d * std::numbers::pi / 180.0;
    // 3 um of size, 5 um of centre offset, 2 um peak to valley of a three-lobe form
    e[static_cast<size_t>(d)] = (3.0 + 5.0 * std::cos(a - 0.4) + 1.0 * std::cos(3.0 * a)) * 1e-3;
  }
  const TruePinError t = true_pin_error(e);
  EXPECT_NEAR(t.roundness_um, 2.0, 1e-9);
  EXPECT_GT(t.max_abs_um, 8.0);
  EXPECT_LE(t.max_abs_um, 9.0);
}

}  // namespace
}  // namespace gaugeloop
