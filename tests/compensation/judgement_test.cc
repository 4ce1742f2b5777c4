// Tests of judging a run against its lobe's tolerances: every characteristic's figure on a
// lobe with a known error, the zones, and the verdicts.
#include "compensation/judgement.h"

#include <cmath>
#include <numbers>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "compensation/analysis.h"
#include "compensation/flat_probe.h"
#include "core/verdict_text.h"
#include "test_lobes.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

constexpr double kW = std::numbers::pi / 180.0;  // rad per degree

const Characteristic& find(const LobeJudgement& j, const std::string& key) {
  for (const Characteristic& c : j.characteristics) {
    if (c.key == key) return c;
  }
  ADD_FAILURE() << "no characteristic " << key;
  static const Characteristic none;
  return none;
}

struct IntakeLobe {
  Part part = testing::intake_flat_part();
  PeriodicSpline lift = testing::spline_of(testing::example_table("intake_flat.csv"));
  DesignReading design = DesignReading::of_lobe(lift, part).value();
  // The analysis of a run reading design + error_um(theta) at every cam degree.
  LobeAnalysis analysed(const DegreeTable& reading_mm, double noise_um = 1e-9) const {
    Result<LobeAnalysis> a =
        analyse_lobe(testing::measured_run(part, reading_mm, noise_um, 11), design, part, AnalysisSettings{});
    EXPECT_TRUE(a.ok()) << a.error().message;
    return a.ok() ? *a : LobeAnalysis{};
  }
  DegreeTable with_error(double (*error_um)(int)) const {
    DegreeTable r = design.table();
    for (int d = 0; d < 360; ++d) r[static_cast<size_t>(d)] += error_um(d) / 1000.0;
    return r;
  }
};

constexpr double kAmplitudeUm = 6.0;
double third_harmonic_um(int d) { return kAmplitudeUm * std::sin(3.0 * d * kW); }

TEST(JudgeLobe, AThirdHarmonicOfKnownAmplitudeReadsAsItsLiftVelocityAndAccelerationError) {
  const IntakeLobe lobe;
  // A sin(3 theta): odd about the base-circle centre (180 deg), so zeroing on the window
  // leaves it whole; judged at the nominal timing, where the error is the harmonic itself.
  const LobeAnalysis a = lobe.analysed(lobe.with_error(third_harmonic_um));
  LobeTolerances t;
  t.lift_error_reference = LiftErrorReference::kNominal;
  t.lift_error_um = {-5.0, 5.0};
  t.velocity_error_mm_per_deg = {-0.001, 0.001};
  Result<LobeJudgement> j = judge_lobe(a, t);
  ASSERT_TRUE(j.ok()) << j.error().message;
  // Without noise the figures are exact but for rounding: tolerance 1e-6 of each figure.
  // Lift: +-A at 30 and 90 deg (whole degrees where sin(3 theta) = +-1).
  const Characteristic& lift = find(*j, "lift_error");
  EXPECT_NEAR(lift.max, kAmplitudeUm, 1e-6);
  EXPECT_NEAR(lift.min, -kAmplitudeUm, 1e-6);
  EXPECT_NEAR(std::abs(lift.value), kAmplitudeUm, 1e-6);
  EXPECT_EQ(lift.unit, "um");
  EXPECT_EQ(lift.verdict, Verdict::kOut);  // 6 um against +-5
  // Velocity: 3 A w cos(3 theta), largest 3 A w at 0 deg, in mm/deg.
  const Characteristic& velocity = find(*j, "velocity_error");
  EXPECT_NEAR(velocity.max, 3.0 * kAmplitudeUm * kW / 1000.0, 1e-12);
  EXPECT_EQ(velocity.unit, "mm/deg");
  EXPECT_EQ(velocity.verdict, Verdict::kIn);  // 3.1e-4 mm/deg against 1e-3
  // Acceleration: -9 A w^2 sin(3 theta), largest 9 A w^2 (at 90 deg), in mm/deg^2.
  const Characteristic& acceleration = find(*j, "acceleration_error");
  EXPECT_NEAR(acceleration.max, 9.0 * kAmplitudeUm * kW * kW / 1000.0, 1e-13);
  EXPECT_EQ(acceleration.unit, "mm/deg^2");
  EXPECT_EQ(acceleration.verdict, Verdict::kNotJudged);
  EXPECT_NEAR(a.harmonic_amplitude_um[3], kAmplitudeUm, 1e-6);
  EXPECT_EQ(j->verdict, Verdict::kOut);

  t.lift_error_um = {-7.0, 7.0};
  j = judge_lobe(a, t);
  ASSERT_TRUE(j.ok());
  EXPECT_EQ(find(*j, "lift_error").verdict, Verdict::kIn);
  EXPECT_EQ(j->verdict, Verdict::kIn);
}

