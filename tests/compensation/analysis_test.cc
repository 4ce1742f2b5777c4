// Tests of the lobe analysis: frame mapping, averaging, zeroing, statistics, phase and runout.
#include "compensation/analysis.h"

#include <cmath>
#include <functional>
#include <random>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "compensation/flat_probe.h"
#include "test_lobes.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

constexpr double kGaugeOffsetMm = 0.2371;  // an arbitrary un-zeroed gauge reading

// A run whose sample at machine degree C is lobe_mm(beta) + gauge offset + noise_mm(rev, C),
// beta = cam_angle_at_probe_deg(part, C).
MeasuredRun synthetic_run(const Part& part, const std::function<double(double)>& lobe_mm, int revolutions,
                          const std::function<double(int, int)>& noise_mm) {
  MeasuredRun run;
  for (int r = 0; r < revolutions; ++r) {
    RevolutionSamples rev;
    rev.revolution = 100 + r;
    for (int c = 0; c < 360; ++c) {
      rev.lift_mm[static_cast<size_t>(c)] = lobe_mm(cam_angle_at_probe_deg(part, c)) + kGaugeOffsetMm + noise_mm(r, c);
    }
    run.revolutions.push_back(rev);
  }
  return run;
}

struct Fixture {
  Part part = testing::intake_flat_part();
  PeriodicSpline lift = testing::spline_of(testing::example_table("intake_flat.csv"));
  DegreeTable design{};
  DegreeTable injected_um = testing::harmonic_error_um(15.0);
  PeriodicSpline injected = PeriodicSpline::fit(injected_um);
  Fixture() { design = flat_probe_reading(lift, part).value(); }
  // The measured lobe: design plus the injected error, at any cam angle.
  double lobe_mm(double beta) const { return lift.value(beta) + injected.value(beta) / 1000.0; }
  // What the analysis should report: the injected error less its mean over the window,
  // since zeroing on the window also removes the error's mean there.
  DegreeTable expected_error_um(const AnalysisSettings& s) const {
    double sum = 0.0;
    int count = 0;
    for (int d = 0; d < 360; ++d) {
      double off = std::remainder(d - s.base_circle_center_deg, 360.0);
      if (std::abs(off) <= s.base_circle_half_width_deg) {
        sum += injected_um[static_cast<size_t>(d)];
        ++count;
      }
    }
    DegreeTable e = injected_um;
    for (double& v : e) v -= sum / count;
    return e;
  }
};

// Noise +a, 0, -a at every degree, in an order that changes from degree to degree: its mean
// is exactly 0 and its sample standard deviation exactly a.
double balanced_noise_mm(int rev, int c, double a_um) {
  const int slot = (rev + c * 7 + (c / 3)) % 3;
  return (slot == 0 ? a_um : slot == 1 ? 0.0 : -a_um) / 1000.0;
}

TEST(AnalyseLobe, RecoversAnInjectedErrorAndTheNoiseSpread) {
  const Fixture fx;
  const AnalysisSettings settings;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [](int r, int c) { return balanced_noise_mm(r, c, 0.5); });
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, settings);
  ASSERT_TRUE(a.ok()) << a.error().message;
  const DegreeTable expected = fx.expected_error_um(settings);
  // The noise averages out exactly; what is left is rounding of mm-sized sums: 1e-9 um.
  for (size_t d = 0; d < 360; ++d) {
    EXPECT_NEAR(a->error_um[d], expected[d], 1e-9) << d;
    EXPECT_NEAR(a->spread_um[d], 0.5, 1e-9) << d;  // sample std of {+a, 0, -a} is a
  }
  EXPECT_NEAR(a->repeatability_um, 0.5, 1e-9);
  EXPECT_EQ(a->design_lift_mm, fx.design);
}

