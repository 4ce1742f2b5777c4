// The database commands and read-only reading as a user runs them: the real binary on a
// database filled through RunStore, made read-only, damaged, or left at an older schema.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/number_text.h"
#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"
#include "tests/support/cli.h"
#include "tests/support/damaged_database.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::run_command;
using testing::run_shell;

using testing::has;

class DbCommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    db_ = dir_ / "data" / "gaugeloop.sqlite";
    Result<RunStore> store = RunStore::open(db_);
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (const char* started : {"2020-11-20T08:00:00Z", "2020-11-21T08:00:00Z"}) {
      Result<std::int64_t> id = store->insert_run(testing::sample_run("intake", 1, "g1", started, 12.0));
      ASSERT_TRUE(id.ok()) << id.error().message;
      ids_.push_back(*id);
    }
    ASSERT_TRUE(store->record_nc_file(ids_[0], (dir_ / "nc" / "CAM_INTAKE_L1.SPF").string()).ok());
    ASSERT_TRUE(store->record_event(testing::sample_refusal_event()).ok());
    data_ = " --data-dir " + db_.parent_path().string();
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(db_, fs::perms::owner_all, fs::perm_options::add, ec);
  }

  // The run ids `runs list --json` prints for the database in `data_dir`.
  std::vector<std::int64_t> listed(const fs::path& data_dir) {
    CommandResult r = run_command("runs list --json --data-dir " + data_dir.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::vector<std::int64_t> ids;
    const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
    if (j.is_array()) {
      for (const auto& run : j) ids.push_back(run["id"].get<std::int64_t>());
    }
    return ids;
  }

  testing::TempDir tmp_;  // before everything that lives in it
  fs::path dir_;
  fs::path db_;
  std::string data_;
  std::vector<std::int64_t> ids_;
};

TEST_F(DbCommandsTest, EveryQueryReadsAFileWithoutWritePermissionAndLeavesItAsItWas) {
  fs::permissions(db_, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  const std::string before = testing::slurp(db_);
  struct stat st {};
  ASSERT_EQ(::stat(db_.c_str(), &st), 0);
  const timespec mtime = st.st_mtim;
  const std::string run = " " + std::to_string(ids_[1]);
  for (const std::string& cmd : std::vector<std::string>{
           "runs list", "runs show" + run, "runs export" + run, "runs compare " + std::to_string(ids_[0]) + run,
           "runs trend --part intake --lobe 1", "runs plot" + run + " --out " + (dir_ / "run.svg").string(), "events",
           "nc history", "nc pending", "db check"}) {
    CommandResult r = run_command(cmd + data_);
    EXPECT_EQ(r.exit_code, 0) << cmd << ": " << r.output;
  }
  // The program was never written: nc check says so, having read the history.
  CommandResult check = run_command("nc check --nc-dir " + (dir_ / "nc").string() + data_);
  EXPECT_EQ(check.exit_code, 5) << check.output;
  EXPECT_TRUE(has(check.output, "not on disk (version 1 was pushed)")) << check.output;

  EXPECT_EQ(testing::slurp(db_), before);
  ASSERT_EQ(::stat(db_.c_str(), &st), 0);
  EXPECT_TRUE(st.st_mtim.tv_sec == mtime.tv_sec && st.st_mtim.tv_nsec == mtime.tv_nsec);
  EXPECT_FALSE(fs::exists(db_.string() + "-wal"));
  EXPECT_FALSE(fs::exists(db_.string() + "-shm"));
  // Writing commands refuse it, saying why.
  CommandResult prune = run_command("runs prune --raw-older-than-days 1" + data_);
  EXPECT_EQ(prune.exit_code, 4) << prune.output;
  EXPECT_TRUE(has(prune.output, "read-only")) << prune.output;
}

TEST_F(DbCommandsTest, QueriesReadOnAReadOnlyMount) {
  const fs::path mounted = dir_ / "mounted";
  fs::create_directories(mounted);
  const std::string setup = "unshare --mount --propagation private sh -c 'mount --bind " + db_.parent_path().string() +
                            " " + mounted.string() + " && mount -o remount,bind,ro " + mounted.string() + " && ";
  CommandResult mount = run_shell(setup + "true'");
  if (mount.exit_code != 0) GTEST_SKIP() << "no read-only bind mount on this machine: " << mount.output;
  CommandResult probe = run_shell(setup + "touch " + (mounted / "probe").string() + "'");
  ASSERT_TRUE(has(probe.output, "Read-only file system")) << "the mount is not read-only: " << probe.output;

  for (const std::string cmd : {"runs list", "nc history", "events", "db check"}) {
    CommandResult r =
        run_shell(setup + testing::gaugeloop_binary() + " " + cmd + " --data-dir " + mounted.string() + "'");
    EXPECT_EQ(r.exit_code, 0) << cmd << ": " << r.output;
  }
  CommandResult list =
      run_shell(setup + testing::gaugeloop_binary() + " runs list --json --data-dir " + mounted.string() + "'");
  EXPECT_TRUE(has(list.output, "\"id\": " + std::to_string(ids_[1]))) << list.output;
}

// It says first how large the file is and what that will take, and at the end what it read.
TEST_F(DbCommandsTest, CheckSaysASoundDatabaseIsSound) {
  CommandResult r = run_command("db check" + data_);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "database " + db_.string() + " is sound (schema version ")) << r.output;
  const std::string mb = format_fixed(static_cast<double>(fs::file_size(db_)) / 1e6, 1) + " MB";
  EXPECT_TRUE(has(r.output, "checking " + db_.string() + ": " + mb +
                                ", every page read once or more: under a second if the file is in memory"))
      << r.output;
  const std::size_t read = r.output.find("\nread ");
  ASSERT_NE(read, std::string::npos) << r.output;
  EXPECT_LT(read, r.output.find(" is sound")) << "what it read comes before the verdict";
}