TEST(JudgeLobe, AKnownTimingErrorReadsAsThePhaseAndLeavesNoBestFitProfileError) {
  const IntakeLobe lobe;
  const LiftTable turned = testing::rotated_table(testing::example_table("intake_flat.csv"), 0.3);
  const DegreeTable reading = flat_probe_reading(testing::spline_of(turned), lobe.part).value();
  const double noise_um = 0.5;
  const LobeAnalysis a = lobe.analysed(reading, noise_um);
  LobeTolerances t;
  t.phase_deg = {-0.25, 0.25};
  t.lift_error_um = {-3.0, 3.0};
  Result<LobeJudgement> j = judge_lobe(a, t);
  ASSERT_TRUE(j.ok()) << j.error().message;
  // Phase within 0.005 deg, as the analysis tests hold it (25 standard deviations of the noise).
  const Characteristic& phase = find(*j, "phase");
  EXPECT_NEAR(phase.value, 0.3, 0.005);
  EXPECT_EQ(phase.unit, "deg");
  EXPECT_EQ(phase.verdict, Verdict::kOut);
  // After the best fit only the noise is left: the mean of 3 revolutions, 0.29 um RMS, under
  // 4.5 of it (2 um) but for one run in 400.
  EXPECT_LT(std::abs(find(*j, "lift_error").value), 4.5 * noise_um / std::sqrt(3.0));
  EXPECT_EQ(find(*j, "lift_error").verdict, Verdict::kIn);
  // At the nominal timing the same lobe is tens of um off on the flanks.
  t.lift_error_reference = LiftErrorReference::kNominal;
  j = judge_lobe(a, t);
  ASSERT_TRUE(j.ok());
  EXPECT_GT(std::abs(find(*j, "lift_error").value), 20.0);
  EXPECT_EQ(find(*j, "lift_error").verdict, Verdict::kOut);
}

TEST(JudgeLobe, TheBaseCircleFiguresAreTheAnalysisFiguresJudgedAgainstUpperLimits) {
  const IntakeLobe lobe;
  // The lobe displaced 4 um towards 180 deg: e cos(theta - 180) on top of the design.
  const LobeAnalysis a = lobe.analysed(lobe.with_error([](int d) { return 4.0 * std::cos((d - 180.0) * kW); }));
  LobeTolerances t;
  t.base_circle_runout_um = {std::nullopt, 1.0};
  t.roundness_um = {std::nullopt, 0.5};
  Result<LobeJudgement> j = judge_lobe(a, t);
  ASSERT_TRUE(j.ok()) << j.error().message;
  // All round the dial would read 2 e = 8 um; over the +-30 deg window with the high point at
  // its centre it reads e (1 - cos 30 deg) = 0.536 um: the first harmonic carries the 8 um.
  EXPECT_NEAR(find(*j, "base_circle_runout_h1").value, 8.0, 0.01);
  EXPECT_EQ(find(*j, "base_circle_runout_h1").verdict, Verdict::kNotJudged);
  EXPECT_NEAR(find(*j, "base_circle_runout").value, 4.0 * (1.0 - std::cos(30.0 * kW)), 1e-6);
  EXPECT_EQ(find(*j, "base_circle_runout").verdict, Verdict::kIn);
  // A displaced circle is still round.
  EXPECT_NEAR(find(*j, "roundness").value, 0.0, 1e-6);
  EXPECT_EQ(find(*j, "roundness").verdict, Verdict::kIn);
  t.base_circle_runout_um = {std::nullopt, 0.5};
  EXPECT_EQ(find(judge_lobe(a, t).value(), "base_circle_runout").verdict, Verdict::kOut);
}

TEST(JudgeLobe, WithoutTolerancesEveryFigureIsGivenAndNothingJudged) {
  const IntakeLobe lobe;
  Result<LobeJudgement> j = judge_lobe(lobe.analysed(lobe.with_error(third_harmonic_um)), LobeTolerances{});
  ASSERT_TRUE(j.ok());
  std::vector<std::string> keys;
  for (const Characteristic& c : j->characteristics) {
    keys.push_back(c.key);
    EXPECT_EQ(c.verdict, Verdict::kNotJudged) << c.key;
  }
  EXPECT_THAT(keys, ::testing::ElementsAre("lift_error", "velocity_error", "acceleration_error", "phase",
                                           "base_circle_runout", "base_circle_runout_h1", "roundness"));
  EXPECT_EQ(j->verdict, Verdict::kNotJudged);
}

ZoneTolerance by_lift(LobeZone zone, double from_mm, double to_mm) {
  ZoneTolerance z;
  z.zone = zone;
  z.by_lift = true;
  z.from_lift_mm = from_mm;
  z.to_lift_mm = to_mm;
  return z;
}

