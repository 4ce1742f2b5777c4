// NC pushes a controls engineer can audit and reverse (table versions per file, the program
// kept whole, the table in force after a rollback) and tables awaiting approval.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <utility>

#include "storage/db_maintenance.h"
#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"
#include "storage_test_support.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using testing::make_record;
using testing::RawDb;
using testing::TempDir;

using testing::has;

// A program as the Sinumerik template renders it: CRLF, tabs, a degree sign, trailing blanks
// and no final newline, so any normalisation of the text shows.
std::string sample_program(int version) {
  std::string p = "; gaugeloop table version " + std::to_string(version) + "\r\n";
  p += "; lobe 2, C step 0.5\xC2\xB0  \r\n";
  p += "CTABDEF(X,C,1,1)\r\n";
  for (int i = 0; i <= 720; ++i) {
    p += "\tC=" + std::to_string(i * 0.5) + " X=" + std::to_string(20.0 + 1e-4 * i) + "\r\n";
  }
  p += "CTABEND   ";
  return p;
}

class NcPushStoreTest : public testing::StoreTest {
 protected:
  std::int64_t add_run(const std::string& started, int lobe = 2, const std::string& machine = "grinder-1") {
    RunRecord r = make_record("intake_flat", started);
    r.lobe = lobe;
    r.machine = machine;
    Result<std::int64_t> id = store().insert_run(r);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return id.ok() ? *id : -1;
  }

  // Pushes `run_id`'s table as the file's next version, as the app does: ask, render, record.
  NcPush push_next(std::int64_t run_id, const std::string& nc_file, const std::string& reason = {}) {
    Result<int> next = store().next_table_version(nc_file);
    EXPECT_TRUE(next.ok()) << next.error().message;
    NcPush p;
    p.nc_file = nc_file;
    p.table_version = next.ok() ? *next : 0;
    p.reason = reason;
    p.table.interpolation = "CSPLINE";
    p.table.block_count = 96;
    p.table.command_error_um = 0.42;
    p.table.point_count = 361;
    p.table.correction_max_um = 12.5;
    Status s = store().record_push(run_id, p, sample_program(p.table_version));
    EXPECT_TRUE(s.ok()) << s.error().message;
    return p;
  }
};

TEST_F(NcPushStoreTest, TableVersionsCountUpPerFile) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  Result<int> first = store().next_table_version("/nc/A.SPF");
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(*first, 1) << "a file never pushed starts at 1";

  push_next(run, "/nc/A.SPF");
  push_next(run, "/nc/B.SPF");
  push_next(run, "/nc/A.SPF");
  ASSERT_TRUE(store().record_nc_file(run, "/nc/A.SPF").ok()) << "version 0: the next one";

  EXPECT_EQ(*store().next_table_version("/nc/A.SPF"), 4);
  EXPECT_EQ(*store().next_table_version("/nc/B.SPF"), 2);
  // The history names a program by its file name inside the NC directory of its first push.
  RawDb raw(db_in(dir_));
  EXPECT_EQ(raw.query_text("SELECT group_concat(table_version, ',') FROM"
                           " (SELECT table_version FROM nc_pushes WHERE nc_file = 'A.SPF' ORDER BY id)"),
            "1,2,3");
  EXPECT_EQ(raw.query_text("SELECT path FROM nc_directory"), "/nc");
  EXPECT_EQ(store().last_push("/nc/A.SPF")->value().nc_file, "/nc/A.SPF") << "read back where it was pushed";
  // A program outside that directory keeps its path.
  push_next(run, "/other/C.SPF");
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes WHERE nc_file = '/other/C.SPF'"), 1);
  // The data directory moved: its NC directory in force is another; the history follows it,
  // and the first push there makes it the history's.
  store().set_nc_dir("/moved/nc");
  EXPECT_EQ(*store().next_table_version("/moved/nc/A.SPF"), 4);
  EXPECT_EQ(store().last_push("/moved/nc/A.SPF")->value().nc_file, "/moved/nc/A.SPF");
  EXPECT_FALSE(store().last_push("/nc/A.SPF")->has_value()) << "the old place is not this history's any more";
  push_next(run, "/moved/nc/A.SPF");
  EXPECT_EQ(raw.query_text("SELECT path FROM nc_directory"), "/moved/nc");
  EXPECT_EQ(raw.query_text("SELECT group_concat(table_version, ',') FROM"
                           " (SELECT table_version FROM nc_pushes WHERE nc_file = 'A.SPF' ORDER BY id)"),
            "1,2,3,4");
  EXPECT_EQ(raw.query_text("SELECT reason FROM nc_pushes WHERE table_version = 3"), "run " + std::to_string(run))
      << "an unsaid reason is the run pushed";
}