TEST(AnalyseLobe, RecoversAnInjectedErrorUnderRandomNoise) {
  const Fixture fx;
  const AnalysisSettings settings;
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> noise_um(-0.3, 0.3);
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [&](int, int) { return noise_um(rng) / 1000.0; });
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, settings);
  ASSERT_TRUE(a.ok()) << a.error().message;
  const DegreeTable expected = fx.expected_error_um(settings);
  // Noise bounded by 0.3 um: the per-degree mean and the window mean each move by at most
  // 0.3 um, so the recovered error is within 0.6 um of the injected one (a hard bound).
  for (size_t d = 0; d < 360; ++d) EXPECT_NEAR(a->error_um[d], expected[d], 0.6) << d;
  // Three values within 0.6 um have a sample std of at most 0.3 * sqrt(3/2) = 0.367 um; uniform
  // noise of std 0.17 um makes the largest over 360 degrees well above 0.2 um.
  EXPECT_LE(a->repeatability_um, 0.3675);
  EXPECT_GT(a->repeatability_um, 0.2);
}

TEST(AnalyseLobe, ZeroesOnTheMeanOverTheBaseCircleWindow) {
  const Fixture fx;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [](int, int) { return 0.0; });
  for (const AnalysisSettings s : {AnalysisSettings{}, AnalysisSettings{170.0, 20.0}, AnalysisSettings{200.0, 5.0}}) {
    Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, s);
    ASSERT_TRUE(a.ok()) << a.error().message;
    // Zero = gauge offset + the injected error's mean over the window (1e-12 mm: rounding).
    const double window_mean_um = fx.injected_um[0] - fx.expected_error_um(s)[0];
    EXPECT_NEAR(a->zero_offset_mm, kGaugeOffsetMm + window_mean_um / 1000.0, 1e-12) << s.base_circle_center_deg;
    EXPECT_NEAR(a->mean_lift_mm[0], fx.design[0] + fx.expected_error_um(s)[0] / 1000.0, 1e-12);
  }
}

TEST(AnalyseLobe, ReportsSummaryFiguresOfTheErrorTable) {
  const Fixture fx;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 4, [](int r, int c) { return 1e-4 * std::sin(r + 0.1 * c); });
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, AnalysisSettings{});
  ASSERT_TRUE(a.ok());
  double max_abs = 0, squares = 0, lo = 1e9, hi = -1e9, spread = 0;
  for (size_t d = 0; d < 360; ++d) {
    max_abs = std::max(max_abs, std::abs(a->error_um[d]));
    squares += a->error_um[d] * a->error_um[d];
    lo = std::min(lo, a->error_um[d]);
    hi = std::max(hi, a->error_um[d]);
    spread = std::max(spread, a->spread_um[d]);
  }
  // Same arithmetic on the same table: 1e-12 um.
  EXPECT_NEAR(a->max_abs_error_um, max_abs, 1e-12);
  EXPECT_NEAR(a->rms_error_um, std::sqrt(squares / 360), 1e-12);
  EXPECT_NEAR(a->peak_to_valley_um, hi - lo, 1e-12);
  EXPECT_NEAR(a->repeatability_um, spread, 1e-12);
  EXPECT_GT(a->peak_to_valley_um, 20.0);  // the 15 um peak error swings both ways
}

TEST(AnalyseLobe, MapsMachineDegreesToTheCamFrame) {
  Fixture fx;
  fx.part.rotation_sense = -1;
  fx.part.c_offset_deg = 37.0;
  fx.part.probe_offset_deg = 90.0;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [](int, int) { return 0.0; });
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, AnalysisSettings{});
  ASSERT_TRUE(a.ok()) << a.error().message;
  const DegreeTable expected = fx.expected_error_um(AnalysisSettings{});
  // Whole-degree offsets: a permutation, exact up to rounding (1e-9 um).
  for (size_t d = 0; d < 360; ++d) EXPECT_NEAR(a->error_um[d], expected[d], 1e-9) << d;
}

