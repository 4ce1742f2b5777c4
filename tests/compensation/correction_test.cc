// Tests of smoothing, the correction update and its guards, and the corrected wheel path.
#include "compensation/correction.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "compensation/flat_probe.h"
#include "test_lobes.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;
using testing::kRadPerDeg;

DegreeTable table_of(double (*f)(double deg)) {
  DegreeTable t{};
  for (int d = 0; d < 360; ++d) t[static_cast<size_t>(d)] = f(d);
  return t;
}

double low_part(double deg) { return 1.0 + std::cos(3 * deg * kRadPerDeg) + 0.2 * std::sin(30 * deg * kRadPerDeg); }
double high_part(double deg) {
  return 0.5 * std::sin(40 * deg * kRadPerDeg + 0.3) + 0.1 * std::cos(180 * deg * kRadPerDeg);
}
double both(double deg) { return low_part(deg) + high_part(deg); }

TEST(SmoothHarmonics, RemovesHarmonicsAboveTheCutoffAndKeepsThoseBelow) {
  const DegreeTable smoothed = smooth_harmonics(table_of(both), 30);
  // FFT round trip of O(1) values over 360 points: rounding ~1e-14; tolerance 1e-9.
  for (int d = 0; d < 360; ++d) EXPECT_NEAR(smoothed[static_cast<size_t>(d)], low_part(d), 1e-9) << d;
}

TEST(SmoothHarmonics, KeepsEverythingAtTheNyquistLimitAndNothingBelowZero) {
  const DegreeTable input = table_of(both);
  const DegreeTable all = smooth_harmonics(input, 180);
  const DegreeTable mean_only = smooth_harmonics(input, 0);
  const DegreeTable none = smooth_harmonics(input, -1);
  for (size_t d = 0; d < 360; ++d) {
    EXPECT_NEAR(all[d], input[d], 1e-9);
    EXPECT_NEAR(mean_only[d], 1.0, 1e-9);  // only the constant of low_part survives
    EXPECT_EQ(none[d], 0.0);
  }
}

LobeAnalysis analysis_with_error(const DegreeTable& error_um) {
  LobeAnalysis a;
  a.error_um = error_um;
  return a;
}

TEST(NextCorrection, AddsGainTimesTheSmoothedErrorToTheCorrectionInForce) {
  DegreeTable error = testing::harmonic_error_um(15.0);
  for (int d = 0; d < 360; ++d) error[static_cast<size_t>(d)] += 2.0 * std::sin(50 * d * kRadPerDeg);  // noise-like
  DegreeTable in_force{};
  for (int d = 0; d < 360; ++d) in_force[static_cast<size_t>(d)] = 3.0 * std::cos(d * kRadPerDeg);
  Result<DegreeTable> next =
      next_correction(analysis_with_error(error), in_force, CompensationSettings{0.5, 30, 100.0});
  ASSERT_TRUE(next.ok()) << next.error().message;
  const DegreeTable injected = testing::harmonic_error_um(15.0);
  // Harmonic 50 is cut, harmonics 2..5 kept: next = in_force + 0.5 * injected (1e-9 um).
  for (size_t d = 0; d < 360; ++d) EXPECT_NEAR((*next)[d], in_force[d] + 0.5 * injected[d], 1e-9) << d;
}

TEST(NextCorrection, RefusesAGainOutsideZeroToOne) {
  const LobeAnalysis a = analysis_with_error(testing::harmonic_error_um(5.0));
  for (double gain : {0.0, -0.5, 1.5, std::nan("")}) {
    Result<DegreeTable> next = next_correction(a, DegreeTable{}, CompensationSettings{gain, 30, 100.0});
    ASSERT_FALSE(next.ok()) << gain;
    EXPECT_EQ(next.error().code, ErrorCode::kRefused);
    EXPECT_THAT(next.error().message, HasSubstr("gain"));
  }
  EXPECT_TRUE(next_correction(a, DegreeTable{}, CompensationSettings{1.0, 30, 100.0}).ok());
}