TEST_F(NcPushStoreTest, AVersionThatIsNotNextIsRefusedAndRecordsNothing) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  const std::int64_t other = add_run("2026-11-22T09:00:00Z");
  push_next(run, "/nc/A.SPF");

  for (int claimed : {1, 3, -1}) {
    NcPush p;
    p.nc_file = "/nc/A.SPF";
    p.table_version = claimed;
    Status s = store().record_push(other, p, "CTABDEF(X,C,1,1)\n");
    ASSERT_FALSE(s.ok()) << "version " << claimed;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
    EXPECT_TRUE(has(s.error().message, "/nc/A.SPF")) << s.error().message;
    if (claimed > 0) {
      EXPECT_TRUE(has(s.error().message, "the next is 2")) << s.error().message;
    }
  }
  RawDb raw(db_in(dir_));
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes"), 1);
  EXPECT_EQ(raw.query_text("SELECT status FROM runs WHERE id = " + std::to_string(other)), "measured")
      << "the run is not marked pushed by a refused push";
}

TEST_F(NcPushStoreTest, TwoWritersCannotBothClaimAVersion) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  Result<RunStore> second = RunStore::open(db_in(dir_));
  ASSERT_TRUE(second.ok()) << second.error().message;
  // Both render version 1 before either records it.
  const int mine = *store().next_table_version("/nc/A.SPF");
  const int theirs = *second->next_table_version("/nc/A.SPF");
  ASSERT_EQ(mine, 1);
  ASSERT_EQ(theirs, 1);
  NcPush p;
  p.nc_file = "/nc/A.SPF";
  p.table_version = mine;
  ASSERT_TRUE(store().record_push(run, p, "first").ok());
  p.table_version = theirs;
  Status s = second->record_push(run, p, "second");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  Result<NcPush> kept = store().load_push("/nc/A.SPF", 1);
  ASSERT_TRUE(kept.ok()) << kept.error().message;
  EXPECT_EQ(kept->program_text, "first");
}

// A program text changed outside SQLite (a damaged page) no longer matches the hash stored with
// it: reading it back for a rollback, or as the last push, is refused naming the push; the full
// check lists it.
TEST_F(NcPushStoreTest, AProgramTextChangedOutsideSqliteIsNeverReadBack) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  push_next(run, "/nc/A.SPF");
  ASSERT_TRUE(store().load_push("/nc/A.SPF", 1).ok());
  RawDb(db_in(dir_)).exec("UPDATE nc_pushes SET program_text = replace(program_text, 'X', 'Y')");
  Result<NcPush> loaded = store().load_push("/nc/A.SPF", 1);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kStorage);
  EXPECT_NE(loaded.error().message.find("table version 1 of /nc/A.SPF: its stored program text does not match"),
            std::string::npos)
      << loaded.error().message;
  EXPECT_NE(loaded.error().message.find("not written to the control"), std::string::npos);
  EXPECT_FALSE(store().last_push("/nc/A.SPF").ok());
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->problems.size(), 1u);
  EXPECT_NE(report->problems[0].find("push 1 (table version 1 of A.SPF): its program text does not match"),
            std::string::npos)
      << report->problems[0];
}

