// A crankpin's tables close where the path bends least: the seam chosen from the path's own
// curvature, any C, and the command error that leaves, measured against the pin's closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "nc_reference.h"
#include "tests/support/angles.h"

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

// The sample pin: throw R 45, pin radius r 25, wheel radius rw 300 mm (examples/crankpin_*.toml).
constexpr double kThrowMm = 45.0;
constexpr double kPinMm = 25.0;
constexpr double kWheelMm = 300.0;

// One following axis of a pin as a closed form of the crank angle t = C (pin angle 0), with
// its first and second derivative per radian.
struct ClosedForm {
  std::function<double(double)> x, dx, d2x;
};

// C-X: X(t) = R cos t + sqrt((r + rw)^2 - R^2 sin^2 t) - (r + rw - R).
ClosedForm cx_infeed() {
  const double a = (kPinMm + kWheelMm) * (kPinMm + kWheelMm);
  const double r2 = kThrowMm * kThrowMm;
  auto s = [=](double t) { return std::sqrt(a - r2 * std::sin(t) * std::sin(t)); };
  auto ds = [=](double t) { return -0.5 * r2 * std::sin(2 * t) / s(t); };
  auto d2s = [=](double t) {
    const double q = s(t);
    return -r2 * std::cos(2 * t) / q - 0.25 * r2 * r2 * std::sin(2 * t) * std::sin(2 * t) / (q * q * q);
  };
  return {[=](double t) { return kThrowMm * std::cos(t) + s(t) - (kPinMm + kWheelMm - kThrowMm); },
          [=](double t) { return -kThrowMm * std::sin(t) + ds(t); },
          [=](double t) { return -kThrowMm * std::cos(t) + d2s(t); }};
}

// C-X-Y: X(t) = R cos t + R, Y(t) = R sin t.
ClosedForm cxy_infeed() {
  return {[](double t) { return kThrowMm * std::cos(t) + kThrowMm; }, [](double t) { return -kThrowMm * std::sin(t); },
          [](double t) { return -kThrowMm * std::cos(t); }};
}
ClosedForm cxy_height() {
  return {[](double t) { return kThrowMm * std::sin(t); }, [](double t) { return kThrowMm * std::cos(t); },
          [](double t) { return -kThrowMm * std::sin(t); }};
}

SampledPath sampled(const ClosedForm& f) {
  SampledPath p;
  p.c_step_deg = 0.01;
  for (int i = 0; i < 36000; ++i) {
    const double t = i * 0.01 * kRadPerDeg;
    p.x_mm.push_back(f.x(t));
    p.dx_dc_mm_per_deg.push_back(f.dx(t) * kRadPerDeg);
    p.d2x_dc2_mm_per_deg2.push_back(f.d2x(t) * kRadPerDeg * kRadPerDeg);
  }
  return p;
}

// The table as rendered, read back by the test's own parser and spline, against the closed
// form every 0.005 deg (between the fine rows too), in um.
double error_against_closed_form_um(const std::string& program, char axis, const ClosedForm& f) {
  const auto nc = testing::ref_interpolant(testing::ref_parse(program, axis));
  double worst = 0.0;
  for (int j = 0; j <= 72000; ++j) {
    const double c = j * 0.005;
    worst = std::max(worst, std::abs(nc(c) - f.x(c * kRadPerDeg)) * 1000.0);
  }
  return worst;
}

// Each following axis of the sample pin: C-X's X, C-X-Y's X and Y.
struct PinPath {
  const char* what;
  ClosedForm f;
  char axis;
};
std::vector<PinPath> pin_paths() {
  return {{"C-X X", cx_infeed(), 'X'}, {"C-X-Y X", cxy_infeed(), 'X'}, {"C-X-Y Y", cxy_height(), 'Y'}};
}

