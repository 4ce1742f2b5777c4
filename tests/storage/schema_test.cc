// The database file as other tools see it: schema version, WAL, the run_samples view,
// concurrent readers, and what open() says when it cannot open.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <fstream>
#include <string>

#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage_test_support.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using storage_internal::latest_schema_version;
using storage_internal::migrations;
using testing::make_record;
using testing::RawDb;
using testing::run_unprivileged;
using testing::sample_lift_mm;
using testing::TempDir;

using testing::has;

TEST(Migrations, AreNumberedOneUpInOrder) {
  int expected = 1;
  for (const auto& m : migrations()) EXPECT_EQ(m.version, expected++);
  EXPECT_EQ(latest_schema_version(), expected - 1);
}

TEST(Schema, UserVersionIsTheLatestMigrationAfterOpen) {
  TempDir dir;
  ASSERT_TRUE(RunStore::open(db_in(dir)).ok());
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), latest_schema_version());
}

TEST(Schema, JournalModeIsWal) {
  TempDir dir;
  ASSERT_TRUE(RunStore::open(db_in(dir)).ok());
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_text("PRAGMA journal_mode"), "wal");
}

TEST(Schema, OpeningTwiceIsIdempotent) {
  TempDir dir;
  std::int64_t id = 0;
  {
    Result<RunStore> first = RunStore::open(db_in(dir));
    ASSERT_TRUE(first.ok()) << first.error().message;
    Result<std::int64_t> inserted = first->insert_run(make_record("a", "2026-11-22T02:34:44Z"));
    ASSERT_TRUE(inserted.ok()) << inserted.error().message;
    id = *inserted;
    // A second store while the first is still open, and another after it closed.
    Result<RunStore> second = RunStore::open(db_in(dir));
    ASSERT_TRUE(second.ok()) << second.error().message;
  }
  Result<RunStore> third = RunStore::open(db_in(dir));
  ASSERT_TRUE(third.ok()) << third.error().message;
  EXPECT_TRUE(third->load_run(id).ok());

  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), latest_schema_version());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE type = 'table'"
                          " AND name IN ('runs', 'run_raw', 'run_tables', 'parts', 'lobes', 'settings',"
                          " 'nc_pushes', 'events', 'degrees')"),
            9);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM runs"), 1);
}

TEST(Schema, HasTheIndexesForListing) {
  TempDir dir;
  ASSERT_TRUE(RunStore::open(db_in(dir)).ok());
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_text("SELECT group_concat(name, ',') FROM"
                           " (SELECT name FROM pragma_index_info('runs_by_part_lobe_started')"
                           " ORDER BY seqno)"),
            "part,lobe,started_utc");
  EXPECT_EQ(raw.query_text("SELECT name FROM pragma_index_info('runs_by_started')"), "started_utc");
}

TEST(Schema, RefusesADatabaseFromANewerGaugeloop) {
  TempDir dir;
  ASSERT_TRUE(RunStore::open(db_in(dir)).ok());
  {
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.exec("PRAGMA user_version = 99"), SQLITE_OK);
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(store.error().message, "schema version 99")) << store.error().message;
  EXPECT_TRUE(has(store.error().message, db_in(dir).string()));
}

TEST(Schema, ProfileColumnsRefuseNull) {
  // The backstop behind insert_run's validation.
  TempDir dir;
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  ASSERT_TRUE(store->insert_run(make_record("a", "2026-11-22T02:34:44Z")).ok());
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.exec("UPDATE run_tables SET error = NULL"), SQLITE_CONSTRAINT);
  EXPECT_EQ(raw.exec("UPDATE runs SET status = 'pushed'"), SQLITE_CONSTRAINT) << "a pushed run must name its NC file";
}

TEST(Schema, RunSamplesViewHasOneRowPerDegreeOfEachRevolution) {
  TempDir dir;
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  constexpr int kRevolutions = 4;
  Result<std::int64_t> id = store->insert_run(make_record("a", "2026-11-22T02:34:44Z", kRevolutions));
  ASSERT_TRUE(id.ok()) << id.error().message;
  // A second run, so the view's rows are seen to belong to the right run.
  ASSERT_TRUE(store->insert_run(make_record("b", "2026-11-22T03:00:00Z", 3)).ok());

  RawDb raw(db_in(dir));
  const std::string run = std::to_string(*id);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_samples WHERE run_id = " + run), 360 * kRevolutions);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_samples"), 360 * (kRevolutions + 3));
  EXPECT_EQ(raw.query_int("SELECT count(DISTINCT angle_deg) FROM run_samples WHERE run_id = " + run), 360);
  EXPECT_EQ(raw.query_int("SELECT max(angle_deg) FROM run_samples"), 359);
  for (const auto& [rev, deg] : {std::pair{0, 0}, std::pair{2, 123}, std::pair{3, 359}}) {
    const double lift =
        raw.query_double("SELECT lift_mm FROM run_samples WHERE run_id = " + run +
                         " AND revolution_index = " + std::to_string(rev) + " AND angle_deg = " + std::to_string(deg));
    EXPECT_NEAR(lift, sample_lift_mm(rev, deg), 0.5e-6 + 1e-12) << rev << "/" << deg;
  }
}

