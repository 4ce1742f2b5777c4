// The crankpin's closed-form kinematics against the eccentric disc: the pin is a disc whose
// centre orbits the main axis, so the cam-grinding formulas give the same wheel path.
#include "compensation/pin_kinematics.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "compensation/pin_path.h"
#include "compensation/wheel_path.h"
#include "test_lobes.h"
#include "tests/support/angles.h"

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

PinGeometry kinematics_pin(PinMode mode, double pin_angle_deg = 0.0) {
  PinGeometry pin;  // R 45, r 25, rw 300: the shop's sample pin
  pin.mode = mode;
  pin.pin_angle_deg = pin_angle_deg;
  return pin;
}

// The BRIEF's eccentric disc: X = e cos psi + sqrt((rc + rw)^2 - e^2 sin^2 psi) - rw - (rc - e).
double disc_x_mm(double e, double rc, double rw, double psi_deg) {
  const double s = e * std::sin(psi_deg * kRadPerDeg);
  return e * std::cos(psi_deg * kRadPerDeg) + std::sqrt((rc + rw) * (rc + rw) - s * s) - rw - (rc - e);
}

TEST(PinKinematics, CxMatchesTheEccentricDiscClosedForm) {
  for (double pin_angle : {0.0, 72.5}) {
    const PinGeometry pin = kinematics_pin(PinMode::kCX, pin_angle);
    double worst = 0.0;
    for (int i = 0; i < 3600; ++i) {
      const double c = 0.1 * i;
      const double want = disc_x_mm(pin.throw_mm, pin.pin_radius_mm, pin.wheel_radius_mm, c + pin_angle);
      worst = std::max(worst, std::abs(design_pin_pose(pin, c).x_mm - want));
    }
    // The issue asks 1e-5 mm; the two are the same formula rearranged, so rounding (~1e-13).
    EXPECT_LT(worst, 1e-5) << "pin_angle " << pin_angle;
    EXPECT_LT(worst, 1e-11) << "pin_angle " << pin_angle;
  }
  // The infeed's zero: X = 0 with the pin farthest from the wheel, 2R nearest.
  const PinGeometry pin = kinematics_pin(PinMode::kCX);
  EXPECT_NEAR(design_pin_pose(pin, 180.0).x_mm, 0.0, 1e-12);
  EXPECT_NEAR(design_pin_pose(pin, 0.0).x_mm, 90.0, 1e-12);
}

// The pin as a cam lobe: a disc of radius rc = r whose centre is e = R from the axis, ground
// with a flat follower's kinematics (lift H = e (1 + cos beta), rb = rc - e, so rc > e: a
// disc that contains the axis). The mapping found: the lobe's nose is the crank radius, and
// the wheel stands at cam angle psi = -t = -(C + pin_angle) (the cam angle is the wheel's
// polar angle in the turning frame, the wheel stands still at machine angle 0), so the cam
// part has rotation_sense -1 and c_offset_deg = -pin_angle_deg. X alone cannot show the sense
// (the disc is symmetric); dX/dC does.
TEST(PinKinematics, CxMatchesTheCamKinematicsOfTheEccentricDiscLobe) {
  const double e = 10.0;
  const double rc = 25.0;
  const double rw = 300.0;
  const double pin_angle = 37.5;
  PinGeometry pin = kinematics_pin(PinMode::kCX, pin_angle);
  pin.throw_mm = e;
  pin.pin_radius_mm = rc;
  pin.wheel_radius_mm = rw;
  Part part = testing::make_part(FollowerKind::kFlat, rc - e, 0.0, rw);
  part.rotation_sense = -1;
  part.c_offset_deg = -pin_angle;
  const PeriodicSpline lift =
      testing::spline_sampled([&](double b) { return e * (1.0 + std::cos(b * kRadPerDeg)); }, 0.1);
  Result<MachinePath> cam = compute_machine_path(lift, part, 0.5);
  ASSERT_TRUE(cam.ok()) << cam.error().message;
  Result<PinPath> path = compute_pin_path(pin, 0.5);
  ASSERT_TRUE(path.ok()) << path.error().message;
  ASSERT_EQ(path->size(), cam->x_mm.size());
  double worst_x = 0.0;
  double worst_dx = 0.0;
  for (size_t k = 0; k < cam->x_mm.size(); ++k) {
    EXPECT_DOUBLE_EQ(cam->c_deg[k], path->c_deg(k));
    worst_x = std::max(worst_x, std::abs(design_pin_pose(pin, cam->c_deg[k]).x_mm - cam->x_mm[k]));
    worst_dx = std::max(worst_dx, std::abs(path->dx_dc_mm_per_deg[k] - cam->dx_dc_mm_per_deg[k]));
  }
  // The issue's 1e-5 mm; the cam path is exact to ~1e-9 mm (wheel_path.h) and the 0.1 deg
  // lift spline of a cosine is off by ~1e-12 mm, so both land far inside it.
  EXPECT_LT(worst_x, 1e-5);
  EXPECT_LT(worst_dx, 1e-5);
}