ZoneTolerance by_angle(LobeZone zone, double from_deg, double to_deg) {
  ZoneTolerance z;
  z.zone = zone;
  z.from_deg = from_deg;
  z.to_deg = to_deg;
  return z;
}

TEST(ZoneArcs, ZonesByLiftFollowTheDesignOnTheirSideOfTheNose) {
  const IntakeLobe lobe;
  LobeTolerances t;
  // The intake lobe lifts from -83 to 83 deg and is 8.5 mm at the nose.
  t.zones = {by_lift(LobeZone::kNose, 7.0, 9.0), by_lift(LobeZone::kBaseCircle, 0.0, 0.001),
             by_lift(LobeZone::kOpeningFlank, 0.001, 7.0), by_lift(LobeZone::kClosingFlank, 0.001, 7.0)};
  Result<std::vector<ZoneArc>> arcs = zone_arcs(t, lobe.design.table());
  ASSERT_TRUE(arcs.ok()) << arcs.error().message;
  ASSERT_EQ(arcs->size(), 4u);
  // In LobeZone order, whatever the file's order.
  const DegreeTable& reading = lobe.design.table();
  auto at = [&](int signed_deg) { return reading[static_cast<size_t>((signed_deg + 360) % 360)]; };
  const ZoneArc& base = (*arcs)[0];
  EXPECT_EQ(base.zone, LobeZone::kBaseCircle);
  EXPECT_EQ(base.from_deg, -base.to_deg);  // a symmetric lobe, across 180 deg
  EXPECT_GT(base.from_deg, 60);
  EXPECT_LT(at(base.from_deg), 0.001);  // its ends are on the base circle, the next degrees off it
  EXPECT_GE(at(base.from_deg - 1), 0.001);
  EXPECT_GE(at(base.to_deg + 1), 0.001);
  EXPECT_EQ((*arcs)[1].zone, LobeZone::kOpeningFlank);
  EXPECT_EQ((*arcs)[1].from_deg, base.to_deg + 1);  // the flank starts where the base circle ends
  EXPECT_EQ((*arcs)[2].zone, LobeZone::kNose);
  EXPECT_EQ((*arcs)[2].from_deg, -(*arcs)[2].to_deg);
  EXPECT_EQ((*arcs)[2].from_deg, (*arcs)[1].to_deg + 1);
  EXPECT_GE(at((*arcs)[2].from_deg), 7.0);
  EXPECT_LT(at((*arcs)[2].from_deg - 1), 7.0);
  EXPECT_EQ((*arcs)[3].zone, LobeZone::kClosingFlank);
  EXPECT_EQ((*arcs)[3].to_deg, base.from_deg - 1);
  size_t covered = 0;
  for (const ZoneArc& arc : *arcs) covered += arc.degrees.size();
  EXPECT_EQ(covered, 360u);
}

TEST(ZoneArcs, ZonesByAngleWrapThroughZeroAndHalfATurn) {
  const IntakeLobe lobe;
  LobeTolerances t;
  t.zones = {by_angle(LobeZone::kNose, -10.0, 10.0), by_angle(LobeZone::kBaseCircle, 100.0, 260.0),
             by_angle(LobeZone::kOpeningFlank, -70.0, -20.5)};
  Result<std::vector<ZoneArc>> arcs = zone_arcs(t, lobe.design.table());
  ASSERT_TRUE(arcs.ok()) << arcs.error().message;
  EXPECT_EQ((*arcs)[0].degrees.size(), 161u);  // 100..260
  EXPECT_EQ((*arcs)[0].from_deg, 100);
  EXPECT_EQ((*arcs)[0].to_deg, -100);
  EXPECT_EQ((*arcs)[1].degrees.size(), 50u);  // -70..-21: whole degrees up to -20.5
  EXPECT_EQ((*arcs)[1].to_deg, -21);
  EXPECT_EQ((*arcs)[2].degrees.size(), 21u);
  EXPECT_EQ((*arcs)[2].degrees.front(), 350);
}

TEST(ZoneArcs, RefusesOverlappingEmptyAndSplitZonesNamingThem) {
  const IntakeLobe lobe;
  LobeTolerances t;
  t.zones = {by_angle(LobeZone::kNose, -10.0, 10.0), by_angle(LobeZone::kClosingFlank, 5.0, 60.0)};
  Result<std::vector<ZoneArc>> arcs = zone_arcs(t, lobe.design.table());
  ASSERT_FALSE(arcs.ok());
  EXPECT_THAT(arcs.error().message, HasSubstr("share cam degree 5"));
  EXPECT_THAT(arcs.error().message, HasSubstr("closing_flank"));

  t.zones = {by_lift(LobeZone::kNose, 9.0, 10.0)};  // above the 8.5 mm nose
  arcs = zone_arcs(t, lobe.design.table());
  ASSERT_FALSE(arcs.ok());
  EXPECT_THAT(arcs.error().message, HasSubstr("holds no whole cam degree"));

  t.zones = {by_lift(LobeZone::kNose, 4.0, 5.0)};  // a band on both flanks
  arcs = zone_arcs(t, lobe.design.table());
  ASSERT_FALSE(arcs.ok());
  EXPECT_THAT(arcs.error().message, HasSubstr("2 separate arcs"));
  EXPECT_THAT(arcs.error().message, HasSubstr("angle_deg"));
}

