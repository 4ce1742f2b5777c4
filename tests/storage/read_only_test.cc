// Reading the run database without write access: a file without write permission, a
// directory this user cannot write, a read-only mount; and what reading refuses.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>

#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"
#include "storage_test_support.h"
#include "tests/support/cli.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::kSkipped;
using testing::make_record;
using testing::RawDb;
using testing::TempDir;

using testing::has;

// What a reader must leave as it found: the bytes, the modification time, and no new file.
struct FileState {
  std::string bytes;
  timespec mtime{};
  std::vector<std::string> names;  // the directory's entries
};

FileState state_of(const fs::path& db) {
  FileState s;
  s.bytes = testing::slurp(db);
  struct stat st {};
  if (::stat(db.c_str(), &st) == 0) s.mtime = st.st_mtim;
  for (const auto& entry : fs::directory_iterator(db.parent_path())) s.names.push_back(entry.path().filename());
  std::sort(s.names.begin(), s.names.end());
  return s;
}

std::string differences(const FileState& before, const FileState& after) {
  std::string d;
  if (before.bytes != after.bytes) d += "the file's bytes changed; ";
  if (before.mtime.tv_sec != after.mtime.tv_sec || before.mtime.tv_nsec != after.mtime.tv_nsec) {
    d += "its modification time changed; ";
  }
  if (before.names != after.names) d += "files appeared or went in its directory; ";
  return d;
}

// Opens read-only, lists and loads: "" if it reads the `expected` runs, else what went wrong.
std::string reads_runs(const fs::path& db, std::size_t expected) {
  Result<RunStore> store = RunStore::open_read_only(db);
  if (!store.ok()) return "open_read_only: " + store.error().message;
  Result<std::vector<RunSummary>> runs = store->list_runs(RunQuery{});
  if (!runs.ok()) return "list_runs: " + runs.error().message;
  if (runs->size() != expected) return "listed " + std::to_string(runs->size()) + " runs";
  Result<StoredRun> run = store->load_run(runs->front().id);
  if (!run.ok()) return "load_run: " + run.error().message;
  return "";
}

class ReadOnlyStore : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> store = RunStore::open(db_in(dir_));
    ASSERT_TRUE(store.ok()) << store.error().message;
    ASSERT_TRUE(store->insert_run(make_record("intake", "2026-11-20T08:00:00Z")).ok());
    ASSERT_TRUE(store->insert_run(make_record("intake", "2026-11-21T08:00:00Z")).ok());
  }  // closed: the last connection folds the -wal into the file and removes it

  TempDir dir_;
};

