// RunStore against real SQLite: round trips, listing, pushes, refusals and what they leave.
#include "storage/run_store.h"
#include "storage/db_maintenance.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "storage_test_support.h"

namespace gaugeloop {
namespace {

using testing::make_record;
using testing::RawDb;
using testing::TempDir;

// Per-degree tables are kept as counts of 0.1 nm: they come back to half a count.
constexpr double kToleranceMm = 0.5e-7 + 1e-12;
constexpr double kToleranceUm = 0.5e-4 + 1e-9;

void expect_near_table(const DegreeTable& got, const DegreeTable& want, double tolerance, const char* what) {
  for (std::size_t d = 0; d < got.size(); ++d) {
    ASSERT_NEAR(got[d], want[d], tolerance) << what << " degree " << d;
  }
}

std::int64_t insert_ok(RunStore& store, const RunRecord& record) {
  Result<std::int64_t> id = store.insert_run(record);
  EXPECT_TRUE(id.ok()) << id.error().message;
  return id.ok() ? *id : -1;
}

void expect_same_run(const StoredRun& got, const RunRecord& want) {
  ASSERT_EQ(got.revolutions.size(), want.measured.revolutions.size());
  for (std::size_t i = 0; i < got.revolutions.size(); ++i) {
    EXPECT_EQ(got.revolutions[i].revolution, want.measured.revolutions[i].revolution);
    for (std::size_t d = 0; d < 360; ++d) {
      ASSERT_NEAR(got.revolutions[i].lift_mm[d], want.measured.revolutions[i].lift_mm[d], kToleranceMm)
          << "revolution " << i << " degree " << d;
    }
  }
  expect_near_table(got.analysis.design_lift_mm, want.analysis.design_lift_mm, kToleranceMm, "design");
  expect_near_table(got.analysis.mean_lift_mm, want.analysis.mean_lift_mm, kToleranceMm, "mean");
  expect_near_table(got.analysis.spread_um, want.analysis.spread_um, kToleranceUm, "spread");
  expect_near_table(got.analysis.error_um, want.analysis.error_um, kToleranceUm, "error");
  expect_near_table(got.correction_um, want.correction_um, kToleranceUm, "correction");
  // Figures are SQLite REALs (harmonics: JSON with 17 digits): the very same doubles.
  EXPECT_EQ(got.analysis.phase_error_deg, want.analysis.phase_error_deg);
  EXPECT_EQ(got.analysis.base_circle_runout_um, want.analysis.base_circle_runout_um);
  EXPECT_EQ(got.analysis.harmonic_amplitude_um, want.analysis.harmonic_amplitude_um);
  EXPECT_EQ(got.settings, want.settings);
  EXPECT_EQ(got.summary.settings_hash, settings_hash(want.settings));
  ASSERT_EQ(got.geometry.has_value(), want.geometry.has_value());
  if (want.geometry) {
    EXPECT_EQ(got.geometry->follower, want.geometry->follower);
    EXPECT_EQ(got.geometry->follower_radius_mm, want.geometry->follower_radius_mm);
    EXPECT_EQ(got.geometry->base_circle_radius_mm, want.geometry->base_circle_radius_mm);
    EXPECT_EQ(got.geometry->wheel_radius_mm, want.geometry->wheel_radius_mm);
    EXPECT_EQ(got.geometry->rotation_sense, want.geometry->rotation_sense);
    EXPECT_EQ(got.geometry->c_offset_deg, want.geometry->c_offset_deg);
    EXPECT_EQ(got.geometry->probe_offset_deg, want.geometry->probe_offset_deg);
  }
  EXPECT_EQ(got.analysis.zero_offset_mm, want.analysis.zero_offset_mm);
  EXPECT_EQ(got.analysis.max_abs_error_um, want.analysis.max_abs_error_um);
  EXPECT_EQ(got.analysis.rms_error_um, want.analysis.rms_error_um);
  EXPECT_EQ(got.analysis.peak_to_valley_um, want.analysis.peak_to_valley_um);
  EXPECT_EQ(got.analysis.repeatability_um, want.analysis.repeatability_um);

  const RunSummary& s = got.summary;
  EXPECT_EQ(s.started_utc, want.started_utc);
  EXPECT_EQ(s.machine, want.machine);
  EXPECT_EQ(s.part, want.part);
  EXPECT_EQ(s.lobe, want.lobe);
  EXPECT_EQ(s.status, "measured");
  EXPECT_EQ(s.revolutions, static_cast<int>(want.measured.revolutions.size()));
  EXPECT_EQ(s.degrees_captured, s.revolutions * 360);
  EXPECT_EQ(s.max_abs_error_um, want.analysis.max_abs_error_um);
  EXPECT_EQ(s.rms_error_um, want.analysis.rms_error_um);
  EXPECT_EQ(s.repeatability_um, want.analysis.repeatability_um);
  EXPECT_EQ(s.nc_file, "");

  EXPECT_EQ(got.finished_utc, want.finished_utc);
  EXPECT_EQ(got.gauge, want.gauge);
  EXPECT_EQ(got.note, want.note);
  EXPECT_EQ(got.polls, want.measured.polls);
  EXPECT_EQ(got.reconnects, want.measured.reconnects);
  EXPECT_EQ(got.discarded_revolutions, want.measured.discarded_revolutions);
}

class RunStoreTest : public testing::StoreTest {
 protected:
};

TEST_F(RunStoreTest, OpenCreatesParentDirectoriesAndFile) {
  EXPECT_TRUE(std::filesystem::is_regular_file(db_in(dir_)));
  EXPECT_EQ(store().path(), db_in(dir_));
}

TEST_F(RunStoreTest, InsertThenLoadReturnsTheSameRunToATenthOfANanometre) {
  const RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z", 4);
  const std::int64_t id = insert_ok(store(), record);

  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->summary.id, id);
  expect_same_run(*loaded, record);
}

// The band of harmonics the correction fed back and the threshold that chose it come back as
// stored; a run without them (an inspection) reads as empty; a band past 0..180 or a negative
// or non-finite threshold is refused, naming the field, and nothing is stored.
TEST_F(RunStoreTest, TheBandFedBackComesBackAsStoredAndANonsenseOneIsRefused) {
  RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z", 4);
  record.harmonics_fed_back = 27;
  record.harmonic_threshold_um = 0.052;
  const std::int64_t id = insert_ok(store(), record);
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->harmonics_fed_back, 27);
  EXPECT_EQ(loaded->harmonic_threshold_um, 0.052);