TEST(JudgeLobe, AnErrorOnOneFlankIsOutInThatZoneOnly) {
  const IntakeLobe lobe;
  // +8 um over the opening flank (-60..-30 deg), nothing elsewhere.
  const LobeAnalysis a = lobe.analysed(lobe.with_error([](int d) { return d >= 300 && d <= 330 ? 8.0 : 0.0; }));
  LobeTolerances t;
  t.lift_error_reference = LiftErrorReference::kNominal;
  ZoneTolerance opening = by_angle(LobeZone::kOpeningFlank, -70.0, -20.0);
  opening.lift_error_um = {-5.0, 5.0};
  ZoneTolerance closing = by_angle(LobeZone::kClosingFlank, 20.0, 70.0);
  closing.lift_error_um = {-5.0, 5.0};
  t.zones = {closing, opening};
  Result<LobeJudgement> j = judge_lobe(a, t);
  ASSERT_TRUE(j.ok()) << j.error().message;
  const Characteristic& o = find(*j, "lift_error.opening_flank");
  EXPECT_NEAR(o.value, 8.0, 1e-6);
  EXPECT_EQ(o.verdict, Verdict::kOut);
  ASSERT_TRUE(o.from_deg && o.to_deg);
  EXPECT_EQ(*o.from_deg, -70);
  EXPECT_EQ(*o.to_deg, -20);
  const Characteristic& c = find(*j, "lift_error.closing_flank");
  EXPECT_NEAR(c.value, 0.0, 1e-6);
  EXPECT_EQ(c.verdict, Verdict::kIn);
  // Per zone for velocity and acceleration too, after the whole-turn figure.
  EXPECT_EQ(j->characteristics[1].key, "lift_error.opening_flank");
  EXPECT_EQ(j->characteristics[2].key, "lift_error.closing_flank");
  EXPECT_EQ(find(*j, "velocity_error.opening_flank").unit, "mm/deg");
  EXPECT_EQ(j->verdict, Verdict::kOut);
}

TEST(Verdicts, ANanFigureIsOutAndOneJudgedInMakesARunIn) {
  EXPECT_EQ(judge(std::nan(""), std::nan(""), Limits{std::nullopt, 1.0}), Verdict::kOut);
  EXPECT_EQ(judge(0.5, 0.5, Limits{}), Verdict::kNotJudged);
  EXPECT_EQ(judge(-1.0, 1.0, Limits{-1.0, 1.0}), Verdict::kIn);
  EXPECT_EQ(judge(-1.0, 1.0, Limits{-0.9, std::nullopt}), Verdict::kOut);
  EXPECT_EQ(combined_verdict({Verdict::kNotJudged, Verdict::kIn}), Verdict::kIn);
  EXPECT_EQ(combined_verdict({Verdict::kIn, Verdict::kOut, Verdict::kNotJudged}), Verdict::kOut);
  EXPECT_EQ(combined_verdict({}), Verdict::kNotJudged);
  EXPECT_EQ(characteristic_title("lift_error.opening_flank"), "Lift error, opening flank");
  EXPECT_EQ(characteristic_title("velocity_error"), "Velocity error, whole turn");
  EXPECT_EQ(characteristic_title("harmonic.3"), "Lift error, harmonic 3");
  Characteristic nose = single_characteristic("lift_error.nose", "um", 12.0, Limits{-10.0, 10.0});
  Characteristic phase = single_characteristic("phase", "deg", 0.1, Limits{-0.25, 0.25});
  Characteristic h1 = single_characteristic("base_circle_runout_h1", "um", 3.0, Limits{});
  EXPECT_EQ(verdict_summary(Verdict::kOut, {nose, phase, h1}), "out: lift_error.nose (2 of 3 characteristics judged)");
  EXPECT_EQ(verdict_summary(Verdict::kIn, {phase, h1}), "in (1 of 2 characteristics judged)");
  EXPECT_EQ(verdict_summary(Verdict::kNotJudged, {h1}), "not judged (no limits given)");
  EXPECT_EQ(characteristic_title("harmonic.x"), "harmonic.x");
}

}  // namespace
}  // namespace gaugeloop
