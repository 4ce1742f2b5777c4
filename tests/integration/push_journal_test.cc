// The push as one recoverable step, on a real NC directory and a real SQLite file: a push
// killed after every one of its steps, a disk full at every level from 0 to 200 KB, and a
// database locked through the push. Each time the next command finds the control and the
// history in agreement: the next push goes through with the next version, `nc check` agrees
// with the journal, no temporary file of ours is left and nothing is called edited by hand.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "cli/embedded_defaults.h"
#include "core/atomic_file.h"
#include "job/nc_push.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/sample_runs.h"
#include "tests/support/table_program.h"
#include "tests/support/temp_dir.h"
#include "tests/support/tmpfs_mount.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::program_for;
using testing::slurp;

// The directory of one test: the database and the NC directory, possibly on a small tmpfs.
class PushJournalTest : public ::testing::Test {
 protected:
  void SetUp() override { use_dir(tmp_.path()); }

  // Another directory for the rest of the test (one on a small tmpfs); its owner removes it.
  void use_dir(const fs::path& dir) {
    dir_ = dir;
    std::error_code ec;
    fs::remove_all(dir_ / "nc", ec);
    fs::remove(db(), ec);
    fs::remove(db().string() + "-wal", ec);
    fs::remove(db().string() + "-shm", ec);
    fs::create_directories(dir_ / "nc");
  }

  fs::path db() const { return dir_ / "gaugeloop.sqlite"; }
  fs::path nc_file() const { return dir_ / "nc" / "CAM_TEST.SPF"; }

  // A stored run to push a table for; its id.
  std::int64_t stored_run(const std::string& started) {
    Result<RunStore> store = RunStore::open(db());
    EXPECT_TRUE(store.ok()) << store.error().message;
    Result<std::int64_t> id = store->insert_run(testing::sample_run("intake", 1, "grinder-1", started, 5.0));
    EXPECT_TRUE(id.ok()) << id.error().message;
    return *id;
  }

  // One push of run `run` through a fresh store, as a command would make it.
  Result<PushCompletion> push(std::int64_t run, const PushOptions& options = {}) {
    Result<RunStore> store = RunStore::open(db());
    if (!store) return store.error();
    PushFacts facts;
    facts.run_id = run;
    facts.reason = "run " + std::to_string(run);
    return push_program(
        *store, nc_file(), facts, [run](int version) { return program_for(run, version, 1.0 + 0.1 * version); },
        options);
  }

  // What every test checks after the trouble: the next command finds agreement.
  //  - the file is no hand edit (nc check's verdict);
  //  - the next push goes through with `expected_next` and leaves the file equal to the
  //    program recorded last, with no open intent and no temporary file of ours.
  void expect_next_push_is_normal(std::int64_t run, int expected_next, const std::string& context) {
    {
      Result<RunStore> store = RunStore::open(db());
      ASSERT_TRUE(store.ok()) << context << ": " << store.error().message;
      Status check = check_not_edited_by_hand(*store, nc_file());
      EXPECT_TRUE(check.ok()) << context << ": false 'edited by hand': " << check.error().message;
    }
    Result<PushCompletion> next = push(run);
    ASSERT_TRUE(next.ok()) << context << ": the next push failed: " << next.error().message;
    EXPECT_EQ(next->table_version, expected_next) << context;
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok());
    Result<std::optional<NcPush>> last = store->last_push(nc_file().string());
    ASSERT_TRUE(last.ok() && *last);
    EXPECT_EQ((**last).table_version, expected_next) << context;
    EXPECT_EQ(*(**last).program_text, slurp(nc_file())) << context << ": the history and the control disagree";
    Result<std::vector<PushIntent>> open = store->open_push_intents();
    ASSERT_TRUE(open.ok());
    EXPECT_TRUE(open->empty()) << context << ": an intent is still open";
    EXPECT_EQ(leftover_count(), 0) << context << ": a temporary file of ours is left";
    EXPECT_TRUE(check_not_edited_by_hand(*store, nc_file()).ok()) << context;
  }

  int leftover_count() const {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir_ / "nc")) {
      if (e.path().filename().string().rfind(atomic_temporary_prefix(nc_file()), 0) == 0) ++n;
    }
    return n;
  }

  testing::TempDir tmp_;
  fs::path dir_;
};