std::string rendered(const CurveTable& t, char axis, const CurveTableFormat& f) {
  const std::string tmpl =
      std::string("{{table_header}}\nCTABDEF(") + axis + ",C,1,1)\n{{table_blocks}}\nCTABEND\nM17\n";
  Result<std::string> text = render_table_program(tmpl, "pin.spf", {}, t, {}, f);
  EXPECT_TRUE(text.ok()) << (text ? "" : text.error().message);
  return text ? *text : std::string();
}

// At a control resolution of 1e-6 mm (MD10200 = 1,000,000) a CSPLINE table at 1 deg of each
// of the pin's paths carries at most 0.001 um of command error: the rounding alone is 0.0005
// um, the spline's own error at 1 deg some 1e-5 um; a seam at C0 (where |X''| is largest)
// cost 0.67 to 0.77 um.
TEST(PinSeam, EveryPinTableAtOneDegreeKeepsANanometreAtFineResolution) {
  CurveTableFormat fine;
  fine.x_increments_per_mm = 1000000.0;
  for (const PinPath& c : pin_paths()) {
    SCOPED_TRACE(c.what);
    const SampledPath path = sampled(c.f);
    Result<CurveTable> t = write_spline_table(path, 1.0, fine);
    ASSERT_TRUE(t.ok()) << t.error().message;
    const std::string program = rendered(*t, c.axis, fine);
    const double measured = error_against_closed_form_um(program, c.axis, c.f);
    EXPECT_LE(measured, 0.001);
    // The writer's own figure agrees with the independent one (both include the rounding).
    EXPECT_NEAR(t->error.max_abs_um, measured, 0.0005);
  }
}

// POLY segments at 1 deg, each the cubic Hermite of the exact path, reach the crankpin paper's
// 5e-7 mm at a resolution of 1e-6 mm on each of the pin's paths. The tolerance is what the
// table cannot avoid: half an increment at the points (0.0005 um), the cubic Hermite's own
// error h^4/384 max|X''''| (1 deg, |X''''| <= R = 45 mm per rad^4: 1.1e-5 um) and the
// coefficients' rounding (0.64 * 0.5e-8 mm: 3.2e-6 um), so 0.000515 um.
TEST(PinSeam, PolySegmentsAtOneDegreeKeepTheGridsHalfIncrement) {
  CurveTableFormat fine;
  fine.x_increments_per_mm = 1000000.0;
  for (const PinPath& c : pin_paths()) {
    SCOPED_TRACE(c.what);
    const SampledPath path = sampled(c.f);
    Result<CurveTable> t = write_poly_table(path, 1.0, fine);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->interpolation, Interpolation::kPoly);
    EXPECT_EQ(t->block_count(), 361);
    const std::string program = rendered(*t, c.axis, fine);
    ASSERT_NE(program.find("POLY PO[C]=(1.000) PO["), std::string::npos) << program.substr(0, 600);
    const double measured = error_against_closed_form_um(program, c.axis, c.f);
    EXPECT_LE(measured, 0.000515);
    EXPECT_NEAR(t->error.max_abs_um, measured, 0.0001) << "the writer's own figure agrees";
    Result<ParsedTable> back = parse_table_program(program, "pin.spf");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->interpolation, Interpolation::kPoly);
    EXPECT_TRUE(compare_table_points(*back, t->points, "pin.spf", fine).ok());
  }
}

