// The pin's wheel path, the normal split onto the axes, the corrected path and the pin's
// speed program.
#include "compensation/pin_path.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "compensation/pin_kinematics.h"
#include "tests/support/angles.h"

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

using ::testing::HasSubstr;

PinGeometry path_pin(PinMode mode, double pin_angle_deg = 20.0) {
  PinGeometry pin;  // R 45, r 25, rw 300
  pin.mode = mode;
  pin.pin_angle_deg = pin_angle_deg;
  return pin;
}

PinPath path_of(const PinGeometry& pin, double step_deg) {
  Result<PinPath> p = compute_pin_path(pin, step_deg);
  EXPECT_TRUE(p.ok()) << (p.ok() ? "" : p.error().message);
  return std::move(p).value();
}

// Largest difference between the path's derivatives and central differences of its values
// (periodic), for one axis.
struct DerivativeGap {
  double first = 0.0;
  double second = 0.0;
};

DerivativeGap gap(const std::vector<double>& v, const std::vector<double>& d1, const std::vector<double>& d2,
                  double h) {
  DerivativeGap g;
  const size_t n = v.size();
  for (size_t k = 0; k < n; ++k) {
    const double prev = v[(k + n - 1) % n];
    const double next = v[(k + 1) % n];
    g.first = std::max(g.first, std::abs(d1[k] - (next - prev) / (2.0 * h)));
    g.second = std::max(g.second, std::abs(d2[k] - (next - 2.0 * v[k] + prev) / (h * h)));
  }
  return g;
}

// At a 0.01 deg step the central differences' truncation is h^2/6 |X'''| ~ 4e-9 mm/deg and
// h^2/12 |X''''| ~ 1e-11 mm/deg^2; rounding of ~1e-14 mm over h and h^2 adds ~1e-12 mm/deg
// and ~1e-9 mm/deg^2 (measured: 4.5e-9 and 2.5e-9). X' is ~0.8 mm/deg and X'' ~0.014
// mm/deg^2 at most; the correction's share of X'' is ~1e-5, and dropping its smallest term
// (the split's curvature) is off by 1.4e-7, so the tolerances sit between.
constexpr double kFirstTolerance = 3e-8;
constexpr double kSecondTolerance = 2e-8;

TEST(PinPath, DerivativesMatchCentralDifferencesInBothModes) {
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = path_pin(mode);
    const PinPath path = path_of(pin, 0.01);
    ASSERT_EQ(path.size(), 36000u);
    const DerivativeGap gx = gap(path.x_mm, path.dx_dc_mm_per_deg, path.d2x_dc2_mm_per_deg2, 0.01);
    const DerivativeGap gy = gap(path.y_mm, path.dy_dc_mm_per_deg, path.d2y_dc2_mm_per_deg2, 0.01);
    EXPECT_LT(gx.first, kFirstTolerance) << pin_mode_name(mode);
    EXPECT_LT(gx.second, kSecondTolerance) << pin_mode_name(mode);
    EXPECT_LT(gy.first, kFirstTolerance) << pin_mode_name(mode);
    EXPECT_LT(gy.second, kSecondTolerance) << pin_mode_name(mode);
    // The rows are the design poses.
    for (size_t k = 0; k < path.size(); k += 997) {
      const PinPose pose = design_pin_pose(pin, path.c_deg(k));
      EXPECT_EQ(path.x_mm[k], pose.x_mm);
      EXPECT_EQ(path.y_mm[k], pose.y_mm);
      EXPECT_EQ(path.contact_psi_deg[k], pose.contact_psi_deg);
      EXPECT_EQ(path.normal_deg[k], pose.normal_deg);
    }
  }
  // C-X leaves Y alone.
  const PinPath cx = path_of(path_pin(PinMode::kCX), 1.0);
  EXPECT_TRUE(std::all_of(cx.y_mm.begin(), cx.y_mm.end(), [](double y) { return y == 0.0; }));
}

TEST(PinPath, RefusesAStepThatDoesNotMakeATurnAndABadPin) {
  for (double step : {0.0, -0.5, 0.7, 2.0, std::numeric_limits<double>::quiet_NaN()}) {
    Result<PinPath> p = compute_pin_path(path_pin(PinMode::kCX), step);
    ASSERT_FALSE(p.ok()) << step;
    EXPECT_EQ(p.error().code, ErrorCode::kInvalidInput);
    EXPECT_THAT(p.error().message, HasSubstr("c_step_deg"));
  }
  PinGeometry pin = path_pin(PinMode::kCX);
  pin.throw_mm = 400.0;
  Result<PinPath> p = compute_pin_path(pin, 1.0);
  ASSERT_FALSE(p.ok());
  EXPECT_THAT(p.error().message, HasSubstr("throw_mm"));
}

