// Integrity checks and online backups of the run database, and the backup made before a
// schema upgrade: on real files, damaged as a failing disk would damage them.
#include "storage/db_maintenance.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"
#include "storage_test_support.h"
#include "tests/support/cli.h"
#include "tests/support/damaged_database.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::make_record;
using testing::RawDb;
using testing::TempDir;

using testing::has;

// The files in `dir` whose names start with `prefix`.
std::vector<std::string> files_starting(const fs::path& dir, const std::string& prefix) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename();
    if (name.starts_with(prefix)) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

class DbMaintenance : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> store = RunStore::open(db_in(dir_));
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (const char* started : {"2026-11-20T08:00:00Z", "2026-11-21T08:00:00Z", "2026-11-22T08:00:00Z"}) {
      Result<std::int64_t> id = store->insert_run(make_record("intake", started));
      ASSERT_TRUE(id.ok()) << id.error().message;
    }
  }

  // Damages the closed database and makes sure SQLite itself sees the damage.
  void damage() {
    ASSERT_TRUE(testing::damage_runs_table(db_in(dir_)));
    ASSERT_NE(testing::sqlite_text(db_in(dir_), "PRAGMA integrity_check"), "ok") << "the damage did not show";
  }

  TempDir dir_;
};

TEST_F(DbMaintenance, ASoundDatabasePassesEveryCheck) {
  Result<RunStore> store = RunStore::open(db_in(dir_));
  ASSERT_TRUE(store.ok());
  Status quick = store->check_integrity(IntegrityCheck::kQuick);
  EXPECT_TRUE(quick.ok()) << quick.error().message;
  Status full = store->check_integrity(IntegrityCheck::kFull);
  EXPECT_TRUE(full.ok()) << full.error().message;
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_TRUE(report->sound()) << report->problems.front();
}

TEST_F(DbMaintenance, FlippedBytesInTheRunsTableAreFoundByEveryCheck) {
  damage();
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_FALSE(report->sound());
  EXPECT_TRUE(report->constraints_checked);

  Result<RunStore> store = RunStore::open(db_in(dir_));
  ASSERT_TRUE(store.ok()) << "the damage leaves the file readable, which is why it must be checked: "
                          << store.error().message;
  for (IntegrityCheck depth : {IntegrityCheck::kQuick, IntegrityCheck::kFull}) {
    Status s = store->check_integrity(depth);
    ASSERT_FALSE(s.ok()) << "a damaged database passed the check";
    EXPECT_EQ(s.error().code, ErrorCode::kStorage);
    EXPECT_TRUE(has(s.error().message, "database " + db_in(dir_).string() + " is damaged: ")) << s.error().message;
    EXPECT_TRUE(has(s.error().message, report->problems.front())) << s.error().message;
    EXPECT_TRUE(has(s.error().message, "restore the last sound backup") ||
                has(s.error().message, "put the last sound backup in its place"))
        << s.error().message;
  }
}

// A cancelled check gives no verdict: not "sound", not a short list of problems. Cancelled
// before it starts, it returns at once; cancelled from another thread while it runs, it either
// ends cancelled or (had it finished first) gives the whole verdict an uncancelled check gives.
TEST_F(DbMaintenance, ACancelledCheckGivesNoVerdict) {
  damage();
  CheckCancel before;
  before.cancel();
  Result<IntegrityReport> cancelled = check_database_file(db_in(dir_), IntegrityCheck::kFull, before);
  ASSERT_FALSE(cancelled.ok()) << "a cancelled check gave a verdict";
  EXPECT_EQ(cancelled.error().code, ErrorCode::kRefused);
  EXPECT_TRUE(has(cancelled.error().message, "cancelled")) << cancelled.error().message;

  Result<IntegrityReport> whole = check_database_file(db_in(dir_));
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  ASSERT_FALSE(whole->sound());
  CheckCancel during;
  std::thread stopper([&during] { during.cancel(); });
  Result<IntegrityReport> raced = check_database_file(db_in(dir_), IntegrityCheck::kFull, during);
  stopper.join();
  if (raced.ok()) {
    EXPECT_EQ(raced->problems, whole->problems);
  } else {
    EXPECT_EQ(raced.error().code, ErrorCode::kRefused) << raced.error().message;
  }
}