// The seam is where the path's curvature vanishes: X'' = -R cos t + ... is 0 near t = 90 and
// 270 (C-X-Y exactly), Y'' = -R sin t at 0 and 180; not at a multiple of 60 degrees.
TEST(PinSeam, TheSeamIsWhereThePathBendsLeastAndTheHeaderSaysWhere) {
  const double x_seam = spline_start_c_deg(sampled(cxy_infeed()));
  EXPECT_TRUE(std::abs(x_seam - 90.0) < 0.011 || std::abs(x_seam - 270.0) < 0.011) << x_seam;
  const double y_seam = spline_start_c_deg(sampled(cxy_height()));
  EXPECT_TRUE(std::abs(y_seam - 0.0) < 0.011 || std::abs(y_seam - 180.0) < 0.011) << y_seam;
  const ClosedForm cx = cx_infeed();
  const double cx_seam = spline_start_c_deg(sampled(cx));
  EXPECT_LT(std::abs(cx.d2x(cx_seam * kRadPerDeg)), 0.01 * kThrowMm) << cx_seam;
  EXPECT_GT(std::abs(std::fmod(cx_seam, 60.0)), 0.5) << "not a multiple of 60 deg: " << cx_seam;

  CurveTableFormat fine;
  fine.x_increments_per_mm = 1000000.0;
  Result<CurveTable> t = write_spline_table(sampled(cx), 1.0, fine);
  ASSERT_TRUE(t.ok()) << t.error().message;
  Result<ParsedTable> back = parse_table_program(rendered(*t, 'X', fine), "pin.spf");
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_TRUE(back->header.count("seam_c_deg"));
  EXPECT_NEAR(std::stod(back->header.at("seam_c_deg")), cx_seam, 1e-9);
  EXPECT_NEAR(back->points.front().c_deg, cx_seam, 1e-9);
}

// The same table closed at C0, where the pin is nearest the wheel and |X''| is largest: the
// natural end is wrong there by the whole curvature, which is what the seam saves.
TEST(PinSeam, ASeamAtTheTurningPointCostsHundredsOfTimesMore) {
  CurveTableFormat fine;
  fine.x_increments_per_mm = 1000000.0;
  const ClosedForm f = cx_infeed();
  const SampledPath path = sampled(f);
  Result<CurveTable> chosen = write_spline_table(path, 1.0, fine);
  ASSERT_TRUE(chosen.ok());
  std::vector<CurvePoint> at_zero;
  for (int k = 0; k <= 360; ++k)
    at_zero.push_back({static_cast<double>(k), fine.round_x_mm(path.x_mm[(k % 360) * 100])});
  Result<CommandError> e = command_position_error(path, at_zero, Interpolation::kCubicSpline);
  ASSERT_TRUE(e.ok());
  EXPECT_GT(e->max_abs_um, 0.5);
  EXPECT_GT(e->max_abs_um, 500.0 * chosen->error.max_abs_um);
}

// A seam at any C (here C-X's, a little off C90) is read back from the program text and kept
// as the points of the table in force: C179.99 + 360 as written and as a double differ in the
// last bit, which must not make the next table refuse its own points.
TEST(PinSeam, ATableClosedOffTheRoundDegreesIsKeptAsThePointsInForce) {
  const SampledPath path = sampled(cx_infeed());
  Result<CurveTable> t = write_spline_table(path, 1.0);
  ASSERT_TRUE(t.ok()) << t.error().message;
  ASSERT_NE(std::fmod(t->points.front().c_deg, 1.0), 0.0) << "the test needs a seam off the whole degrees";
  Result<ParsedTable> back = parse_table_program(rendered(*t, 'X', CurveTableFormat{}), "pin.spf");
  ASSERT_TRUE(back.ok()) << back.error().message;
  TablePointsInForce in_force;
  in_force.interpolation = back->interpolation;
  for (const CurvePoint& p : back->points) in_force.c_deg.push_back(p.c_deg);
  Result<CurveTable> kept = write_table_at_points(path, in_force);
  ASSERT_TRUE(kept.ok()) << kept.error().message;
  EXPECT_EQ(kept->points.size(), t->points.size());
  EXPECT_NEAR(kept->error.max_abs_um, t->error.max_abs_um, 1e-9);
  Result<CurveTable> chosen = write_default_table(path, TableChoiceSettings{0.1, 10.0, true}, {}, &in_force);
  ASSERT_TRUE(chosen.ok()) << chosen.error().message;
  EXPECT_EQ(chosen->points.front().c_deg, t->points.front().c_deg) << "the next table keeps the seam in force";
}

}  // namespace
}  // namespace gaugeloop
