// The SPC summaries the SQLite file makes from one statement over the window's characteristics
// against the same summaries made here run by run (summarize_characteristics over
// RunStore::characteristics), on a real file on disk: the same runs, keys, order, counts and
// limits, and the same mean and squared deviations to the bit (the same values summed in the
// same order, oldest run first; a REAL comes back from SQLite exactly).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "report/cam_report.h"
#include "report/spc.h"
#include "storage/run_store.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

Characteristic judged(const std::string& key, const std::string& unit, double value, Limits limits) {
  Characteristic c;
  c.key = key;
  c.unit = unit;
  c.value = value;
  c.min = value;
  c.max = value;
  c.limits = limits;
  const bool out = (limits.lower && value < *limits.lower) || (limits.upper && value > *limits.upper);
  c.verdict = limits.lower || limits.upper ? (out ? Verdict::kOut : Verdict::kIn) : Verdict::kNotJudged;
  return c;
}

// 40 runs of lobe 1 on two machines, with a key whose limits change at run 20, one with an
// upper limit only, one that never moves, one without limits, and one that first appears at
// run 30 (so it comes last); and runs of another lobe that no query here selects.
class SpcSummariesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> s = RunStore::open(tmp_.path() / "runs.sqlite");
    ASSERT_TRUE(s.ok()) << s.error().message;
    store_.emplace(std::move(*s));
    for (int i = 0; i < 40; ++i) {
      char started[32];
      std::snprintf(started, sizeof started, "2026-11-%02dT%02d:00:00Z", 1 + i / 4, 6 * (i % 4));
      RunRecord r = testing::sample_run("intake", 1, i % 3 == 0 ? "g2" : "g1", started, 5.0);
      const double wave = std::sin(0.7 * i) * 9.0 + 0.01 * i;
      std::vector<Characteristic>& c = r.characteristics;
      if (i >= 30) c.push_back(judged("velocity_error.nose", "mm/deg", 1e-5 * wave, Limits{-4e-5, 4e-5}));
      c.push_back(judged("lift_error", "um", wave, i < 20 ? Limits{-12.0, 12.0} : Limits{-8.0, 8.0}));
      c.push_back(judged("roundness", "um", 2.0 + std::fabs(wave) / 3.0, Limits{std::nullopt, 4.0}));
      c.push_back(judged("phase", "deg", 0.25, Limits{-0.5, 0.5}));
      c.push_back(judged("dial_runout", "um", 1.0 + 0.1 * (i % 5), Limits{}));
      std::vector<Verdict> verdicts;
      for (const Characteristic& k : c) verdicts.push_back(k.verdict);
      r.verdict = combined_verdict(verdicts);
      Result<std::int64_t> id = store_->insert_run(r);
      ASSERT_TRUE(id.ok()) << id.error().message;
      RunRecord other = testing::sample_run("intake", 2, "g1", started, 3.0);
      other.characteristics.push_back(judged("lift_error", "um", 100.0 + i, Limits{-12.0, 12.0}));
      other.verdict = Verdict::kOut;
      ASSERT_TRUE(store_->insert_run(other).ok());
    }
  }

  void expect_same(const RunQuery& q) {
    Result<CharacteristicSummaries> sql = store_->characteristic_summaries(q);
    ASSERT_TRUE(sql.ok()) << sql.error().message;
    Result<std::vector<RunCharacteristics>> runs = store_->characteristics(q);
    ASSERT_TRUE(runs.ok()) << runs.error().message;
    const CharacteristicSummaries here = summarize_characteristics(*runs);
    EXPECT_EQ(sql->runs, here.runs);
    EXPECT_EQ(sql->first_started_utc, here.first_started_utc);
    EXPECT_EQ(sql->last_started_utc, here.last_started_utc);
    ASSERT_EQ(sql->by_key.size(), here.by_key.size());
    for (std::size_t i = 0; i < here.by_key.size(); ++i) {
      const CharacteristicSummary& a = sql->by_key[i];
      const CharacteristicSummary& b = here.by_key[i];
      SCOPED_TRACE(b.key);
      EXPECT_EQ(a.key, b.key) << "the order keys first appear";
      EXPECT_EQ(a.unit, b.unit);
      EXPECT_EQ(a.n, b.n);
      EXPECT_EQ(a.all_equal, b.all_equal);
      EXPECT_EQ(a.mean, b.mean);
      EXPECT_EQ(a.squares, b.squares);
      EXPECT_EQ(a.limits.lower, b.limits.lower);
      EXPECT_EQ(a.limits.upper, b.limits.upper);
      EXPECT_EQ(a.limits_from_run, b.limits_from_run);
      EXPECT_EQ(a.limits_changed, b.limits_changed);
      EXPECT_EQ(a.out_count, b.out_count);
      EXPECT_EQ(a.judged_count, b.judged_count);
    }
  }

  testing::TempDir tmp_;
  std::optional<RunStore> store_;
};

RunQuery lobe_one() {
  RunQuery q;
  q.part = "intake";
  q.lobe = 1;
  q.limit = 10000;
  return q;
}