TEST(Schema, RawLiftsAreBigEndianCountsOfATenthOfANanometre) {
  TempDir dir;
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  ASSERT_TRUE(store->insert_run(make_record("a", "2026-11-22T02:34:44Z")).ok());
  RawDb raw(db_in(dir));
  // sample_lift_mm(0, 0) = 1.5 mm exactly = 15,000,000 counts = 0x00E4E1C0.
  EXPECT_EQ(raw.query_text("SELECT hex(substr(lift, 1, 4)) FROM run_raw"), "00E4E1C0");
  EXPECT_EQ(raw.query_int("SELECT length(lift) FROM run_raw"), 3 * 1440);
  EXPECT_EQ(raw.query_text("SELECT amplifier_revolutions FROM run_raw"), "[100,101,102]");
}

// The views decode in SQL what C++ encoded, negative values and the extremes included: a
// person with sqlite3 reads the same numbers gaugeloop does.
TEST(Schema, ViewsDecodeNegativeAndExtremeValuesAsTheStoreDoes) {
  TempDir dir;
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  RunRecord r = make_record("a", "2026-11-22T02:34:44Z");
  r.measured.revolutions[1].lift_mm[7] = -214.7483647;   // INT32_MIN + 1 counts
  r.measured.revolutions[2].lift_mm[359] = 214.7483647;  // INT32_MAX counts
  r.analysis.error_um[10] = -0.0001;                     // -1 count
  r.analysis.error_um[11] = -123456.7891;
  r.correction_um[12] = 0.0;
  Result<std::int64_t> id = store->insert_run(r);
  ASSERT_TRUE(id.ok()) << id.error().message;
  Result<StoredRun> loaded = store->load_run(*id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;

  RawDb raw(db_in(dir));
  const std::string run = std::to_string(*id);
  auto sample = [&](int rev, int deg) {
    return raw.query_double("SELECT lift_mm FROM run_samples WHERE run_id = " + run + " AND revolution_index = " +
                            std::to_string(rev) + " AND angle_deg = " + std::to_string(deg));
  };
  EXPECT_DOUBLE_EQ(sample(1, 7), -214.7483647);
  EXPECT_DOUBLE_EQ(sample(2, 359), 214.7483647);
  for (int rev = 0; rev < 3; ++rev) {
    for (int deg = 0; deg < 360; deg += 17) {
      const auto ri = static_cast<std::size_t>(rev);
      const auto d = static_cast<std::size_t>(deg);
      EXPECT_DOUBLE_EQ(sample(rev, deg), loaded->revolutions[ri].lift_mm[d]) << rev << "/" << deg;
    }
  }
  auto profile = [&](const std::string& column, int deg) {
    return raw.query_double("SELECT " + column + " FROM run_profile WHERE run_id = " + run +
                            " AND angle_deg = " + std::to_string(deg));
  };
  EXPECT_DOUBLE_EQ(profile("error_um", 10), -0.0001);
  EXPECT_DOUBLE_EQ(profile("error_um", 11), -123456.7891);
  for (int deg = 0; deg < 360; deg += 7) {
    const auto d = static_cast<std::size_t>(deg);
    EXPECT_DOUBLE_EQ(profile("design_lift_mm", deg), loaded->analysis.design_lift_mm[d]) << deg;
    EXPECT_DOUBLE_EQ(profile("mean_lift_mm", deg), loaded->analysis.mean_lift_mm[d]) << deg;
    EXPECT_DOUBLE_EQ(profile("spread_um", deg), loaded->analysis.spread_um[d]) << deg;
    EXPECT_DOUBLE_EQ(profile("error_um", deg), loaded->analysis.error_um[d]) << deg;
    EXPECT_DOUBLE_EQ(profile("correction_um", deg), loaded->correction_um[d]) << deg;
  }
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_profile WHERE run_id = " + run), 360);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_harmonics WHERE run_id = " + run), 31);
  EXPECT_DOUBLE_EQ(raw.query_double("SELECT amplitude_um FROM run_harmonics WHERE harmonic = 3"),
                   r.analysis.harmonic_amplitude_um[3]);
}

TEST(Schema, TheCatalogueHoldsEveryPartAndLobeWithTheLatestGeometry) {
  TempDir dir;
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  RunRecord first = make_record("a", "2026-11-22T02:34:44Z");
  ASSERT_TRUE(store->insert_run(first).ok());
  RunRecord second = make_record("a", "2026-11-22T03:00:00Z");
  second.geometry->c_offset_deg = 13.0;  // re-clamped
  ASSERT_TRUE(store->insert_run(second).ok());
  RunRecord unknown = make_record("b", "2026-11-22T03:10:00Z");
  unknown.geometry.reset();
  ASSERT_TRUE(store->insert_run(unknown).ok());

  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM parts"), 2);
  EXPECT_EQ(raw.query_text("SELECT follower FROM parts WHERE name = 'a'"), "roller");
  EXPECT_EQ(raw.query_text("SELECT coalesce(follower, 'unknown') FROM parts WHERE name = 'b'"), "unknown");
  EXPECT_EQ(raw.query_double("SELECT c_offset_deg FROM lobes WHERE part = 'a' AND lobe = 2"), 13.0);
  // Each run keeps the mapping it was measured with.
  EXPECT_EQ(raw.query_double("SELECT c_offset_deg FROM runs WHERE started_utc = '2026-11-22T02:34:44Z'"), 12.5);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM settings"), 1) << "two runs with the same settings share one row";
}