// A push killed (the process ends on the spot, as kill -9 or a power cut would end it, with no
// clean-up) right after each of its steps. Before the rename the control keeps the old program
// and the journal abandons the intent; from the rename on the control holds the new one and
// the journal records it as pushed. Either way the next push gets the next version.
TEST_F(PushJournalTest, APushKilledAfterEveryStepIsReconciledByTheNextCommand) {
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(run).ok());  // version 1 on the control
  const PushStep steps[] = {PushStep::kIntentRecorded, PushStep::kTemporaryWritten, PushStep::kFlushed,
                            PushStep::kRenamed, PushStep::kRecorded};
  int version_in_force = 1;
  for (PushStep step : steps) {
    const std::string context = "killed after '" + std::string(push_step_name(step)) + "'";
    const std::string before = slurp(nc_file());
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      PushOptions options;
      options.observer = [step](PushStep reached) {
        if (reached == step) ::_exit(0);
      };
      Result<PushCompletion> r = push(run, options);
      ::_exit(r.ok() ? 1 : 2);  // the step was never reached
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << context << ": the child did not stop there";
    const bool renamed = step == PushStep::kRenamed || step == PushStep::kRecorded;
    if (renamed) {
      EXPECT_NE(slurp(nc_file()), before) << context;
    } else {
      EXPECT_EQ(slurp(nc_file()), before) << context << ": the control changed before the rename";
    }
    if (step == PushStep::kRenamed) {
      // Written, its record interrupted: nc check names it, before anything reconciles.
      const auto check = testing::run_command("nc check --data-dir " + dir_.string() + " --program CAM_TEST");
      EXPECT_EQ(check.exit_code, 0) << context << ": " << check.output;
      EXPECT_NE(check.output.find("interrupted"), std::string::npos) << context << ": " << check.output;
    }
    if (renamed) ++version_in_force;
    expect_next_push_is_normal(run, version_in_force + 1, context);
    ++version_in_force;
  }
}

// The database's write-ahead log deleted after a run and a push were committed to it (the
// process killed before a checkpoint, then the -wal removed): the history silently lost them.
// The marks beside the database notice it: `db check` names what was lost, the next
// writer records it as an event and hands out none of the lost ids again, and the program the
// lost push wrote is refused as newer than the history, not called edited by hand.
TEST_F(PushJournalTest, AWriteAheadLogDeletedAfterACommitIsNoticedAndNoIdIsHandedOutTwice) {
  const std::int64_t first = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(first).ok());  // version 1, and the marks
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    Result<RunStore> store = RunStore::open(db());
    if (!store) ::_exit(2);
    Result<std::int64_t> run =
        store->insert_run(testing::sample_run("intake", 1, "grinder-1", "2026-11-30T09:00:00Z", 5.0));
    if (!run || !store->mark_ids()) ::_exit(3);
    PushFacts facts;
    facts.run_id = *run;
    Result<PushCompletion> pushed =
        push_program(*store, nc_file(), facts, [&run](int version) { return program_for(*run, version, 1.3); });
    ::_exit(pushed.ok() && pushed->table_version == 2 ? 0 : 4);  // no checkpoint: the commits stay in the -wal
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << WEXITSTATUS(status);
  ASSERT_TRUE(fs::exists(db().string() + "-wal"));
  fs::remove(db().string() + "-wal");
  fs::remove(db().string() + "-shm");

  const auto checked = testing::run_command("db check --data-dir " + dir_.string());
  EXPECT_NE(checked.exit_code, 0) << checked.output;
  EXPECT_NE(checked.output.find("lost commits: gaugeloop.sqlite.ids says run ids up to 2 and push ids up to 2 "
                                "were handed out, the database holds them up to 1 and 1"),
            std::string::npos)
      << checked.output;
  EXPECT_NE(checked.output.find("run 2 and push 2 are not in the history"), std::string::npos) << checked.output;

  const auto nc = testing::run_command("nc check --data-dir " + dir_.string() + " --program CAM_TEST");
  EXPECT_NE(nc.exit_code, 0) << nc.output;
  EXPECT_NE(nc.output.find("holds table version 2 of run 2, newer than any push the history holds"), std::string::npos)
      << nc.output;
  EXPECT_EQ(nc.output.find("edited by hand"), std::string::npos) << nc.output;

  const auto reconciled = testing::run_command("nc reconcile --data-dir " + dir_.string());
  EXPECT_NE(reconciled.output.find("lost commits"), std::string::npos) << reconciled.output;
  EXPECT_EQ(stored_run("2026-11-30T10:00:00Z"), 3) << "run id 2 was handed out before: never again";
  Result<RunStore> store = RunStore::open(db());
  ASSERT_TRUE(store.ok());
  EventQuery q;
  Result<std::vector<StoredEvent>> events = store->list_events(q);
  ASSERT_TRUE(events.ok()) << events.error().message;
  int lost = 0;
  for (const StoredEvent& e : *events) lost += e.event.code == "lost commits" ? 1 : 0;
  EXPECT_EQ(lost, 1) << "recorded once, by the first writer that noticed";
  const auto after = testing::run_command("db check --data-dir " + dir_.string());
  EXPECT_EQ(after.exit_code, 0) << after.output;
}

