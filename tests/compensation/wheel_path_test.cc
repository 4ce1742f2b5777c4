// Tests of the wheel path: exact disc cases, the example lobes, and the refusals.
#include "compensation/wheel_path.h"

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_lobes.h"

namespace gaugeloop {
namespace {

using ::testing::ContainsRegex;
using testing::Disc;
using ::testing::HasSubstr;
using testing::make_part;

// The eccentric disc of the cam-grinding kinematics under each follower: the same lobe, so the same exact
// infeed whatever follower its lift table was written for.
struct DiscCase {
  const char* follower;
  FollowerKind kind;
  double rr_mm;
};

class EccentricDisc : public ::testing::TestWithParam<DiscCase> {
 protected:
  // The lift table this follower would have for the disc, as knots every 0.1 deg.
  PeriodicSpline lift() const {
    const DiscCase& c = GetParam();
    if (c.kind == FollowerKind::kFlat) {
      return testing::spline_sampled([&](double d) { return disc_.flat_lift_mm(d); }, 0.1);
    }
    return testing::spline_sampled([&](double d) { return disc_.roller_lift_mm(d, c.rr_mm); }, 0.1);
  }
  Part part() const { return make_part(GetParam().kind, disc_.base_circle_mm(), GetParam().rr_mm, kWheelMm); }

