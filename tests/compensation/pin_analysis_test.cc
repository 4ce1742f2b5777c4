// Tests of reading a pin from its gauge (analyse_pin), its tolerances (judge_pin) and its
// correction (decide_pin_correction).
#include "compensation/pin_analysis.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "compensation/pin_kinematics.h"
#include "core/tolerance.h"
#include "tests/support/angles.h"

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

using ::testing::HasSubstr;

// A pin as ground, in the pin frame: radius error a0, centre moved a1 along the crank radius
// and b1 across it, ovality and three lobes. What the gauge reads at pin-frame angle psi (um).
struct GroundPin {
  double a0_um = 4.0;
  double a1_um = -6.0;
  double b1_um = 9.0;
  double ovality_um = 1.5;  // A2 cos 2 psi
  double lobes_um = 0.8;    // A3 cos (3 psi + 0.4)
  double reading_um(double psi_deg) const {
    const double psi = psi_deg * kRadPerDeg;
    return a0_um + a1_um * std::cos(psi) + b1_um * std::sin(psi) + form_um(psi_deg);
  }
  // What roundness is of: the reading less its circle.
  double form_um(double psi_deg) const {
    const double psi = psi_deg * kRadPerDeg;
    return ovality_um * std::cos(2.0 * psi) + lobes_um * std::cos(3.0 * psi + 0.4);
  }
  double roundness_um() const {
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (int d = 0; d < 360; ++d) {
      lo = std::min(lo, form_um(d));
      hi = std::max(hi, form_um(d));
    }
    return hi - lo;
  }
};

PinGeometry sample_pin(PinMode mode) {
  PinGeometry pin;  // R 45, r 25, rw 300
  pin.mode = mode;
  pin.pin_angle_deg = 120.4;  // not whole degrees: the samples fall between pin degrees in both modes
  pin.gauge_offset_deg = 170.25;
  return pin;
}

// `revolutions` revolutions of the gauge on `ground`, one sample per machine degree, each at
// the pin-frame angle the kinematics put under the gauge there, with Gaussian noise of
// `sigma_um` (seeded).
MeasuredRun measure(const GroundPin& ground, const PinGeometry& pin, int revolutions, double sigma_um = 0.0,
                    std::uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_um > 0.0 ? sigma_um : 1.0);
  MeasuredRun run;
  for (int r = 0; r < revolutions; ++r) {
    RevolutionSamples rev;
    rev.revolution = 40 + r;
    for (int c = 0; c < 360; ++c) {
      const double e_um = ground.reading_um(gauge_psi_deg(pin, c)) + (sigma_um > 0.0 ? noise(rng) : 0.0);
      rev.lift_mm[static_cast<size_t>(c)] = e_um / 1000.0;
    }
    run.revolutions.push_back(rev);
  }
  return run;
}

double index_error_deg(const GroundPin& ground, const PinGeometry& pin) {
  return std::atan2(ground.b1_um, pin.throw_mm * 1000.0) / kRadPerDeg;
}

class PinAnalysisModes : public ::testing::TestWithParam<PinMode> {};