TEST(SplitAlongDirection, TheMovesProjectionOnTheDirectionIsTheDisplacement) {
  for (double n : {-30.0, -7.5, 0.0, 12.0, 45.0, 100.0}) {
    for (const std::vector<double>& axes :
         {std::vector<double>{0.0}, std::vector<double>{0.0, 90.0}, std::vector<double>{0.0, 60.0, 135.0}}) {
      Result<std::vector<double>> u = split_along_direction(0.037, n, axes);
      ASSERT_TRUE(u.ok()) << u.error().message;
      double projection = 0.0;
      for (size_t k = 0; k < axes.size(); ++k) projection += (*u)[k] * std::cos((axes[k] - n) * kRadPerDeg);
      EXPECT_NEAR(projection, 0.037, 1e-15) << n;  // rounding of a few terms of 0.04 mm
    }
  }
}

TEST(SplitAlongDirection, XAndYGiveTheDirectionCosinesAndXAloneTheSecant) {
  const double d = 0.02;
  const double n = -8.0;
  Result<std::vector<double>> xy = split_along_direction(d, n, {0.0, 90.0});
  ASSERT_TRUE(xy.ok());
  EXPECT_NEAR((*xy)[0], d * std::cos(n * kRadPerDeg), 1e-16);
  EXPECT_NEAR((*xy)[1], d * std::sin(n * kRadPerDeg), 1e-16);
  Result<std::vector<double>> x = split_along_direction(d, n, {0.0});
  ASSERT_TRUE(x.ok());
  ASSERT_EQ(x->size(), 1u);
  EXPECT_NEAR((*x)[0], d / std::cos(n * kRadPerDeg), 1e-16);
}

TEST(SplitAlongDirection, RefusesADirectionNoAxisCanMoveAlong) {
  Result<std::vector<double>> u = split_along_direction(0.01, 90.0, {0.0});
  ASSERT_FALSE(u.ok());
  EXPECT_EQ(u.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(u.error().message, HasSubstr("90.0000 deg"));
  EXPECT_FALSE(split_along_direction(0.01, 0.0, {90.0, -90.0}).ok());
  EXPECT_FALSE(split_along_direction(0.01, 0.0, {}).ok());
}

PinPath corrected(const PinGeometry& pin, const DegreeTable& c_um, double step_deg) {
  Result<PinPath> p = corrected_pin_path(pin, c_um, step_deg);
  EXPECT_TRUE(p.ok()) << (p.ok() ? "" : p.error().message);
  return std::move(p).value();
}

// The distance from the wheel centre to the pin's nominal centre at row k (core/pin.h).
double centre_distance_mm(const PinGeometry& pin, const PinPath& path, size_t k) {
  const double t = crank_angle_deg(pin, path.c_deg(k)) * kRadPerDeg;
  const double dx = path.x_mm[k] + pin.pin_radius_mm + pin.wheel_radius_mm - pin.throw_mm - pin.throw_mm * std::cos(t);
  return std::hypot(dx, path.y_mm[k] - pin.throw_mm * std::sin(t));
}

TEST(CorrectedPinPath, ZeroCorrectionIsTheDesignBitForBit) {
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = path_pin(mode);
    const PinPath design = path_of(pin, 0.1);
    const PinPath moved = corrected(pin, DegreeTable{}, 0.1);
    EXPECT_EQ(moved.x_mm, design.x_mm);
    EXPECT_EQ(moved.dx_dc_mm_per_deg, design.dx_dc_mm_per_deg);
    EXPECT_EQ(moved.d2x_dc2_mm_per_deg2, design.d2x_dc2_mm_per_deg2);
    EXPECT_EQ(moved.y_mm, design.y_mm);
    EXPECT_EQ(moved.dy_dc_mm_per_deg, design.dy_dc_mm_per_deg);
    EXPECT_EQ(moved.d2y_dc2_mm_per_deg2, design.d2y_dc2_mm_per_deg2);
    EXPECT_EQ(moved.contact_psi_deg, design.contact_psi_deg);
    EXPECT_EQ(moved.normal_deg, design.normal_deg);
  }
}