  RunRecord without = make_record("intake-flat", "2026-11-22T02:35:44Z", 4);
  Result<StoredRun> plain = store().load_run(insert_ok(store(), without));
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_FALSE(plain->harmonics_fed_back.has_value());
  EXPECT_FALSE(plain->harmonic_threshold_um.has_value());

  RunRecord wide = make_record("intake-flat", "2026-11-22T02:36:44Z", 4);
  wide.harmonics_fed_back = 181;
  Result<std::int64_t> refused = store().insert_run(wide);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("harmonics_fed_back 181"), std::string::npos) << refused.error().message;
  RunRecord negative = make_record("intake-flat", "2026-11-22T02:37:44Z", 4);
  negative.harmonic_threshold_um = -0.1;
  refused = store().insert_run(negative);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("harmonic_threshold_um"), std::string::npos) << refused.error().message;
  Result<std::vector<RunSummary>> all = store().list_runs(RunQuery{});
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->size(), 2u) << "the refused runs left nothing";
}

// What the central history copies: the whole record, its details and characteristics as
// load_run has them, and nothing of what is kept per degree.
TEST_F(RunStoreTest, TheRunsRecordIsTheRunWithoutWhatIsKeptPerDegree) {
  RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z", 4);
  Characteristic c;
  c.key = "lift_error";
  c.unit = "um";
  c.value = 3.5;
  c.limits.upper = 12.0;
  c.verdict = Verdict::kIn;
  record.characteristics.push_back(c);
  const std::int64_t id = insert_ok(store(), record);
  Result<StoredRun> whole = store().load_run(id);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  Result<StoredRun> rec = store().load_run_record(id);
  ASSERT_TRUE(rec.ok()) << rec.error().message;
  EXPECT_EQ(rec->summary.uuid, whole->summary.uuid);
  EXPECT_EQ(rec->summary.max_abs_error_um, whole->summary.max_abs_error_um);
  EXPECT_EQ(rec->finished_utc, whole->finished_utc);
  EXPECT_EQ(rec->settings, whole->settings);
  EXPECT_EQ(rec->analysis.harmonic_amplitude_um, whole->analysis.harmonic_amplitude_um);
  EXPECT_EQ(rec->analysis.zero_offset_mm, whole->analysis.zero_offset_mm);
  EXPECT_EQ(rec->analysis.roundness_um, whole->analysis.roundness_um);
  ASSERT_EQ(rec->characteristics.size(), 1u);
  EXPECT_EQ(rec->characteristics[0].value, 3.5);
  EXPECT_FALSE(whole->revolutions.empty());
  EXPECT_TRUE(rec->revolutions.empty());
  auto all_zero = [](const auto& v) { return std::all_of(v.begin(), v.end(), [](double x) { return x == 0.0; }); };
  EXPECT_FALSE(all_zero(whole->analysis.error_um));
  EXPECT_TRUE(all_zero(rec->analysis.error_um)) << "the profile is not read";
  EXPECT_EQ(store().load_run_record(id + 100).error().code, ErrorCode::kNotFound);
}