// The database the service's config names, whatever its file name; --db names a file itself,
// so it does not go with --config.
TEST_F(DbCommandsTest, CheckAndBackupTakeTheServicesConfig) {
  const fs::path renamed = dir_ / "data" / "runs-7.sqlite";
  fs::rename(db_, renamed);
  const fs::path config = tmp_.write("gaugeloop.toml", "[database]\npath = \"data/runs-7.sqlite\"\n");
  CommandResult r = run_command("db check --config " + config.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "database " + renamed.string() + " is sound")) << r.output;
  const fs::path copy = dir_ / "copy" / "gaugeloop.sqlite";
  fs::create_directories(copy.parent_path());
  r = run_command("db backup " + copy.string() + " --config " + config.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(listed(copy.parent_path()).size(), 2u);
  r = run_command("db check --config " + config.string() + " --db " + renamed.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "--config excludes --db")) << r.output;
  r = run_command("db check --config " + config.string() + data_);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "--data-dir excludes --config")) << r.output;
}

// (The service starts beside a damaged file and finds it with its check on a thread of its own:
// ServiceTest.ADamagedDatabaseIsFoundBesideTheRunningServiceAndRunsAreRefused.)
// An upgrade checks the copy it makes first, and a damaged file's copy is damaged too: refused,
// the file as it was (its schema version, its bytes), no backup left behind.
TEST_F(DbCommandsTest, AnUpgradeOfADamagedFileIsRefusedAndChangesNothing) {
  const int latest = storage_internal::latest_schema_version();
  ASSERT_EQ(testing::sqlite_text(db_, "PRAGMA user_version = " + std::to_string(latest - 1)), "");
  ASSERT_EQ(testing::sqlite_text(db_, "PRAGMA user_version"), std::to_string(latest - 1));
  ASSERT_TRUE(testing::damage_runs_table(db_));
  const std::string before = testing::slurp(db_);
  CommandResult up = run_command("db upgrade --db " + db_.string());
  EXPECT_NE(up.exit_code, 0) << up.output;
  EXPECT_TRUE(has(up.output, "not upgraded from schema version " + std::to_string(latest - 1))) << up.output;
  EXPECT_TRUE(has(up.output, "is damaged: ")) << up.output;
  EXPECT_EQ(testing::slurp(db_), before) << "a refused upgrade changed the file";
  for (const auto& e : fs::directory_iterator(db_.parent_path())) {
    EXPECT_FALSE(e.path().filename().string().find("backup") != std::string::npos) << e.path();
  }
}

TEST_F(DbCommandsTest, ADamagedDatabaseIsRefusedByCheck) {
  ASSERT_TRUE(testing::damage_runs_table(db_));
  ASSERT_NE(testing::sqlite_text(db_, "PRAGMA integrity_check"), "ok") << "the damage did not show";

  CommandResult check = run_command("db check --db " + db_.string());
  EXPECT_EQ(check.exit_code, 4) << check.output;
  EXPECT_TRUE(has(check.output, "database " + db_.string() + " is damaged: ")) << check.output;
  EXPECT_TRUE(has(check.output, "gaugeloop db backup")) << check.output;
}