// `gaugeloop nc reconcile` finishes an interrupted push by itself, and says what it did.
TEST_F(PushJournalTest, ReconcileRecordsAProgramTheControlHoldsAndRemovesLeftovers) {
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(run).ok());
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    PushOptions options;
    options.observer = [](PushStep reached) {
      if (reached == PushStep::kRenamed) ::_exit(0);
    };
    ::_exit(push(run, options).ok() ? 1 : 2);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  // A temporary file left by a write killed mid-way, as the journal would find it.
  { std::ofstream(dir_ / "nc" / (atomic_temporary_prefix(nc_file()) + "aB3xYz")) << "half a program"; }
  // Not ours: another name is never touched.
  { std::ofstream(dir_ / "nc" / ".CAM_TEST.SPF.tmp-keep-me-please") << "someone's file"; }
  // nc check names it and leaves it.
  const auto check = testing::run_command("nc check --data-dir " + dir_.string() + " --program CAM_TEST");
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find(atomic_temporary_prefix(nc_file()) + "aB3xYz: a temporary file left by an "
                                                                   "interrupted write of CAM_TEST.SPF"),
            std::string::npos)
      << check.output;
  EXPECT_EQ(check.output.find("keep-me-please"), std::string::npos) << check.output;
  EXPECT_TRUE(fs::exists(dir_ / "nc" / (atomic_temporary_prefix(nc_file()) + "aB3xYz")));

  const auto r = testing::run_command("nc reconcile --data-dir " + dir_.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 interrupted push(es) recorded, 0 abandoned, 1 temporary file(s) removed"),
            std::string::npos)
      << r.output;
  EXPECT_TRUE(fs::exists(dir_ / "nc" / ".CAM_TEST.SPF.tmp-keep-me-please"));
  Result<RunStore> store = RunStore::open(db());
  ASSERT_TRUE(store.ok());
  Result<std::optional<NcPush>> last = store->last_push(nc_file().string());
  ASSERT_TRUE(last.ok() && *last);
  EXPECT_EQ((**last).table_version, 2);
  EXPECT_EQ(*(**last).program_text, slurp(nc_file()));
}