// The records of many runs read at once (the central sync's batch) are each run's record, in id
// order after the id given, at most the limit: the statements prepared once serve every run.
TEST_F(RunStoreTest, TheRecordsOfRunsAfterAnIdAreEachRunsRecordInIdOrder) {
  std::vector<std::int64_t> ids;
  for (int i = 0; i < 4; ++i) {
    RunRecord record = make_record(i % 2 == 0 ? "intake" : "exhaust", "2026-11-22T02:3" + std::to_string(i) + ":44Z");
    for (int k = 0; k <= i; ++k) {
      Characteristic c;
      c.key = "lift_error." + std::to_string(k);
      c.unit = "um";
      c.value = 1.5 + i;
      c.verdict = Verdict::kIn;
      record.characteristics.push_back(c);
    }
    record.note = "run " + std::to_string(i);
    ids.push_back(insert_ok(store(), record));
  }
  Result<std::vector<StoredRun>> after_first = store().run_records_after(ids[0], 2);
  ASSERT_TRUE(after_first.ok()) << after_first.error().message;
  ASSERT_EQ(after_first->size(), 2u);
  for (std::size_t i = 0; i < after_first->size(); ++i) {
    const StoredRun& batch = (*after_first)[i];
    Result<StoredRun> one = store().load_run_record(ids[i + 1]);
    ASSERT_TRUE(one.ok()) << one.error().message;
    EXPECT_EQ(batch.summary.id, ids[i + 1]);
    EXPECT_EQ(batch.summary.uuid, one->summary.uuid);
    EXPECT_EQ(batch.note, one->note);
    EXPECT_EQ(batch.settings, one->settings);
    EXPECT_EQ(batch.finished_utc, one->finished_utc);
    EXPECT_EQ(batch.analysis.harmonic_amplitude_um, one->analysis.harmonic_amplitude_um);
    ASSERT_EQ(batch.characteristics.size(), i + 2);  // each run its own, not the last one's
    EXPECT_EQ(batch.characteristics.back().value, one->characteristics.back().value);
  }
  Result<std::vector<StoredRun>> all = store().run_records_after(0, 100);
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->size(), 4u);
  EXPECT_TRUE(store().run_records_after(ids.back(), 10)->empty());
  EXPECT_FALSE(store().run_records_after(0, 0).ok());
}

TEST_F(RunStoreTest, ReopeningTheFileKeepsTheRun) {
  const RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z");
  const std::int64_t id = insert_ok(store(), record);
  store_.reset();

  Result<RunStore> reopened = RunStore::open(db_in(dir_));
  ASSERT_TRUE(reopened.ok()) << reopened.error().message;
  Result<StoredRun> loaded = reopened->load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  expect_same_run(*loaded, record);
}

TEST_F(RunStoreTest, ListsNewestFirst) {
  const std::int64_t older = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  const std::int64_t newer = insert_ok(store(), make_record("a", "2026-11-22T03:00:00Z"));
  // Inserted later but started earlier: sorts by start time, not by id.
  const std::int64_t oldest = insert_ok(store(), make_record("a", "2026-11-21T23:59:59Z"));

  Result<std::vector<RunSummary>> runs = store().list_runs({});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 3u);
  EXPECT_EQ((*runs)[0].id, newer);
  EXPECT_EQ((*runs)[1].id, older);
  EXPECT_EQ((*runs)[2].id, oldest);
}

TEST_F(RunStoreTest, RunsStartedInTheSameSecondListByIdNewestFirst) {
  const std::int64_t first = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  const std::int64_t second = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  Result<std::vector<RunSummary>> runs = store().list_runs({});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_EQ((*runs)[0].id, second);
  EXPECT_EQ((*runs)[1].id, first);
}

TEST_F(RunStoreTest, ListByPartFiltersOtherParts) {
  insert_ok(store(), make_record("intake", "2026-11-22T01:00:00Z"));
  const std::int64_t exhaust = insert_ok(store(), make_record("exhaust", "2026-11-22T02:00:00Z"));
  insert_ok(store(), make_record("intake", "2026-11-22T03:00:00Z"));

  Result<std::vector<RunSummary>> runs = store().list_runs([&] {
    RunQuery q;
    q.limit = 50;
    q.part = "exhaust";
    return q;
  }());
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].id, exhaust);
  EXPECT_EQ((*runs)[0].part, "exhaust");

  runs = store().list_runs([&] {
    RunQuery q;
    q.limit = 50;
    q.part = "no-such-part";
    return q;
  }());
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  EXPECT_TRUE(runs->empty());
}