// What is no run database is never called sound: a device, an empty file, another program's
// SQLite file. A command that writes refuses the foreign file too, and leaves it as it was.
TEST_F(DbCommandsTest, CheckRefusesWhatIsNoRunDatabaseAndMeasureLeavesAForeignFileAlone) {
  for (const char* device : {"/dev/null", "/dev/zero"}) {
    CommandResult r = run_command(std::string("db check --db ") + device);
    EXPECT_EQ(r.exit_code, 4) << device << ": " << r.output;
    EXPECT_TRUE(has(r.output, "is not a regular file")) << r.output;
  }
  const fs::path empty = dir_ / "empty.sqlite";
  { std::ofstream(empty).flush(); }
  CommandResult r = run_command("db check --db " + empty.string());
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_TRUE(has(r.output, "is empty (0 bytes)")) << r.output;

  const fs::path foreign_dir = dir_ / "foreign";
  fs::create_directories(foreign_dir);
  const fs::path foreign = foreign_dir / "gaugeloop.sqlite";
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(foreign.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db,
                           "CREATE TABLE customers (id INTEGER PRIMARY KEY, name TEXT);"
                           "INSERT INTO customers (name) VALUES ('Anna');",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  const std::string before = testing::slurp(foreign);
  r = run_command("db check --db " + foreign.string());
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_TRUE(has(r.output,
                  "is a SQLite file gaugeloop did not write (no gaugeloop schema version, tables "
                  "customers)"))
      << r.output;
  Result<RunStore> opened = RunStore::open(foreign);
  ASSERT_FALSE(opened.ok()) << "a writer would have migrated it";
  EXPECT_NE(opened.error().message.find("Nothing was changed"), std::string::npos) << opened.error().message;
  EXPECT_TRUE(testing::slurp(foreign) == before) << "the foreign file was changed";
  EXPECT_EQ(testing::sqlite_text(foreign, "SELECT group_concat(name) FROM sqlite_schema"), "customers");
}

TEST_F(DbCommandsTest, ABackupHoldsTheSameRunsAndIsNeverOverwrittenUnlessTold) {
  const fs::path copy = dir_ / "copy" / "gaugeloop.sqlite";
  fs::create_directories(copy.parent_path());
  CommandResult r = run_command("db backup " + copy.string() + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "backed up to " + copy.string())) << r.output;
  EXPECT_EQ(listed(copy.parent_path()), listed(db_.parent_path()));
  EXPECT_EQ(listed(copy.parent_path()).size(), 2u);

  r = run_command("db backup " + copy.string() + data_);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, copy.string() + " exists already")) << r.output;
  r = run_command("db backup --force " + copy.string() + data_);
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST_F(DbCommandsTest, AnOlderSchemaIsRefusedByQueriesAndUpgradedByDbUpgradeAfterABackup) {
  const fs::path old_dir = dir_ / "old";
  const fs::path old_db = old_dir / "gaugeloop.sqlite";
  fs::create_directories(old_dir);
  {
    storage_internal::Connection conn;
    conn.path = old_db;
    ASSERT_EQ(sqlite3_open(old_db.c_str(), &conn.db), SQLITE_OK);
    ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 3).ok());
    ASSERT_EQ(sqlite3_exec(conn.db,
                           "INSERT INTO events (at_utc, kind, code, message) VALUES "
                           "('2020-11-22T02:00:00Z', 'fault', 'gauge timeout', 'no reply')",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
  }
  for (const std::string cmd : {"runs list", "nc history", "events"}) {
    CommandResult r = run_command(cmd + " --data-dir " + old_dir.string());
    EXPECT_EQ(r.exit_code, 4) << cmd << ": " << r.output;
    EXPECT_TRUE(has(r.output, "schema version 3")) << r.output;
    EXPECT_TRUE(has(r.output, "run `gaugeloop db upgrade --db " + old_db.string() + "`")) << r.output;
  }
  EXPECT_EQ(testing::sqlite_text(old_db, "PRAGMA user_version"), "3");

  CommandResult up = run_command("db upgrade --data-dir " + old_dir.string());
  ASSERT_EQ(up.exit_code, 0) << up.output;
  EXPECT_TRUE(has(up.output, "upgraded from schema version 3 to ")) << up.output;
  std::vector<fs::path> backups;
  for (const auto& e : fs::directory_iterator(old_dir)) {
    if (e.path().filename().string().starts_with("gaugeloop.sqlite.schema3-backup-")) backups.push_back(e.path());
  }
  ASSERT_EQ(backups.size(), 1u) << up.output;
  EXPECT_TRUE(has(up.output, "kept in " + backups[0].string())) << up.output;
  EXPECT_EQ(testing::sqlite_text(backups[0], "PRAGMA user_version"), "3");
  EXPECT_EQ(run_command("runs list --data-dir " + old_dir.string()).exit_code, 0);

  CommandResult again = run_command("db upgrade --data-dir " + old_dir.string());
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_TRUE(has(again.output, "nothing to upgrade")) << again.output;
}

}  // namespace
}  // namespace gaugeloop
