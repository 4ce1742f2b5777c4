// Tests of the inspection figures: velocity and acceleration error and their noise, dial
// runout and roundness of the base circle, on error tables whose answer is known.
#include "compensation/inspection.h"
#include "tests/support/angles.h"

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

using ::testing::HasSubstr;

DegreeTable table_of_fn(const std::function<double(double)>& f_of_deg) {
  DegreeTable t{};
  for (int d = 0; d < 360; ++d) t[static_cast<size_t>(d)] = f_of_deg(d);
  return t;
}

// A band-limited table is differentiated exactly in the spectrum, so the only error is the
// FFT's rounding: 1e-9 of the figure is far above it and far below any wrong factor.
TEST(InspectionDerivatives, ThirdHarmonicGivesItsVelocityAndAcceleration) {
  const double a_um = 4.0;
  const DegreeTable error = table_of_fn([&](double d) { return 1.5 + a_um * std::sin(3.0 * d * kRadPerDeg); });
  const Result<ErrorDerivatives> r = error_derivatives(error);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const double v_max = 3.0 * a_um * kRadPerDeg / 1000.0;                 // mm/deg, at 0 deg
  const double acc_max = 9.0 * a_um * kRadPerDeg * kRadPerDeg / 1000.0;  // mm/deg^2, at 30 deg
  EXPECT_NEAR(r->max_abs_velocity_error_mm_per_deg, v_max, 1e-9 * v_max);
  EXPECT_NEAR(r->max_abs_acceleration_error_mm_per_deg2, acc_max, 1e-9 * acc_max);
  // The extremes repeat every 60 degrees; rounding picks which is reported.
  EXPECT_EQ(r->max_velocity_error_deg % 60, 0);
  EXPECT_EQ(r->max_acceleration_error_deg % 60, 30);
  for (size_t d = 0; d < 360; ++d) {
    const double theta = static_cast<double>(d) * kRadPerDeg;
    EXPECT_NEAR(r->velocity_error_mm_per_deg[d], v_max * std::cos(3.0 * theta), 1e-9 * v_max) << d;
    EXPECT_NEAR(r->acceleration_error_mm_per_deg2[d], -acc_max * std::sin(3.0 * theta), 1e-9 * acc_max) << d;
  }
}

TEST(InspectionDerivatives, HarmonicsAboveTheCutoffAreFilteredOut) {
  const DegreeTable error = table_of_fn([](double d) { return 2.0 * std::sin(40.0 * d * kRadPerDeg); });
  const Result<ErrorDerivatives> default_cut = error_derivatives(error);
  ASSERT_TRUE(default_cut.ok());
  EXPECT_LT(default_cut->max_abs_velocity_error_mm_per_deg, 1e-15);
  const Result<ErrorDerivatives> wide = error_derivatives(error, InspectionSettings{.max_harmonic = 40});
  ASSERT_TRUE(wide.ok());
  const double v_max = 40.0 * 2.0 * kRadPerDeg / 1000.0;  // at 0 deg, where cos(40 theta) = 1
  EXPECT_NEAR(wide->max_abs_velocity_error_mm_per_deg, v_max, 1e-9 * v_max);
}

TEST(InspectionDerivatives, RefusesNonFiniteErrorAndBadCutoff) {
  DegreeTable error{};
  error[17] = std::numeric_limits<double>::quiet_NaN();
  const Result<ErrorDerivatives> nan = error_derivatives(error);
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(nan.error().message, HasSubstr("cam degree 17"));
  EXPECT_FALSE(error_derivatives(DegreeTable{}, InspectionSettings{.max_harmonic = 0}).ok());
  EXPECT_FALSE(error_derivatives(DegreeTable{}, InspectionSettings{.max_harmonic = 180}).ok());
}