// Without noise the only error is the periodic spline's resampling between the gauge's
// angles (about 1.14 deg apart at most in C-X): (5/384) h^4 |f''''| is below 1e-6 um for
// these harmonics; tolerance 1e-4 um.
TEST_P(PinAnalysisModes, RecoversEveryFigureOfAKnownPinWithoutNoise) {
  const PinGeometry pin = sample_pin(GetParam());
  const GroundPin ground;
  Result<PinAnalysis> a = analyse_pin(measure(ground, pin, 3), pin);
  ASSERT_TRUE(a.ok()) << a.error().message;
  constexpr double kTol = 1e-4;
  EXPECT_NEAR(a->radius_error_um, ground.a0_um, kTol);
  EXPECT_NEAR(a->diameter_error_um, 2.0 * ground.a0_um, 2 * kTol);
  EXPECT_NEAR(a->stroke_error_um, ground.a1_um, kTol);
  EXPECT_NEAR(a->index_error_deg, index_error_deg(ground, pin), 1e-8);
  EXPECT_NEAR(a->roundness_um, ground.roundness_um(), kTol);
  const LobeAnalysis& t = a->table;
  EXPECT_EQ(t.revolutions, 3);
  EXPECT_EQ(t.phase_error_deg, a->index_error_deg);
  EXPECT_EQ(t.roundness_um, a->roundness_um);
  EXPECT_NEAR(t.peak_to_valley_residual_um, ground.roundness_um(), kTol);
  EXPECT_NEAR(t.repeatability_um, 0.0, 1e-9);
  EXPECT_NEAR(t.harmonic_amplitude_um[2], ground.ovality_um, kTol);
  EXPECT_NEAR(t.harmonic_amplitude_um[3], ground.lobes_um, kTol);
  for (int d = 0; d < 360; ++d) {
    const size_t i = static_cast<size_t>(d);
    EXPECT_EQ(t.design_lift_mm[i], 0.0);
    EXPECT_NEAR(t.error_um[i], ground.reading_um(d), kTol) << "pin degree " << d;
    EXPECT_NEAR(t.mean_lift_mm[i] * 1000.0, t.error_um[i], 1e-9);
    EXPECT_NEAR(t.residual_error_um[i], ground.form_um(d), kTol) << "pin degree " << d;
  }
}

// With noise sigma s per sample over n revolutions, the mean of one pin degree carries about
// s / sqrt(n), and each circle coefficient, a projection over 360 degrees, about
// s sqrt(2 / (360 n)) (a0: s / sqrt(360 n)); the check allows 5 times that. Roundness is a
// peak to valley of the residual: the noise's own extremes add to it, about 3 s / sqrt(n) each
// way, so it is checked to lie between the pin's and that much above.
TEST_P(PinAnalysisModes, RecoversTheFiguresThroughNoiseToAFewSigmasOfTheMean) {
  const PinGeometry pin = sample_pin(GetParam());
  const GroundPin ground;
  constexpr double kSigmaUm = 0.5;
  constexpr int kRevolutions = 8;
  Result<PinAnalysis> a = analyse_pin(measure(ground, pin, kRevolutions, kSigmaUm), pin);
  ASSERT_TRUE(a.ok()) << a.error().message;
  const double coefficient_sigma = kSigmaUm * std::sqrt(2.0 / (360.0 * kRevolutions));
  EXPECT_NEAR(a->radius_error_um, ground.a0_um, 5.0 * coefficient_sigma);
  EXPECT_NEAR(a->stroke_error_um, ground.a1_um, 5.0 * coefficient_sigma);
  EXPECT_NEAR(a->index_error_deg, index_error_deg(ground, pin),
              5.0 * coefficient_sigma / (pin.throw_mm * 1000.0) / kRadPerDeg);
  const double mean_sigma = kSigmaUm / std::sqrt(static_cast<double>(kRevolutions));
  EXPECT_GT(a->roundness_um, ground.roundness_um() - 2.0 * mean_sigma);
  EXPECT_LT(a->roundness_um, ground.roundness_um() + 8.0 * mean_sigma);
  // The spread is of single readings: s, a little less where the spline interpolates between
  // two samples (at most a quarter of the variance at mid-interval).
  double squares = 0.0;
  for (double s : a->table.spread_um) squares += s * s;
  const double rms_spread = std::sqrt(squares / 360.0);
  EXPECT_GT(rms_spread, 0.7 * kSigmaUm);
  EXPECT_LT(rms_spread, 1.15 * kSigmaUm);
  EXPECT_GT(a->table.repeatability_um, kSigmaUm);
}

INSTANTIATE_TEST_SUITE_P(BothModes, PinAnalysisModes, ::testing::Values(PinMode::kCX, PinMode::kCXY),
                         [](const ::testing::TestParamInfo<PinMode>& mode) {
                           return mode.param == PinMode::kCX ? std::string("CX") : std::string("CXY");
                         });