TEST_F(RunStoreTest, SerialAndOperatorComeBackAndEmptyIsStoredAsNull) {
  RunRecord marked = make_record("intake", "2026-11-22T01:00:00Z");
  marked.serial = "CS-2026-0042 \u00e9";  // free text, not only ASCII
  marked.operator_name = "Anna K.";
  const std::int64_t id = insert_ok(store(), marked);
  const std::int64_t bare = insert_ok(store(), make_record("intake", "2026-11-22T02:00:00Z"));

  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->summary.serial, "CS-2026-0042 \u00e9");
  EXPECT_EQ(loaded->summary.operator_name, "Anna K.");
  loaded = store().load_run(bare);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->summary.serial, "");
  EXPECT_EQ(loaded->summary.operator_name, "");
  RawDb raw(db_in(dir_));
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM runs WHERE serial IS NULL AND operator IS NULL AND id = " +
                          std::to_string(bare)),
            1)
      << "not given is NULL, not an empty text";
}

TEST_F(RunStoreTest, ListBySerialMatchesExactly) {
  RunRecord a = make_record("intake", "2026-11-22T01:00:00Z");
  a.serial = "CS-42";
  const std::int64_t id = insert_ok(store(), a);
  RunRecord b = make_record("intake", "2026-11-22T02:00:00Z");
  b.serial = "CS-420";
  insert_ok(store(), b);
  RunRecord c = make_record("intake", "2026-11-22T03:00:00Z");
  c.serial = "cs-42";
  insert_ok(store(), c);
  insert_ok(store(), make_record("intake", "2026-11-22T04:00:00Z"));

  RunQuery q;
  q.serial = "CS-42";
  Result<std::vector<RunSummary>> runs = store().list_runs(q);
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u) << "neither a longer serial nor another case matches";
  EXPECT_EQ((*runs)[0].id, id);
  EXPECT_EQ((*runs)[0].serial, "CS-42");
  // A part's runs are one index seek away, however long the history.
  const std::string plan =
      RawDb(db_in(dir_))
          .query_plan("SELECT id FROM runs AS r WHERE r.serial = 'CS-42' ORDER BY r.started_utc DESC, r.id DESC");
  EXPECT_NE(plan.find("runs_by_serial"), std::string::npos) << plan;
}

// Each filter `runs list` and GET /api/runs offer, alone and as a lobe's, is one index seek
// that also gives the newest-first order: no full scan and no sort of all a part's runs.
// (status alone walks runs_by_started newest first and stops at the limit.)
TEST_F(RunStoreTest, EveryListFilterIsServedByAnIndexInTimeOrder) {
  insert_ok(store(), make_record("intake", "2026-11-22T01:00:00Z"));
  const std::pair<const char*, const char*> filters[] = {
      {"r.part = 'a'", "runs_by_part_started (part=?)"},
      {"r.part = 'a' AND r.lobe = 3", "runs_by_part_lobe_started (part=? AND lobe=?)"},
      {"r.part = 'a' AND r.lobe = 3 AND r.started_utc >= '2026'",
       "runs_by_part_lobe_started (part=? AND lobe=? AND started_utc>?)"},
      {"r.machine = 'g'", "runs_by_machine_started (machine=?)"},
      {"r.machine = 'g' AND r.part = 'a' AND r.lobe = 3", "runs_by_lobe_started (machine=? AND part=? AND lobe=?)"},
      {"r.serial = 's'", "runs_by_serial (serial=?)"},
      {"r.verdict = 'out'", "runs_by_verdict (verdict=?)"},
      {"r.started_utc >= '2026'", "runs_by_started (started_utc>?)"},
      {"r.started_utc < '2026'", "runs_by_started (started_utc<?)"},
      {"r.status = 'measured'", "SCAN r USING INDEX runs_by_started"},
  };
  for (const auto& [where, index] : filters) {
    const std::string plan = RawDb(db_in(dir_))
                                 .query_plan("SELECT id FROM runs AS r WHERE " + std::string(where) +
                                             " ORDER BY r.started_utc DESC, r.id DESC LIMIT 50");
    EXPECT_NE(plan.find(index), std::string::npos) << where << "\n" << plan;
    EXPECT_EQ(plan.find("TEMP B-TREE"), std::string::npos) << where << ": a sort of every run it selects\n" << plan;
  }
}

