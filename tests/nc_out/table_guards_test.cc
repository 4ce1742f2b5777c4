// Guards: each refusal names what, the C degree, the value and the limit.
#include "nc_out/table_guards.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "tests/nc_out/analytic_path.h"

namespace gaugeloop {
namespace {

using testing::analytic_path;
using ::testing::HasSubstr;

// X = 4 (1 - cos C): 0 .. 8 mm; |dX/dC| <= 4 k = 0.0698 mm/deg at C90; |d2X/dC2| <= 4 k^2 =
// 0.00122 mm/deg^2 at C0. At 60 rpm (360 deg/s): 25.1 mm/s and 157.9 mm/s^2.
AxisLimits roomy() { return {-1.0, 9.0, 30.0, 200.0, 60.0}; }

TEST(PathGuards, AcceptsAPathWithinLimits) { EXPECT_TRUE(check_path_guards(analytic_path(4.0, 0.0), roomy()).ok()); }

TEST(PathGuards, RefusesNaNNamingTheDegree) {
  SampledPath p = analytic_path(4.0, 0.0);
  p.x_mm[1234] = std::numeric_limits<double>::quiet_NaN();
  Status s = check_path_guards(p, roomy());
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_THAT(s.error().message, HasSubstr("NaN or infinity at C12.340"));
}

TEST(PathGuards, RefusesInfinityInADerivative) {
  SampledPath p = analytic_path(4.0, 0.0);
  p.d2x_dc2_mm_per_deg2[500] = std::numeric_limits<double>::infinity();
  Status s = check_path_guards(p, roomy());
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("at C5.000"));
}

TEST(PathGuards, RefusesXAboveTheAxisLimit) {
  AxisLimits l = roomy();
  l.x_max_mm = 7.5;
  Status s = check_path_guards(analytic_path(4.0, 0.0), l);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  // First row above 7.5: 4 (1 - cos C) > 7.5 from C151.04.
  EXPECT_THAT(s.error().message, HasSubstr("at C151.050 is above the axis limit x_max_mm 7.5000 mm"));
}

TEST(PathGuards, RefusesXBelowTheAxisLimit) {
  AxisLimits l = roomy();
  l.x_min_mm = 0.5;
  Status s = check_path_guards(analytic_path(4.0, 0.0), l);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("X 0.0000 mm at C0.000 is below the axis limit x_min_mm 0.5000"));
}

TEST(PathGuards, RefusesVelocityAndSaysWhichSpeedFits) {
  AxisLimits l = roomy();
  l.x_velocity_max_mm_per_s = 20.0;
  Status s = check_path_guards(analytic_path(4.0, 0.0), l);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_THAT(s.error().message, HasSubstr("X velocity"));
  EXPECT_THAT(s.error().message, HasSubstr("exceeds the limit 20.00 mm/s at 60.00 rpm"));
  // The first row over 20 mm/s: 25.13 sin C > 20 from C52.74.
  EXPECT_THAT(s.error().message, HasSubstr("at C52.7"));
}

TEST(PathGuards, RefusesAccelerationAndSaysWhichSpeedFits) {
  AxisLimits l = roomy();
  l.x_acceleration_max_mm_per_s2 = 100.0;
  Status s = check_path_guards(analytic_path(4.0, 0.0), l);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("X acceleration 157.9 mm/s^2 at C0.000 exceeds the limit 100.0 mm/s^2"));
  // Acceleration goes with the square of the speed: 60 sqrt(100 / 157.9) = 47.75 rpm.
  EXPECT_THAT(s.error().message, HasSubstr("grind at most 47.75 rpm"));
}

TEST(PathGuards, ANegativeSpeedCountsLikeAPositiveOne) {
  AxisLimits l = roomy();
  l.speed_rpm = -60.0;
  EXPECT_TRUE(check_path_guards(analytic_path(4.0, 0.0), l).ok());
  l.x_velocity_max_mm_per_s = 20.0;
  EXPECT_FALSE(check_path_guards(analytic_path(4.0, 0.0), l).ok());
}

TEST(PathGuards, RefusesUnusableLimitsAsInvalidInput) {
  for (AxisLimits l : {AxisLimits{1.0, 1.0, 30.0, 200.0, 60.0}, AxisLimits{-1.0, 9.0, 0.0, 200.0, 60.0},
                       AxisLimits{-1.0, 9.0, 30.0, -1.0, 60.0}, AxisLimits{-1.0, 9.0, 30.0, 200.0, 0.0}}) {
    Status s = check_path_guards(analytic_path(4.0, 0.0), l);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  }
}

TEST(TableGuards, RefusesATablePointOutsideTheLimits) {
  const SampledPath p = analytic_path(4.0, 0.0);
  Result<CurveTable> t = write_linear_table(p, 1.0);
  ASSERT_TRUE(t.ok());
  EXPECT_TRUE(check_table_guards(*t, p, roomy()).ok());
  t->points[180].x_mm = 12.0;
  Status s = check_table_guards(*t, p, roomy());
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("curve table point X 12.0000 mm at C180.000 is above"));
}

TEST(TableGuards, RefusesASplineWhoseAccelerationBreaksTheLimitWhereThePathKeepsIt) {
  // A 5 deg spline closed at C0 (the writers no longer close it there: spline_start_c_deg):
  // natural ends force S'' = 0 at C0, where X'' is largest; the spline makes up for it with
  // more curvature one segment in: ~200 mm/s^2 near C5 against the path's 157.9.
  const SampledPath p = testing::analytic_path(4.0, 0.0);
  Result<CurveTable> t = CurveTable{};
  t->interpolation = Interpolation::kCubicSpline;
  const CurveTableFormat format;
  for (int k = 0; k <= 72; ++k) {
    t->points.push_back({5.0 * k, format.round_x_mm(p.x_mm[static_cast<std::size_t>(k % 72) * 500])});
  }
  Result<CommandError> e = command_position_error(p, t->points, t->interpolation);
  ASSERT_TRUE(e.ok());
  t->error = *e;
  AxisLimits l = roomy();
  l.x_acceleration_max_mm_per_s2 = 180.0;
  EXPECT_TRUE(check_path_guards(p, l).ok());
  Status s = check_table_guards(*t, p, l);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("curve table X acceleration 180.1 mm/s^2 at C4.490"));
  l.x_acceleration_max_mm_per_s2 = 250.0;
  EXPECT_TRUE(check_table_guards(*t, p, l).ok());
}

}  // namespace
}  // namespace gaugeloop