// The files of a push are recorded with its intent and read back once it is completed: the
// table first, with its hash; the others with their texts. A text changed outside SQLite is
// refused on read and listed by the full check; version_that_wrote finds the push behind a
// file by its hash, completed or abandoned.
TEST_F(NcPushStoreTest, EveryFileOfAPushIsRecordedWithItsHashAndText) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  PushIntent intent;
  intent.run_id = run;
  intent.push.nc_file = "/nc/A.SPF";
  intent.push.table_version = 1;
  intent.push.program_text = "N10 G1 X1\n";
  intent.files.push_back(PushFile{PushFileRole::kSpeed, "/nc/A_SPEED.SPF", {}, std::string("N10 F100\n"), 0});
  intent.files.push_back(PushFile{PushFileRole::kMain, "/nc/A_MAIN.MPF", {}, std::string("N10 CALL A\n"), 0});
  Result<std::int64_t> id = store().begin_push(intent);
  ASSERT_TRUE(id.ok()) << id.error().message;
  Result<std::vector<PushFile>> open = store().files_of_last_push("/nc/A.SPF");
  ASSERT_TRUE(open.ok());
  EXPECT_TRUE(open->empty()) << "not the push in force before it is completed";
  ASSERT_TRUE(store().complete_push(*id, "written").ok());
  Result<std::vector<PushFile>> files = store().files_of_last_push("/nc/A.SPF");
  ASSERT_TRUE(files.ok()) << files.error().message;
  ASSERT_EQ(files->size(), 3u);
  EXPECT_EQ((*files)[0].role, PushFileRole::kTable);
  EXPECT_EQ((*files)[0].hash, settings_hash("N10 G1 X1\n"));
  EXPECT_FALSE((*files)[0].text.has_value());
  EXPECT_EQ((*files)[1].role, PushFileRole::kMain);
  EXPECT_EQ((*files)[1].path, "/nc/A_MAIN.MPF");
  EXPECT_EQ((*files)[1].text, std::optional<std::string>("N10 CALL A\n"));
  EXPECT_EQ((*files)[1].table_version, 1);
  EXPECT_EQ((*files)[2].role, PushFileRole::kSpeed);

  // Version 2, abandoned: its speed text is still known as ours.
  intent.push.table_version = 2;
  intent.push.program_text = "N10 G1 X2\n";
  intent.files[0].text = "N10 F200\n";
  Result<std::int64_t> second = store().begin_push(intent);
  ASSERT_TRUE(second.ok()) << second.error().message;
  ASSERT_TRUE(store().abandon_push(*second, "not written").ok());
  EXPECT_EQ(*store().version_that_wrote("/nc/A_SPEED.SPF", settings_hash("N10 F200\n")), std::optional<int>(2));
  EXPECT_EQ(*store().version_that_wrote("/nc/A_SPEED.SPF", settings_hash("N10 F100\n")), std::optional<int>(1));
  EXPECT_EQ(*store().version_that_wrote("/nc/A_SPEED.SPF", settings_hash("N10 F999\n")), std::nullopt);
  EXPECT_EQ(*store().version_that_wrote("/nc/A.SPF", settings_hash("N10 G1 X1\n")), std::optional<int>(1));

  RawDb(db_in(dir_)).exec("UPDATE nc_push_files SET text = 'N10 F1000\n' WHERE text = 'N10 F100\n'");
  Result<std::vector<PushFile>> damaged = store().files_of_last_push("/nc/A.SPF");
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(damaged.error().code, ErrorCode::kStorage);
  EXPECT_NE(damaged.error().message.find("the speed file /nc/A_SPEED.SPF of table version 1: its stored text does "
                                         "not match"),
            std::string::npos)
      << damaged.error().message;
  Result<IntegrityReport> report = check_database_file(db_in(dir_));
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->problems.size(), 1u);
  EXPECT_NE(report->problems[0].find("the speed file A_SPEED.SPF of table version 1: its text does not match"),
            std::string::npos)
      << report->problems[0];
}

TEST_F(NcPushStoreTest, ProgramTextRoundTripsByteForByte) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  push_next(run, "/nc/A.SPF");
  Result<NcPush> loaded = store().load_push("/nc/A.SPF", 1);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  ASSERT_TRUE(loaded->program_text.has_value());
  EXPECT_EQ(loaded->program_text->size(), sample_program(1).size());
  EXPECT_TRUE(*loaded->program_text == sample_program(1)) << "the text differs";
  EXPECT_EQ(loaded->program_hash, settings_hash(sample_program(1)));

  // The text given in NcPush is kept the same way when no argument is passed.
  NcPush p;
  p.nc_file = "/nc/A.SPF";
  p.program_text = "N10 G1 X1\n\n\tN20 M17 \r";
  ASSERT_TRUE(store().record_push(run, p).ok());
  Result<std::optional<NcPush>> last = store().last_push("/nc/A.SPF");
  ASSERT_TRUE(last.ok()) << last.error().message;
  ASSERT_TRUE(last->has_value());
  EXPECT_EQ((*last)->program_text, p.program_text);
}