// SQLite loads no CHECK constraints on a read-only connection: the report must say so.
TEST_F(DbMaintenance, ACheckWithoutWriteAccessSaysTheConstraintsWentUnverified) {
  damage();
  fs::permissions(db_in(dir_), fs::perms::owner_read | fs::perms::others_read);
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_FALSE(report->constraints_checked);
}

TEST_F(DbMaintenance, AFileThatIsNotADatabaseIsReportedNotFailed) {
  const fs::path junk = dir_.path() / "junk.sqlite";
  std::ofstream(junk) << std::string(8192, 'x');
  Result<IntegrityReport> report = check_database_file(junk);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_FALSE(report->sound());
  EXPECT_TRUE(has(report->problems.front(), "not a database")) << report->problems.front();
}

TEST_F(DbMaintenance, ARowPointingAtAMissingRunIsAProblem) {
  {
    RawDb raw(db_in(dir_));
    ASSERT_EQ(raw.exec("PRAGMA foreign_keys = OFF"), SQLITE_OK);
    ASSERT_EQ(raw.exec("INSERT INTO events (id, at_utc, kind, code, message, run_id) VALUES "
                       "(41, '2026-11-22T09:00:00Z', 'fault', 'gauge timeout', 'no reply', 999)"),
              SQLITE_OK);
  }
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->problems.size(), 1u);
  EXPECT_EQ(report->problems.front(), "events row 41: refers to a missing runs row");
}

TEST_F(DbMaintenance, ABackupLoadsTheSameRuns) {
  const fs::path copy = dir_.path() / "copy.sqlite";
  Status s = backup_database_file(db_in(dir_), copy, false);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(files_starting(dir_.path(), "copy"), std::vector<std::string>{"copy.sqlite"}) << "no temporary left";

  Result<RunStore> original = RunStore::open_read_only(db_in(dir_));
  Result<RunStore> backup = RunStore::open_read_only(copy);
  ASSERT_TRUE(original.ok() && backup.ok());
  Result<std::vector<RunSummary>> a = original->list_runs(RunQuery{});
  Result<std::vector<RunSummary>> b = backup->list_runs(RunQuery{});
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(b->size(), 3u);
  for (std::size_t i = 0; i < a->size(); ++i) {
    Result<StoredRun> ra = original->load_run((*a)[i].id);
    Result<StoredRun> rb = backup->load_run((*b)[i].id);
    ASSERT_TRUE(ra.ok() && rb.ok());
    EXPECT_EQ(rb->summary.started_utc, ra->summary.started_utc);
    EXPECT_EQ(rb->correction_um, ra->correction_um);
    EXPECT_EQ(rb->revolutions.size(), ra->revolutions.size());
  }
  EXPECT_EQ(testing::sqlite_text(copy, "PRAGMA integrity_check"), "ok");
}

// The copy is one snapshot of what was committed, taken while a writer holds the lock.
TEST_F(DbMaintenance, ABackupWhileAnotherConnectionWritesHoldsTheCommittedRunsOnly) {
  RawDb writer(db_in(dir_));
  ASSERT_EQ(writer.exec("BEGIN IMMEDIATE"), SQLITE_OK);
  ASSERT_EQ(writer.exec("DELETE FROM runs WHERE id = 1"), SQLITE_OK);
  const fs::path copy = dir_.path() / "copy.sqlite";
  Status s = backup_database_file(db_in(dir_), copy, false);
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_EQ(writer.exec("ROLLBACK"), SQLITE_OK);
  EXPECT_EQ(testing::sqlite_text(copy, "SELECT count(*) FROM runs"), "3");
}

TEST_F(DbMaintenance, ABackupNeverReplacesAFileUnlessTold) {
  const fs::path copy = dir_.path() / "copy.sqlite";
  std::ofstream(copy) << "last week's backup";
  Status s = backup_database_file(db_in(dir_), copy, false);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(has(s.error().message, copy.string() + " exists already")) << s.error().message;
  EXPECT_TRUE(has(s.error().message, "--force")) << s.error().message;
  EXPECT_EQ(testing::slurp(copy), "last week's backup");
  EXPECT_EQ(files_starting(dir_.path(), "copy"), std::vector<std::string>{"copy.sqlite"});

  s = backup_database_file(db_in(dir_), copy, true);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(testing::sqlite_text(copy, "SELECT count(*) FROM runs"), "3");
}