// The verdict filter, every value of it, is one index seek with the sort (runs_by_verdict),
// however long the history: the plan SQLite makes for list_runs' query, and the runs it finds.
TEST_F(RunStoreTest, TheVerdictFilterIsServedByItsIndex) {
  RunRecord judged = make_record("intake", "2026-11-22T01:00:00Z");
  judged.verdict = Verdict::kOut;
  ASSERT_TRUE(store().insert_run(judged).ok());
  ASSERT_TRUE(store().insert_run(make_record("intake", "2026-11-22T02:00:00Z")).ok());
  for (const Verdict v : {Verdict::kIn, Verdict::kOut, Verdict::kNotJudged}) {
    RunQuery q;
    q.verdict = v;
    Result<std::vector<RunSummary>> runs = store().list_runs(q);
    ASSERT_TRUE(runs.ok()) << runs.error().message;
    for (const RunSummary& r : *runs) EXPECT_EQ(r.verdict, v);
    sqlite3* handle = nullptr;
    ASSERT_EQ(sqlite3_open(db_in(dir_).c_str(), &handle), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    const std::string sql = "EXPLAIN QUERY PLAN SELECT id FROM runs AS r WHERE r.verdict = '" +
                            std::string(verdict_name(v)) + "' ORDER BY r.started_utc DESC, r.id DESC LIMIT 50";
    ASSERT_EQ(sqlite3_prepare_v2(handle, sql.c_str(), -1, &st, nullptr), SQLITE_OK);
    std::string plan;
    while (sqlite3_step(st) == SQLITE_ROW)
      plan += reinterpret_cast<const char*>(sqlite3_column_text(st, 3)) + std::string("\n");
    sqlite3_finalize(st);
    sqlite3_close(handle);
    EXPECT_NE(plan.find("INDEX runs_by_verdict (verdict=?)"), std::string::npos) << plan;
    EXPECT_EQ(plan.find("TEMP B-TREE"), std::string::npos) << "the index gives the order too\n" << plan;
  }
  Result<std::vector<RunSummary>> out = store().list_runs([] {
    RunQuery q;
    q.verdict = Verdict::kOut;
    return q;
  }());
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->size(), 1u);
}

TEST_F(RunStoreTest, SerialAndOperatorOverSixtyFourCharactersOrWithControlsAreRefused) {
  RunRecord r = make_record("intake", "2026-11-22T01:00:00Z");
  r.serial = std::string(64, 'S');
  r.operator_name = std::string(32, 'O') + std::string(32, 'o');
  insert_ok(store(), r);
  r.serial = std::string(65, 'S');
  Result<std::int64_t> id = store().insert_run(r);
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(id.error().message.find("serial is 65 characters long; at most 64"), std::string::npos)
      << id.error().message;
  r.serial = "ok";
  r.operator_name = "anna\tbert";
  id = store().insert_run(r);
  ASSERT_FALSE(id.ok());
  EXPECT_NE(id.error().message.find("operator has a control character at character 5"), std::string::npos)
      << id.error().message;
  EXPECT_EQ(RawDb(db_in(dir_)).counts().runs, 1);

  // Characters, not bytes: 64 two-byte letters are 64 characters.
  std::string umlauts;
  for (int i = 0; i < 64; ++i) umlauts += "\u00fc";
  EXPECT_TRUE(check_run_identity("--serial", umlauts).ok());
  EXPECT_FALSE(check_run_identity("--serial", umlauts + "u").ok());
  Status bad = check_run_identity("--serial", std::string("A\xff"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("--serial is not valid UTF-8 at byte 2"), std::string::npos)
      << bad.error().message;
  EXPECT_FALSE(check_run_identity("--operator", "anna\x7f").ok()) << "DEL is a control character";
  EXPECT_FALSE(check_run_identity("--operator", "anna\u0085").ok()) << "so is NEL";
  EXPECT_TRUE(check_run_identity("--operator", "").ok()) << "empty: not given";
}

TEST_F(RunStoreTest, ListKeepsToTheLimit) {
  for (int hour = 10; hour < 15; ++hour) {
    insert_ok(store(), make_record("a", "2026-11-22T" + std::to_string(hour) + ":00:00Z"));
  }
  Result<std::vector<RunSummary>> runs = store().list_runs([&] {
    RunQuery q;
    q.limit = 2;
    q.part = "";
    return q;
  }());
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_EQ((*runs)[0].started_utc, "2026-11-22T14:00:00Z");
  EXPECT_EQ((*runs)[1].started_utc, "2026-11-22T13:00:00Z");
}

TEST_F(RunStoreTest, ListRefusesALimitBelowOne) {
  Result<std::vector<RunSummary>> runs = store().list_runs([&] {
    RunQuery q;
    q.limit = 0;
    q.part = "";
    return q;
  }());
  ASSERT_FALSE(runs.ok());
  EXPECT_EQ(runs.error().code, ErrorCode::kInvalidInput);
}

TEST_F(RunStoreTest, RecordNcFileMarksTheRunPushed) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  const std::int64_t other = insert_ok(store(), make_record("a", "2026-11-22T02:40:00Z"));

  Status s = store().record_nc_file(id, "/nc/CAM_L2.MPF");
  ASSERT_TRUE(s.ok()) << s.error().message;

  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->summary.status, "pushed");
  EXPECT_EQ(loaded->summary.nc_file, "/nc/CAM_L2.MPF");

  Result<std::vector<RunSummary>> runs = store().list_runs({});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_EQ((*runs)[0].id, other);
  EXPECT_EQ((*runs)[0].status, "measured");
  EXPECT_EQ((*runs)[0].nc_file, "");
  EXPECT_EQ((*runs)[1].status, "pushed");
  EXPECT_EQ((*runs)[1].nc_file, "/nc/CAM_L2.MPF");
}

