// Tests of the wheel path: exact disc cases, the example lobes, and the refusals.
#include "compensation/wheel_path.h"

#include <cmath>
#include <cstdlib>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_lobes.h"

namespace gaugeloop {
namespace {

using ::testing::ContainsRegex;
using testing::Disc;
using ::testing::HasSubstr;
using testing::make_part;

TEST(WheelPath, EccentricDiscWithFlatFollowerMatchesExactInfeed) {
  const Disc disc{20.0, 5.0};
  const double rw = 200.0;
  // Knots every 0.1 deg (h = 1.7e-3 rad): spline error in H is 5/384 h^4 e = 6e-13 mm and in
  // H' is h^3/24 e = 1.1e-9 mm/rad; psi is inverted to 1e-10 deg. X then agrees with the
  // exact formula to ~1e-9 mm. Tolerance 1e-8 mm, tighter than the 1e-5 mm the brief asks.
  const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.flat_lift_mm(d); }, 0.1);
  Result<WheelPath> path =
      compute_wheel_path(lift, make_part(FollowerKind::kFlat, disc.base_circle_mm(), 0.0, rw), 0.1);
  ASSERT_TRUE(path.ok()) << path.error().message;
  ASSERT_EQ(path->psi_deg.size(), 3600u);
  double worst = 0.0;
  for (size_t k = 0; k < path->psi_deg.size(); ++k) {
    worst = std::max(worst, std::abs(path->x_mm[k] - disc.exact_infeed_mm(path->psi_deg[k], rw)));
  }
  EXPECT_LT(worst, 1e-8);
}

TEST(WheelPath, EccentricDiscGivesTheSameInfeedForKnifeEdgeAndRoller) {
  // The disc is the same lobe whatever follower the lift table was written for, so the wheel
  // path is the same exact formula. The knife-edge lift has |H''''| ~ 10 mm/rad^4; on 0.1 deg
  // knots that is ~1e-12 mm of spline error; tolerance 1e-8 mm as for the flat follower.
  const Disc disc{20.0, 5.0};
  const double rw = 200.0;
  for (double rr : {0.0, 8.0}) {
    const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.roller_lift_mm(d, rr); }, 0.1);
    const FollowerKind kind = rr == 0.0 ? FollowerKind::kKnifeEdge : FollowerKind::kRoller;
    Result<WheelPath> path = compute_wheel_path(lift, make_part(kind, disc.base_circle_mm(), rr, rw), 0.5);
    ASSERT_TRUE(path.ok()) << path.error().message;
    ASSERT_EQ(path->psi_deg.size(), 720u);
    for (size_t k = 0; k < path->psi_deg.size(); ++k) {
      EXPECT_NEAR(path->x_mm[k], disc.exact_infeed_mm(path->psi_deg[k], rw), 1e-8)
          << "rr " << rr << " psi " << path->psi_deg[k];
    }
  }
}

TEST(WheelPath, PsiGridIsUniformFromZero) {
  const Disc disc;
  const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.flat_lift_mm(d); }, 1.0);
  Result<WheelPath> path =
      compute_wheel_path(lift, make_part(FollowerKind::kFlat, disc.base_circle_mm(), 0, 200), 0.25);
  ASSERT_TRUE(path.ok());
  ASSERT_EQ(path->psi_deg.size(), 1440u);
  for (size_t k = 0; k < path->psi_deg.size(); ++k) EXPECT_DOUBLE_EQ(path->psi_deg[k], 0.25 * static_cast<double>(k));
}

TEST(WheelPath, IntakeFlatLobeComputes) {
  const PeriodicSpline lift = testing::spline_of(testing::example_table("intake_flat.csv"));
  Result<WheelPath> path = compute_wheel_path(lift, testing::intake_flat_part(), 1.0);
  ASSERT_TRUE(path.ok()) << path.error().message;
  ASSERT_EQ(path->x_mm.size(), 360u);
  // The table is symmetric about the nose, so H'(0) = 0, psi(0) = 0 and X(0) = H(0) = 8.5 mm;
  // 1e-9 mm allows for rounding in the spline solve.
  EXPECT_NEAR(path->x_mm[0], 8.5, 1e-9);
  // On the base circle (lift 0 from 100 to 260 deg; the wheel angle differs from the follower
  // angle only where H' != 0) the infeed is 0; 1e-9 mm: spline ringing from the flanks decays
  // by ~0.27 per knot and is far below that 40 knots away.
  for (int psi = 140; psi <= 220; ++psi) EXPECT_NEAR(path->x_mm[static_cast<size_t>(psi)], 0.0, 1e-9) << psi;
  for (double x : path->x_mm) EXPECT_LE(x, 8.5 + 1e-9);
}

TEST(WheelPath, RejectsAStepThatDoesNotDivideTheTurn) {
  const Disc disc;
  const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.flat_lift_mm(d); }, 1.0);
  const Part part = make_part(FollowerKind::kFlat, disc.base_circle_mm(), 0, 200);
  for (double step : {0.7, 0.0, -1.0, 400.0, std::nan("")}) {
    Result<WheelPath> path = compute_wheel_path(lift, part, step);
    ASSERT_FALSE(path.ok()) << step;
    EXPECT_EQ(path.error().code, ErrorCode::kInvalidInput);
    EXPECT_THAT(path.error().message, HasSubstr("step"));
  }
}