// A push killed after its table is in place and before its main program is written: the
// control defines the new table and couples the old one, so it grinds the old. `nc check` says
// so (exit 5) before anything reconciles, `nc reconcile` writes the main program again for the
// table on the control (the built-in template), and `nc check` then agrees.
TEST_F(PushJournalTest, APushKilledBeforeItsMainProgramIsFoundByCheckAndRepairedByReconcile) {
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  PushOptions options;
  options.main.template_text = std::string(embedded::kNcMainTemplate);
  options.main.template_name = "embedded:cam_main.mpf";
  options.main.part = "intake";
  options.main.lobe = 1;
  auto push_alternating = [&](const PushOptions& o) {
    Result<RunStore> store = RunStore::open(db());
    if (!store) return Result<PushCompletion>(store.error());
    PushFacts facts;
    facts.run_id = run;
    facts.reason = "run " + std::to_string(run);
    return push_program(
        *store, nc_file(), facts,
        [run](int version) {
          return program_for(run, version, 1.0 + 0.1 * version, {1, 2});
        },
        o);
  };
  ASSERT_TRUE(push_alternating(options).ok());  // version 1: table 1, coupled
  const fs::path main_file = dir_ / "nc" / "CAM_TEST_MAIN.MPF";
  const std::string main_v1 = slurp(main_file);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    PushOptions cut = options;
    cut.observer = [](PushStep reached) {
      if (reached == PushStep::kRenamed) ::_exit(0);
    };
    ::_exit(push_alternating(cut).ok() ? 1 : 2);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  ASSERT_EQ(slurp(main_file), main_v1) << "the cut came before the main program";

  const std::string data = " --data-dir " + dir_.string() + " --program CAM_TEST";
  const auto check = testing::run_command("nc check" + data);
  EXPECT_EQ(check.exit_code, 5) << check.output;
  EXPECT_NE(check.output.find("CAM_TEST_MAIN.MPF couples table 1, that of version 1, while CAM_TEST.SPF on the "
                              "control is version 2 (table 2): the control grinds version 1"),
            std::string::npos)
      << check.output;

  const auto reconciled = testing::run_command("nc reconcile --data-dir " + dir_.string());
  ASSERT_EQ(reconciled.exit_code, 0) << reconciled.output;
  EXPECT_NE(reconciled.output.find("1 interrupted push(es) recorded, 0 abandoned, 0 temporary file(s) removed, 1 "
                                   "main program(s) written again"),
            std::string::npos)
      << reconciled.output;
  EXPECT_NE(slurp(main_file).find("EGON(X,\"FINE\",C,2,0)"), std::string::npos) << slurp(main_file);
  const auto again = testing::run_command("nc check" + data);
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("table version 2 as pushed"), std::string::npos) << again.output;
  // The main program written again is the one the push recorded, byte for byte.
  Result<RunStore> store = RunStore::open(db());
  ASSERT_TRUE(store.ok());
  Result<std::vector<PushFile>> recorded = store->files_of_last_push(nc_file().string());
  ASSERT_TRUE(recorded.ok()) << recorded.error().message;
  ASSERT_EQ(recorded->size(), 2u);
  EXPECT_EQ((*recorded)[1].text, std::optional<std::string>(slurp(main_file)));

  // A main program gone from the control: nc check names it (exit 5), reconciliation puts it back.
  const std::string main_v2 = slurp(main_file);
  fs::remove(main_file);
  const auto gone = testing::run_command("nc check" + data);
  EXPECT_EQ(gone.exit_code, 5) << gone.output;
  EXPECT_NE(gone.output.find("CAM_TEST_MAIN.MPF is not on the control: the main program of version 2 is missing"),
            std::string::npos)
      << gone.output;
  const auto put_back = testing::run_command("nc reconcile --data-dir " + dir_.string());
  ASSERT_EQ(put_back.exit_code, 0) << put_back.output;
  EXPECT_NE(put_back.output.find("1 other file(s) of a push written again"), std::string::npos) << put_back.output;
  EXPECT_EQ(slurp(main_file), main_v2);
  EXPECT_EQ(testing::run_command("nc check" + data).exit_code, 0);
}