TEST_F(NcPushStoreTest, ListLoadAndLastPush) {
  const std::int64_t r1 = add_run("2026-11-22T08:00:00Z", 2);
  const std::int64_t r2 = add_run("2026-11-22T09:00:00Z", 3);
  const std::int64_t r3 = add_run("2026-11-22T10:00:00Z", 2, "grinder-2");
  push_next(r1, "/nc/L2.SPF", "run 1");
  push_next(r2, "/nc/L3.SPF");
  push_next(r1, "/nc/L2.SPF", "approved by anna");
  push_next(r3, "/nc/G2_L2.SPF");

  Result<std::vector<NcPush>> all = store().list_pushes(PushQuery{});
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->size(), 4u);
  EXPECT_EQ((*all)[0].nc_file, "/nc/G2_L2.SPF") << "newest first";
  EXPECT_EQ((*all)[3].nc_file, "/nc/L2.SPF");
  for (const NcPush& p : *all) EXPECT_FALSE(p.program_text.has_value()) << "lists stay light";
  EXPECT_EQ((*all)[1].run_id, r1);
  EXPECT_EQ((*all)[1].table_version, 2);
  EXPECT_EQ((*all)[1].reason, "approved by anna");
  EXPECT_EQ((*all)[1].table.interpolation, "CSPLINE");
  EXPECT_EQ((*all)[1].table.block_count, 96);
  EXPECT_EQ((*all)[1].table.command_error_um, 0.42);
  EXPECT_EQ((*all)[1].table.point_count, 361);
  EXPECT_EQ((*all)[1].table.correction_max_um, 12.5);
  EXPECT_GT((*all)[0].id, (*all)[1].id);

  PushQuery by_file;
  by_file.nc_file = "/nc/L2.SPF";
  EXPECT_EQ(store().list_pushes(by_file)->size(), 2u);
  PushQuery by_lobe;
  by_lobe.lobe = 2;
  by_lobe.machine = "grinder-1";
  Result<std::vector<NcPush>> lobe2 = store().list_pushes(by_lobe);
  ASSERT_EQ(lobe2->size(), 2u);
  EXPECT_EQ((*lobe2)[0].run_id, r1);
  PushQuery by_machine;
  by_machine.machine = "grinder-2";
  by_machine.part = "intake_flat";
  ASSERT_EQ(store().list_pushes(by_machine)->size(), 1u);
  PushQuery limited;
  limited.limit = 1;
  ASSERT_EQ(store().list_pushes(limited)->size(), 1u);
  limited.limit = 0;
  EXPECT_EQ(store().list_pushes(limited).error().code, ErrorCode::kInvalidInput);

  Result<NcPush> v1 = store().load_push("/nc/L2.SPF", 1);
  ASSERT_TRUE(v1.ok()) << v1.error().message;
  EXPECT_EQ(v1->reason, "run 1");
  EXPECT_EQ(v1->program_text, sample_program(1));

  Result<NcPush> missing = store().load_push("/nc/L2.SPF", 7);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_TRUE(has(missing.error().message, "/nc/L2.SPF")) << missing.error().message;
  EXPECT_TRUE(has(missing.error().message, "version 7")) << missing.error().message;
  EXPECT_TRUE(has(missing.error().message, "1 to 2")) << missing.error().message;
  Result<NcPush> never = store().load_push("/nc/NEVER.SPF", 1);
  ASSERT_FALSE(never.ok());
  EXPECT_TRUE(has(never.error().message, "nothing was ever pushed")) << never.error().message;

  Result<std::optional<NcPush>> last = store().last_push("/nc/L2.SPF");
  ASSERT_TRUE(last.ok()) << last.error().message;
  ASSERT_TRUE(last->has_value());
  EXPECT_EQ((*last)->table_version, 2);
  EXPECT_EQ((*last)->program_text, sample_program(2));
  Result<std::optional<NcPush>> none = store().last_push("/nc/NEVER.SPF");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());

  // load_run keeps listing the run's pushes, with the new fields and without the text.
  Result<StoredRun> run = store().load_run(r1);
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_EQ(run->pushes.size(), 2u);
  EXPECT_EQ(run->pushes[1].table_version, 2);
  EXPECT_FALSE(run->pushes[1].program_text.has_value());
}