TEST(WheelPath, RejectsRadiiThatAreNotPositive) {
  const Disc disc;
  const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.flat_lift_mm(d); }, 1.0);
  struct Case {
    Part part;
    const char* field;
  };
  const Case cases[] = {
      {make_part(FollowerKind::kFlat, 0.0, 0, 200), "base_circle_radius_mm"},
      {make_part(FollowerKind::kRoller, 15.0, 0.0, 200), "follower_radius_mm"},
      {make_part(FollowerKind::kRoller, 15.0, -3.0, 200), "follower_radius_mm"},
      {make_part(FollowerKind::kFlat, 15.0, 0, -5.0), "wheel_radius_mm"},
      {make_part(FollowerKind::kKnifeEdge, 15.0, 0, std::nan("")), "wheel_radius_mm"},
  };
  for (const Case& c : cases) {
    Result<WheelPath> path = compute_wheel_path(lift, c.part, 1.0);
    ASSERT_FALSE(path.ok()) << c.field;
    EXPECT_EQ(path.error().code, ErrorCode::kInvalidInput);
    EXPECT_THAT(path.error().message, HasSubstr(c.field));
  }
}

TEST(WheelPath, RefusesAFlatFollowerOnANonConvexLobeNamingTheRange) {
  // p = 10 + 3 (1 + cos 3 beta): p + p'' = 13 - 24 cos 3 beta <= 0 where cos 3 beta >= 13/24,
  // i.e. within 19.1 deg of 0, 120 and 240 deg.
  const PeriodicSpline lift =
      testing::spline_sampled([](double d) { return 3.0 * (1.0 + std::cos(3 * d * testing::kRadPerDeg)); }, 0.5);
  Result<WheelPath> path = compute_wheel_path(lift, make_part(FollowerKind::kFlat, 10.0, 0, 200), 1.0);
  ASSERT_FALSE(path.ok());
  EXPECT_EQ(path.error().code, ErrorCode::kRefused);
  EXPECT_THAT(path.error().message, HasSubstr("convex"));
  EXPECT_THAT(path.error().message, ContainsRegex("34[01]\\.[0-9] to 19\\.[01] deg"));
  EXPECT_THAT(path.error().message, ContainsRegex("10[01]\\.[0-9] to 139\\.[01] deg"));
  EXPECT_THAT(path.error().message, ContainsRegex("22[01]\\.[0-9] to 259\\.[01] deg"));
}

TEST(WheelPath, RefusesARollerThatUndercutsTheLobe) {
  // Pitch curve rho = 41 + 3 cos 3 beta... at the nose its radius of curvature is
  // rho^2 / (rho - rho'') = 41^2 / (41 + 27) = 24.7 mm < rr = 25 mm.
  const PeriodicSpline lift =
      testing::spline_sampled([](double d) { return 3.0 * (1.0 + std::cos(3 * d * testing::kRadPerDeg)); }, 0.5);
  Result<WheelPath> path = compute_wheel_path(lift, make_part(FollowerKind::kRoller, 10.0, 25.0, 200), 1.0);
  ASSERT_FALSE(path.ok());
  EXPECT_EQ(path.error().code, ErrorCode::kRefused);
  EXPECT_THAT(path.error().message, HasSubstr("undercut"));
}

// The number after `marker` in `text`, or NaN.
double number_after(const std::string& text, const std::string& marker) {
  const size_t at = text.find(marker);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + marker.size(), nullptr);
}

TEST(WheelPath, RefusesAWheelTooLargeForTheConcaveFlankOfTheExhaustRoller) {
  const PeriodicSpline lift = testing::spline_of(testing::example_table("exhaust_roller.csv"));
  Result<WheelPath> path = compute_wheel_path(lift, testing::exhaust_roller_part(100.0), 1.0);
  ASSERT_FALSE(path.ok());
  EXPECT_EQ(path.error().code, ErrorCode::kRefused);
  EXPECT_THAT(path.error().message, HasSubstr("largest wheel"));
  EXPECT_THAT(path.error().message, HasSubstr("cam angle"));
  // The largest wheel that fits must lie between the wheel accepted below and the one refused.
  const double largest = number_after(path.error().message, "radius below ");
  EXPECT_GT(largest, 45.0);
  EXPECT_LT(largest, 100.0);

  // Just above the reported radius is refused; just below is accepted.
  EXPECT_FALSE(compute_wheel_path(lift, testing::exhaust_roller_part(largest + 0.02), 1.0).ok());
  EXPECT_TRUE(compute_wheel_path(lift, testing::exhaust_roller_part(largest - 0.02), 1.0).ok());
}

TEST(WheelPath, AcceptsAWheelThatFitsTheExhaustRoller) {
  const PeriodicSpline lift = testing::spline_of(testing::example_table("exhaust_roller.csv"));
  Result<WheelPath> path = compute_wheel_path(lift, testing::exhaust_roller_part(45.0), 1.0);
  ASSERT_TRUE(path.ok()) << path.error().message;
  // At the nose (symmetric table) alpha = 0, so |W| = rb + rr + H + rw - rr: X(0) = H(0).
  EXPECT_NEAR(path->x_mm[0], 9.5, 1e-9);
  EXPECT_NEAR(path->x_mm[180], 0.0, 1e-9);
}

}  // namespace
}  // namespace gaugeloop
