// Tests of the periodic cubic spline: interpolation, accuracy, continuity, input checks.
#include "compensation/periodic_spline.h"

#include <cmath>
#include <random>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_lobes.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;
using testing::kRadPerDeg;

// f(beta) = sin(beta) + 0.5 cos(2 beta), beta in rad; |f''''| <= 1 + 0.5 * 16 = 9.
double f(double deg) { return std::sin(deg * kRadPerDeg) + 0.5 * std::cos(2 * deg * kRadPerDeg); }
double f1(double deg) { return std::cos(deg * kRadPerDeg) - std::sin(2 * deg * kRadPerDeg); }
double f2(double deg) { return -std::sin(deg * kRadPerDeg) - 2.0 * std::cos(2 * deg * kRadPerDeg); }
constexpr double kMaxF4 = 9.0;

// Error bounds of cubic spline interpolation with end conditions exact for the function
// (periodic qualifies), h the widest knot spacing in rad (Hall and Meyer, 1976):
// |s - f| <= 5/384 h^4 |f''''|, |s' - f'| <= 1/24 h^3 |f''''|, |s'' - f''| <= 3/8 h^2 |f''''|.
struct Bounds {
  double value, d1, d2;
};
Bounds spline_bounds(double h_deg) {
  const double h = h_deg * kRadPerDeg;
  return {5.0 / 384.0 * std::pow(h, 4) * kMaxF4, std::pow(h, 3) / 24.0 * kMaxF4, 3.0 / 8.0 * h * h * kMaxF4};
}

std::vector<double> jittered_knots(unsigned seed, double* widest_deg) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.4, 0.4);
  std::vector<double> knots;
  for (int i = 0; i < 240; ++i) knots.push_back(1.5 * i + 0.5 + jitter(rng));  // spacing 0.7..2.3 deg
  *widest_deg = 0.0;
  for (size_t i = 0; i < knots.size(); ++i) {
    const double next = (i + 1 < knots.size()) ? knots[i + 1] : knots[0] + 360.0;
    *widest_deg = std::max(*widest_deg, next - knots[i]);
  }
  return knots;
}

TEST(PeriodicSpline, ReproducesKnotsExactly) {
  double widest = 0.0;
  const std::vector<double> knots = jittered_knots(7, &widest);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> any(-5.0, 5.0);
  std::vector<double> values;
  for (size_t i = 0; i < knots.size(); ++i) values.push_back(any(rng));
  Result<PeriodicSpline> s = PeriodicSpline::fit(knots, values);
  ASSERT_TRUE(s.ok());
  // 1e-12: an interpolating spline returns the knot value itself; only rounding may differ.
  for (size_t i = 0; i < knots.size(); ++i) EXPECT_NEAR(s->value(knots[i]), values[i], 1e-12) << knots[i];
}

TEST(PeriodicSpline, MatchesSmoothFunctionAndRadianDerivatives) {
  const PeriodicSpline s = testing::spline_sampled(f, 1.0);
  const Bounds b = spline_bounds(1.0);  // 1.1e-8, 2.0e-6 per rad, 1.0e-3 per rad^2
  for (double deg = 0.13; deg < 360.0; deg += 0.37) {
    EXPECT_NEAR(s.value(deg), f(deg), b.value) << deg;
    EXPECT_NEAR(s.d1(deg), f1(deg), b.d1) << deg;
    EXPECT_NEAR(s.d2(deg), f2(deg), b.d2) << deg;
  }
}

TEST(PeriodicSpline, FitsADegreeTableWithKnotsAtWholeDegrees) {
  DegreeTable table{};
  for (int d = 0; d < 360; ++d) table[static_cast<size_t>(d)] = f(d);
  const PeriodicSpline s = PeriodicSpline::fit(table);
  ASSERT_EQ(s.size(), 360);
  const Bounds b = spline_bounds(1.0);  // as above, same knots
  for (double deg = 0.5; deg < 360.0; deg += 1.0) EXPECT_NEAR(s.value(deg), f(deg), b.value) << deg;
}