// Read as if C-X-Y (evenly spaced, psi = -C + const), a C-X run shows form that is not on the
// pin: the mapping through the C-X kinematics is what takes it away.
TEST(AnalysePin, MapsCXSamplesThroughTheCXKinematics) {
  const PinGeometry cx = sample_pin(PinMode::kCX);
  GroundPin ground;
  ground.ovality_um = 0.0;
  ground.lobes_um = 0.0;
  const MeasuredRun run = measure(ground, cx, 2);
  Result<PinAnalysis> right = analyse_pin(run, cx);
  ASSERT_TRUE(right.ok()) << right.error().message;
  EXPECT_LT(right->roundness_um, 1e-4);
  PinGeometry wrong = cx;
  wrong.mode = PinMode::kCXY;
  Result<PinAnalysis> mismapped = analyse_pin(run, wrong);
  ASSERT_TRUE(mismapped.ok()) << mismapped.error().message;
  EXPECT_GT(mismapped->roundness_um, 1.0);
}

TEST(AnalysePin, RefusesARevolutionWithAMissingReadingNamingItAndTheDegree) {
  const PinGeometry pin = sample_pin(PinMode::kCX);
  MeasuredRun run = measure(GroundPin{}, pin, 3);
  run.revolutions[1].lift_mm[123] = std::numeric_limits<double>::quiet_NaN();
  Result<PinAnalysis> a = analyse_pin(run, pin);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(a.error().message, HasSubstr("revolution 41"));
  EXPECT_THAT(a.error().message, HasSubstr("machine degree 123"));
}

TEST(AnalysePin, RefusesFewerThanTwoRevolutionsAndAnInvalidPin) {
  const PinGeometry pin = sample_pin(PinMode::kCXY);
  Result<PinAnalysis> one = analyse_pin(measure(GroundPin{}, pin, 1), pin);
  ASSERT_FALSE(one.ok());
  EXPECT_EQ(one.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(one.error().message, HasSubstr("1 complete revolution"));

  PinGeometry bad = pin;
  bad.throw_mm = 400.0;  // beyond r + rw: the wheel cannot reach it
  Result<PinAnalysis> unreachable = analyse_pin(measure(GroundPin{}, pin, 2), bad);
  ASSERT_FALSE(unreachable.ok());
  EXPECT_EQ(unreachable.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(unreachable.error().message, HasSubstr("throw_mm"));
}

PinAnalysis figures(double roundness, double diameter, double stroke, double index) {
  PinAnalysis a;
  a.roundness_um = roundness;
  a.diameter_error_um = diameter;
  a.radius_error_um = diameter / 2.0;
  a.stroke_error_um = stroke;
  a.index_error_deg = index;
  return a;
}

TEST(JudgePin, GivesTheFourFiguresInOrderNotJudgedWithoutLimits) {
  const std::vector<Characteristic> c = judge_pin(figures(3.0, -8.0, 5.0, 0.01), PinTolerances{});
  ASSERT_EQ(c.size(), 4u);
  const char* keys[] = {"roundness", "diameter_error", "stroke_error", "index_error"};
  const char* units[] = {"um", "um", "um", "deg"};
  const double values[] = {3.0, -8.0, 5.0, 0.01};
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(c[i].key, keys[i]);
    EXPECT_EQ(c[i].unit, units[i]);
    EXPECT_EQ(c[i].value, values[i]);
    EXPECT_EQ(c[i].min, values[i]);
    EXPECT_EQ(c[i].max, values[i]);
    EXPECT_EQ(c[i].verdict, Verdict::kNotJudged) << keys[i];
  }
}

TEST(JudgePin, JudgesEachFigureAgainstItsLimits) {
  PinTolerances tol;
  tol.roundness_um.upper = 2.0;
  tol.diameter_error_um = {-10.0, 10.0};
  tol.stroke_error_um = {-4.0, 4.0};
  tol.index_error_deg = {-0.05, 0.05};
  const std::vector<Characteristic> c = judge_pin(figures(3.0, -8.0, 5.0, 0.01), tol);
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c[0].verdict, Verdict::kOut);  // roundness 3 > 2
  EXPECT_EQ(c[1].verdict, Verdict::kIn);   // diameter -8 in [-10, 10]
  EXPECT_EQ(c[2].verdict, Verdict::kOut);  // stroke 5 > 4
  EXPECT_EQ(c[3].verdict, Verdict::kIn);   // index 0.01 in [-0.05, 0.05]
  EXPECT_EQ(c[1].limits.lower, -10.0);
  const std::vector<Characteristic> fine = judge_pin(figures(1.0, 2.0, -3.0, -0.04), tol);
  for (const Characteristic& f : fine) EXPECT_EQ(f.verdict, Verdict::kIn) << f.key;
}