TEST(AnalyseLobe, ResamplesFractionalOffsetsOntoWholeCamDegrees) {
  Fixture fx;
  fx.part.c_offset_deg = 0.5;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [](int, int) { return 0.0; });
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, AnalysisSettings{});
  ASSERT_TRUE(a.ok()) << a.error().message;
  const DegreeTable expected = fx.expected_error_um(AnalysisSettings{});
  // Re-interpolating the lobe at half-degree offsets: the lobe is a spline with knots at whole
  // degrees, sampled half-way between, so the error is the spline's own interpolation error,
  // bounded by 5/384 h^4 |H''''|; with |H''''| up to ~3e3 mm/rad^4 on the flanks that is
  // ~4e-6 mm. Tolerance 0.01 um.
  for (size_t d = 0; d < 360; ++d) EXPECT_NEAR(a->error_um[d], expected[d], 0.01) << d;
}

TEST(AnalyseLobe, RefusesFewerThanThreeRevolutions) {
  const Fixture fx;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 2, [](int, int) { return 0.0; });
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, AnalysisSettings{});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(a.error().message, HasSubstr("at least 3"));
}

TEST(AnalyseLobe, RefusesAWindowOffTheBaseCircleNamingTheDegrees) {
  const Fixture fx;
  const MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [](int, int) { return 0.0; });
  // Window 60..100 deg: the intake lift is 1.08 mm at 60 deg and reaches 0 near 100 deg.
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, AnalysisSettings{80.0, 20.0});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(a.error().message, HasSubstr("not on the base circle"));
  EXPECT_THAT(a.error().message, HasSubstr("60.0 to "));
  EXPECT_THAT(a.error().message, HasSubstr("at 60 deg"));
}

TEST(AnalyseLobe, RejectsNonFiniteSamples) {
  const Fixture fx;
  MeasuredRun run = synthetic_run(
      fx.part, [&](double b) { return fx.lobe_mm(b); }, 3, [](int, int) { return 0.0; });
  run.revolutions[1].lift_mm[77] = std::nan("");
  Result<LobeAnalysis> a = analyse_lobe(run, fx.design, fx.part, AnalysisSettings{});
  ASSERT_FALSE(a.ok());
  EXPECT_THAT(a.error().message, HasSubstr("machine degree 77"));
}

TEST(FitPhaseError, RecoversARotatedLobe) {
  const Fixture fx;
  LobeAnalysis a;
  a.design_lift_mm = fx.design;
  const PeriodicSpline design = PeriodicSpline::fit(fx.design);
  for (int d = 0; d < 360; ++d) a.mean_lift_mm[static_cast<size_t>(d)] = design.value(d - 0.3);
  Result<PhaseFit> fit = fit_phase_error(a);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  // The measurement is exactly the design spline rotated: Gauss-Newton converges to the
  // rotation to ~1e-10 deg; tolerance 1e-6 deg, residual below 1e-4 um.
  EXPECT_NEAR(fit->phase_error_deg, 0.3, 1e-6);
  EXPECT_LT(fit->rms_residual_um, 1e-4);

  for (int d = 0; d < 360; ++d) a.mean_lift_mm[static_cast<size_t>(d)] = design.value(d + 8.0);
  Result<PhaseFit> too_far = fit_phase_error(a, 5.0);
  ASSERT_FALSE(too_far.ok());
  EXPECT_EQ(too_far.error().code, ErrorCode::kRefused);
}

TEST(FirstHarmonicRunout, IsTwiceTheEccentricity) {
  DegreeTable e = testing::harmonic_error_um(6.0);  // harmonics 2..5 do not count
  for (int d = 0; d < 360; ++d) e[static_cast<size_t>(d)] += 4.0 * std::cos((d - 30.0) * testing::kRadPerDeg);
  // Discrete orthogonality of harmonics over 360 points: exact up to rounding, 1e-9 um.
  EXPECT_NEAR(first_harmonic_runout_um(e), 8.0, 1e-9);
}

}  // namespace
}  // namespace gaugeloop