TEST_F(RunStoreTest, TableInForceIsTheLastPushedRunOfThatMachinePartAndLobe) {
  auto none = store().last_pushed_run("grinder-1", "a", 2);
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->has_value()) << "nothing pushed yet";

  const std::int64_t pushed = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  ASSERT_TRUE(store().record_nc_file(pushed, "/nc/A.SPF").ok());
  insert_ok(store(), make_record("a", "2026-11-22T02:40:00Z"));  // newer, but never pushed
  RunRecord other_lobe = make_record("a", "2026-11-22T02:50:00Z");
  other_lobe.lobe = 3;
  ASSERT_TRUE(store().record_nc_file(insert_ok(store(), other_lobe), "/nc/A3.SPF").ok());
  RunRecord other_machine = make_record("a", "2026-11-22T02:55:00Z");
  other_machine.machine = "grinder-2";
  ASSERT_TRUE(store().record_nc_file(insert_ok(store(), other_machine), "/nc/A.SPF").ok());

  auto in_force = store().last_pushed_run("grinder-1", "a", 2);
  ASSERT_TRUE(in_force.ok()) << in_force.error().message;
  ASSERT_TRUE(in_force->has_value());
  EXPECT_EQ(**in_force, pushed);

  RunRecord next = make_record("a", "2026-11-22T03:00:00Z");
  next.correction_in_force_run = pushed;
  const std::int64_t next_id = insert_ok(store(), next);
  auto loaded = store().load_run(next_id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->correction_in_force_run, pushed);
  auto first = store().load_run(pushed);
  ASSERT_TRUE(first.ok());
  EXPECT_FALSE(first->correction_in_force_run.has_value());
}

TEST_F(RunStoreTest, CorrectionInForceMustNameAStoredRun) {
  RunRecord r = make_record("a", "2026-11-22T03:00:00Z");
  r.correction_in_force_run = 999;
  Result<std::int64_t> id = store().insert_run(r);
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(RawDb(db_in(dir_)).counts().runs, 0);
}

TEST_F(RunStoreTest, RecordNcFileOnAMissingRunIsNotFoundAndChangesNothing) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  Status s = store().record_nc_file(id + 1, "/nc/CAM_L2.MPF");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_NE(s.error().message.find("run " + std::to_string(id + 1)), std::string::npos) << s.error().message;

  RawDb raw(db_in(dir_));
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM runs WHERE status = 'pushed'"), 0);
}

TEST_F(RunStoreTest, RecordNcFileRefusesAnEmptyPath) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  Status s = store().record_nc_file(id, "");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->summary.status, "measured");
}

TEST_F(RunStoreTest, LoadOfAMissingRunIsNotFound) {
  Result<StoredRun> loaded = store().load_run(42);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kNotFound);
  EXPECT_NE(loaded.error().message.find("run 42"), std::string::npos) << loaded.error().message;
  EXPECT_NE(loaded.error().message.find(db_in(dir_).string()), std::string::npos);
}

TEST_F(RunStoreTest, MovedStoreKeepsWorking) {
  RunStore moved = std::move(*store_);
  store_.reset();
  const std::int64_t id = insert_ok(moved, make_record("a", "2026-11-22T02:34:44Z"));
  EXPECT_TRUE(moved.load_run(id).ok());
  EXPECT_EQ(moved.path(), db_in(dir_));
}

// ---- Refusals: a bad record leaves no row behind ----

class RunStoreRefusalTest : public RunStoreTest {
 protected:
  // Inserts, expects kInvalidInput mentioning every fragment, and no rows anywhere.
  void expect_refused(const RunRecord& record, std::initializer_list<std::string> fragments) {
    Result<std::int64_t> id = store().insert_run(record);
    ASSERT_FALSE(id.ok()) << "stored as run " << *id;
    EXPECT_EQ(id.error().code, ErrorCode::kInvalidInput) << id.error().message;
    for (const std::string& f : fragments) {
      EXPECT_NE(id.error().message.find(f), std::string::npos) << "'" << f << "' not in: " << id.error().message;
    }
    RawDb raw(db_in(dir_));
    const RawDb::Counts n = raw.counts();
    EXPECT_EQ(n.runs, 0);
    EXPECT_EQ(n.raw, 0);
    EXPECT_EQ(n.tables, 0);
    EXPECT_EQ(raw.query_int("SELECT count(*) FROM settings"), 0);
    // And the store is still usable afterwards.
    EXPECT_TRUE(store().insert_run(make_record("a", "2026-11-22T02:34:44Z")).ok());
  }