// WAL: a reader on another connection is not blocked by a writer holding the write lock.
// Deterministic: the lock is held by a raw connection for the whole test, no threads.
TEST(Concurrency, ReaderOpensListsAndLoadsWhileAnotherConnectionHoldsTheWriteLock) {
  TempDir dir;
  Result<RunStore> writer = RunStore::open(db_in(dir));
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  const RunRecord record = make_record("a", "2026-11-22T02:34:44Z");
  Result<std::int64_t> id = writer->insert_run(record);
  ASSERT_TRUE(id.ok()) << id.error().message;

  RawDb locker(db_in(dir));
  ASSERT_EQ(locker.exec("BEGIN IMMEDIATE"), SQLITE_OK) << locker.errmsg();
  ASSERT_EQ(locker.exec("UPDATE runs SET note = 'uncommitted'"), SQLITE_OK) << locker.errmsg();

  Result<RunStore> reader = RunStore::open(db_in(dir));
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  Result<std::vector<RunSummary>> runs = reader->list_runs({});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  Result<StoredRun> loaded = reader->load_run(*id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->note, record.note) << "saw another connection's uncommitted write";
  EXPECT_TRUE(writer->list_runs({}).ok());

  ASSERT_EQ(locker.exec("COMMIT"), SQLITE_OK) << locker.errmsg();
  loaded = reader->load_run(*id);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(loaded->note, "uncommitted");
}

// ---- open() failures ----

TEST(OpenFailure, ParentThatIsAFileIsAClearIoError) {
  TempDir dir;
  const std::filesystem::path blocker = dir.path() / "not-a-dir";
  std::ofstream(blocker) << "x";
  const std::filesystem::path db = blocker / "runs" / "runs.sqlite";
  Result<RunStore> store = RunStore::open(db);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kIo);
  EXPECT_TRUE(has(store.error().message, db.string())) << store.error().message;
  EXPECT_TRUE(has(store.error().message, "--data-dir is writable")) << store.error().message;
}

TEST(OpenFailure, PathThatIsADirectoryIsAClearStorageError) {
  TempDir dir;
  Result<RunStore> store = RunStore::open(dir.path());
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_EQ(store.error().message, "cannot open run database " + dir.path().string() +
                                       ": unable to open database file;"
                                       " check the --data-dir is writable");
}

TEST(OpenFailure, UnwritableDirectoryIsAClearStorageError) {
  TempDir dir;
  dir.share();
  const std::filesystem::path ro = dir.path() / "ro";
  std::filesystem::create_directory(ro);
  std::filesystem::permissions(ro, std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec |
                                       std::filesystem::perms::others_read | std::filesystem::perms::others_exec);
  const std::string failure = run_unprivileged([&]() -> std::string {
    Result<RunStore> store = RunStore::open(ro / "runs.sqlite");
    if (store.ok()) return "opened a database in a read-only directory";
    if (store.error().code != ErrorCode::kStorage) return "wrong code: " + store.error().message;
    if (!has(store.error().message, "cannot open run database " + (ro / "runs.sqlite").string()) ||
        !has(store.error().message, "writable")) {
      return "unclear message: " + store.error().message;
    }
    return "";
  });
  EXPECT_EQ(failure, "");
}

TEST(OpenFailure, ReadOnlyFileIsRefusedAtOpenNotAtTheFirstInsert) {
  TempDir dir;
  dir.share();
  ASSERT_TRUE(RunStore::open(db_in(dir)).ok());
  std::filesystem::permissions(db_in(dir).parent_path(),
                               std::filesystem::perms::all);  // the directory is not the point
  std::filesystem::permissions(db_in(dir), std::filesystem::perms::owner_read | std::filesystem::perms::others_read);
  const std::string failure = run_unprivileged([&]() -> std::string {
    Result<RunStore> store = RunStore::open(db_in(dir));
    if (store.ok()) return "opened a read-only database for writing";
    if (store.error().code != ErrorCode::kStorage) return "wrong code: " + store.error().message;
    if (!has(store.error().message, "read-only")) return "unclear message: " + store.error().message;
    return "";
  });
  EXPECT_EQ(failure, "");
}

TEST(OpenFailure, AFileThatIsNotADatabaseSaysSo) {
  TempDir dir;
  std::filesystem::create_directories(db_in(dir).parent_path());
  std::ofstream(db_in(dir)) << std::string(4096, 'x');
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(store.error().message, "not a database")) << store.error().message;
  EXPECT_TRUE(has(store.error().message, db_in(dir).string())) << store.error().message;
}

TEST(OpenFailure, EmptyPathIsInvalidInput) {
  Result<RunStore> store = RunStore::open("");
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kInvalidInput);
}

}  // namespace
}  // namespace gaugeloop