// A data directory copied elsewhere keeps the paths of the control it was kept for: asked about
// the copy's program, nc check says the history records no push to it and where its pushes
// went, instead of calling it "version 0 as pushed".
// A data directory copied (or moved, or restored from a backup elsewhere) keeps its history for
// the NC directory it is used with: check and rollback work on the copy's files and never reach
// the directory it came from; a program the copy never pushed is not "as pushed".
TEST_F(PushJournalTest, ACopiedOrMovedDataDirectoryChecksAndRollsBackItsOwnPrograms) {
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(run).ok());
  ASSERT_TRUE(push(run).ok());
  const std::string original = slurp(nc_file());
  const fs::path copy = dir_ / "copy";
  fs::create_directories(copy);
  fs::copy(db(), copy / "gaugeloop.sqlite");
  fs::copy(dir_ / "nc", copy / "nc", fs::copy_options::recursive);
  const std::string data = " --data-dir " + copy.string();

  auto check = testing::run_command("nc check" + data);
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find((copy / "nc" / "CAM_TEST.SPF").string() + ": table version 2 as pushed"),
            std::string::npos)
      << check.output;
  EXPECT_EQ(check.output.find(nc_file().string()), std::string::npos) << "the original is not checked\n"
                                                                      << check.output;

  const auto rollback = testing::run_command("nc rollback 1 --by test" + data);
  ASSERT_EQ(rollback.exit_code, 0) << rollback.output;
  EXPECT_NE(rollback.output.find((copy / "nc" / "CAM_TEST.SPF").string() + ": table version 3 written"),
            std::string::npos)
      << rollback.output;
  EXPECT_EQ(slurp(nc_file()), original) << "the rollback did not reach the original's NC directory";
  EXPECT_FALSE(fs::exists(dir_ / "nc" / "CAM_TEST_MAIN.MPF")) << "nor wrote a main program there";
  check = testing::run_command("nc check" + data);
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("table version 3 as pushed"), std::string::npos) << check.output;
  const auto history = testing::run_command("nc history --data-dir " + dir_.string());
  EXPECT_EQ(history.output.find("      3 "), std::string::npos) << "the original's history is its own\n"
                                                                << history.output;

  // Moved as a whole (a restored backup in another place): its history follows it.
  const fs::path moved = dir_ / "moved";
  fs::rename(copy, moved);
  check = testing::run_command("nc check --data-dir " + moved.string());
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find((moved / "nc" / "CAM_TEST.SPF").string() + ": table version 3 as pushed"),
            std::string::npos)
      << check.output;

  // A program the history never pushed (one of ours, copied in by hand) is not "as pushed".
  fs::copy_file(moved / "nc" / "CAM_TEST.SPF", moved / "nc" / "CAM_OTHER.SPF");
  check = testing::run_command("nc check --data-dir " + moved.string() + " --program CAM_OTHER");
  EXPECT_EQ(check.exit_code, 5) << check.output;
  EXPECT_NE(check.output.find("records no push to this file"), std::string::npos) << check.output;
  EXPECT_NE(check.output.find("its pushes went to " + (moved / "nc" / "CAM_TEST.SPF").string()), std::string::npos)
      << check.output;
}

// A database locked by another program through the whole push: the intent cannot be
// recorded, so nothing is written to the control and the error says so; once the lock is
// gone the next push is normal. Locked only once the program is in place: the control holds
// it, its record is completed by the next push.
TEST_F(PushJournalTest, ADatabaseLockedThroughThePushLosesNothing) {
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(run).ok());
  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open(db().c_str(), &other), SQLITE_OK);
  const std::string before = slurp(nc_file());

  ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);
  Result<PushCompletion> locked = push(run);
  ASSERT_EQ(sqlite3_exec(other, "ROLLBACK", nullptr, nullptr, nullptr), SQLITE_OK);
  ASSERT_FALSE(locked.ok());
  EXPECT_NE(locked.error().message.find("was not pushed (the program on the control is unchanged)"), std::string::npos)
      << locked.error().message;
  EXPECT_EQ(slurp(nc_file()), before);
  expect_next_push_is_normal(run, 2, "locked through the push");

  PushOptions lock_after_rename;
  lock_after_rename.observer = [other](PushStep reached) {
    if (reached == PushStep::kRenamed) sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr);
  };
  Result<PushCompletion> late = push(run, lock_after_rename);
  ASSERT_EQ(sqlite3_exec(other, "ROLLBACK", nullptr, nullptr, nullptr), SQLITE_OK);
  ASSERT_FALSE(late.ok());
  EXPECT_NE(late.error().message.find("is on the control, but its record was not completed"), std::string::npos)
      << late.error().message;
  expect_next_push_is_normal(run, 4, "locked after the rename");
  sqlite3_close(other);
}