  RunRecord good_ = make_record("a", "2026-11-22T02:34:44Z");
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
};

TEST_F(RunStoreRefusalTest, NaNInTheProfileNamesTableColumnAndDegree) {
  good_.analysis.mean_lift_mm[17] = kNaN;
  expect_refused(good_, {"run_profile.mean_lift_mm", "cam degree 17", "NaN"});
}

TEST_F(RunStoreRefusalTest, ALiftBeyondWhatACountCanHoldIsRefused) {
  good_.analysis.design_lift_mm[42] = 250.0;  // the blob keeps +-214.7 mm
  expect_refused(good_, {"design_lift_mm", "degree 42", "250", "214.7"});
}

TEST_F(RunStoreRefusalTest, NaNHarmonicIsRefused) {
  good_.analysis.harmonic_amplitude_um[7] = kNaN;
  expect_refused(good_, {"harmonic 7", "NaN"});
}

TEST_F(RunStoreRefusalTest, RotationSenseOtherThanPlusOrMinusOneIsRefused) {
  good_.geometry->rotation_sense = 0;
  expect_refused(good_, {"rotation sense", "+1 or -1"});
}

TEST_F(RunStoreRefusalTest, NaNInTheCorrectionIsRefused) {
  good_.correction_um[359] = kNaN;
  expect_refused(good_, {"run_profile.correction_um", "cam degree 359"});
}

TEST_F(RunStoreRefusalTest, InfinityInARawRevolutionIsRefused) {
  good_.measured.revolutions[1].lift_mm[5] = std::numeric_limits<double>::infinity();
  expect_refused(good_, {"run_samples.lift_mm of revolution 1", "machine degree 5", "infinity"});
}

TEST_F(RunStoreRefusalTest, NaNInASummaryFigureIsRefused) {
  good_.analysis.rms_error_um = kNaN;
  expect_refused(good_, {"runs.rms_error_um"});
}

TEST_F(RunStoreRefusalTest, FewerThanThreeRevolutionsAreRefused) {
  good_.measured.revolutions.resize(2);
  expect_refused(good_, {"at least 3", "has 2"});
}

TEST_F(RunStoreRefusalTest, RepeatedAmplifierRevolutionIsRefused) {
  good_.measured.revolutions[2].revolution = good_.measured.revolutions[1].revolution;
  expect_refused(good_, {"revolution 2", "out of order or repeated"});
}

TEST_F(RunStoreRefusalTest, MalformedTimestampIsRefused) {
  good_.started_utc = "2026-11-22 02:34:44";
  expect_refused(good_, {"started_utc", "ISO 8601"});
}

TEST_F(RunStoreRefusalTest, FinishBeforeStartIsRefused) {
  good_.finished_utc = "2026-11-22T02:34:43Z";
  expect_refused(good_, {"finished_utc", "before"});
}

TEST_F(RunStoreRefusalTest, EmptyPartIsRefused) {
  good_.part.clear();
  expect_refused(good_, {"part name is empty"});
}

// A failure inside the transaction, after the runs row is written, rolls back the whole run.
// The fault is injected through the database itself: a trigger that aborts the last insert.
TEST_F(RunStoreTest, FailureHalfWayThroughTheInsertRollsEverythingBack) {
  RawDb raw(db_in(dir_));
  ASSERT_EQ(raw.exec("CREATE TRIGGER fail_at_200 BEFORE INSERT ON run_tables"
                     " BEGIN SELECT RAISE(ABORT, 'injected fault'); END"),
            SQLITE_OK)
      << raw.errmsg();

  Result<std::int64_t> id = store().insert_run(make_record("a", "2026-11-22T02:34:44Z"));
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kStorage);
  EXPECT_NE(id.error().message.find("injected fault"), std::string::npos) << id.error().message;
  EXPECT_NE(id.error().message.find(db_in(dir_).string()), std::string::npos);
  EXPECT_NE(id.error().message.find("store the run of part a"), std::string::npos);
  const RawDb::Counts n = raw.counts();
  EXPECT_EQ(n.runs, 0);
  EXPECT_EQ(n.raw, 0);
  EXPECT_EQ(n.tables, 0);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM settings"), 0);

  // The connection was left out of the transaction: the next insert works.
  ASSERT_EQ(raw.exec("DROP TRIGGER fail_at_200"), SQLITE_OK) << raw.errmsg();
  Result<std::int64_t> again = store().insert_run(make_record("a", "2026-11-22T02:34:44Z"));
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(raw.counts().tables, 1);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_profile"), 360);
}

TEST_F(RunStoreTest, LoadReportsAProfileDeletedByHand) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  RawDb raw(db_in(dir_));
  ASSERT_EQ(raw.exec("DELETE FROM run_tables"), SQLITE_OK);
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  EXPECT_NE(loaded.error().message.find("profile (run_tables) is missing"), std::string::npos)
      << loaded.error().message;
}