  static constexpr double kWheelMm = 200.0;
  const Disc disc_{20.0, 5.0};
};

TEST_P(EccentricDisc, InfeedAndItsDerivativesMatchTheExactFormulaAtATenthOfADegree) {
  Result<WheelPath> path = compute_wheel_path(lift(), part(), 0.1);
  ASSERT_TRUE(path.ok()) << path.error().message;
  ASSERT_EQ(path->psi_deg.size(), 3600u);
  ASSERT_EQ(path->dx_dpsi_mm_per_deg.size(), 3600u);
  ASSERT_EQ(path->d2x_dpsi2_mm_per_deg2.size(), 3600u);
  double worst_x = 0.0;
  double worst_v = 0.0;
  double worst_a = 0.0;
  for (size_t k = 0; k < path->psi_deg.size(); ++k) {
    const double psi = path->psi_deg[k];
    worst_x = std::max(worst_x, std::abs(path->x_mm[k] - disc_.exact_infeed_mm(psi, kWheelMm)));
    worst_v =
        std::max(worst_v, std::abs(path->dx_dpsi_mm_per_deg[k] - disc_.exact_infeed_d1_mm_per_deg(psi, kWheelMm)));
    worst_a =
        std::max(worst_a, std::abs(path->d2x_dpsi2_mm_per_deg2[k] - disc_.exact_infeed_d2_mm_per_deg2(psi, kWheelMm)));
  }
  std::printf("%s worst x %.3g v %.3g a %.3g\n", GetParam().follower, worst_x, worst_v, worst_a);
  // TOLERANCE_COMMENT
  EXPECT_LT(worst_x, 1e-8) << GetParam().follower;
  EXPECT_LT(worst_v, 1e-7) << GetParam().follower;
  EXPECT_LT(worst_a, 1e-8) << GetParam().follower;
}

INSTANTIATE_TEST_SUITE_P(AllFollowers, EccentricDisc,
                         ::testing::Values(DiscCase{"flat", FollowerKind::kFlat, 0.0},
                                           DiscCase{"knife_edge", FollowerKind::kKnifeEdge, 0.0},
                                           DiscCase{"roller", FollowerKind::kRoller, 8.0}),
                         [](const ::testing::TestParamInfo<DiscCase>& p) { return std::string(p.param.follower); });

// Largest gap between the analytic derivatives of a path and central differences of the
// values below them, and the peaks, over one turn of psi at `step_deg`.
struct DifferenceCheck {
  double worst_v = 0.0;  // |X' - (X(k+1) - X(k-1)) / 2h|, mm/deg
  double worst_a = 0.0;  // |X'' - (X'(k+1) - X'(k-1)) / 2h|, mm/deg^2
  double peak_v = 0.0;
  double peak_a = 0.0;
};

DifferenceCheck check_against_differences(const PeriodicSpline& lift, const Part& part, double step_deg) {
  DifferenceCheck c;
  Result<WheelPath> path = compute_wheel_path(lift, part, step_deg);
  EXPECT_TRUE(path.ok()) << path.error().message;
  if (!path.ok()) return c;
  const size_t n = path->psi_deg.size();
  for (size_t k = 0; k < n; ++k) {
    const size_t prev = (k + n - 1) % n;
    const size_t next = (k + 1) % n;
    const double v_diff = (path->x_mm[next] - path->x_mm[prev]) / (2 * step_deg);
    const double a_diff = (path->dx_dpsi_mm_per_deg[next] - path->dx_dpsi_mm_per_deg[prev]) / (2 * step_deg);
    c.worst_v = std::max(c.worst_v, std::abs(path->dx_dpsi_mm_per_deg[k] - v_diff));
    c.worst_a = std::max(c.worst_a, std::abs(path->d2x_dpsi2_mm_per_deg2[k] - a_diff));
    c.peak_v = std::max(c.peak_v, std::abs(path->dx_dpsi_mm_per_deg[k]));
    c.peak_a = std::max(c.peak_a, std::abs(path->d2x_dpsi2_mm_per_deg2[k]));
  }
  return c;
}

TEST(WheelPath, DerivativesConvergeToDifferencesOfTheInfeedOnEveryExampleLobe) {
  // The disc above checks the formulas exactly, but not the roller's concave flanks. Here the
  // analytic X' and X'' must agree with central differences of the rows beside them. X' must
  // converge as a difference of a C3 function does, as h^2 (h^2/6 |X'''|): the gap falls 4x
  // from h = 0.02 to 0.01 deg (measured); bound: below 0.3x and below 1e-4 of the peak. X''
  // cannot be held to a rate: X''' jumps at every knot of the lift spline (its H''' does),
  // and a difference straddling a jump J misses by up to J h / 4, erratically with where the
  // knots fall. Measured at h = 0.01: intake 1.5e-6 of a 6.9e-3 mm/deg^2 peak; exhaust
  // 1.6e-4 of 0.1 mm/deg^2 beside its concave flanks, where the 45 mm wheel nearly matches
  // the flank and amplifies the jumps. Bound: 1e-2 of the peak; a wrong curvature term
  // misses by a good fraction of the peak.
  for (const testing::ExampleLobe& lobe : testing::example_lobes()) {
    const PeriodicSpline lift = testing::spline_of(testing::example_table(std::string(lobe.name) + ".csv"));
    const DifferenceCheck coarse = check_against_differences(lift, lobe.part, 0.02);
    const DifferenceCheck fine = check_against_differences(lift, lobe.part, 0.01);
    EXPECT_LT(fine.worst_v, 0.3 * coarse.worst_v) << lobe.name;
    EXPECT_LT(fine.worst_v, 1e-4 * fine.peak_v) << lobe.name;
    EXPECT_LT(fine.worst_a, 1e-2 * fine.peak_a) << lobe.name;
  }
}

TEST(MachinePath, RowsAreTheWheelAtTheirOwnCAngleForEitherSenseAndAnyOffset) {
  // C = s psi + c0, so the row at C is the wheel at psi = s (C - c0), and dX/dC = s dX/dpsi.
  // c0 = 37.3 deg is no whole number of 0.5 deg steps: the rows fall between the psi grid's.
  // Tolerances as for the disc path above (1e-9 mm, 1e-9 mm/deg, 1e-8 mm/deg^2).
  const Disc disc{20.0, 5.0};
  const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.flat_lift_mm(d); }, 0.1);
  for (int sense : {1, -1}) {
    Part part = make_part(FollowerKind::kFlat, disc.base_circle_mm(), 0.0, 200.0);
    part.rotation_sense = sense;
    part.c_offset_deg = 37.3;
    Result<MachinePath> path = compute_machine_path(lift, part, 0.5);
    ASSERT_TRUE(path.ok()) << path.error().message;
    ASSERT_EQ(path->c_deg.size(), 720u);
    for (size_t k = 0; k < path->c_deg.size(); ++k) {
      EXPECT_DOUBLE_EQ(path->c_deg[k], 0.5 * static_cast<double>(k));
      const double psi = sense * (path->c_deg[k] - part.c_offset_deg);
      EXPECT_NEAR(path->x_mm[k], disc.exact_infeed_mm(psi, 200.0), 1e-9) << sense << " C " << path->c_deg[k];
      EXPECT_NEAR(path->dx_dc_mm_per_deg[k], sense * disc.exact_infeed_d1_mm_per_deg(psi, 200.0), 1e-9);
      EXPECT_NEAR(path->d2x_dc2_mm_per_deg2[k], disc.exact_infeed_d2_mm_per_deg2(psi, 200.0), 1e-8);
    }
  }
}