TEST(NextCorrection, RefusesACorrectionOverTheLimitNamingDegreeAndValue) {
  DegreeTable error{};
  for (int d = 0; d < 360; ++d) error[static_cast<size_t>(d)] = 60.0 * std::cos((d - 90) * kRadPerDeg);
  DegreeTable in_force{};
  for (int d = 0; d < 360; ++d) in_force[static_cast<size_t>(d)] = 60.0 * std::cos((d - 90) * kRadPerDeg);
  Result<DegreeTable> next =
      next_correction(analysis_with_error(error), in_force, CompensationSettings{1.0, 30, 100.0});
  ASSERT_FALSE(next.ok());
  EXPECT_EQ(next.error().code, ErrorCode::kRefused);
  EXPECT_THAT(next.error().message, HasSubstr("120.0 um at cam degree 90"));
  // Within the limit the same step is accepted.
  EXPECT_TRUE(next_correction(analysis_with_error(error), in_force, CompensationSettings{1.0, 30, 130.0}).ok());
}

TEST(CorrectedWheelPath, ZeroCorrectionGivesTheDesignPath) {
  struct Case {
    const char* file;
    Part part;
  };
  for (const Case& c : {Case{"intake_flat.csv", testing::intake_flat_part()},
                        Case{"exhaust_roller.csv", testing::exhaust_roller_part(45.0)}}) {
    const LiftTable design = testing::example_table(c.file);
    Result<WheelPath> corrected = corrected_wheel_path(design, DegreeTable{}, c.part, 0.5);
    Result<WheelPath> plain = compute_wheel_path(testing::spline_of(design), c.part, 0.5);
    ASSERT_TRUE(corrected.ok()) << corrected.error().message;
    ASSERT_TRUE(plain.ok());
    EXPECT_EQ(corrected->psi_deg, plain->psi_deg);
    EXPECT_EQ(corrected->x_mm, plain->x_mm) << c.file;  // the same lift spline: identical
  }
}

// Grinds with the corrected path and reads the result; the reading must be the design's
// minus the correction.
void expect_ground_reading_lowered_by_correction(const char* file, const Part& part, double tolerance_mm) {
  const LiftTable design = testing::example_table(file);
  const DegreeTable correction_um = testing::harmonic_error_um(10.0);
  Result<WheelPath> path = corrected_wheel_path(design, correction_um, part, 0.1);
  ASSERT_TRUE(path.ok()) << path.error().message;
  Result<DegreeTable> ground = ground_lobe_reading(*path, part);
  ASSERT_TRUE(ground.ok()) << ground.error().message;
  Result<DegreeTable> reading = flat_probe_reading(testing::spline_of(design), part);
  ASSERT_TRUE(reading.ok());
  double worst = 0.0;
  for (size_t d = 0; d < 360; ++d) {
    worst = std::max(worst, std::abs((*ground)[d] - ((*reading)[d] - correction_um[d] / 1000.0)));
  }
  EXPECT_LT(worst, tolerance_mm) << file;
}

TEST(CorrectedWheelPath, LowersTheGroundFlatLobeByTheCorrection) {
  // Flat follower: the target lift is the reading, so the only error is the round trip's
  // interpolation (see flat_probe_test). Tolerance 1e-8 mm (4e-10 mm measured).
  expect_ground_reading_lowered_by_correction("intake_flat.csv", testing::intake_flat_part(), 1e-8);
}

TEST(CorrectedWheelPath, LowersTheGroundRollerLobeReadingByTheCorrection) {
  // Roller: the correction is moved to the follower angle beta = theta + alpha and divided by
  // cos(alpha), exact to first order. The second-order remainder is about c^2 / R for a
  // 10 um correction on radii of ~10 mm: ~1e-5 mm (2.2e-5 mm measured). Tolerance 1e-4 mm
  // (0.1 um); applying the correction at theta instead of beta misses by 7.7 um.
  expect_ground_reading_lowered_by_correction("exhaust_roller.csv", testing::exhaust_roller_part(45.0), 1e-4);
}

TEST(CorrectedWheelPath, RejectsANonFiniteCorrection) {
  DegreeTable correction{};
  correction[12] = std::nan("");
  Result<WheelPath> path =
      corrected_wheel_path(testing::example_table("intake_flat.csv"), correction, testing::intake_flat_part(), 1.0);
  ASSERT_FALSE(path.ok());
  EXPECT_EQ(path.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(path.error().message, HasSubstr("degree 12"));
}

}  // namespace
}  // namespace gaugeloop