TEST_F(RunStoreTest, LoadReportsRawSamplesDeletedByHandButNeverPruned) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  RawDb raw(db_in(dir_));
  ASSERT_EQ(raw.exec("DELETE FROM run_raw"), SQLITE_OK);
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  EXPECT_NE(loaded.error().message.find("raw revolutions are missing but it was never pruned"), std::string::npos)
      << loaded.error().message;
}

// A page changed outside SQLite keeps the row's shape: a correction zeroed (as a zeroed page
// did) or raw revolutions zeroed read as numbers. The checksum stored with them finds it: the
// run is refused with a message naming it, and the full check lists it; a row stored before
// checksums (NULL) is read as it is.
TEST_F(RunStoreTest, NumbersChangedOutsideSqliteAreFoundByTheirChecksum) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  const std::int64_t other = insert_ok(store(), make_record("a", "2026-11-22T03:00:00Z"));
  ASSERT_TRUE(store().load_run(id).ok());
  {
    RawDb raw(db_in(dir_));
    ASSERT_EQ(raw.exec("UPDATE run_tables SET correction = zeroblob(1440) WHERE run_id = " + std::to_string(id)),
              SQLITE_OK);
    ASSERT_EQ(raw.exec("UPDATE run_raw SET lift = zeroblob(length(lift)) WHERE run_id = " + std::to_string(other)),
              SQLITE_OK);
  }
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  for (const char* part : {"run 1 is damaged", "do not match the checksum", "not used as the base of a correction",
                           "run_tables", "restore a backup"}) {
    EXPECT_NE(loaded.error().message.find(part), std::string::npos) << part << ": " << loaded.error().message;
  }
  Result<StoredRun> raw_loaded = store().load_run(other);
  ASSERT_FALSE(raw_loaded.ok());
  EXPECT_NE(raw_loaded.error().message.find("raw revolutions, run_raw"), std::string::npos)
      << raw_loaded.error().message;

  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->problems,
            (std::vector<std::string>{
                "run 2: its raw revolutions (run_raw) do not match the checksum stored with them (a page changed "
                "outside SQLite)",
                "run 1: its profile and correction (run_tables) do not match the checksum stored with them (a page "
                "changed outside SQLite)"}));
  Result<IntegrityReport> quick = check_database_file(db_in(dir_), IntegrityCheck::kQuick);
  ASSERT_TRUE(quick.ok());
  EXPECT_TRUE(quick->sound()) << "the quick check reads pages only";

  RawDb(db_in(dir_)).exec("UPDATE run_tables SET checksum = NULL WHERE run_id = " + std::to_string(id));
  ASSERT_TRUE(store().load_run(id).ok()) << "a row without a checksum is not checked";
}

// A settings text changed outside SQLite (a zeroed overflow page leaves NUL characters, flipped
// bytes invalid UTF-8) no longer matches the hash it is stored under: every run using it is
// refused when read, naming it, and the full check lists it.
TEST_F(RunStoreTest, ASettingsTextChangedOutsideSqliteIsFoundByItsHash) {
  RunRecord record = make_record("a", "2026-11-22T02:34:44Z");
  record.settings = "[part]\nname = \"a\"\n";
  const std::int64_t id = insert_ok(store(), record);
  ASSERT_TRUE(store().load_run(id).ok());
  RawDb(db_in(dir_)).exec("UPDATE settings SET text = CAST(CAST(text AS BLOB) || X'9A' AS TEXT)");
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  EXPECT_NE(loaded.error().message.find("its settings text does not match the hash"), std::string::npos)
      << loaded.error().message;
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->problems.size(), 1u);
  EXPECT_NE(report->problems[0].find("the text does not match the hash it is stored under"), std::string::npos)
      << report->problems[0];
}

TEST_F(RunStoreTest, TheSchemaRefusesABlobOfTheWrongLength) {
  insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  RawDb raw(db_in(dir_));
  EXPECT_EQ(raw.exec("UPDATE run_tables SET error = zeroblob(1436)"), SQLITE_CONSTRAINT);
  EXPECT_EQ(raw.exec("UPDATE run_raw SET lift = zeroblob(1440 * 2)"), SQLITE_CONSTRAINT);
}

// ---- In memory ----

TEST(RunStoreInMemory, StoresAndLoadsARun) {
  Result<RunStore> store = RunStore::open(":memory:");
  ASSERT_TRUE(store.ok()) << store.error().message;
  const RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z", 3);
  Result<std::int64_t> id = store->insert_run(record);
  ASSERT_TRUE(id.ok()) << id.error().message;
  Result<StoredRun> loaded = store->load_run(*id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  expect_same_run(*loaded, record);
}

}  // namespace
}  // namespace gaugeloop