TEST_F(NcPushStoreTest, TheTableInForceAfterARollbackIsTheRolledBackRun) {
  const std::int64_t run1 = add_run("2026-11-22T08:00:00Z");
  const std::int64_t run2 = add_run("2026-11-22T09:00:00Z");
  push_next(run1, "/nc/A.SPF");
  push_next(run2, "/nc/A.SPF");
  EXPECT_EQ(**store().last_pushed_run("grinder-1", "intake_flat", 2), run2);

  // Rollback to version 1: run 1's table goes back on the control.
  Result<NcPush> old = store().load_push("/nc/A.SPF", 1);
  ASSERT_TRUE(old.ok()) << old.error().message;
  NcPush back = *old;
  back.table_version = *store().next_table_version("/nc/A.SPF");
  back.reason = "rollback to version 1";
  back.pushed_utc.clear();
  ASSERT_TRUE(store().record_push(old->run_id, back).ok());

  Result<std::optional<std::int64_t>> in_force = store().last_pushed_run("grinder-1", "intake_flat", 2);
  ASSERT_TRUE(in_force.ok()) << in_force.error().message;
  ASSERT_TRUE(in_force->has_value());
  EXPECT_EQ(**in_force, run1) << "run 2 is newer, but run 1's table is the one on the control";
  Result<std::optional<NcPush>> last = store().last_push("/nc/A.SPF");
  EXPECT_EQ((*last)->table_version, 3);
  EXPECT_EQ((*last)->reason, "rollback to version 1");
  EXPECT_EQ((*last)->program_text, sample_program(1));
}

// ---- Tables awaiting approval ----

PendingTable pending_for(std::int64_t run_id, const std::string& nc_file, const std::string& text) {
  PendingTable t;
  t.run_id = run_id;
  t.nc_file = nc_file;
  t.program_text = text;
  t.verdict = PendingVerdict::kHold;
  t.reason = "correction 31 um exceeds the 25 um step limit";
  t.table.interpolation = "G1";
  t.table.block_count = 721;
  t.table.command_error_um = 0.31;
  t.table.correction_max_um = 31.0;
  t.table.point_count = 721;
  return t;
}

// Every column of one nc_pending row, to show a refusal changed nothing.
std::string pending_row(RawDb& raw, std::int64_t id) {
  return raw.query_text(
      "SELECT status || '|' || coalesce(decided_utc, '-') || '|' || coalesce(decided_by, '-') || '|' ||"
      " coalesce(note, '-') || '|' || coalesce(push_id, '-') || '|' || coalesce(superseded_by, '-')"
      " FROM nc_pending WHERE id = " +
      std::to_string(id));
}