TEST_F(ReadOnlyStore, ReadsAFileWithoutWritePermissionAndLeavesItAsItWas) {
  fs::permissions(db_in(dir_), fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  const FileState before = state_of(db_in(dir_));
  EXPECT_EQ(reads_runs(db_in(dir_), 2), "");

  // Root ignores permission bits: what proves nothing was written is the file itself.
  Result<RunStore> store = RunStore::open_read_only(db_in(dir_));
  ASSERT_TRUE(store.ok()) << store.error().message;
  EventRecord e;
  e.code = "gauge timeout";
  e.message = "must not be stored";
  Result<std::int64_t> written = store->record_event(e);
  ASSERT_FALSE(written.ok()) << "a read-only store wrote an event";
  EXPECT_EQ(written.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(written.error().message, "opened for reading only")) << written.error().message;
  EXPECT_EQ(differences(before, state_of(db_in(dir_))), "");
  EXPECT_FALSE(fs::exists(db_in(dir_).string() + "-wal"));
  EXPECT_FALSE(fs::exists(db_in(dir_).string() + "-shm"));
}

TEST_F(ReadOnlyStore, ReadsInADirectoryThisUserCannotWrite) {
  dir_.share();
  fs::permissions(db_in(dir_).parent_path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                                 fs::perms::others_read | fs::perms::others_exec);
  const FileState before = state_of(db_in(dir_));
  EXPECT_EQ(testing::run_unprivileged([&] { return reads_runs(db_in(dir_), 2); }), "");
  EXPECT_EQ(differences(before, state_of(db_in(dir_))), "");
}

TEST_F(ReadOnlyStore, ReadsOnAReadOnlyMount) {
  const FileState before = state_of(db_in(dir_));
  const std::string result = testing::run_on_read_only_mount(db_in(dir_).parent_path(), [&](const fs::path& mounted) {
    return reads_runs(mounted / db_in(dir_).filename(), 2);
  });
  if (result.starts_with(kSkipped)) GTEST_SKIP() << "no read-only mount on this machine: " << result;
  EXPECT_EQ(result, "");
  EXPECT_EQ(differences(before, state_of(db_in(dir_))), "");
}

// The service holds the database open, so the newest run is still in the -wal: a reader on a
// read-only mount must see it (an immutable open would not).
TEST_F(ReadOnlyStore, ReadsRunsStillInTheWriteAheadLogOnAReadOnlyMount) {
  Result<RunStore> writer = RunStore::open(db_in(dir_));
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  ASSERT_TRUE(writer->insert_run(make_record("intake", "2026-11-22T08:00:00Z")).ok());
  ASSERT_GT(fs::file_size(db_in(dir_).string() + "-wal"), 0u) << "the third run should be in the log only";
  const std::string result = testing::run_on_read_only_mount(db_in(dir_).parent_path(), [&](const fs::path& mounted) {
    return reads_runs(mounted / db_in(dir_).filename(), 3);
  });
  if (result.starts_with(kSkipped)) GTEST_SKIP() << "no read-only mount on this machine: " << result;
  EXPECT_EQ(result, "");
}

TEST_F(ReadOnlyStore, RefusesAnOlderSchemaNamingTheCommandThatUpgradesIt) {
  TempDir old;
  fs::create_directories(db_in(old).parent_path());
  {
    storage_internal::Connection conn;
    conn.path = db_in(old);
    ASSERT_EQ(sqlite3_open(db_in(old).c_str(), &conn.db), SQLITE_OK);
    ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 3).ok());
  }
  const FileState before = state_of(db_in(old));
  Result<RunStore> store = RunStore::open_read_only(db_in(old));
  ASSERT_FALSE(store.ok()) << "read a version-3 database as if it were current";
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(store.error().message, "schema version 3")) << store.error().message;
  EXPECT_TRUE(has(store.error().message, "`gaugeloop db upgrade --db " + db_in(old).string() + "`"))
      << store.error().message;
  EXPECT_EQ(differences(before, state_of(db_in(old))), "") << "neither upgraded nor backed up";
  EXPECT_EQ(RawDb(db_in(old)).query_int("PRAGMA user_version"), 3);
}

TEST_F(ReadOnlyStore, RefusesANewerSchemaAsOpenDoes) {
  ASSERT_EQ(RawDb(db_in(dir_)).exec("PRAGMA user_version = 99"), SQLITE_OK);
  Result<RunStore> store = RunStore::open_read_only(db_in(dir_));
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(store.error().message, "schema version 99")) << store.error().message;
  EXPECT_TRUE(has(store.error().message, "newer")) << store.error().message;
}

TEST_F(ReadOnlyStore, NeverCreatesAFile) {
  const fs::path missing = dir_.path() / "elsewhere" / "runs.sqlite";
  Result<RunStore> store = RunStore::open_read_only(missing);
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kNotFound);
  EXPECT_TRUE(has(store.error().message, missing.string())) << store.error().message;
  EXPECT_FALSE(fs::exists(missing.parent_path()));
}

TEST_F(ReadOnlyStore, AnEmptyFileHasNoSchemaToRead) {
  const fs::path empty = dir_.path() / "empty.sqlite";
  std::ofstream{empty};
  Result<RunStore> store = RunStore::open_read_only(empty);
  ASSERT_FALSE(store.ok());
  EXPECT_TRUE(has(store.error().message, "no gaugeloop schema")) << store.error().message;
  EXPECT_EQ(fs::file_size(empty), 0u);
}

// A file without write bits is frozen: readers rely on it, so writers refuse it even as root.
TEST_F(ReadOnlyStore, OpenForWritingRefusesAFileWithoutWritePermissionEvenForRoot) {
  fs::permissions(db_in(dir_), fs::perms::owner_read | fs::perms::others_read);
  const FileState before = state_of(db_in(dir_));
  Result<RunStore> store = RunStore::open(db_in(dir_));
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(store.error().message, "read-only")) << store.error().message;
  EXPECT_EQ(differences(before, state_of(db_in(dir_))), "");
}

}  // namespace
}  // namespace gaugeloop