// The database and the NC directory on one small file system, filled to every level from 0
// to 200 KB free in 4 KB steps before a push. Whatever the push managed, once space is freed
// the next push is normal: nothing half-recorded, nothing half-written.
TEST_F(PushJournalTest, ADiskFullAtEveryLevelLosesNothing) {
  testing::TmpfsMount fs_small(8 * 1024);
  if (!fs_small.mounted()) GTEST_SKIP() << fs_small.why_not();
  use_dir(fs_small.dir());
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(run).ok());
  int version = 1;
  int pushed_while_full = 0;
  for (int free_kb = 0; free_kb <= 200; free_kb += 4) {
    const std::string context = std::to_string(free_kb) + " KB free";
    const fs::path filler = fs_small.dir() / "filler";
    {
      const std::uintmax_t have = fs_small.free_bytes();
      const std::uintmax_t want = static_cast<std::uintmax_t>(free_kb) * 1024;
      ASSERT_GT(have, want) << context;
      std::ofstream out(filler, std::ios::binary);
      const std::string block(have - want, 'f');
      out.write(block.data(), static_cast<std::streamsize>(block.size()));
    }
    Result<PushCompletion> r = push(run);
    if (r.ok()) {
      ++pushed_while_full;
      version = r->table_version;
    } else {
      // Whatever failed, the control holds a program the history knows of.
      Result<RunStore> store = RunStore::open(db());
      if (store) {
        EXPECT_TRUE(check_not_edited_by_hand(*store, nc_file()).ok()) << context;
      }
    }
    fs::remove(filler);
    // The next command: reconciles what the full disk interrupted, then pushes.
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << context << ": " << store.error().message;
    Result<ReconcileReport> rec = reconcile_pushes(*store, nc_file());
    ASSERT_TRUE(rec.ok()) << context << ": " << rec.error().message;
    Result<int> next = store->next_table_version(nc_file().string());
    ASSERT_TRUE(next.ok());
    expect_next_push_is_normal(run, *next, context);
    version = *next;
  }
  EXPECT_GE(version, 52);  // 51 levels, each followed by a normal push
  // The smallest levels cannot hold a program, the largest can: both paths were taken.
  EXPECT_GT(pushed_while_full, 0);
  EXPECT_LT(pushed_while_full, 51);
}

// nc check compares the header's identity too: a gaugeloop table of another run and version
// with the same points is not the table last pushed.
TEST_F(PushJournalTest, ACopiedInTableOfAnotherRunIsNotTheTableLastPushed) {
  const std::int64_t run = stored_run("2026-11-30T08:00:00Z");
  ASSERT_TRUE(push(run).ok());
  // Same points as version 1 (same stroke), but the header of run 99, version 7.
  Result<std::string> other = program_for(99, 1, 1.1);
  ASSERT_TRUE(other.ok());
  std::string copied = *other;
  const std::string from = "; gaugeloop table_version: 1";
  ASSERT_NE(copied.find(from), std::string::npos);
  copied.replace(copied.find(from), from.size(), "; gaugeloop table_version: 7");
  ASSERT_TRUE(write_file_atomically(nc_file(), copied).ok());
  Result<RunStore> store = RunStore::open(db());
  ASSERT_TRUE(store.ok());
  Status check = check_not_edited_by_hand(*store, nc_file());
  ASSERT_FALSE(check.ok());
  EXPECT_EQ(check.error().code, ErrorCode::kRefused);
  EXPECT_NE(check.error().message.find("is not the table last pushed"), std::string::npos) << check.error().message;
  EXPECT_NE(check.error().message.find("run_id 99"), std::string::npos) << check.error().message;
}

}  // namespace
}  // namespace gaugeloop