// Monte Carlo against the closed form. The derivative's noise is a sum over the kept
// harmonics, so one table holds about 2 K / (weighting) independent values: some 33 for the
// velocity and 22 for the acceleration at K = 30 (high harmonics dominate). 200 tables give
// some 4400 degrees of freedom: a relative sampling error of the RMS of about 1 %, so 5 %
// is over 4 standard deviations, while a wrong factor (sqrt 2, the revolutions) is 41 % off.
TEST(InspectionDerivatives, NoiseMatchesMonteCarlo) {
  const double gauge_noise_um = 0.5;
  const int revolutions = 4;
  const int trials = 200;
  std::mt19937 rng(12345);
  std::normal_distribution<double> noise(0.0, gauge_noise_um);
  double sum_v2 = 0.0;
  double sum_a2 = 0.0;
  for (int t = 0; t < trials; ++t) {
    DegreeTable error{};
    for (double& e : error) {
      for (int r = 0; r < revolutions; ++r) e += noise(rng) / revolutions;
    }
    const Result<ErrorDerivatives> d = error_derivatives(error);
    ASSERT_TRUE(d.ok());
    for (size_t k = 0; k < 360; ++k) {
      sum_v2 += d->velocity_error_mm_per_deg[k] * d->velocity_error_mm_per_deg[k];
      sum_a2 += d->acceleration_error_mm_per_deg2[k] * d->acceleration_error_mm_per_deg2[k];
    }
  }
  const double v_rms = std::sqrt(sum_v2 / (trials * 360.0));
  const double a_rms = std::sqrt(sum_a2 / (trials * 360.0));
  const Result<double> v_model = derivative_noise_rms(gauge_noise_um, revolutions, 1);
  const Result<double> a_model = derivative_noise_rms(gauge_noise_um, revolutions, 2);
  ASSERT_TRUE(v_model.ok() && a_model.ok());
  EXPECT_NEAR(v_rms, *v_model, 0.05 * *v_model);
  EXPECT_NEAR(a_rms, *a_model, 0.05 * *a_model);
}

TEST(InspectionDerivatives, NoiseFigureFollowsTheCutoffAndRefusesBadInput) {
  const Result<double> k30 = derivative_noise_rms(1.0, 1, 1);
  const Result<double> k10 = derivative_noise_rms(1.0, 1, 1, InspectionSettings{.max_harmonic = 10});
  ASSERT_TRUE(k30.ok() && k10.ok());
  // sum k^2 over 1..K is K(K+1)(2K+1)/6: 9455 at 30, 385 at 10.
  EXPECT_NEAR(*k30 / *k10, std::sqrt(9455.0 / 385.0), 1e-12);
  EXPECT_FALSE(derivative_noise_rms(-1.0, 3, 1).ok());
  EXPECT_FALSE(derivative_noise_rms(std::numeric_limits<double>::infinity(), 3, 1).ok());
  EXPECT_FALSE(derivative_noise_rms(1.0, 0, 1).ok());
  EXPECT_FALSE(derivative_noise_rms(1.0, 3, 3).ok());
  EXPECT_FALSE(derivative_noise_rms(1.0, 3, 1, InspectionSettings{.max_harmonic = 200}).ok());
}