TEST_F(DbMaintenance, ABackupOntoTheDatabaseItselfIsRefused) {
  Status s = backup_database_file(db_in(dir_), db_in(dir_), true);
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.error().message, "is the database itself")) << s.error().message;
  EXPECT_EQ(testing::sqlite_text(db_in(dir_), "SELECT count(*) FROM runs"), "3");
}

TEST_F(DbMaintenance, ABackupOfADamagedDatabaseLeavesNothingBehind) {
  damage();
  const fs::path copy = dir_.path() / "copy.sqlite";
  Status s = backup_database_file(db_in(dir_), copy, false);
  ASSERT_FALSE(s.ok()) << "a damaged database was backed up as if sound";
  EXPECT_EQ(s.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(s.error().message, "not written, the copy is not sound")) << s.error().message;
  EXPECT_EQ(files_starting(dir_.path(), "copy"), std::vector<std::string>{});
}

// ---- the backup before a schema upgrade ----

// A version-3 database made with the version-3 migrations, holding one event if `with_event`.
void make_v3_database(const fs::path& db, bool with_event = true) {
  fs::create_directories(db.parent_path());
  storage_internal::Connection conn;
  conn.path = db;
  ASSERT_EQ(sqlite3_open(db.c_str(), &conn.db), SQLITE_OK);
  ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 3).ok());
  if (!with_event) return;
  ASSERT_EQ(sqlite3_exec(conn.db,
                         "INSERT INTO events (id, at_utc, kind, code, message) VALUES "
                         "(7, '2026-11-22T02:00:00Z', 'fault', 'gauge timeout', 'no reply')",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
}

TEST(SchemaUpgradeBackup, AnOlderFileIsCopiedBeforeItIsUpgraded) {
  TempDir dir;
  make_v3_database(db_in(dir));
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  const std::optional<SchemaUpgrade> upgrade = store->schema_upgrade();
  ASSERT_TRUE(upgrade.has_value()) << "upgraded without a backup";
  EXPECT_EQ(upgrade->from_version, 3);
  const std::string name = upgrade->backup.filename();
  EXPECT_TRUE(name.starts_with(db_in(dir).filename().string() + ".schema3-backup-")) << name;
  EXPECT_EQ(upgrade->backup.parent_path(), db_in(dir).parent_path());

  EXPECT_EQ(testing::sqlite_text(upgrade->backup, "PRAGMA user_version"), "3") << "the file as it was";
  EXPECT_EQ(testing::sqlite_text(upgrade->backup, "SELECT code FROM events WHERE id = 7"), "gauge timeout");
  EXPECT_EQ(testing::sqlite_text(upgrade->backup, "PRAGMA integrity_check"), "ok");
  EXPECT_EQ(RawDb(db_in(dir)).query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
}

TEST(SchemaUpgradeBackup, ANewOrCurrentDatabaseIsNotCopied) {
  TempDir dir;
  Result<RunStore> fresh = RunStore::open(db_in(dir));
  ASSERT_TRUE(fresh.ok());
  EXPECT_FALSE(fresh->schema_upgrade().has_value());
  Result<RunStore> again = RunStore::open(db_in(dir));
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->schema_upgrade().has_value());
  EXPECT_EQ(files_starting(db_in(dir).parent_path(), db_in(dir).filename().string() + ".schema").size(), 0u);
}

// A file killed while its schema was being created holds no record: nothing to keep.
TEST(SchemaUpgradeBackup, AnOlderFileWithoutRunsOrEventsIsUpgradedWithoutACopy) {
  TempDir dir;
  make_v3_database(db_in(dir), /*with_event=*/false);
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_FALSE(store->schema_upgrade().has_value());
  EXPECT_EQ(files_starting(db_in(dir).parent_path(), db_in(dir).filename().string() + ".schema").size(), 0u);
  EXPECT_EQ(RawDb(db_in(dir)).query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
}

}  // namespace
}  // namespace gaugeloop