TEST(JudgePin, TheNewKeysHaveTitles) {
  EXPECT_EQ(characteristic_title("diameter_error"), "Pin diameter error");
  EXPECT_EQ(characteristic_title("stroke_error"), "Pin stroke (throw) error");
  EXPECT_EQ(characteristic_title("index_error"), "Pin index error");
}

// A pin analysis whose error is known exactly, harmonics 0..3 only.
PinAnalysis analysis_of(const GroundPin& ground, double spread_um = 0.1, int revolutions = 5) {
  PinAnalysis a;
  for (int d = 0; d < 360; ++d) {
    a.table.error_um[static_cast<size_t>(d)] = ground.reading_um(d);
    a.table.spread_um[static_cast<size_t>(d)] = spread_um;
  }
  a.table.repeatability_um = spread_um;
  a.table.revolutions = revolutions;
  return a;
}

DegreeTable in_force_table() {
  DegreeTable t{};
  for (int d = 0; d < 360; ++d) t[static_cast<size_t>(d)] = 2.0 * std::sin(d * kRadPerDeg) - 1.0;
  return t;
}

TEST(DecidePinCorrection, AddsGainTimesTheWholeSmoothedErrorToTheCorrectionInForce) {
  const GroundPin ground;
  CompensationSettings s;
  s.gain = 0.5;
  s.choose_harmonics = false;
  s.max_harmonic = 10;  // keeps harmonics 0..3 whole: the circle's constant and first harmonic too
  const DegreeTable in_force = in_force_table();
  Result<CompensationDecision> d = decide_pin_correction(analysis_of(ground), in_force, s);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_TRUE(d->apply()) << d->reasons();
  EXPECT_EQ(d->harmonics.harmonics, 10);
  for (int deg = 0; deg < 360; ++deg) {
    const size_t i = static_cast<size_t>(deg);
    // FFT round trip of O(10) um: rounding ~1e-13; tolerance 1e-9.
    EXPECT_NEAR(d->correction_um[i], in_force[i] + 0.5 * ground.reading_um(deg), 1e-9) << deg;
    EXPECT_NEAR(d->change_um[i], 0.5 * ground.reading_um(deg), 1e-9) << deg;
  }
}

TEST(DecidePinCorrection, ChoosesTheHarmonicBandFromTheNoise) {
  const PinGeometry pin = sample_pin(PinMode::kCX);
  GroundPin ground;
  ground.lobes_um = 0.8;  // the highest harmonic on the pin: 3
  Result<PinAnalysis> a = analyse_pin(measure(ground, pin, 8, 0.5, 11), pin);
  ASSERT_TRUE(a.ok()) << a.error().message;
  CompensationSettings s;  // choose_harmonics, cap 30
  Result<CompensationDecision> d = decide_pin_correction(*a, DegreeTable{}, s);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_TRUE(d->apply()) << d->reasons();
  // Noise of 0.5 um over 8 revolutions: about 0.013 um per harmonic amplitude, threshold 4
  // times that; harmonic 3 (0.8 um) stands far above, the noise's harmonics do not.
  EXPECT_GT(d->harmonics.noise_um, 0.008);
  EXPECT_LT(d->harmonics.noise_um, 0.02);
  EXPECT_EQ(d->harmonics.harmonics, 3);
  // Without the lobes the band ends at the ovality.
  ground.lobes_um = 0.0;
  Result<PinAnalysis> oval = analyse_pin(measure(ground, pin, 8, 0.5, 11), pin);
  ASSERT_TRUE(oval.ok()) << oval.error().message;
  Result<CompensationDecision> d2 = decide_pin_correction(*oval, DegreeTable{}, s);
  ASSERT_TRUE(d2.ok()) << d2.error().message;
  EXPECT_EQ(d2->harmonics.harmonics, 2);
}