// An eccentricity e reads e cos(theta - theta0); the extremes over a window of whole-degree
// half width fall on whole degrees, so the expected figures are exact to rounding.
TEST(InspectionBaseCircle, DialRunoutOfAnEccentricityOverAWindow) {
  const double e_um = 2.5;
  const AnalysisSettings window{.base_circle_center_deg = 180.0, .base_circle_half_width_deg = 30.0};
  const double w = 30.0 * kRadPerDeg;
  // High point at the window centre: from e at the centre down to e cos(w) at the ends.
  const Result<BaseCircleInspection> centred = inspect_base_circle(
      table_of_fn([&](double d) { return 0.7 + e_um * std::cos((d - 180.0) * kRadPerDeg); }), window);
  ASSERT_TRUE(centred.ok()) << centred.error().message;
  EXPECT_NEAR(centred->dial_runout_um, e_um * (1.0 - std::cos(w)), 1e-9);
  EXPECT_EQ(centred->degrees_used, 61);
  // High point 90 degrees away: the slope of the eccentricity across the window, 2 e sin(w).
  const Result<BaseCircleInspection> across =
      inspect_base_circle(table_of_fn([&](double d) { return e_um * std::cos((d - 270.0) * kRadPerDeg); }), window);
  ASSERT_TRUE(across.ok());
  EXPECT_NEAR(across->dial_runout_um, 2.0 * e_um * std::sin(w), 1e-9);
  // A window that wraps through 0 deg.
  const AnalysisSettings wrapped{.base_circle_center_deg = 0.0, .base_circle_half_width_deg = 40.0};
  const Result<BaseCircleInspection> wraps =
      inspect_base_circle(table_of_fn([&](double d) { return e_um * std::cos((d - 90.0) * kRadPerDeg); }), wrapped);
  ASSERT_TRUE(wraps.ok());
  EXPECT_NEAR(wraps->dial_runout_um, 2.0 * e_um * std::sin(40.0 * kRadPerDeg), 1e-9);
  EXPECT_EQ(wraps->degrees_used, 81);
}

// The least-squares fit holds the mean and the eccentricity exactly: nothing is left.
TEST(InspectionBaseCircle, RoundnessOfAnEccentricCircleIsZero) {
  const AnalysisSettings window{.base_circle_center_deg = 180.0, .base_circle_half_width_deg = 30.0};
  const Result<BaseCircleInspection> r = inspect_base_circle(
      table_of_fn([](double d) { return -1.2 + 3.0 * std::cos((d - 200.0) * kRadPerDeg); }), window);
  ASSERT_TRUE(r.ok());
  EXPECT_GT(r->dial_runout_um, 0.5);
  EXPECT_LT(r->roundness_um, 1e-9);
}

// Over degrees 1..359 a sin(3 theta) is orthogonal to 1, cos and sin (the one degree left out,
// 0, is where it and sin vanish), so the fit leaves it whole: peak to valley 2 A, exactly.
TEST(InspectionBaseCircle, RoundnessOfAThirdHarmonicIsItsPeakToValley) {
  const double a_um = 1.5;
  const AnalysisSettings window{.base_circle_center_deg = 180.0, .base_circle_half_width_deg = 179.0};
  const Result<BaseCircleInspection> r = inspect_base_circle(table_of_fn([&](double d) {
                                                               return 0.4 + a_um * std::sin(3.0 * d * kRadPerDeg) +
                                                                      2.0 * std::cos((d - 60.0) * kRadPerDeg);
                                                             }),
                                                             window);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->degrees_used, 359);
  EXPECT_NEAR(r->roundness_um, 2.0 * a_um, 1e-9);
  EXPECT_GT(r->dial_runout_um, 2.0 * a_um + 1.0);  // the eccentricity is in the dial's figure
}

TEST(InspectionBaseCircle, RefusesBadInput) {
  const AnalysisSettings narrow{.base_circle_center_deg = 180.2, .base_circle_half_width_deg = 0.5};
  const Result<BaseCircleInspection> few = inspect_base_circle(DegreeTable{}, narrow);
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(few.error().message, HasSubstr("fewer than 3"));
  EXPECT_FALSE(inspect_base_circle(DegreeTable{},
                                   AnalysisSettings{.base_circle_center_deg = 180.0, .base_circle_half_width_deg = 0.0})
                   .ok());
  DegreeTable error{};
  error[200] = std::numeric_limits<double>::infinity();
  const Result<BaseCircleInspection> inf = inspect_base_circle(error, AnalysisSettings{});
  ASSERT_FALSE(inf.ok());
  EXPECT_THAT(inf.error().message, HasSubstr("cam degree 200"));
}

}  // namespace
}  // namespace gaugeloop