TEST_F(SpcSummariesTest, TheWholeLobeSumsUpFromOneStatementAsRunByRun) {
  const RunQuery q = lobe_one();
  expect_same(q);
  // What the comparison compares: 40 runs, five keys, the late one last, the changed limits.
  Result<CharacteristicSummaries> s = store_->characteristic_summaries(q);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->runs, 40);
  ASSERT_EQ(s->by_key.size(), 5u);
  EXPECT_EQ(s->by_key[0].key, "lift_error");
  EXPECT_EQ(s->by_key[4].key, "velocity_error.nose");
  EXPECT_EQ(s->by_key[4].n, 10);
  EXPECT_TRUE(s->by_key[0].limits_changed);
  EXPECT_EQ(s->by_key[0].limits.upper, 8.0) << "the newest run's";
  EXPECT_GT(s->by_key[0].out_count, 0);
  EXPECT_TRUE(s->by_key[2].all_equal);
  EXPECT_EQ(s->by_key[2].mean, 0.25);
  EXPECT_EQ(s->by_key[3].judged_count, 0) << "no limits: not judged";
}

TEST_F(SpcSummariesTest, EveryFilterAndWindowSumsUpTheSameRuns) {
  RunQuery newest = lobe_one();
  newest.limit = 7;  // within the runs with the late key, limits unchanged
  expect_same(newest);
  newest.limit = 15;  // the late key in some runs only
  expect_same(newest);
  RunQuery machine = lobe_one();
  machine.machine = "g2";
  expect_same(machine);
  RunQuery since = lobe_one();
  since.since_utc = "2026-11-04T00:00:00Z";
  since.until_utc = "2026-11-08T00:00:00Z";
  expect_same(since);
  RunQuery none = lobe_one();
  none.part = "exhaust";
  expect_same(none);
  Result<CharacteristicSummaries> empty = store_->characteristic_summaries(none);
  ASSERT_TRUE(empty.ok());
  EXPECT_EQ(empty->runs, 0);
  EXPECT_TRUE(empty->by_key.empty());
}

TEST_F(SpcSummariesTest, ATrendPlotReadsItsKeyOfEveryRunAndEveryKeyWhenNoRunHasIt) {
  const RunQuery q = lobe_one();
  Result<std::vector<RunCharacteristics>> all = store_->characteristics(q);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->size(), 40u);
  // One key: the same runs in the same order, each with that characteristic alone (the nose's
  // velocity from run 30 on, none before), as read with every other.
  Result<std::vector<RunCharacteristics>> nose = trend_plot_runs(*store_, q, "velocity_error.nose");
  ASSERT_TRUE(nose.ok()) << nose.error().message;
  ASSERT_EQ(nose->size(), all->size());
  int with_key = 0;
  for (std::size_t i = 0; i < all->size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ((*nose)[i].run.id, (*all)[i].run.id);
    const Characteristic* expected = nullptr;
    for (const Characteristic& c : (*all)[i].characteristics) {
      if (c.key == "velocity_error.nose") expected = &c;
    }
    ASSERT_EQ((*nose)[i].characteristics.size(), expected ? 1u : 0u);
    if (!expected) continue;
    ++with_key;
    const Characteristic& got = (*nose)[i].characteristics.front();
    EXPECT_EQ(got.key, expected->key);
    EXPECT_EQ(got.value, expected->value);
    EXPECT_EQ(got.limits.upper, expected->limits.upper);
    EXPECT_EQ(got.verdict, expected->verdict);
  }
  EXPECT_EQ(with_key, 10);
  // A key no run has: the newest run with every characteristic, so that the plot's refusal names
  // those it has.
  Result<std::vector<RunCharacteristics>> none = trend_plot_runs(*store_, q, "lift_error.zone9");
  ASSERT_TRUE(none.ok()) << none.error().message;
  ASSERT_EQ(none->size(), 1u);
  EXPECT_EQ(none->back().run.id, all->back().run.id);
  EXPECT_EQ(none->back().characteristics.size(), all->back().characteristics.size());
  const testing::TempDir out;
  const Status refused = write_trend_plot(*none, "lift_error.zone9", out.path() / "trend.svg");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("the newest run has: dial_runout, lift_error, phase, roundness"),
            std::string::npos)
      << refused.error().message;
}

TEST_F(SpcSummariesTest, TheFiguresFromTheSummariesAreTheFiguresFromTheRuns) {
  Result<CharacteristicSummaries> sql = store_->characteristic_summaries(lobe_one());
  Result<std::vector<RunCharacteristics>> runs = store_->characteristics(lobe_one());
  ASSERT_TRUE(sql.ok() && runs.ok());
  const std::vector<SpcFigure> a = spc_figures(*sql);
  const std::vector<SpcFigure> b = spc_figures(*runs);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE(b[i].key);
    ASSERT_EQ(a[i].cpk.has_value(), b[i].cpk.has_value());
    if (b[i].cpk) {
      EXPECT_NEAR(*a[i].cpk, *b[i].cpk, 1e-9);
    }
    EXPECT_EQ(a[i].not_computed, b[i].not_computed);
    EXPECT_EQ(a[i].caution, b[i].caution);
  }
}

}  // namespace
}  // namespace gaugeloop