TEST_F(NcPushStoreTest, ANewerPendingTableSupersedesTheOlderOneForTheSameFile) {
  const std::int64_t run1 = add_run("2026-11-22T08:00:00Z");
  const std::int64_t run2 = add_run("2026-11-22T09:00:00Z");
  PendingTable first = pending_for(run1, "/nc/A.SPF", sample_program(1));
  first.created_utc = "2026-11-22T08:01:00Z";
  Result<std::int64_t> a = store().add_pending(first);
  ASSERT_TRUE(a.ok()) << a.error().message;
  Result<std::int64_t> other_file = store().add_pending(pending_for(run1, "/nc/B.SPF", "B"));
  ASSERT_TRUE(other_file.ok()) << other_file.error().message;
  PendingTable second = pending_for(run2, "/nc/A.SPF", sample_program(2));
  second.verdict = PendingVerdict::kApply;
  second.created_utc = "2026-11-22T09:01:00Z";
  Result<std::int64_t> b = store().add_pending(second);
  ASSERT_TRUE(b.ok()) << b.error().message;

  Result<PendingTable> old = store().load_pending(*a);
  ASSERT_TRUE(old.ok()) << old.error().message;
  EXPECT_EQ(old->status, PendingStatus::kSuperseded);
  EXPECT_EQ(old->superseded_by, *b);
  EXPECT_EQ(old->decided_utc, "2026-11-22T09:01:00Z");
  EXPECT_EQ(old->program_text, sample_program(1)) << "kept for the record";
  EXPECT_EQ(store().load_pending(*other_file)->status, PendingStatus::kPending) << "another file is not touched";

  Result<PendingTable> now = store().load_pending(*b);
  ASSERT_TRUE(now.ok());
  EXPECT_EQ(now->status, PendingStatus::kPending);
  EXPECT_EQ(now->verdict, PendingVerdict::kApply);
  EXPECT_EQ(now->run_id, run2);
  EXPECT_EQ(now->program_text, sample_program(2));
  EXPECT_EQ(now->table.block_count, 721);
  EXPECT_EQ(now->table.command_error_um, 0.31);

  PendingQuery waiting;
  waiting.status = PendingStatus::kPending;
  Result<std::vector<PendingTable>> list = store().list_pending(waiting);
  ASSERT_TRUE(list.ok()) << list.error().message;
  ASSERT_EQ(list->size(), 2u);
  EXPECT_EQ((*list)[0].id, *b) << "newest first";
  EXPECT_EQ((*list)[1].id, *other_file);
  EXPECT_TRUE((*list)[0].program_text.empty()) << "lists stay light";
  EXPECT_EQ((*list)[1].verdict, PendingVerdict::kHold);
  EXPECT_EQ((*list)[1].reason, "correction 31 um exceeds the 25 um step limit");
  PendingQuery for_a;
  for_a.nc_file = "/nc/A.SPF";
  EXPECT_EQ(store().list_pending(for_a)->size(), 2u);

  // The schema itself keeps one pending table per file.
  RawDb raw(db_in(dir_));
  EXPECT_NE(raw.exec("INSERT INTO nc_pending (run_id, created_utc, nc_file, program_text, verdict)"
                     " VALUES (1, '2026-11-22T10:00:00Z', 'A.SPF', 'x', 'apply')"),
            SQLITE_OK);
}

TEST_F(NcPushStoreTest, RejectingIsOnlyFromPendingAndARefusalChangesNothing) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  Result<std::int64_t> a = store().add_pending(pending_for(run, "/nc/A.SPF", "A1"));
  ASSERT_TRUE(a.ok()) << a.error().message;
  Status s = store().reject_pending(*a, "anna", "lobe 2 flank looks wrong");
  ASSERT_TRUE(s.ok()) << s.error().message;
  Result<PendingTable> t = store().load_pending(*a);
  EXPECT_EQ(t->status, PendingStatus::kRejected);
  EXPECT_EQ(t->decided_by, "anna");
  EXPECT_EQ(t->note, "lobe 2 flank looks wrong");
  EXPECT_EQ(t->decided_utc.size(), 20u) << t->decided_utc;

  RawDb raw(db_in(dir_));
  const std::string before = pending_row(raw, *a);
  s = store().reject_pending(*a, "bert", "again");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_TRUE(has(s.error().message, "already rejected")) << s.error().message;
  EXPECT_TRUE(has(s.error().message, "anna")) << s.error().message;
  s = store().record_approved_push(*a, NcPush{}, "bert");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_EQ(pending_row(raw, *a), before);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes"), 0) << "a refused approval records no push";
  EXPECT_EQ(raw.query_text("SELECT status FROM runs"), "measured");

  EXPECT_EQ(store().reject_pending(*a + 10, "anna", "").error().code, ErrorCode::kNotFound);
  Result<std::int64_t> b = store().add_pending(pending_for(run, "/nc/A.SPF", "A2"));
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(store().reject_pending(*b, "", "").error().code, ErrorCode::kInvalidInput) << "someone must decide";
  EXPECT_EQ(store().load_pending(*b)->status, PendingStatus::kPending);
}

