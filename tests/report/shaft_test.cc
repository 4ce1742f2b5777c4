// The shaft record: lobe verdicts, index errors from known phases and frame mappings, the
// shaft verdict, and the newest run of each lobe read from a real store.
#include "report/shaft.h"

#include <gtest/gtest.h>

#include "tests/report/stored_run_test.h"
#include "tests/support/sample_runs.h"

namespace gaugeloop {
namespace {

StoredRun lobe_run(std::int64_t id, int lobe, double c_offset_deg, int rotation_sense, double phase_deg,
                   Verdict verdict = Verdict::kIn) {
  StoredRun r;
  r.summary.id = id;
  r.summary.lobe = lobe;
  r.summary.verdict = verdict;
  r.summary.phase_error_deg = phase_deg;
  Part g;
  g.c_offset_deg = c_offset_deg;
  g.rotation_sense = rotation_sense;
  g.probe_offset_deg = 7.0;  // never enters the nose position
  r.geometry = g;
  return r;
}

// Intake lobe 1 at the reference, exhaust lobe 2 at 110 deg; the reference stands at C = 30.
ShaftLayout two_lobes(std::optional<double> tolerance_deg = 0.5) {
  ShaftLayout s;
  s.name = "test shaft";
  s.reference_c_deg = 30.0;
  s.index_tolerance_deg = tolerance_deg;
  s.lobes = {ShaftLobe{1, "intake", "intake.toml", 0.0}, ShaftLobe{2, "exhaust", "exhaust.toml", 110.0}};
  return s;
}

TEST(ShaftRecord, WrapsTo180Exclusive) {
  EXPECT_DOUBLE_EQ(wrap_deg_180(0.0), 0.0);
  EXPECT_DOUBLE_EQ(wrap_deg_180(180.0), 180.0);
  EXPECT_DOUBLE_EQ(wrap_deg_180(-180.0), 180.0);
  EXPECT_DOUBLE_EQ(wrap_deg_180(190.0), -170.0);
  EXPECT_DOUBLE_EQ(wrap_deg_180(-190.0), 170.0);
  EXPECT_DOUBLE_EQ(wrap_deg_180(540.0), 180.0);
  EXPECT_DOUBLE_EQ(wrap_deg_180(-359.5), 0.5);
}

TEST(ShaftRecord, KnownPhasesGiveKnownIndexErrors) {
  // Lobe 1: c0 = 30 (its nominal), s = +1, phase +0.2: nose at 30.2, index error +0.2.
  // Lobe 2: c0 = 140 (its nominal 30 + 110), s = +1, phase -0.3: nose at 139.7, error -0.3;
  // relative to lobe 1: -0.3 - 0.2 = -0.5.
  const ShaftRecord rec =
      shaft_record(two_lobes(), "S-1", {lobe_run(11, 1, 30.0, 1, 0.2), lobe_run(12, 2, 140.0, 1, -0.3)});
  ASSERT_EQ(rec.lobes.size(), 2u);
  EXPECT_NEAR(*rec.lobes[0].index_error_deg, 0.2, 1e-12);
  EXPECT_NEAR(*rec.lobes[0].nose_c_deg, 30.2, 1e-12);
  EXPECT_NEAR(*rec.lobes[0].relative_error_deg, 0.0, 1e-12);
  EXPECT_NEAR(rec.lobes[1].nominal_c_deg, 140.0, 1e-12);
  EXPECT_NEAR(*rec.lobes[1].index_error_deg, -0.3, 1e-12);
  EXPECT_NEAR(*rec.lobes[1].relative_error_deg, -0.5, 1e-12);
  EXPECT_EQ(rec.lobes[0].index_verdict, "in");
  EXPECT_EQ(rec.lobes[1].index_verdict, "in");
  EXPECT_EQ(rec.lobes[1].verdict, "in");
  EXPECT_EQ(rec.lobes[1].run->id, 12);
  EXPECT_EQ(rec.verdict, "in");
}

TEST(ShaftRecord, NegativeRotationSenseTurnsThePhaseTheOtherWay) {
  // s = -1: a phase of +0.3 puts the nose at C = 140 - 0.3 = 139.7, index error -0.3.
  const ShaftRecord rec =
      shaft_record(two_lobes(), "S-1", {lobe_run(11, 1, 30.0, -1, 0.0), lobe_run(12, 2, 140.0, -1, 0.3)});
  EXPECT_NEAR(*rec.lobes[1].index_error_deg, -0.3, 1e-12);
  EXPECT_NEAR(*rec.lobes[1].nose_c_deg, 139.7, 1e-12);
}

TEST(ShaftRecord, IndexErrorWrapsAt180) {
  // Reference at C = 0, lobe 2 nominal at 180. Its c0 is written as -179.8 (the same place as
  // 180.2): the error is +0.2, not -359.8. A nose at 359.9 against nominal 0 is -0.1.
  ShaftLayout s = two_lobes();
  s.reference_c_deg = 0.0;
  s.lobes[1].angle_deg = 180.0;
  const ShaftRecord rec = shaft_record(s, "S-1", {lobe_run(11, 1, 359.9, 1, 0.0), lobe_run(12, 2, -179.8, 1, 0.0)});
  EXPECT_NEAR(*rec.lobes[0].index_error_deg, -0.1, 1e-9);
  EXPECT_NEAR(*rec.lobes[1].index_error_deg, 0.2, 1e-9);
  EXPECT_NEAR(*rec.lobes[1].relative_error_deg, 0.3, 1e-9);
  EXPECT_NEAR(*rec.lobes[1].nose_c_deg, 180.2, 1e-9);
}

TEST(ShaftRecord, AClampingErrorMovesEveryLobeAndCancelsAgainstTheDatum) {
  // Both lobes ground 2 deg on from their nominal: each index +2 (out of +-0.5), relative 0.
  const ShaftRecord rec =
      shaft_record(two_lobes(), "S-1", {lobe_run(11, 1, 32.0, 1, 0.0), lobe_run(12, 2, 142.0, 1, 0.0)});
  EXPECT_NEAR(*rec.lobes[0].index_error_deg, 2.0, 1e-12);
  EXPECT_NEAR(*rec.lobes[1].index_error_deg, 2.0, 1e-12);
  EXPECT_NEAR(*rec.lobes[1].relative_error_deg, 0.0, 1e-12);
  EXPECT_EQ(rec.lobes[0].index_verdict, "out");
  EXPECT_EQ(rec.verdict, "out");
}

TEST(ShaftRecord, ShaftVerdictWords) {
  // A lobe out: out, whatever else.
  EXPECT_EQ(
      shaft_record(two_lobes(), "S", {lobe_run(1, 1, 30, 1, 0), lobe_run(2, 2, 140, 1, 0, Verdict::kOut)}).verdict,
      "out");
  // A lobe not measured, nothing out: incomplete, and the missing lobe says so.
  const ShaftRecord missing = shaft_record(two_lobes(), "S", {lobe_run(1, 1, 30, 1, 0), std::nullopt});
  EXPECT_EQ(missing.verdict, "incomplete");
  EXPECT_EQ(missing.lobes[1].verdict, "not_measured");
  EXPECT_FALSE(missing.lobes[1].run.has_value());
  EXPECT_FALSE(missing.lobes[1].index_error_deg.has_value());
  // A missing lobe with another out: out.
  EXPECT_EQ(shaft_record(two_lobes(), "S", {lobe_run(1, 1, 30, 1, 0, Verdict::kOut), std::nullopt}).verdict, "out");
  // Every lobe in but no index tolerance: the index is not judged, nor the shaft.
  const ShaftRecord untoleranced =
      shaft_record(two_lobes(std::nullopt), "S", {lobe_run(1, 1, 30, 1, 0), lobe_run(2, 2, 140, 1, 0)});
  EXPECT_EQ(untoleranced.lobes[1].index_verdict, "not_judged");
  EXPECT_EQ(untoleranced.verdict, "not_judged");
  // A lobe not judged: not judged.
  EXPECT_EQ(shaft_record(two_lobes(), "S", {lobe_run(1, 1, 30, 1, 0), lobe_run(2, 2, 140, 1, 0, Verdict::kNotJudged)})
                .verdict,
            "not_judged");
}

TEST(ShaftRecord, ARunWithoutItsFrameMappingHasNoIndexAndSaysWhy) {
  StoredRun no_geometry = lobe_run(2, 2, 140, 1, 0);
  no_geometry.geometry.reset();
  const ShaftRecord rec = shaft_record(two_lobes(), "S", {lobe_run(1, 1, 30, 1, 0), no_geometry});
  EXPECT_FALSE(rec.lobes[1].index_error_deg.has_value());
  EXPECT_NE(rec.lobes[1].note.find("frame mapping"), std::string::npos);
  EXPECT_EQ(rec.lobes[1].index_verdict, "not_judged");
  EXPECT_EQ(rec.verdict, "not_judged");
  // The datum without an index: nothing is relative to it.
  const ShaftRecord no_datum = shaft_record(two_lobes(), "S", {no_geometry, lobe_run(1, 1, 30, 1, 0)});
  EXPECT_FALSE(no_datum.lobes[1].relative_error_deg.has_value());
}

TEST(ShaftRecord, JsonCarriesNullsForWhatIsNotGiven) {
  const nlohmann::json j =
      shaft_record_json(shaft_record(two_lobes(), "S-9", {lobe_run(1, 1, 30, 1, 0.1), std::nullopt}));
  EXPECT_EQ(j["serial"], "S-9");
  EXPECT_EQ(j["verdict"], "incomplete");
  EXPECT_EQ(j["datum_lobe"], 1);
  EXPECT_EQ(j["index_tolerance_deg"], 0.5);
  ASSERT_EQ(j["lobes"].size(), 2u);
  EXPECT_NEAR(j["lobes"][0]["index_error_deg"].get<double>(), 0.1, 1e-12);
  EXPECT_TRUE(j["lobes"][1]["run_id"].is_null());
  EXPECT_TRUE(j["lobes"][1]["index_error_deg"].is_null());
  EXPECT_EQ(j["lobes"][1]["verdict"], "not_measured");
}

TEST(ShaftRecord, TextHasARowPerLobeAndTheVerdict) {
  const std::string text =
      shaft_record_text(shaft_record(two_lobes(), "CS-7", {lobe_run(11, 1, 30.0, 1, 0.2), std::nullopt}));
  EXPECT_NE(text.find("serial CS-7"), std::string::npos) << text;
  EXPECT_NE(text.find("index tolerance +-0.500 deg, datum lobe 1"), std::string::npos) << text;
  EXPECT_NE(text.find("in               +0.200     +0.200     +0.000  in"), std::string::npos) << text;
  EXPECT_NE(text.find("not_measured"), std::string::npos) << text;
  EXPECT_NE(text.find("shaft verdict: incomplete"), std::string::npos) << text;
  EXPECT_NE(text.find("lobe 2: no run of this part, lobe and serial"), std::string::npos) << text;
}

class ShaftStoreTest : public testing::StoredRunTest {};

TEST_F(ShaftStoreTest, TakesTheNewestRunOfEachLobeWithThatSerial) {
  // sample_run: phase 0.25 deg, c_offset 10 deg, rotation sense +1, so a lobe at 10 deg
  // nominal has index error +0.25 (reference 10, angle 0).
  RunRecord old_run = testing::sample_run("intake", 1, "grinder-1", "2026-11-22T02:00:00Z", 5.0);
  old_run.serial = "CS-100";
  old_run.analysis.phase_error_deg = 1.0;
  insert(old_run);
  RunRecord newest = testing::sample_run("intake", 1, "grinder-1", "2026-11-22T03:00:00Z", 5.0);
  newest.serial = "CS-100";
  const std::int64_t newest_id = insert(newest);
  RunRecord other_serial = testing::sample_run("intake", 1, "grinder-1", "2026-11-22T04:00:00Z", 5.0);
  other_serial.serial = "CS-101";
  insert(other_serial);

  ShaftLayout s = two_lobes();
  s.reference_c_deg = 10.0;
  s.lobes[0].part = "intake";
  Result<ShaftRecord> rec = load_shaft_record(*store_, s, "CS-100");
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  ASSERT_TRUE(rec->lobes[0].run.has_value());
  EXPECT_EQ(rec->lobes[0].run->id, newest_id);
  EXPECT_NEAR(*rec->lobes[0].index_error_deg, 0.25, 1e-12);
  EXPECT_EQ(rec->lobes[1].verdict, "not_measured");

  EXPECT_FALSE(load_shaft_record(*store_, s, "").ok());
}

}  // namespace
}  // namespace gaugeloop