TEST(CorrectedPinPath, AConstantCorrectionBringsTheWheelInByItInBothModes) {
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = path_pin(mode);
    const PinPath design = path_of(pin, 0.1);
    for (double c_um : {1.0, 20.0}) {
      DegreeTable table;
      table.fill(c_um);
      const PinPath moved = corrected(pin, table, 0.1);
      // C-X-Y moves along the line of centres: exact. C-X moves X by d / cos n, which also
      // carries the wheel d tan n across the line: the distance changes by a second-order
      // d^2 tan^2 n / (2 (r + rw)) more, 3e-11 mm at 1 um and 1.2e-8 mm at 20 um
      // (tan^2 n <= R^2 / ((r + rw)^2 - R^2) = 0.0196). Plus rounding on 325 mm (~1e-13).
      const double d = c_um / 1000.0;
      const double reach = pin.pin_radius_mm + pin.wheel_radius_mm;
      const double tan2_max = pin.throw_mm * pin.throw_mm / (reach * reach - pin.throw_mm * pin.throw_mm);
      const double second_order = mode == PinMode::kCX ? d * d * tan2_max / (2.0 * reach) : 0.0;
      double worst = 0.0;
      for (size_t k = 0; k < design.size(); ++k) {
        const double shrink = centre_distance_mm(pin, design, k) - centre_distance_mm(pin, moved, k);
        worst = std::max(worst, std::abs(shrink - d));
      }
      EXPECT_LT(worst, 1e-9 + second_order) << pin_mode_name(mode) << " c " << c_um;
    }
  }
}

DegreeTable cos2(double amplitude_um) {
  DegreeTable t;
  for (size_t i = 0; i < t.size(); ++i) t[i] = amplitude_um * std::cos(2.0 * static_cast<double>(i) * kRadPerDeg);
  return t;
}

TEST(CorrectedPinPath, TheMoveAlongTheNormalIsTheCorrectionAtTheContactAngle) {
  const double amplitude_um = 20.0;
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = path_pin(mode);
    const PinPath design = path_of(pin, 0.1);
    const PinPath moved = corrected(pin, cos2(amplitude_um), 0.1);
    double worst = 0.0;
    for (size_t k = 0; k < design.size(); ++k) {
      const double n = design.normal_deg[k] * kRadPerDeg;
      const double along =
          (moved.x_mm[k] - design.x_mm[k]) * std::cos(n) + (moved.y_mm[k] - design.y_mm[k]) * std::sin(n);
      const double want = -amplitude_um * std::cos(2.0 * design.contact_psi_deg[k] * kRadPerDeg) / 1000.0;
      worst = std::max(worst, std::abs(along - want));
    }
    // The whole-degree periodic spline of A cos 2 psi is off by at most ~5/384 h^4 |c''''|
    // = 2e-8 A um (h = 1 deg in rad), 4e-10 mm at A = 20 um; rounding of the difference of
    // two ~90 mm values adds ~1e-14 mm.
    EXPECT_LT(worst, 1e-9) << pin_mode_name(mode);
  }
}

TEST(CorrectedPinPath, DerivativesMatchCentralDifferencesInBothModes) {
  for (PinMode mode : {PinMode::kCX, PinMode::kCXY}) {
    const PinGeometry pin = path_pin(mode);
    DegreeTable c = cos2(20.0);
    for (size_t i = 0; i < c.size(); ++i) c[i] += 5.0 * std::sin(3.0 * static_cast<double>(i) * kRadPerDeg) + 3.0;
    const PinPath moved = corrected(pin, c, 0.01);
    const DerivativeGap gx = gap(moved.x_mm, moved.dx_dc_mm_per_deg, moved.d2x_dc2_mm_per_deg2, 0.01);
    const DerivativeGap gy = gap(moved.y_mm, moved.dy_dc_mm_per_deg, moved.d2y_dc2_mm_per_deg2, 0.01);
    // As for the design; the correction's spline adds ~1e-9 mm/deg^2 at most (its third
    // derivative jumps at the knots by ~1e-7 mm/deg^3, times h).
    EXPECT_LT(gx.first, kFirstTolerance) << pin_mode_name(mode);
    EXPECT_LT(gx.second, kSecondTolerance) << pin_mode_name(mode);
    EXPECT_LT(gy.first, kFirstTolerance) << pin_mode_name(mode);
    EXPECT_LT(gy.second, kSecondTolerance) << pin_mode_name(mode);
    // The correction does move the path, so the check above is not the design's again.
    const PinPath design = path_of(pin, 0.01);
    double moved_by = 0.0;
    for (size_t k = 0; k < design.size(); ++k) {
      moved_by = std::max(moved_by, std::abs(moved.d2x_dc2_mm_per_deg2[k] - design.d2x_dc2_mm_per_deg2[k]));
    }
    EXPECT_GT(moved_by, 1e-6) << pin_mode_name(mode);
  }
}

TEST(CorrectedPinPath, RefusesANonFiniteCorrection) {
  DegreeTable c{};
  c[123] = std::numeric_limits<double>::infinity();
  Result<PinPath> p = corrected_pin_path(path_pin(PinMode::kCX), c, 0.1);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(p.error().message, HasSubstr("pin degree 123"));
}