TEST(DecidePinCorrection, RefusesACorrectionBeyondTheLimitNamingThePinDegree) {
  GroundPin ground;
  ground.a0_um = 0.0;
  ground.a1_um = 80.0;  // largest at pin degree 0
  ground.b1_um = 0.0;
  ground.ovality_um = 0.0;
  ground.lobes_um = 0.0;
  CompensationSettings s;
  s.max_correction_um = 100.0;
  s.max_change_um = 500.0;
  DegreeTable in_force{};
  in_force.fill(30.0);
  Result<CompensationDecision> d = decide_pin_correction(analysis_of(ground), in_force, s);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->verdict, CompensationVerdict::kRefuse);
  ASSERT_EQ(d->findings.size(), 1u);
  EXPECT_EQ(d->findings[0].guard, CompensationGuard::kCorrectionLimit);
  EXPECT_THAT(d->reasons(), HasSubstr("110.0 um at pin degree 0"));
  EXPECT_EQ(d->largest_correction_deg, 0);
}

TEST(DecidePinCorrection, HoldsALargeChangeAndADoubtfulMeasurement) {
  GroundPin ground;
  ground.a0_um = -1.0;
  ground.a1_um = 0.0;
  ground.b1_um = -60.0;  // largest change -61 at pin degree 90
  ground.ovality_um = 0.0;
  ground.lobes_um = 0.0;
  CompensationSettings s;
  s.max_change_um = 50.0;
  s.max_repeatability_um = 2.0;
  Result<CompensationDecision> d = decide_pin_correction(analysis_of(ground, 3.0), DegreeTable{}, s);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->verdict, CompensationVerdict::kHold);
  ASSERT_EQ(d->findings.size(), 2u);
  EXPECT_EQ(d->findings[0].guard, CompensationGuard::kChangeLimit);
  EXPECT_THAT(d->findings[0].reason, HasSubstr("-61.0 um at pin degree 90"));
  EXPECT_EQ(d->findings[1].guard, CompensationGuard::kRepeatability);
  EXPECT_THAT(d->findings[1].reason, HasSubstr("chips on the pin"));
  // A pin has no timing: an index error is corrected, not held.
  PinAnalysis turned = analysis_of(GroundPin{});
  turned.index_error_deg = 5.0;
  turned.table.phase_error_deg = 5.0;
  Result<CompensationDecision> t = decide_pin_correction(turned, DegreeTable{}, CompensationSettings{});
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_TRUE(t->apply()) << t->reasons();
}

TEST(DecidePinCorrection, RefusesBadSettingsAndNonFiniteInput) {
  const PinAnalysis a = analysis_of(GroundPin{});
  CompensationSettings s;
  s.gain = 0.0;
  Result<CompensationDecision> gain = decide_pin_correction(a, DegreeTable{}, s);
  ASSERT_FALSE(gain.ok());
  EXPECT_EQ(gain.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(gain.error().message, HasSubstr("gain"));

  DegreeTable in_force{};
  in_force[17] = std::numeric_limits<double>::infinity();
  Result<CompensationDecision> nan = decide_pin_correction(a, in_force, CompensationSettings{});
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(nan.error().message, HasSubstr("pin degree 17"));
}

}  // namespace
}  // namespace gaugeloop