TEST(PinKinematics, DpsiDcIsTheSlopeOfTheContactAngle) {
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = kinematics_pin(mode, 15.0);
    const double h = 1e-3;
    double worst = 0.0;
    for (int i = 0; i < 720; ++i) {
      const double c = 0.5 * i;
      double diff = design_pin_pose(pin, c + h).contact_psi_deg - design_pin_pose(pin, c - h).contact_psi_deg;
      diff -= 360.0 * std::round(diff / 360.0);  // across the wrap at 0/360
      worst = std::max(worst, std::abs(design_pin_pose(pin, c).dpsi_dc - diff / (2.0 * h)));
    }
    // Central difference: truncation h^2/6 |psi'''| ~ 1e-8 deg/deg at most, rounding
    // 1e-13 deg / 1e-3 deg ~ 1e-10.
    EXPECT_LT(worst, 1e-7) << pin_mode_name(mode);
  }
}

double speed_ratio_over_a_turn(const PinGeometry& pin) {
  double lo = 1e300;
  double hi = 0.0;
  for (int i = 0; i < 3600; ++i) {
    const double v = pin_grinding_point_speed_mm_per_min(pin, 0.1 * i, 60.0);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  return hi / lo;
}

TEST(PinKinematics, GrindingPointSpeedVariesByTheIssuesRatioInCxAndNotInCxy) {
  // (r + rw + R) / (r + rw - R) = 370 / 280 = 1.32143: the extremes at t = 0 and 180, both
  // on the 0.1 deg grid, so only rounding separates them.
  EXPECT_NEAR(speed_ratio_over_a_turn(kinematics_pin(PinMode::kCX)), 370.0 / 280.0, 1e-9);
  EXPECT_NEAR(speed_ratio_over_a_turn(kinematics_pin(PinMode::kCX)), 1.3214, 5e-5);
  EXPECT_NEAR(speed_ratio_over_a_turn(kinematics_pin(PinMode::kCXY)), 1.0, 1e-12);
  // C-X-Y at 60 rpm: the pin's circumference once a turn, 2 pi r 60 mm/min.
  EXPECT_NEAR(pin_grinding_point_speed_mm_per_min(kinematics_pin(PinMode::kCXY), 33.0, 60.0),
              2.0 * std::numbers::pi * 25.0 * 60.0, 1e-9);
}

TEST(PinKinematics, WheelTouchesThePinAlongTheNormalInBothModes) {
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = kinematics_pin(mode, -20.0);
    const double reach = pin.pin_radius_mm + pin.wheel_radius_mm;
    double worst_distance = 0.0;
    double worst_normal = 0.0;
    for (int i = 0; i < 3600; ++i) {
      const double c = 0.1 * i;
      const PinPose pose = design_pin_pose(pin, c);
      const double t = crank_angle_deg(pin, c) * kRadPerDeg;
      // core/pin.h: the wheel centre at X + (r + rw - R) on X (and Y in C-X-Y).
      const double dx = pose.x_mm + reach - pin.throw_mm - pin.throw_mm * std::cos(t);
      const double dy = pose.y_mm - pin.throw_mm * std::sin(t);
      worst_distance = std::max(worst_distance, std::abs(std::hypot(dx, dy) - reach));
      const double phi = mode == PinMode::kCXY ? 0.0 : -std::asin(pin.throw_mm * std::sin(t) / reach) / kRadPerDeg;
      worst_normal = std::max(worst_normal, std::abs(std::atan2(dy, dx) / kRadPerDeg - pose.normal_deg));
      worst_normal = std::max(worst_normal, std::abs(pose.normal_deg - phi));
      if (mode == PinMode::kCXY) {
        EXPECT_EQ(pose.normal_deg, 0.0);
      }
    }
    // Rounding on 325 mm (~1e-13 mm, ~1e-12 deg); 1e-9 leaves room and still catches any slip.
    EXPECT_LT(worst_distance, 1e-9) << pin_mode_name(mode);
    EXPECT_LT(worst_normal, 1e-9) << pin_mode_name(mode);
  }
}

}  // namespace
}  // namespace gaugeloop