TEST(MachinePath, WithNoOffsetIsThePsiPathRowForRow) {
  const PeriodicSpline lift = testing::spline_of(testing::example_table("exhaust_roller.csv"));
  const Part part = testing::exhaust_roller_part(45.0);
  Result<MachinePath> machine = compute_machine_path(lift, part, 1.0);
  Result<WheelPath> cam = compute_wheel_path(lift, part, 1.0);
  ASSERT_TRUE(machine.ok() && cam.ok());
  EXPECT_EQ(machine->x_mm, cam->x_mm);  // the same computation at the same angles
  EXPECT_EQ(machine->dx_dc_mm_per_deg, cam->dx_dpsi_mm_per_deg);
  EXPECT_EQ(machine->d2x_dc2_mm_per_deg2, cam->d2x_dpsi2_mm_per_deg2);
}

TEST(MachinePath, RejectsABadStepSenseOrOffsetAndRefusesWhatThePathRefuses) {
  const PeriodicSpline lift = testing::spline_of(testing::example_table("exhaust_roller.csv"));
  Part part = testing::exhaust_roller_part(45.0);
  EXPECT_EQ(compute_machine_path(lift, part, 0.7).error().code, ErrorCode::kInvalidInput);
  part.rotation_sense = 0;
  EXPECT_THAT(compute_machine_path(lift, part, 1.0).error().message, HasSubstr("rotation_sense"));
  part.rotation_sense = 1;
  part.c_offset_deg = std::nan("");
  EXPECT_THAT(compute_machine_path(lift, part, 1.0).error().message, HasSubstr("c_offset_deg"));
  Result<MachinePath> too_big = compute_machine_path(lift, testing::exhaust_roller_part(100.0), 1.0);
  ASSERT_FALSE(too_big.ok());
  EXPECT_EQ(too_big.error().code, ErrorCode::kRefused);
}

TEST(SlideMotion, ScalesPerDegreeFiguresByTheSpindleSpeed) {
  // 60 rpm turns C 360 deg/s: 0.1 mm/deg is 36 mm/s; 0.002 mm/deg^2 is 259.2 mm/s^2. A
  // negative speed turns C the other way: the velocity changes sign, the acceleration not.
  EXPECT_DOUBLE_EQ(spindle_deg_per_s(60.0), 360.0);
  EXPECT_NEAR(slide_velocity_mm_per_s(0.1, 60.0), 36.0, 1e-12);
  EXPECT_NEAR(slide_acceleration_mm_per_s2(0.002, 60.0), 259.2, 1e-9);
  EXPECT_NEAR(slide_velocity_mm_per_s(0.1, -60.0), -36.0, 1e-12);
  EXPECT_NEAR(slide_acceleration_mm_per_s2(0.002, -60.0), 259.2, 1e-9);
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
