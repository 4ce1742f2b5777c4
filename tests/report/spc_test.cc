// The SPC figures against figures worked out by hand in the comments.
#include "report/spc.h"

#include <gtest/gtest.h>

#include <cmath>

namespace gaugeloop {
namespace {

Characteristic make(const std::string& key, double value, Limits limits = {}, Verdict verdict = Verdict::kNotJudged) {
  Characteristic c;
  c.key = key;
  c.unit = key == "phase" ? "deg" : "um";
  c.value = value;
  c.min = value;
  c.max = value;
  c.limits = limits;
  c.verdict = verdict;
  return c;
}

RunCharacteristics run(std::int64_t id, std::vector<Characteristic> characteristics) {
  RunCharacteristics r;
  r.run.id = id;
  r.characteristics = std::move(characteristics);
  return r;
}

const SpcFigure& figure(const std::vector<SpcFigure>& figures, const std::string& key) {
  for (const SpcFigure& f : figures) {
    if (f.key == key) return f;
  }
  ADD_FAILURE() << "no figure for " << key;
  static const SpcFigure none;
  return none;
}

Limits both(double lower, double upper) { return Limits{lower, upper}; }

TEST(Spc, FiveRunsTwoSidedLimitsMatchTheHandFigures) {
  // Values 1, 2, 3, 4, 5 um, limits -5..+8 um.
  //   mean = 15 / 5 = 3
  //   deviations -2, -1, 0, 1, 2; squares 4 + 1 + 0 + 1 + 4 = 10
  //   s = sqrt(10 / (5 - 1)) = sqrt(2.5) = 1.58113883
  //   Cp  = (8 - (-5)) / (6 * 1.58113883) = 13 / 9.48683298 = 1.37032032
  //   Cpk = min(8 - 3, 3 - (-5)) / (3 * 1.58113883) = 5 / 4.74341649 = 1.05409255
  // Run 5's value 5 is judged out (a tighter limit of another day would do it; the verdict is
  // counted as stored), run 1 was not judged: 1 out of 4 judged.
  std::vector<RunCharacteristics> runs;
  const Verdict verdicts[] = {Verdict::kNotJudged, Verdict::kIn, Verdict::kIn, Verdict::kIn, Verdict::kOut};
  for (int i = 0; i < 5; ++i) runs.push_back(run(i + 1, {make("lift_error", i + 1.0, both(-5, 8), verdicts[i])}));
  const std::vector<SpcFigure> figures = spc_figures(runs);
  ASSERT_EQ(figures.size(), 1u);
  const SpcFigure& f = figures[0];
  EXPECT_EQ(f.key, "lift_error");
  EXPECT_EQ(f.unit, "um");
  EXPECT_EQ(f.n, 5);
  EXPECT_DOUBLE_EQ(f.mean, 3.0);
  ASSERT_TRUE(f.sd.has_value());
  EXPECT_NEAR(*f.sd, 1.58113883, 1e-8);
  ASSERT_TRUE(f.cp.has_value());
  EXPECT_NEAR(*f.cp, 1.37032032, 1e-8);
  ASSERT_TRUE(f.cpk.has_value());
  EXPECT_NEAR(*f.cpk, 1.05409255, 1e-8);
  EXPECT_EQ(f.cpk_side, "both");
  EXPECT_EQ(f.out_count, 1);
  EXPECT_EQ(f.judged_count, 4);
  EXPECT_EQ(f.limits_from_run, 5);
  EXPECT_FALSE(f.limits_changed);
  EXPECT_TRUE(f.not_computed.empty()) << f.not_computed;
}

TEST(Spc, CpkUsesTheNearerLimit) {
  // Values -1, -2, -3 deg, limits -4..+10: mean -2, s = sqrt((1 + 0 + 1) / 2) = 1.
  //   Cp  = 14 / 6 = 2.33333333
  //   Cpk = min(10 - (-2), -2 - (-4)) / 3 = 2 / 3 = 0.66666667 (the lower side)
  const std::vector<SpcFigure> figures =
      spc_figures({run(1, {make("phase", -1, both(-4, 10))}), run(2, {make("phase", -2, both(-4, 10))}),
                   run(3, {make("phase", -3, both(-4, 10))})});
  const SpcFigure& f = figure(figures, "phase");
  EXPECT_DOUBLE_EQ(f.mean, -2.0);
  EXPECT_DOUBLE_EQ(*f.sd, 1.0);
  EXPECT_NEAR(*f.cp, 14.0 / 6.0, 1e-12);
  EXPECT_NEAR(*f.cpk, 2.0 / 3.0, 1e-12);
  EXPECT_EQ(f.unit, "deg");
}

TEST(Spc, UpperLimitOnlyGivesCpuAndNoCp) {
  // Runout 2, 4, 6 um, upper limit 10 um: mean 4, s = sqrt((4 + 0 + 4) / 2) = 2.
  //   CPU = (10 - 4) / (3 * 2) = 1.0; no Cp without a lower limit.
  const Limits upper{std::nullopt, 10.0};
  const std::vector<SpcFigure> figures = spc_figures({run(1, {make("base_circle_runout", 2, upper, Verdict::kIn)}),
                                                      run(2, {make("base_circle_runout", 4, upper, Verdict::kIn)}),
                                                      run(3, {make("base_circle_runout", 6, upper, Verdict::kIn)})});
  const SpcFigure& f = figure(figures, "base_circle_runout");
  EXPECT_DOUBLE_EQ(*f.sd, 2.0);
  EXPECT_FALSE(f.cp.has_value());
  ASSERT_TRUE(f.cpk.has_value());
  EXPECT_NEAR(*f.cpk, 1.0, 1e-12);
  EXPECT_EQ(f.cpk_side, "upper");
  EXPECT_NE(f.not_computed.find("CPU"), std::string::npos) << f.not_computed;
  EXPECT_EQ(f.out_count, 0);
  EXPECT_EQ(f.judged_count, 3);
}

TEST(Spc, LowerLimitOnlyGivesCpl) {
  // 3, 5, 7 with a lower limit 1: mean 5, s = 2, CPL = (5 - 1) / (3 * 2) = 0.66666667.
  const Limits lower{1.0, std::nullopt};
  const std::vector<SpcFigure> figures =
      spc_figures({run(1, {make("roundness", 3, lower)}), run(2, {make("roundness", 5, lower)}),
                   run(3, {make("roundness", 7, lower)})});
  const SpcFigure& f = figure(figures, "roundness");
  EXPECT_FALSE(f.cp.has_value());
  EXPECT_NEAR(*f.cpk, 4.0 / 6.0, 1e-12);
  EXPECT_EQ(f.cpk_side, "lower");
}

TEST(Spc, OneRunGivesTheMeanAndSaysWhyNothingElse) {
  const std::vector<SpcFigure> figures = spc_figures({run(7, {make("lift_error", 2.5, both(-5, 5), Verdict::kIn)})});
  const SpcFigure& f = figure(figures, "lift_error");
  EXPECT_EQ(f.n, 1);
  EXPECT_DOUBLE_EQ(f.mean, 2.5);
  EXPECT_FALSE(f.sd.has_value());
  EXPECT_FALSE(f.cp.has_value());
  EXPECT_FALSE(f.cpk.has_value());
  EXPECT_TRUE(f.cpk_side.empty());
  EXPECT_NE(f.not_computed.find("1 run"), std::string::npos) << f.not_computed;
  EXPECT_EQ(f.judged_count, 1);
}

TEST(Spc, EqualValuesGiveSZeroAndNoRatios) {
  // 0.1 three times: the mean computed as (0.1 + 0.1 + 0.1) / 3 is not exactly 0.1, which
  // would make s a few 1e-17 and Cp about 1e17; s is 0 and Cp, Cpk are not given.
  const std::vector<SpcFigure> figures =
      spc_figures({run(1, {make("lift_error", 0.1, both(-1, 1))}), run(2, {make("lift_error", 0.1, both(-1, 1))}),
                   run(3, {make("lift_error", 0.1, both(-1, 1))})});
  const SpcFigure& f = figure(figures, "lift_error");
  EXPECT_DOUBLE_EQ(f.mean, 0.1);
  ASSERT_TRUE(f.sd.has_value());
  EXPECT_EQ(*f.sd, 0.0);
  EXPECT_FALSE(f.cp.has_value());
  EXPECT_FALSE(f.cpk.has_value());
  EXPECT_NE(f.not_computed.find("s = 0"), std::string::npos) << f.not_computed;
}

TEST(Spc, AKeyMissingInSomeRunsCountsOnlyTheRunsThatHaveIt) {
  // Roundness only in runs 1 and 3: 2 and 4 um, mean 3, s = sqrt((1 + 1) / 1) = 1.41421356.
  // Lift error in all three: 1, 2, 3.
  const std::vector<SpcFigure> figures =
      spc_figures({run(1, {make("lift_error", 1), make("roundness", 2)}), run(2, {make("lift_error", 2)}),
                   run(3, {make("roundness", 4), make("lift_error", 3)})});
  ASSERT_EQ(figures.size(), 2u);
  EXPECT_EQ(figures[0].key, "lift_error");  // in the order keys first appear
  EXPECT_EQ(figures[1].key, "roundness");
  EXPECT_EQ(figures[0].n, 3);
  EXPECT_DOUBLE_EQ(figures[0].mean, 2.0);
  EXPECT_EQ(figures[1].n, 2);
  EXPECT_DOUBLE_EQ(figures[1].mean, 3.0);
  EXPECT_NEAR(*figures[1].sd, std::sqrt(2.0), 1e-12);
  EXPECT_EQ(figures[1].limits_from_run, 3);
  // No limits: no ratios, and said so.
  EXPECT_FALSE(figures[1].cpk.has_value());
  EXPECT_NE(figures[1].not_computed.find("no limits"), std::string::npos);
}

TEST(Spc, LimitsComeFromTheNewestRunAndAChangeIsFlagged) {
  const std::vector<SpcFigure> figures =
      spc_figures({run(1, {make("lift_error", 1, both(-10, 10))}), run(2, {make("lift_error", 2, both(-5, 5))}),
                   run(3, {make("lift_error", 3, both(-5, 5))})});
  const SpcFigure& f = figure(figures, "lift_error");
  EXPECT_TRUE(f.limits_changed);
  EXPECT_EQ(f.limits_from_run, 3);
  EXPECT_EQ(f.limits.lower, -5.0);
  EXPECT_EQ(f.limits.upper, 5.0);
  // s = 1, Cp = 10 / 6 with the newest limits.
  EXPECT_NEAR(*f.cp, 10.0 / 6.0, 1e-12);

  const std::vector<SpcFigure> same =
      spc_figures({run(1, {make("lift_error", 1, both(-5, 5))}), run(2, {make("lift_error", 2, both(-5, 5))})});
  EXPECT_FALSE(figure(same, "lift_error").limits_changed);
}

TEST(Spc, ARatioThatWouldOverflowIsLeftOut) {
  // s = 1e-150 / sqrt(2) against limits 2e300 apart: Cp would be about 5e449, past a double.
  const std::vector<SpcFigure> figures = spc_figures({run(1, {make("lift_error", 0.0, both(-1e300, 1e300))}),
                                                      run(2, {make("lift_error", 1e-150, both(-1e300, 1e300))})});
  const SpcFigure& f = figure(figures, "lift_error");
  ASSERT_TRUE(f.sd.has_value());
  EXPECT_GT(*f.sd, 0.0);
  EXPECT_FALSE(f.cp.has_value());
  EXPECT_FALSE(f.cpk.has_value());
  EXPECT_FALSE(f.not_computed.empty());
}

TEST(Spc, JsonHasEveryKeyAndNullsForWhatIsNotGiven) {
  const nlohmann::json j =
      spc_figure_json(spc_figures({run(4, {make("roundness", 3.0, Limits{std::nullopt, 5.0})})})[0]);
  for (const char* key : {"key", "title", "unit", "n", "mean", "sd", "lsl", "usl", "limits_from_run", "limits_changed",
                          "cp", "cpk", "cpk_side", "out", "judged", "note"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["n"], 1);
  EXPECT_TRUE(j["sd"].is_null());
  EXPECT_TRUE(j["lsl"].is_null());
  EXPECT_EQ(j["usl"], 5.0);
  EXPECT_EQ(j["limits_from_run"], 4);
  EXPECT_TRUE(j["cpk"].is_null());
}

TEST(Spc, APinsRoundnessIsTitledAsThePinsAndALobesAsTheBaseCircles) {
  const std::vector<SpcFigure> pin = spc_figures(
      {run(1, {make("roundness", 3.0, Limits{std::nullopt, 4.0}), make("diameter_error", 0.2, both(-8, 8))}),
       run(2, {make("roundness", 3.5, Limits{std::nullopt, 4.0}), make("diameter_error", 0.1, both(-8, 8))})});
  EXPECT_EQ(figure(pin, "roundness").part_kind, PartKind::kPin);
  EXPECT_EQ(spc_figure_json(figure(pin, "roundness"))["title"], "Pin roundness");
  const std::string text = spc_table_text(pin);
  EXPECT_NE(text.find("Pin roundness"), std::string::npos) << text;
  EXPECT_EQ(text.find("Base circle"), std::string::npos) << text;

  const std::vector<SpcFigure> lobe = spc_figures({run(3, {make("roundness", 1.0, Limits{std::nullopt, 4.0})})});
  EXPECT_EQ(spc_figure_json(lobe[0])["title"], "Base circle roundness");
}

TEST(Spc, TableHasARowPerCharacteristicAndSaysWhatIsMissing) {
  // Lift error 1, 2, 3 um against -5..+5 (s = 1, Cp = 10 / 6 = 1.67, Cpk = min(3, 7) / 3 =
  // 1.00); runout 2 um once against an upper limit of 10.
  const std::string text = spc_table_text(spc_figures(
      {run(1, {make("lift_error", 1, both(-5, 5), Verdict::kIn), make("base_circle_runout", 2, Limits{{}, 10.0})}),
       run(2, {make("lift_error", 2, both(-5, 5), Verdict::kIn)}),
       run(3, {make("lift_error", 3, both(-5, 5), Verdict::kIn)})}));
  EXPECT_NE(text.find("Lift error, whole turn"), std::string::npos) << text;
  EXPECT_NE(text.find("+2.00          1.00         -5.00         +5.00    1.67       1.00  0/3"), std::string::npos)
      << text;
  EXPECT_NE(text.find("Base circle runout (dial)"), std::string::npos) << text;
  EXPECT_NE(text.find("+10.00       -          -  0/0"), std::string::npos) << text;
  EXPECT_NE(text.find("Base circle runout (dial): 1 run"), std::string::npos) << text;
  EXPECT_NE(text.find("LSL, USL: the limits of the newest run"), std::string::npos) << text;
  // Three runs: a first look. Bissell's interval: 1.00 +- 1.96 sqrt(1/27 + 1/4) = 1.00 +- 1.05.
  EXPECT_NE(text.find("Lift error, whole turn: 3 runs: Cp and Cpk from fewer than 25 runs are a first look, not a "
                      "capability (Cpk's 95 % interval -0.05 .. 2.05)"),
            std::string::npos)
      << text;
}

TEST(Spc, TwentyFiveRunsGiveCpkWithItsIntervalAndNoCaution) {
  // 25 runs alternating 1 and 3 um against -5..+5 (mean 1.96): Cpk = (5 - 1.96) / (3 s), and
  // the interval as Bissell's, to 1e-12.
  std::vector<RunCharacteristics> runs;
  for (int i = 0; i < 25; ++i) runs.push_back(run(i + 1, {make("lift_error", i % 2 == 0 ? 1.0 : 3.0, both(-5, 5))}));
  const SpcFigure f = figure(spc_figures(runs), "lift_error");
  ASSERT_TRUE(f.cpk.has_value());
  EXPECT_TRUE(f.caution.empty()) << f.caution;
  const double half = 1.96 * std::sqrt(1.0 / (9.0 * 25) + *f.cpk * *f.cpk / (2.0 * 24));
  ASSERT_TRUE(f.cpk_low95 && f.cpk_high95);
  EXPECT_NEAR(*f.cpk_low95, *f.cpk - half, 1e-12);
  EXPECT_NEAR(*f.cpk_high95, *f.cpk + half, 1e-12);
  EXPECT_EQ(spc_figure_json(f)["caution"], "");
  EXPECT_NEAR(spc_figure_json(f)["cpk_low95"].get<double>(), *f.cpk - half, 1e-12);
  std::vector<RunCharacteristics> few(runs.begin(), runs.begin() + 24);
  EXPECT_FALSE(figure(spc_figures(few), "lift_error").caution.empty()) << "24 runs: a first look";
}

TEST(Spc, HugeValuesGiveAFiniteMeanAndNoInfiniteS) {
  // 1.5e308 and -1.5e308: their sum is fine, but 1.5e308 twice would overflow a plain sum, and
  // the squared deviations overflow whatever the order.
  const std::vector<SpcFigure> same =
      spc_figures({run(1, {make("lift_error", 1.5e308)}), run(2, {make("lift_error", 1.7e308)})});
  EXPECT_NEAR(figure(same, "lift_error").mean, 1.6e308, 1e294);
  EXPECT_FALSE(figure(same, "lift_error").sd.has_value());
  EXPECT_NE(figure(same, "lift_error").not_computed.find("finite s"), std::string::npos);
}

TEST(Spc, NoRunsNoFigures) { EXPECT_TRUE(spc_figures(std::vector<RunCharacteristics>{}).empty()); }

}  // namespace
}  // namespace gaugeloop