TEST(PeriodicSpline, InterpolatesOnNonUniformKnots) {
  double widest = 0.0;
  const std::vector<double> knots = jittered_knots(3, &widest);
  std::vector<double> values;
  for (double k : knots) values.push_back(f(k));
  Result<PeriodicSpline> s = PeriodicSpline::fit(knots, values);
  ASSERT_TRUE(s.ok());
  const Bounds b = spline_bounds(widest);  // widest spacing <= 2.3 deg
  for (double deg = 0.05; deg < 360.0; deg += 0.29) {
    EXPECT_NEAR(s->value(deg), f(deg), b.value) << deg;
    EXPECT_NEAR(s->d1(deg), f1(deg), b.d1) << deg;
    EXPECT_NEAR(s->d2(deg), f2(deg), b.d2) << deg;
  }
}

TEST(PeriodicSpline, IsTwiceContinuouslyDifferentiableAtEveryKnotAndAcrossTheWrap) {
  double widest = 0.0;
  const std::vector<double> knots = jittered_knots(5, &widest);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> any(-1.0, 1.0);
  std::vector<double> values;
  for (size_t i = 0; i < knots.size(); ++i) values.push_back(any(rng));
  Result<PeriodicSpline> s = PeriodicSpline::fit(knots, values);
  ASSERT_TRUE(s.ok());
  // Left and right limits 2e-9 deg (3.5e-11 rad) apart. Random data on 1.5 deg knots give
  // |s''| ~ 1e4 per rad^2 and |s'''| ~ 1e6 per rad^3, so across the gap s' moves < 1e-6 and
  // s'' < 1e-4: tolerances 1e-4 and 1e-3. A spline that is only C1 would jump by ~1e4 in s''.
  const double eps = 1e-9;
  for (double k : knots) {
    EXPECT_NEAR(s->value(k - eps), s->value(k + eps), 1e-6) << k;
    EXPECT_NEAR(s->d1(k - eps), s->d1(k + eps), 1e-4) << k;
    EXPECT_NEAR(s->d2(k - eps), s->d2(k + eps), 1e-3) << k;
  }
  // The wrap: 360 - eps and 0 + eps are neighbours.
  EXPECT_NEAR(s->d2(360.0 - eps), s->d2(eps), 1e-3);
}

TEST(PeriodicSpline, WrapsAnyAngleIntoOneTurn) {
  const PeriodicSpline s = testing::spline_sampled(f, 1.0);
  for (double deg = 0.7; deg < 360.0; deg += 13.1) {
    // 1e-9: wrapping 720 deg away loses a few ulps of 1e3 in the angle (~1e-13 deg).
    EXPECT_NEAR(s.value(deg + 720.0), s.value(deg), 1e-9);
    EXPECT_NEAR(s.value(deg - 1080.0), s.value(deg), 1e-9);
    EXPECT_NEAR(s.d1(deg - 360.0), s.d1(deg), 1e-9);
  }
}

TEST(PeriodicSpline, FitRejectsUnsortedInput) {
  Result<PeriodicSpline> s = PeriodicSpline::fit({0.0, 90.0, 80.0, 270.0}, {0.0, 1.0, 2.0, 3.0});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(s.error().message, HasSubstr("strictly increasing"));
  EXPECT_THAT(s.error().message, HasSubstr("80"));
}

TEST(PeriodicSpline, FitRejectsDuplicatesOutOfRangeTooFewMismatchedAndNaN) {
  const auto code = [](const Result<PeriodicSpline>& r) { return r.ok() ? ErrorCode::kInternal : r.error().code; };
  EXPECT_EQ(code(PeriodicSpline::fit({0, 90, 90, 270}, {0, 1, 2, 3})), ErrorCode::kInvalidInput);
  EXPECT_EQ(code(PeriodicSpline::fit({0, 90, 180, 360}, {0, 1, 2, 3})), ErrorCode::kInvalidInput);
  EXPECT_EQ(code(PeriodicSpline::fit({-1, 90, 180, 270}, {0, 1, 2, 3})), ErrorCode::kInvalidInput);
  EXPECT_EQ(code(PeriodicSpline::fit({0, 120, 240}, {0, 1, 2})), ErrorCode::kInvalidInput);
  EXPECT_EQ(code(PeriodicSpline::fit({0, 90, 180, 270}, {0, 1, 2})), ErrorCode::kInvalidInput);
  EXPECT_EQ(code(PeriodicSpline::fit({0, 90, 180, 270}, {0, std::nan(""), 2, 3})), ErrorCode::kInvalidInput);
  EXPECT_TRUE(PeriodicSpline::fit({0, 90, 180, 270}, {0, 1, 2, 3}).ok());
}

}  // namespace
}  // namespace gaugeloop
