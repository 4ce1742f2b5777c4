// RunStore against real SQLite: round trips, listing, pushes, refusals and what they leave.
#include "storage/run_store.h"

#include <gtest/gtest.h>

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

// Raw lifts are stored as JSON with 6 decimals, so they come back to half of 1e-6 mm.
constexpr double kJsonToleranceMm = 0.5e-6 + 1e-12;

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
      ASSERT_NEAR(got.revolutions[i].lift_mm[d], want.measured.revolutions[i].lift_mm[d], kJsonToleranceMm)
          << "revolution " << i << " degree " << d;
    }
  }
  // Profile and figures are SQLite REALs: the very same doubles.
  EXPECT_EQ(got.analysis.design_lift_mm, want.analysis.design_lift_mm);
  EXPECT_EQ(got.analysis.mean_lift_mm, want.analysis.mean_lift_mm);
  EXPECT_EQ(got.analysis.spread_um, want.analysis.spread_um);
  EXPECT_EQ(got.analysis.error_um, want.analysis.error_um);
  EXPECT_EQ(got.correction_um, want.correction_um);
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

class RunStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> opened = RunStore::open(dir_.db());
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    store_.emplace(std::move(opened).value());
  }

  RunStore& store() { return *store_; }

  TempDir dir_;
  std::optional<RunStore> store_;
};

TEST_F(RunStoreTest, OpenCreatesParentDirectoriesAndFile) {
  EXPECT_TRUE(std::filesystem::is_regular_file(dir_.db()));
  EXPECT_EQ(store().path(), dir_.db());
}

TEST_F(RunStoreTest, InsertThenLoadReturnsTheSameRunToJsonPrecision) {
  const RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z", 4);
  const std::int64_t id = insert_ok(store(), record);

  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->summary.id, id);
  expect_same_run(*loaded, record);
}

TEST_F(RunStoreTest, ReopeningTheFileKeepsTheRun) {
  const RunRecord record = make_record("intake-flat", "2026-11-22T02:34:44Z");
  const std::int64_t id = insert_ok(store(), record);
  store_.reset();

  Result<RunStore> reopened = RunStore::open(dir_.db());
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

  Result<std::vector<RunSummary>> runs = store().list_runs({.limit = 50, .part = "exhaust"});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].id, exhaust);
  EXPECT_EQ((*runs)[0].part, "exhaust");

  runs = store().list_runs({.limit = 50, .part = "no-such-part"});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  EXPECT_TRUE(runs->empty());
}

TEST_F(RunStoreTest, ListKeepsToTheLimit) {
  for (int hour = 10; hour < 15; ++hour) {
    insert_ok(store(), make_record("a", "2026-11-22T" + std::to_string(hour) + ":00:00Z"));
  }
  Result<std::vector<RunSummary>> runs = store().list_runs({.limit = 2, .part = ""});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_EQ((*runs)[0].started_utc, "2026-11-22T14:00:00Z");
  EXPECT_EQ((*runs)[1].started_utc, "2026-11-22T13:00:00Z");
}

TEST_F(RunStoreTest, ListRefusesALimitBelowOne) {
  Result<std::vector<RunSummary>> runs = store().list_runs({.limit = 0, .part = ""});
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

TEST_F(RunStoreTest, TableInForceIsTheNewestPushedRunOfThatMachinePartAndLobe) {
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
  EXPECT_EQ(RawDb(dir_.db()).counts().runs, 0);
}

TEST_F(RunStoreTest, RecordNcFileOnAMissingRunIsNotFoundAndChangesNothing) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  Status s = store().record_nc_file(id + 1, "/nc/CAM_L2.MPF");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_NE(s.error().message.find("run " + std::to_string(id + 1)), std::string::npos) << s.error().message;

  RawDb raw(dir_.db());
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
  EXPECT_NE(loaded.error().message.find(dir_.db().string()), std::string::npos);
}

TEST_F(RunStoreTest, MovedStoreKeepsWorking) {
  RunStore moved = std::move(*store_);
  store_.reset();
  const std::int64_t id = insert_ok(moved, make_record("a", "2026-11-22T02:34:44Z"));
  EXPECT_TRUE(moved.load_run(id).ok());
  EXPECT_EQ(moved.path(), dir_.db());
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
    RawDb raw(dir_.db());
    const RawDb::Counts n = raw.counts();
    EXPECT_EQ(n.runs, 0);
    EXPECT_EQ(n.revolutions, 0);
    EXPECT_EQ(n.profile, 0);
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

TEST_F(RunStoreRefusalTest, NaNInTheCorrectionIsRefused) {
  good_.correction_um[359] = kNaN;
  expect_refused(good_, {"run_profile.correction_um", "cam degree 359"});
}

TEST_F(RunStoreRefusalTest, InfinityInARawRevolutionIsRefused) {
  good_.measured.revolutions[1].lift_mm[5] = std::numeric_limits<double>::infinity();
  expect_refused(good_, {"run_revolutions.lift_mm of revolution 1", "machine degree 5", "infinity"});
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
// The fault is injected through the database itself: a trigger that aborts one profile row.
TEST_F(RunStoreTest, FailureHalfWayThroughTheInsertRollsEverythingBack) {
  RawDb raw(dir_.db());
  ASSERT_EQ(raw.exec("CREATE TRIGGER fail_at_200 BEFORE INSERT ON run_profile"
                     " WHEN NEW.angle_deg = 200 BEGIN SELECT RAISE(ABORT, 'injected fault'); END"),
            SQLITE_OK)
      << raw.errmsg();

  Result<std::int64_t> id = store().insert_run(make_record("a", "2026-11-22T02:34:44Z"));
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kStorage);
  EXPECT_NE(id.error().message.find("injected fault"), std::string::npos) << id.error().message;
  EXPECT_NE(id.error().message.find(dir_.db().string()), std::string::npos);
  EXPECT_NE(id.error().message.find("store the run of part a"), std::string::npos);
  const RawDb::Counts n = raw.counts();
  EXPECT_EQ(n.runs, 0);
  EXPECT_EQ(n.revolutions, 0);
  EXPECT_EQ(n.profile, 0);

  // The connection was left out of the transaction: the next insert works.
  ASSERT_EQ(raw.exec("DROP TRIGGER fail_at_200"), SQLITE_OK) << raw.errmsg();
  Result<std::int64_t> again = store().insert_run(make_record("a", "2026-11-22T02:34:44Z"));
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(raw.counts().profile, 360);
}

TEST_F(RunStoreTest, LoadReportsAProfileRowDeletedByHand) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  RawDb raw(dir_.db());
  ASSERT_EQ(raw.exec("DELETE FROM run_profile WHERE angle_deg = 90"), SQLITE_OK);
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  EXPECT_NE(loaded.error().message.find("cam degree 90 is missing"), std::string::npos) << loaded.error().message;
}

TEST_F(RunStoreTest, LoadReportsRawLiftsThatAreNotNumbers) {
  const std::int64_t id = insert_ok(store(), make_record("a", "2026-11-22T02:34:44Z"));
  RawDb raw(dir_.db());
  // Still passes the table's CHECK (valid JSON, 360 elements), but holds strings.
  ASSERT_EQ(raw.exec("UPDATE run_revolutions SET lift_mm = (SELECT json_group_array('x')"
                     " FROM run_profile WHERE run_id = " +
                     std::to_string(id) + ") WHERE revolution_index = 1"),
            SQLITE_OK)
      << raw.errmsg();
  Result<StoredRun> loaded = store().load_run(id);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  EXPECT_NE(loaded.error().message.find("lift_mm of revolution 1"), std::string::npos) << loaded.error().message;
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