TEST_F(NcPushStoreTest, AnApprovedPushIsRecordedAndMarkedInOneStep) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  Result<std::int64_t> a = store().add_pending(pending_for(run, "/nc/A.SPF", "as rendered"));
  ASSERT_TRUE(a.ok()) << a.error().message;

  NcPush written;
  written.table_version = *store().next_table_version("/nc/A.SPF");
  written.program_text = sample_program(written.table_version);
  Status s = store().record_approved_push(*a, written, "anna", "checked against the drawing");
  ASSERT_TRUE(s.ok()) << s.error().message;

  Result<PendingTable> t = store().load_pending(*a);
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(t->status, PendingStatus::kApproved);
  EXPECT_EQ(t->decided_by, "anna");
  EXPECT_EQ(t->note, "checked against the drawing");
  Result<std::optional<NcPush>> last = store().last_push("/nc/A.SPF");
  ASSERT_TRUE(last.ok() && last->has_value());
  const NcPush& p = **last;
  EXPECT_EQ(t->push_id, p.id);
  EXPECT_EQ(p.run_id, run);
  EXPECT_EQ(p.table_version, 1);
  EXPECT_EQ(p.reason, "approved by anna");
  EXPECT_EQ(p.program_text, sample_program(1)) << "the text written, not the one kept pending";
  EXPECT_EQ(p.table.interpolation, "G1") << "unset figures come from the pending table";
  EXPECT_EQ(p.table.block_count, 721);
  EXPECT_EQ(p.table.command_error_um, 0.31);
  EXPECT_EQ(p.table.correction_max_um, 31.0);
  EXPECT_EQ(**store().last_pushed_run("grinder-1", "intake_flat", 2), run);
  EXPECT_EQ(store().load_run(run)->summary.status, "pushed");
}

TEST_F(NcPushStoreTest, AFailedApprovedPushLeavesTheTablePendingAndNoPush) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  Result<std::int64_t> a = store().add_pending(pending_for(run, "/nc/A.SPF", "A1"));
  ASSERT_TRUE(a.ok()) << a.error().message;
  RawDb raw(db_in(dir_));
  const std::string before = pending_row(raw, *a);

  NcPush stale;  // rendered as version 2, but the file has none yet
  stale.table_version = 2;
  Status s = store().record_approved_push(*a, stale, "anna");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  NcPush elsewhere;
  elsewhere.nc_file = "/nc/B.SPF";
  s = store().record_approved_push(*a, elsewhere, "anna");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(has(s.error().message, "/nc/A.SPF")) << s.error().message;

  EXPECT_EQ(pending_row(raw, *a), before);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes"), 0);
  EXPECT_EQ(raw.query_text("SELECT status FROM runs"), "measured") << "the run is not marked pushed";

  // Superseded while the approver looked at it: refused, nothing recorded.
  Result<std::int64_t> b = store().add_pending(pending_for(run, "/nc/A.SPF", "A2"));
  ASSERT_TRUE(b.ok());
  s = store().record_approved_push(*a, NcPush{}, "anna");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_TRUE(has(s.error().message, "superseded")) << s.error().message;
  EXPECT_TRUE(has(s.error().message, "pending table " + std::to_string(*b))) << s.error().message;
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes"), 0);
}

