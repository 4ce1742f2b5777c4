// Atomic runs: a child process storing runs is killed (SIGKILL) at 50 different moments of
// its file I/O, and each time the database must hold every run whole or not at all, and pass
// PRAGMA integrity_check. The moment is chosen deterministically: a VFS shim counts the
// child's writes, syncs and truncates and kills the process just before the k-th one.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage_test_support.h"

namespace gaugeloop {
namespace {

using testing::make_record;
using testing::RawDb;
using testing::sample_lift_mm;
using testing::TempDir;

// ---- A VFS that forwards to the default one and dies at the k-th write, sync or truncate ----

sqlite3_vfs* g_real_vfs = nullptr;
long g_io_count = 0;
long g_kill_at = 0;  // 0: never

void count_io() {
  if (++g_io_count == g_kill_at) ::raise(SIGKILL);
}

struct ShimFile {
  sqlite3_file base;
  sqlite3_file* real;  // allocated right after this struct
};

sqlite3_file* real_of(sqlite3_file* f) { return reinterpret_cast<ShimFile*>(f)->real; }

int shim_close(sqlite3_file* f) {
  sqlite3_file* r = real_of(f);
  const int rc = r->pMethods != nullptr ? r->pMethods->xClose(r) : SQLITE_OK;
  return rc;
}
int shim_read(sqlite3_file* f, void* buf, int n, sqlite3_int64 off) {
  return real_of(f)->pMethods->xRead(real_of(f), buf, n, off);
}
int shim_write(sqlite3_file* f, const void* buf, int n, sqlite3_int64 off) {
  count_io();
  return real_of(f)->pMethods->xWrite(real_of(f), buf, n, off);
}
int shim_truncate(sqlite3_file* f, sqlite3_int64 size) {
  count_io();
  return real_of(f)->pMethods->xTruncate(real_of(f), size);
}
int shim_sync(sqlite3_file* f, int flags) {
  count_io();
  return real_of(f)->pMethods->xSync(real_of(f), flags);
}
int shim_file_size(sqlite3_file* f, sqlite3_int64* size) { return real_of(f)->pMethods->xFileSize(real_of(f), size); }
int shim_lock(sqlite3_file* f, int l) { return real_of(f)->pMethods->xLock(real_of(f), l); }
int shim_unlock(sqlite3_file* f, int l) { return real_of(f)->pMethods->xUnlock(real_of(f), l); }
int shim_check_reserved(sqlite3_file* f, int* out) { return real_of(f)->pMethods->xCheckReservedLock(real_of(f), out); }
int shim_file_control(sqlite3_file* f, int op, void* arg) {
  return real_of(f)->pMethods->xFileControl(real_of(f), op, arg);
}
int shim_sector_size(sqlite3_file* f) { return real_of(f)->pMethods->xSectorSize(real_of(f)); }
int shim_device(sqlite3_file* f) { return real_of(f)->pMethods->xDeviceCharacteristics(real_of(f)); }
int shim_shm_map(sqlite3_file* f, int page, int size, int extend, void volatile** out) {
  return real_of(f)->pMethods->xShmMap(real_of(f), page, size, extend, out);
}
int shim_shm_lock(sqlite3_file* f, int offset, int n, int flags) {
  return real_of(f)->pMethods->xShmLock(real_of(f), offset, n, flags);
}
void shim_shm_barrier(sqlite3_file* f) { real_of(f)->pMethods->xShmBarrier(real_of(f)); }
int shim_shm_unmap(sqlite3_file* f, int del) { return real_of(f)->pMethods->xShmUnmap(real_of(f), del); }

// Version 2: no memory-mapped I/O (xFetch), so every page write goes through xWrite.
const sqlite3_io_methods kShimMethods = {
    2,
    shim_close,
    shim_read,
    shim_write,
    shim_truncate,
    shim_sync,
    shim_file_size,
    shim_lock,
    shim_unlock,
    shim_check_reserved,
    shim_file_control,
    shim_sector_size,
    shim_device,
    shim_shm_map,
    shim_shm_lock,
    shim_shm_barrier,
    shim_shm_unmap,
    nullptr,
    nullptr,
};

int shim_open(sqlite3_vfs*, sqlite3_filename name, sqlite3_file* f, int flags, int* out_flags) {
  auto* shim = reinterpret_cast<ShimFile*>(f);
  shim->real = reinterpret_cast<sqlite3_file*>(shim + 1);
  std::memset(shim->real, 0, static_cast<std::size_t>(g_real_vfs->szOsFile));
  const int rc = g_real_vfs->xOpen(g_real_vfs, name, shim->real, flags, out_flags);
  // Methods set even on failure when the real file has some: SQLite then calls xClose.
  shim->base.pMethods = shim->real->pMethods != nullptr ? &kShimMethods : nullptr;
  return rc;
}
int shim_delete(sqlite3_vfs*, const char* name, int sync_dir) {
  count_io();
  return g_real_vfs->xDelete(g_real_vfs, name, sync_dir);
}
int shim_access(sqlite3_vfs*, const char* name, int flags, int* out) {
  return g_real_vfs->xAccess(g_real_vfs, name, flags, out);
}
int shim_full_pathname(sqlite3_vfs*, const char* name, int n, char* out) {
  return g_real_vfs->xFullPathname(g_real_vfs, name, n, out);
}
int shim_randomness(sqlite3_vfs*, int n, char* out) { return g_real_vfs->xRandomness(g_real_vfs, n, out); }
int shim_sleep(sqlite3_vfs*, int us) { return g_real_vfs->xSleep(g_real_vfs, us); }
int shim_current_time(sqlite3_vfs*, double* out) { return g_real_vfs->xCurrentTime(g_real_vfs, out); }
int shim_last_error(sqlite3_vfs*, int n, char* out) { return g_real_vfs->xGetLastError(g_real_vfs, n, out); }
int shim_current_time64(sqlite3_vfs*, sqlite3_int64* out) { return g_real_vfs->xCurrentTimeInt64(g_real_vfs, out); }

sqlite3_vfs g_shim_vfs{};

// In the child only: makes the shim the default VFS, dying before I/O operation `kill_at`.
void install_kill_vfs(long kill_at) {
  g_real_vfs = sqlite3_vfs_find(nullptr);
  g_shim_vfs.iVersion = 2;
  g_shim_vfs.szOsFile = static_cast<int>(sizeof(ShimFile)) + g_real_vfs->szOsFile;
  g_shim_vfs.mxPathname = g_real_vfs->mxPathname;
  g_shim_vfs.zName = "gaugeloop-kill-shim";
  g_shim_vfs.xOpen = shim_open;
  g_shim_vfs.xDelete = shim_delete;
  g_shim_vfs.xAccess = shim_access;
  g_shim_vfs.xFullPathname = shim_full_pathname;
  g_shim_vfs.xRandomness = shim_randomness;
  g_shim_vfs.xSleep = shim_sleep;
  g_shim_vfs.xCurrentTime = shim_current_time;
  g_shim_vfs.xGetLastError = shim_last_error;
  g_shim_vfs.xCurrentTimeInt64 = shim_current_time64;
  g_io_count = 0;
  g_kill_at = kill_at;
  sqlite3_vfs_register(&g_shim_vfs, /*makeDflt=*/1);
}

constexpr int kRunsPerChild = 3;

std::string note_for(int iteration, int k) {
  return "iteration " + std::to_string(iteration) + " run " + std::to_string(k);
}

struct ChildResult {
  bool killed = false;
  int exit_code = -1;
  long io_count = 0;  // reported by a child that was not killed
};

// Forks a child that opens the store and inserts kRunsPerChild runs, dying before I/O
// operation `kill_at` (0: never). The child reports its I/O count through a pipe.
ChildResult run_child(const std::filesystem::path& db, int iteration, long kill_at) {
  int fds[2];
  EXPECT_EQ(::pipe(fds), 0);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    install_kill_vfs(kill_at);
    int code = 0;
    {
      Result<RunStore> store = RunStore::open(db);
      if (!store.ok()) code = 3;
      for (int k = 0; code == 0 && k < kRunsPerChild; ++k) {
        RunRecord r = make_record("crash", "2026-11-22T02:34:44Z");
        r.note = note_for(iteration, k);
        if (!store->insert_run(r).ok()) code = 4;
      }
    }
    const long count = g_io_count;
    [[maybe_unused]] auto n = ::write(fds[1], &count, sizeof count);
    ::_exit(code);
  }
  ::close(fds[1]);
  ChildResult result;
  [[maybe_unused]] auto n = ::read(fds[0], &result.io_count, sizeof result.io_count);
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  result.killed = WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

TEST(CrashSafety, KilledAtFiftyMomentsTheDatabaseHoldsWholeRunsOnly) {
  // Calibration: how many writes, syncs and truncates one child makes on an existing
  // database, so the kills spread over all of it (opening, each insert, each commit).
  TempDir scratch;
  ChildResult first = run_child(db_in(scratch), -1, 0);
  ASSERT_EQ(first.exit_code, 0);
  ChildResult calibration = run_child(db_in(scratch), -1, 0);
  ASSERT_EQ(calibration.exit_code, 0);
  const long per_child = calibration.io_count;
  ASSERT_GT(per_child, kRunsPerChild * 2) << "the shim sees no I/O: the test would prove nothing";

  TempDir dir;
  constexpr int kIterations = 50;
  std::int64_t runs_before = 0;
  int killed = 0;
  int killed_with_a_partial_child = 0;  // killed after some but not all of its runs committed
  for (int i = 0; i < kIterations; ++i) {
    // Iteration 0 kills at the very first write, on a database that does not exist yet.
    const long kill_at = 1 + (static_cast<long>(i) * per_child) / kIterations;
    const ChildResult child = run_child(db_in(dir), i, kill_at);
    if (child.killed) {
      ++killed;
    } else {
      ASSERT_EQ(child.exit_code, 0) << "iteration " << i << ": the child failed without being killed";
    }

    if (!std::filesystem::exists(db_in(dir))) {
      ASSERT_EQ(runs_before, 0);
      continue;  // killed before the file was created
    }
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.query_text("PRAGMA integrity_check"), "ok") << "iteration " << i;
    if (const std::int64_t version = raw.query_int("PRAGMA user_version");
        version < storage_internal::latest_schema_version()) {
      // Killed while creating the schema: each migration commits whole, so the file holds
      // exactly a whole earlier version (version 2 brought run_raw, version 3 nc_pending,
      // version 5 nc_push_intents) and
      // no run yet; the next open completes it.
      ASSERT_EQ(runs_before, 0);
      ASSERT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'run_raw'"), version >= 2 ? 1 : 0)
          << "iteration " << i << ", version " << version;
      ASSERT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_pending'"), version >= 3 ? 1 : 0)
          << "iteration " << i << ", version " << version;
      ASSERT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_pushes_v3'"), 0)
          << "iteration " << i << ", version " << version;
      ASSERT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_push_intents'"),
                version >= 5 ? 1 : 0)
          << "iteration " << i << ", version " << version;
      continue;
    }
    ASSERT_EQ(raw.query_int("PRAGMA foreign_key_check"), 0) << "iteration " << i;
    const RawDb::Counts n = raw.counts();
    ASSERT_GE(n.runs, runs_before) << "iteration " << i;
    ASSERT_LE(n.runs, runs_before + kRunsPerChild) << "iteration " << i;
    if (!child.killed) {
      ASSERT_EQ(n.runs, runs_before + kRunsPerChild);
    }
    ASSERT_EQ(n.raw, n.runs) << "iteration " << i << ": a run without its raw samples";
    ASSERT_EQ(n.tables, n.runs) << "iteration " << i << ": a run without its profile";
    const std::int64_t added = n.runs - runs_before;
    if (child.killed && added > 0 && added < kRunsPerChild) ++killed_with_a_partial_child;
    // The runs this child committed are its first `added`, each whole and right.
    Result<RunStore> store = RunStore::open(db_in(dir));
    ASSERT_TRUE(store.ok()) << "iteration " << i << ": " << store.error().message;
    Result<std::vector<RunSummary>> runs = store->list_runs([&] {
      RunQuery q;
      q.limit = kRunsPerChild;
      q.part = "crash";
      return q;
    }());
    ASSERT_TRUE(runs.ok()) << runs.error().message;
    for (std::int64_t k = 0; k < added; ++k) {
      const RunSummary& s = (*runs)[static_cast<std::size_t>(added - 1 - k)];
      Result<StoredRun> loaded = store->load_run(s.id);
      ASSERT_TRUE(loaded.ok()) << "iteration " << i << ": " << loaded.error().message;
      EXPECT_EQ(loaded->note, note_for(i, static_cast<int>(k)));
      ASSERT_EQ(loaded->revolutions.size(), 3u);
      EXPECT_NEAR(loaded->revolutions[2].lift_mm[359], sample_lift_mm(2, 359), 1e-7);
    }
    runs_before = n.runs;
  }
  std::printf("per child %ld I/O operations; %d of %d children killed, %d after committing some runs\n", per_child,
              killed, kIterations, killed_with_a_partial_child);
  // The kills must really land in the middle of things for the test to mean anything.
  EXPECT_GE(killed, kIterations - 5);
  EXPECT_GE(killed_with_a_partial_child, 10);
}

}  // namespace
}  // namespace gaugeloop
