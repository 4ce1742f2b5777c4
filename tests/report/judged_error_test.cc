// Which error a stored run's verdicts judge, and the limits per degree its pictures draw: the
// curve by the run's reference (best fit, nominal, a pin's least-squares circle), its figures,
// and the band the whole turn's limits and a zone's make together.
#include "report/judged_error.h"

#include <gtest/gtest.h>

#include <cmath>

namespace gaugeloop {
namespace {

// A run of a lobe whose raw error is 5 sin(deg) and whose best-fit error is 2 sin(deg).
StoredRun lobe_run(LiftErrorReference reference) {
  StoredRun run;
  run.lift_error_reference = reference;
  for (std::size_t d = 0; d < 360; ++d) {
    const double s = std::sin(static_cast<double>(d) * 3.14159265358979 / 180.0);
    run.analysis.error_um[d] = 5.0 * s;
    run.analysis.residual_error_um[d] = 2.0 * s;
  }
  return run;
}

TEST(JudgedError, ALobeJudgedAfterTheBestFitIsItsResidualWithTheRawBesideIt) {
  const JudgedError j = judged_error(lobe_run(LiftErrorReference::kBestFit));
  EXPECT_EQ(j.basis, JudgedError::Basis::kBestFit);
  EXPECT_EQ(j.name, "lift error after the best-fit phase");
  EXPECT_EQ(j.reference, "after best-fit phase");
  ASSERT_TRUE(j.raw_error_um.has_value());
  EXPECT_DOUBLE_EQ((*j.raw_error_um)[90], 5.0);
  EXPECT_DOUBLE_EQ(j.error_um[90], 2.0);
  // The figures are the judged curve's: 2 sin(deg) has max 2 at 90 deg, RMS 2/sqrt(2), peak to
  // valley 4 (exact at whole degrees: sin 90 and sin 270 are sampled).
  EXPECT_NEAR(j.max_abs_um, 2.0, 1e-12);
  EXPECT_TRUE(j.max_abs_at_deg == 90 || j.max_abs_at_deg == -90) << j.max_abs_at_deg;
  EXPECT_NEAR(j.rms_um, 2.0 / std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(j.peak_to_valley_um, 4.0, 1e-12);
}

TEST(JudgedError, ALobeJudgedAtNominalTimingIsItsRawErrorAlone) {
  const JudgedError j = judged_error(lobe_run(LiftErrorReference::kNominal));
  EXPECT_EQ(j.basis, JudgedError::Basis::kNominal);
  EXPECT_FALSE(j.raw_error_um.has_value()) << "the raw error is the judged one: nothing to draw beside it";
  EXPECT_NEAR(j.max_abs_um, 5.0, 1e-12);
  EXPECT_EQ(j.reference, "at nominal timing");
}

TEST(JudgedError, ARunStoredWithoutItsBestFitTableIsChartedAtNominalTimingAndSaysSo) {
  StoredRun run = lobe_run(LiftErrorReference::kBestFit);
  run.analysis.residual_error_um.fill(0.0);
  const JudgedError j = judged_error(run);
  EXPECT_EQ(j.basis, JudgedError::Basis::kNominalNoBestFit);
  EXPECT_NEAR(j.max_abs_um, 5.0, 1e-12);
  EXPECT_NE(j.name.find("kept no best-fit error"), std::string::npos) << j.name;
}

TEST(JudgedError, APinIsJudgedLessItsLeastSquaresCircle) {
  StoredRun run = lobe_run(LiftErrorReference::kNominal);  // a pin's runs store nominal
  run.settings = "part.kind = pin\npin.mode = c-x\n";
  const JudgedError j = judged_error(run);
  EXPECT_EQ(j.basis, JudgedError::Basis::kLeastSquaresCircle);
  EXPECT_NEAR(j.max_abs_um, 2.0, 1e-12);
  ASSERT_TRUE(j.raw_error_um.has_value());
  EXPECT_TRUE(judges_error_curve("roundness", PartKind::kPin));
  EXPECT_FALSE(judges_error_curve("diameter_error", PartKind::kPin));
}

TEST(JudgedError, TheErrorCurvesFiguresNameItAndTheOthersDoNot) {
  for (const char* key : {"lift_error", "lift_error.closing_ramp", "velocity_error", "acceleration_error.nose"}) {
    EXPECT_TRUE(judges_error_curve(key, PartKind::kLobe)) << key;
  }
  for (const char* key : {"phase", "base_circle_runout", "roundness", "lift_errorx"}) {
    EXPECT_FALSE(judges_error_curve(key, PartKind::kLobe)) << key;
  }
}

// The band per degree: the whole turn's +-12 everywhere, narrowed to +-8 over a closing ramp at
// cam 40..60 deg, and a zone looser than the whole turn (+-20 over the nose) leaves +-12 there,
// since the whole turn is judged at every degree too. One-sided zone limits narrow one side.
TEST(JudgedError, LimitsPerDegreeAreTheNarrowerOfTheWholeTurnsAndTheZones) {
  std::vector<Characteristic> cs;
  Characteristic whole = single_characteristic("lift_error", "um", 0.0, Limits{-12.0, 12.0});
  cs.push_back(whole);
  Characteristic ramp = single_characteristic("lift_error.closing_ramp", "um", 0.0, Limits{-8.0, 8.0});
  ramp.from_deg = 40;
  ramp.to_deg = 60;
  cs.push_back(ramp);
  Characteristic nose = single_characteristic("lift_error.nose", "um", 0.0, Limits{-20.0, 20.0});
  nose.from_deg = -10;
  nose.to_deg = 10;
  cs.push_back(nose);
  Characteristic flank = single_characteristic("lift_error.opening_flank", "um", 0.0, Limits{std::nullopt, 5.0});
  flank.from_deg = -60;
  flank.to_deg = -40;
  cs.push_back(flank);
  cs.push_back(single_characteristic("velocity_error", "mm/deg", 0.0, Limits{-1.0, 1.0}));

  const DegreeLimits by_cam = limits_per_cam_degree(cs, "lift_error");
  EXPECT_EQ(by_cam[50].upper, 8.0);
  EXPECT_EQ(by_cam[50].lower, -8.0);
  EXPECT_EQ(by_cam[39].upper, 12.0);
  EXPECT_EQ(by_cam[61].upper, 12.0);
  EXPECT_EQ(by_cam[0].upper, 12.0) << "the looser nose zone does not widen the whole turn's";
  EXPECT_EQ(by_cam[355].upper, 12.0);
  EXPECT_EQ(by_cam[310].upper, 5.0) << "cam 310 = -50 deg, in the opening flank";
  EXPECT_EQ(by_cam[310].lower, -12.0);
  EXPECT_EQ(by_cam[180].upper, 12.0);

  const DegreeLimits by_nose = limits_per_degree(cs, "lift_error");
  EXPECT_EQ(by_nose[static_cast<std::size_t>(-50 + 179)].upper, 5.0);
  EXPECT_EQ(by_nose[static_cast<std::size_t>(50 + 179)].upper, 8.0);

  // No whole-turn limits: only the zone's degrees have any.
  const std::vector<Characteristic> zone_only = {ramp};
  const DegreeLimits z = limits_per_cam_degree(zone_only, "lift_error");
  EXPECT_FALSE(z[39].any());
  EXPECT_EQ(z[40].upper, 8.0);
}

}  // namespace
}  // namespace gaugeloop
