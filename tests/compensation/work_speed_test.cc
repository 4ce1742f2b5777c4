#include "compensation/work_speed.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "compensation/wheel_path.h"
#include "test_lobes.h"
#include "tests/support/angles.h"

namespace gaugeloop {
namespace {

using testing::kPi;

using testing::Disc;
using ::testing::HasSubstr;
using testing::make_part;

MachinePath intake_path(double step_deg) {
  Result<MachinePath> p = compute_machine_path(testing::spline_of(testing::example_table("intake_flat.csv")),
                                               testing::intake_flat_part(), step_deg);
  EXPECT_TRUE(p.ok());
  return std::move(p).value();
}

TEST(ContactArc, OnTheBaseCircleTheContactPointRunsAtTheBaseRadius) {
  EXPECT_NEAR(contact_arc_mm_per_deg(0.0, 0.0, 0.0, 18.0, 200.0), 18.0 * kPi / 180.0, 1e-12);
  // A zero lift: the whole turn is base circle, 2 pi rb n mm/min.
  const PeriodicSpline zero = testing::spline_sampled([](double) { return 0.0; }, 1.0);
  Result<MachinePath> path = compute_machine_path(zero, testing::intake_flat_part(), 1.0);
  ASSERT_TRUE(path.ok()) << path.error().message;
  for (double v : grinding_point_speed_mm_per_min(*path, testing::intake_flat_part(), 60.0)) {
    EXPECT_NEAR(v, 2.0 * kPi * 18.0 * 60.0, 1e-6);
  }
}

// The eccentric disc: the contact point is rc u(phi) from the disc's centre, with
// phi = psi + asin(e sin psi / Rw), Rw = rc + rw, so ds/dpsi = rc (1 + e cos psi / sqrt(Rw^2 - e^2 sin^2 psi)).
// Any follower: the roller's lift table describes the same disc, so the same surface speed.
class ContactArcOfTheDisc : public ::testing::TestWithParam<double> {};

TEST_P(ContactArcOfTheDisc, MatchesTheEccentricDiscsClosedForm) {
  const Disc disc{20.0, 5.0};
  const double rw = 200.0;
  const double rr = GetParam();
  const Part part = rr > 0.0 ? make_part(FollowerKind::kRoller, disc.base_circle_mm(), rr, rw)
                             : make_part(FollowerKind::kFlat, disc.base_circle_mm(), 0.0, rw);
  const PeriodicSpline lift = testing::spline_sampled(
      [&](double d) { return rr > 0.0 ? disc.roller_lift_mm(d, rr) : disc.flat_lift_mm(d); }, 0.1);
  Result<MachinePath> path = compute_machine_path(lift, part, 0.5);
  ASSERT_TRUE(path.ok()) << path.error().message;
  const double big_r = disc.rc_mm + rw;
  double worst = 0.0;
  for (size_t k = 0; k < path->c_deg.size(); ++k) {
    const double psi = path->c_deg[k] * kPi / 180.0;
    const double s = disc.e_mm * std::sin(psi);
    const double exact_per_rad = disc.rc_mm * (1.0 + disc.e_mm * std::cos(psi) / std::sqrt(big_r * big_r - s * s));
    const double got = contact_arc_mm_per_deg(path->x_mm[k], path->dx_dc_mm_per_deg[k], path->d2x_dc2_mm_per_deg2[k],
                                              part.base_circle_radius_mm, rw);
    worst = std::max(worst, std::abs(got * 180.0 / kPi - exact_per_rad));
  }
  // The path is exact to ~1e-8 mm/deg^2 in X''; times rw that is a few 1e-6 mm/rad.
  EXPECT_LT(worst, 1e-4);
}

INSTANTIATE_TEST_SUITE_P(FlatAndRoller, ContactArcOfTheDisc, ::testing::Values(0.0, 8.0));

TEST(WorkSpeedPlan, HoldsTheTargetOnTheLobeAndTheBaseSpeedOnTheBaseCircle) {
  const MachinePath path = intake_path(0.5);
  WorkSpeedSettings s;  // 60 rpm, 2000 mm/min on the lobe
  Result<WorkSpeedPlan> plan = plan_work_speed(path, testing::intake_flat_part(), s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  ASSERT_EQ(plan->program.speed_rpm.size(), path.x_mm.size());
  double lobe_max = 0.0;
  double constant_lobe_max = 0.0;
  int at_target = 0;
  for (size_t k = 0; k < path.x_mm.size(); ++k) {
    EXPECT_LE(plan->program.speed_rpm[k], 60.0 + 1e-9);
    if (path.x_mm[k] > s.lobe_threshold_mm) {
      lobe_max = std::max(lobe_max, plan->grinding_point_speed_mm_per_min[k]);
      constant_lobe_max = std::max(constant_lobe_max, plan->constant_grinding_point_speed_mm_per_min[k]);
      if (std::abs(plan->grinding_point_speed_mm_per_min[k] - 2000.0) < 1e-6) ++at_target;
    }
  }
  // The base circle (180 +- 60 deg here) keeps 60 rpm.
  EXPECT_NEAR(plan->program.speed_rpm[360], 60.0, 1e-12);
  EXPECT_LE(lobe_max, 2000.0 + 1e-6);
  // At constant speed the flanks run several times faster than the target.
  EXPECT_GT(constant_lobe_max, 3.0 * 2000.0);
  // Most of the lobe is at the target, not below it.
  EXPECT_GT(at_target, 200);
  EXPECT_GT(plan->cycle_time_s, plan->constant_cycle_time_s);
  EXPECT_DOUBLE_EQ(plan->constant_cycle_time_s, 1.0);
  EXPECT_LE(plan->largest_c_acceleration_deg_per_s2, s.c_acceleration_max_deg_per_s2 * (1.0 + 1e-9));
  std::printf("cycle %.3f s against %.3f s; lobe %.0f mm/min against %.0f at constant speed\n", plan->cycle_time_s,
              plan->constant_cycle_time_s, lobe_max, constant_lobe_max);
}

// The variable-speed camshaft paper's program: one grinding-point speed all round, the rise and
// return (X between 5 % and 95 % of its largest value) slowed to the flank speed. No row faster
// than its target; most of the flanks at the flank speed; the base circle reaching the other
// where C has room to ramp (at 1000 deg/s^2 from the flank's 9 rpm to the base circle's 71 it
// needs some 90 deg, so only the middle of the base circle gets there, and the short nose
// between the two slow flanks not at all).
TEST(WorkSpeedPlan, TheFlankHoldSlowsOnlyTheRiseAndReturn) {
  const MachinePath path = intake_path(0.5);
  WorkSpeedSettings s;
  s.hold = SpeedHold::kFlanks;
  s.base_speed_rpm = 1000.0;  // no cap of its own: the targets and the slide decide
  s.grinding_point_speed_mm_per_min = 8000.0;
  s.flank_speed_mm_per_min = 2000.0;
  Result<WorkSpeedPlan> plan = plan_work_speed(path, testing::intake_flat_part(), s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  const double x_max = *std::max_element(path.x_mm.begin(), path.x_mm.end());
  int flank_rows = 0, flank_at_target = 0, base_at_target = 0, base_rows = 0;
  for (size_t k = 0; k < path.x_mm.size(); ++k) {
    const double v = plan->grinding_point_speed_mm_per_min[k];
    if (is_flank_row(path.x_mm[k], x_max)) {
      ++flank_rows;
      EXPECT_LE(v, 2000.0 * (1 + 1e-9)) << "C " << path.c_deg[k];
      if (v > 1999.0) ++flank_at_target;
    } else {
      EXPECT_LE(v, 8000.0 * (1 + 1e-9)) << "C " << path.c_deg[k];
      if (path.x_mm[k] < 1e-6) {
        ++base_rows;
        if (v > 7999.0) ++base_at_target;
      }
    }
  }
  EXPECT_GT(flank_at_target, flank_rows * 6 / 10) << "the flanks are ground at the flank speed";
  EXPECT_GT(base_at_target, base_rows / 5) << "the middle of the base circle reaches 8000";
  // The baseline: the same hold with the flanks at 8000 too is faster round the turn.
  s.flank_speed_mm_per_min = 8000.0;
  Result<WorkSpeedPlan> baseline = plan_work_speed(path, testing::intake_flat_part(), s);
  ASSERT_TRUE(baseline.ok());
  EXPECT_LT(baseline->cycle_time_s, plan->cycle_time_s);
}

TEST(WorkSpeedPlan, ConstantWhenTheTargetIsNeverReached) {
  WorkSpeedSettings s;
  s.lobe_speed_mm_per_min = 1e5;
  Result<WorkSpeedPlan> plan = plan_work_speed(intake_path(1.0), testing::intake_flat_part(), s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  for (double n : plan->program.speed_rpm) EXPECT_DOUBLE_EQ(n, 60.0);
  EXPECT_NEAR(plan->cycle_time_s, 1.0, 1e-12);
}

TEST(WorkSpeedPlan, TheCAccelerationLimitBites) {
  WorkSpeedSettings s;
  s.c_acceleration_max_deg_per_s2 = 500.0;
  Result<WorkSpeedPlan> slow = plan_work_speed(intake_path(0.5), testing::intake_flat_part(), s);
  ASSERT_TRUE(slow.ok()) << slow.error().message;
  EXPECT_LE(slow->largest_c_acceleration_deg_per_s2, 500.0 * (1.0 + 1e-9));
  EXPECT_GT(slow->largest_c_acceleration_deg_per_s2, 0.9 * 500.0);
  // Slowing down earlier and speeding up later costs time against the default limit.
  Result<WorkSpeedPlan> fast = plan_work_speed(intake_path(0.5), testing::intake_flat_part(), WorkSpeedSettings{});
  ASSERT_TRUE(fast.ok());
  EXPECT_GT(slow->cycle_time_s, fast->cycle_time_s + 0.01);
}

TEST(WorkSpeedPlan, TheSlideLimitsBiteAtVariableSpeed) {
  const MachinePath path = intake_path(0.5);
  WorkSpeedSettings s;
  s.lobe_speed_mm_per_min = 1e5;  // only the slide holds C back
  double v_at_base = 0.0;
  double a_at_base = 0.0;
  for (size_t k = 0; k < path.x_mm.size(); ++k) {
    v_at_base = std::max(v_at_base, std::abs(path.dx_dc_mm_per_deg[k]) * 360.0);
    a_at_base = std::max(a_at_base, std::abs(path.d2x_dc2_mm_per_deg2[k]) * 360.0 * 360.0);
  }
  s.x_velocity_max_mm_per_s = 0.5 * v_at_base;
  s.x_acceleration_max_mm_per_s2 = 0.5 * a_at_base;
  Result<WorkSpeedPlan> plan = plan_work_speed(path, testing::intake_flat_part(), s);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_LE(plan->largest_x_velocity_mm_per_s, s.x_velocity_max_mm_per_s * (1.0 + 1e-9));
  EXPECT_LE(plan->largest_x_acceleration_mm_per_s2, s.x_acceleration_max_mm_per_s2 * (1.0 + 1e-9));
  EXPECT_GT(plan->largest_x_acceleration_mm_per_s2, 0.4 * s.x_acceleration_max_mm_per_s2);
  EXPECT_LT(*std::min_element(plan->program.speed_rpm.begin(), plan->program.speed_rpm.end()), 50.0);
}

TEST(WorkSpeedPlan, RefusesSettingsNamingTheKey) {
  WorkSpeedSettings s;
  s.lobe_speed_mm_per_min = -1.0;
  Result<WorkSpeedPlan> plan = plan_work_speed(intake_path(1.0), testing::intake_flat_part(), s);
  ASSERT_FALSE(plan.ok());
  EXPECT_EQ(plan.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(plan.error().message, HasSubstr("[speed] lobe_speed_mm_per_min"));
  s = WorkSpeedSettings{};
  s.c_acceleration_max_deg_per_s2 = std::nan("");
  EXPECT_THAT(validate(s).error().message, HasSubstr("c_acceleration_max_deg_per_s2"));
}

}  // namespace
}  // namespace gaugeloop