TEST(PinWorkSpeed, CxHoldsTheTargetAndTakesLongerThanTheBaseSpeed) {
  const PinGeometry pin = path_pin(PinMode::kCX);
  const PinPath path = path_of(pin, 0.1);
  WorkSpeedSettings s;  // 60 rpm base, 2000 mm/min target, 1000 deg/s^2, 300 mm/s, 20000 mm/s^2
  const std::vector<double> at_base = pin_grinding_point_speed_mm_per_min(path, pin, s.base_speed_rpm);
  // The target is below what the base speed gives anywhere (~8100 mm/min at the slowest row).
  ASSERT_GT(*std::min_element(at_base.begin(), at_base.end()), s.lobe_speed_mm_per_min);
  Result<WorkSpeedPlan> plan = plan_pin_work_speed(path, pin, s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ASSERT_EQ(plan->program.speed_rpm.size(), path.size());
  EXPECT_EQ(plan->constant_grinding_point_speed_mm_per_min, at_base);
  // Nothing binds at 11-15 rpm (C accelerates by tens of deg/s^2, the slide runs at a few
  // mm/s), so every row is a row where the target should hold: within 1 %.
  ASSERT_LT(plan->largest_c_acceleration_deg_per_s2, 0.5 * s.c_acceleration_max_deg_per_s2);
  ASSERT_LT(plan->largest_x_velocity_mm_per_s, 0.5 * s.x_velocity_max_mm_per_s);
  ASSERT_LT(plan->largest_x_acceleration_mm_per_s2, 0.5 * s.x_acceleration_max_mm_per_s2);
  for (size_t k = 0; k < path.size(); ++k) {
    ASSERT_NEAR(plan->grinding_point_speed_mm_per_min[k], s.lobe_speed_mm_per_min, 0.01 * s.lobe_speed_mm_per_min)
        << "C " << path.c_deg(k);
  }
  // The program itself varies as the speed did: by (r + rw + R) / (r + rw - R).
  const auto [lo, hi] = std::minmax_element(plan->program.speed_rpm.begin(), plan->program.speed_rpm.end());
  EXPECT_NEAR(*hi / *lo, 370.0 / 280.0, 0.01);
  EXPECT_GT(plan->cycle_time_s, plan->constant_cycle_time_s);
  EXPECT_DOUBLE_EQ(plan->constant_cycle_time_s, 1.0);
}

TEST(PinWorkSpeed, CxyProgramIsConstant) {
  const PinGeometry pin = path_pin(PinMode::kCXY);
  const PinPath path = path_of(pin, 0.1);
  WorkSpeedSettings s;
  Result<WorkSpeedPlan> plan = plan_pin_work_speed(path, pin, s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  const auto [lo, hi] = std::minmax_element(plan->program.speed_rpm.begin(), plan->program.speed_rpm.end());
  // 2000 mm/min over a 25 mm pin: 2000 / (2 pi 25) = 12.732 rpm at every row (rounding only).
  EXPECT_NEAR(*lo, 2000.0 / (2.0 * std::numbers::pi * 25.0), 1e-9);
  EXPECT_NEAR(*hi - *lo, 0.0, 1e-9);
  EXPECT_NEAR(plan->cycle_time_s, 60.0 / *lo, 1e-9);
}

TEST(PinWorkSpeed, TheSlideLimitsOfYBindInCxy) {
  // C-X-Y moves Y as much as X: a Y speed limit the slides share slows C where Y runs
  // fastest (t = 0 and 180), which a planner that only looked at X would miss.
  const PinGeometry pin = path_pin(PinMode::kCXY, 0.0);
  const PinPath path = path_of(pin, 0.1);
  WorkSpeedSettings s;
  s.lobe_speed_mm_per_min = 1e5;  // no target below the base speed
  s.x_velocity_max_mm_per_s = 100.0;
  s.c_acceleration_max_deg_per_s2 = 1e6;
  Result<WorkSpeedPlan> plan = plan_pin_work_speed(path, pin, s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  // |Y'| = R pi/180 mm/deg at t = 0, where X' = 0: omega <= 100 / 0.785 = 127 deg/s.
  const double w_limit = 100.0 / (pin.throw_mm * kRadPerDeg);
  EXPECT_NEAR(6.0 * plan->program.speed_rpm[0], w_limit, 1e-6);
  EXPECT_LE(plan->largest_x_velocity_mm_per_s, 100.0 * (1.0 + 1e-9));
}

TEST(PinWorkSpeed, RefusesBadSettingsAndABadPath) {
  const PinGeometry pin = path_pin(PinMode::kCX);
  WorkSpeedSettings s;
  s.base_speed_rpm = -1.0;
  EXPECT_FALSE(plan_pin_work_speed(path_of(pin, 1.0), pin, s).ok());
  PinPath empty;
  Result<WorkSpeedPlan> plan = plan_pin_work_speed(empty, pin, WorkSpeedSettings{});
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
}

}  // namespace
}  // namespace gaugeloop
