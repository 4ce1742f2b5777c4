// The envelope of the wheel along a pin path: the design path gives back a round pin, a path
// made for another pin gives back that pin.
#include "compensation/pin_envelope.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "compensation/pin_kinematics.h"

namespace gaugeloop {
namespace {

constexpr double kStepDeg = 0.1;
constexpr int kRows = 3600;

PinGeometry envelope_pin(PinMode mode, double pin_angle_deg) {
  PinGeometry pin;  // R 45, r 25, rw 300
  pin.mode = mode;
  pin.pin_angle_deg = pin_angle_deg;
  return pin;
}

struct Path {
  std::vector<double> x_mm;
  std::vector<double> y_mm;
};

// The design path of `pin`, with X read on the infeed zero of `nominal` (core/pin.h: the zero
// depends on r + rw - R, so a path made for another pin is shifted onto the nominal one's X).
Path design_path(const PinGeometry& pin, const PinGeometry& nominal) {
  const double shift_mm = (pin.pin_radius_mm + pin.wheel_radius_mm - pin.throw_mm) -
                          (nominal.pin_radius_mm + nominal.wheel_radius_mm - nominal.throw_mm);
  Path p;
  for (int k = 0; k < kRows; ++k) {
    const PinPose pose = design_pin_pose(pin, k * kStepDeg);
    p.x_mm.push_back(pose.x_mm + shift_mm);
    p.y_mm.push_back(pose.y_mm);
  }
  return p;
}

class PinEnvelopeRoundTrip : public ::testing::TestWithParam<std::tuple<PinMode, double>> {};

// The figure is 1e-4 mm; the parabola refinement keeps the 0.1 deg grid far below it.
TEST_P(PinEnvelopeRoundTrip, DesignPathGrindsARoundPinOfRadiusR) {
  const auto [mode, angle_deg] = GetParam();
  const PinGeometry pin = envelope_pin(mode, angle_deg);
  const Path p = design_path(pin, pin);
  Result<DegreeTable> error = ground_pin_radius_error_mm(pin, kStepDeg, p.x_mm, p.y_mm);
  ASSERT_TRUE(error) << error.error().message;
  double worst_mm = 0.0;
  for (double e : *error) worst_mm = std::max(worst_mm, std::abs(e));
  EXPECT_LE(worst_mm, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(BothModes, PinEnvelopeRoundTrip,
                         ::testing::Combine(::testing::Values(PinMode::kCX, PinMode::kCXY),
                                            ::testing::Values(0.0, 37.0)));

class PinEnvelopeOtherPin : public ::testing::TestWithParam<PinMode> {};

// A pin of radius r + dr whose centre sits (dx, dy) off the nominal one in the pin frame: its
// design path is the design formula with throw |R + dx, dy| and the angle turned by
// atan2(dy, R + dx). Its support function about the nominal centre is r + dr + (dx, dy).u(psi).
TEST_P(PinEnvelopeOtherPin, RadiusErrorIsTheOtherPinsOffsetCircle) {
  const PinGeometry pin = envelope_pin(GetParam(), 37.0);
  const double dr_mm = 0.012, dx_mm = 0.008, dy_mm = -0.005;
  PinGeometry other = pin;
  other.pin_radius_mm += dr_mm;
  other.throw_mm = std::hypot(pin.throw_mm + dx_mm, dy_mm);
  other.pin_angle_deg += std::atan2(dy_mm, pin.throw_mm + dx_mm) * 180.0 / std::numbers::pi;
  const Path p = design_path(other, pin);
  Result<DegreeTable> error = ground_pin_radius_error_mm(pin, kStepDeg, p.x_mm, p.y_mm);
  ASSERT_TRUE(error) << error.error().message;
  for (int d = 0; d < 360; ++d) {
    const double psi = d * std::numbers::pi / 180.0;
    const double expected_mm = dr_mm + dx_mm * std::cos(psi) + dy_mm * std::sin(psi);
    EXPECT_NEAR((*error)[static_cast<size_t>(d)], expected_mm, 1e-6) << "pin degree " << d;
  }
}

INSTANTIATE_TEST_SUITE_P(BothModes, PinEnvelopeOtherPin, ::testing::Values(PinMode::kCX, PinMode::kCXY));

TEST(PinEnvelope, AnyAngleAgreesWithTheWholeDegrees) {
  const PinGeometry pin = envelope_pin(PinMode::kCX, 0.0);
  Path p = design_path(pin, pin);
  for (int k = 0; k < kRows; ++k)
    p.x_mm[static_cast<size_t>(k)] += 0.003 * std::cos(3.0 * k * kStepDeg * std::numbers::pi / 180.0);
  Result<DegreeTable> whole = ground_pin_radius_error_mm(pin, kStepDeg, p.x_mm, p.y_mm);
  ASSERT_TRUE(whole);
  Result<std::vector<double>> at = ground_pin_radius_error_at_mm(pin, kStepDeg, p.x_mm, p.y_mm, {10.0, 370.0, -350.0});
  ASSERT_TRUE(at) << at.error().message;
  ASSERT_EQ(at->size(), 3u);
  for (double e : *at) EXPECT_NEAR(e, (*whole)[10], 1e-12);
  EXPECT_GT(std::abs((*whole)[10]), 1e-4);  // the wave is there, so the comparison means something
}

TEST(PinEnvelope, RefusesABadPath) {
  const PinGeometry pin = envelope_pin(PinMode::kCX, 0.0);
  Path p = design_path(pin, pin);
  EXPECT_FALSE(ground_pin_radius_error_mm(pin, 0.7, p.x_mm, p.y_mm));  // does not divide 360
  EXPECT_FALSE(ground_pin_radius_error_mm(pin, 0.2, p.x_mm, p.y_mm));  // wrong row count
  std::vector<double> short_y(p.y_mm.begin(), p.y_mm.end() - 1);
  EXPECT_FALSE(ground_pin_radius_error_mm(pin, kStepDeg, p.x_mm, short_y));
  p.x_mm[100] = std::nan("");
  Result<DegreeTable> nan_path = ground_pin_radius_error_mm(pin, kStepDeg, p.x_mm, p.y_mm);
  ASSERT_FALSE(nan_path);
  EXPECT_NE(nan_path.error().message.find("C 10.000"), std::string::npos) << nan_path.error().message;
  PinGeometry bad = pin;
  bad.throw_mm = 400.0;
  EXPECT_FALSE(ground_pin_radius_error_mm(bad, kStepDeg, design_path(pin, pin).x_mm, p.y_mm));
  EXPECT_FALSE(ground_pin_radius_error_at_mm(pin, kStepDeg, design_path(pin, pin).x_mm, p.y_mm, {std::nan("")}));
}

}  // namespace
}  // namespace gaugeloop