TEST_F(NcPushStoreTest, PendingTablesAreRefusedWhenIncomplete) {
  const std::int64_t run = add_run("2026-11-22T08:00:00Z");
  PendingTable no_text = pending_for(run, "/nc/A.SPF", "");
  EXPECT_EQ(store().add_pending(no_text).error().code, ErrorCode::kInvalidInput);
  PendingTable no_run = pending_for(run + 1, "/nc/A.SPF", "x");
  EXPECT_EQ(store().add_pending(no_run).error().code, ErrorCode::kNotFound);
  PendingTable bad_error = pending_for(run, "/nc/A.SPF", "x");
  bad_error.table.command_error_um = -1.0;
  EXPECT_EQ(store().add_pending(bad_error).error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(RawDb(db_in(dir_)).query_int("SELECT count(*) FROM nc_pending"), 0);
}

// ---- Upgrading a version-2 database ----

// A version-2 database with three runs and pushes to two files, interleaved, made with the
// released migrations; push 6 was deleted by hand (its id must not come back).
void make_v2_database(const std::filesystem::path& path) {
  std::filesystem::create_directories(path.parent_path());
  {
    storage_internal::Connection conn;
    conn.path = path;
    ASSERT_EQ(sqlite3_open(path.c_str(), &conn.db), SQLITE_OK);
    Status s = storage_internal::apply_migrations_up_to(conn, 2);
    ASSERT_TRUE(s.ok()) << s.error().message;
  }
  RawDb raw(path);
  for (int run = 1; run <= 3; ++run) {
    const std::string n = std::to_string(run);
    raw.exec(
        "INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, status, revolutions,"
        " degrees_captured, zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um, repeatability_um,"
        " nc_file) VALUES ('2026-11-2" +
        n + "T08:00:00Z', '2026-11-2" + n + "T08:00:05Z', 'grinder-1', 'intake_flat', 2, 'tcp:x', 'pushed', 3, 1080," +
        " 0.2, 7.0, 5.0, 14.0, 0.7, '/nc/A.SPF')");
  }
  // id: 1 A (run 1), 2 B (run 1), 3 A (run 2), 4 A (run 3), 5 B (run 2), 6 A (deleted).
  const char* pushes[] = {"(1, 'A')", "(1, 'B')", "(2, 'A')", "(3, 'A')", "(2, 'B')", "(3, 'A')"};
  for (const char* p : pushes) {
    const std::string v(p);
    raw.exec(
        "INSERT INTO nc_pushes (run_id, pushed_utc, nc_file, point_count, correction_max_um, program_hash)"
        " VALUES (" +
        v.substr(1, 1) + ", '2026-11-25T08:00:00Z', '/nc/" + v.substr(5, 1) + ".SPF', 361, 16.5, '0123456789abcdef')");
  }
  raw.exec("DELETE FROM nc_pushes WHERE id = 6");
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 2);
}

TEST(MigrationFromV2, KeepsEveryPushAndNumbersThemPerFileInPushOrder) {
  TempDir dir;
  make_v2_database(db_in(dir));
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;

  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_text("PRAGMA integrity_check"), "ok");
  EXPECT_EQ(raw.query_int("PRAGMA foreign_key_check"), 0);
  EXPECT_EQ(raw.query_text("SELECT group_concat(id || ':' || nc_file || ':' || table_version, ' ') FROM"
                           " (SELECT * FROM nc_pushes ORDER BY id)"),
            "1:A.SPF:1 2:B.SPF:1 3:A.SPF:2 4:A.SPF:3 5:B.SPF:2");
  // Schema 18: the directory of the newest push is the history's, its programs named by file.
  EXPECT_EQ(raw.query_text("SELECT path FROM nc_directory"), "/nc");
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes WHERE point_count = 361 AND correction_max_um = 16.5"
                          " AND program_hash = '0123456789abcdef' AND run_id IS NOT NULL"),
            5)
      << "what version 2 recorded is kept";
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes WHERE program_text IS NULL AND reason IS NULL"), 5);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_pushes_v3'"), 0);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pending"), 0);

  Result<NcPush> v3 = store->load_push("/nc/A.SPF", 3);
  ASSERT_TRUE(v3.ok()) << v3.error().message;
  EXPECT_EQ(v3->run_id, 3);
  EXPECT_FALSE(v3->program_text.has_value()) << "version 2 did not keep the text";
  EXPECT_EQ(v3->reason, "");
  EXPECT_EQ(*store->next_table_version("/nc/A.SPF"), 4);
  EXPECT_EQ(*store->next_table_version("/nc/B.SPF"), 3);
  EXPECT_EQ(**store->last_pushed_run("grinder-1", "intake_flat", 2), 2) << "push 5 (run 2) was the last";

  NcPush next;
  next.nc_file = "/nc/A.SPF";
  next.table_version = 4;
  ASSERT_TRUE(store->record_push(1, next, "text").ok());
  EXPECT_EQ(raw.query_int("SELECT id FROM nc_pushes WHERE table_version = 4"), 7)
      << "the id of the push deleted by hand is not reused";
}

TEST(MigrationFromV2, AnEmptyVersion2DatabaseUpgrades) {
  TempDir dir;
  std::filesystem::create_directories(db_in(dir).parent_path());
  {
    storage_internal::Connection conn;
    conn.path = db_in(dir);
    ASSERT_EQ(sqlite3_open(db_in(dir).c_str(), &conn.db), SQLITE_OK);
    ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 2).ok());
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ(RawDb(db_in(dir)).query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(*store->next_table_version("/nc/A.SPF"), 1);
}

}  // namespace
}  // namespace gaugeloop
