// The main program beside the table: every push writes the table to the other of two table
// numbers and then the main program coupling it; read back from the NC directory. A main
// program that could not be written leaves the machine coupling the previous table, which
// the new one did not redefine.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "core/atomic_file.h"
#include "core/text_file.h"
#include "job/nc_push.h"
#include "nc_out/main_program.h"
#include "nc_out/table_program.h"
#include "storage/run_store.h"
#include "tests/support/failing_nc_files.h"
#include "tests/support/sample_runs.h"
#include "tests/support/store_test.h"
#include "tests/support/table_program.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

class MainProgramPushTest : public testing::StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    if (HasFatalFailure()) return;
    fs::create_directories(dir_ / "nc");
    Result<std::int64_t> id =
        store_->insert_run(testing::sample_run("intake", 1, "grinder-1", "2026-12-01T08:00:00Z", 5.0));
    ASSERT_TRUE(id.ok()) << id.error().message;
    run_ = *id;
    Result<std::string> tmpl =
        read_regular_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_main.mpf", "main template");
    ASSERT_TRUE(tmpl.ok()) << tmpl.error().message;
    main_.template_text = *tmpl;
    main_.template_name = "cam_main.mpf";
    main_.part = "intake";
    main_.lobe = 1;
    main_.created_utc = "2026-12-01T08:05:00Z";
  }

  fs::path nc_file() const { return dir_ / "nc" / "CAM_TEST.SPF"; }
  fs::path main_file() const { return dir_ / "nc" / "CAM_TEST_MAIN.MPF"; }

  Result<PushCompletion> push(NcFiles& files, const std::function<void(PushStep)>& observer = {},
                              bool archive = false) {
    PushFacts facts;
    facts.run_id = run_;
    facts.reason = "run " + std::to_string(run_);
    PushOptions options;
    options.files = &files;
    options.main = main_;
    options.observer = observer;
    return push_program(
        *store_, nc_file(), facts,
        [this, archive](int version) -> Result<std::string> {
          Result<std::string> p = testing::program_for(run_, version, 1.0 + version, {1, 2});
          if (!p || !archive) return p;
          return *archive_header(nc_file().stem().string(), NcProgramKind::kSubprogram) + *p;
        },
        options);
  }

  // The CTABDEF number of the table on the control.
  int table_on_control() {
    Result<std::string> text = read_regular_file(nc_file(), "table");
    EXPECT_TRUE(text.ok());
    if (!text.ok()) return -1;
    Result<ParsedTable> t = parse_table_program(*text, nc_file().string());
    EXPECT_TRUE(t.ok()) << t.error().message;
    return t.ok() ? t->table_number : -1;
  }

  // The table number the main program on the control couples.
  int coupled() {
    Result<std::string> text = read_regular_file(main_file(), "main program");
    EXPECT_TRUE(text.ok());
    if (!text.ok()) return -1;
    Result<int> n = coupled_table_number(*text, main_file().string());
    EXPECT_TRUE(n.ok()) << n.error().message;
    return n.ok() ? *n : -1;
  }

  std::int64_t run_ = 0;
  MainProgramSource main_;
};

TEST_F(MainProgramPushTest, ThreePushesAlternateTheTableNumberAndTheMainProgramCouplesTheOneJustWritten) {
  testing::FailingNcFiles files;
  const int expected[] = {0, 1, 2, 1};
  for (int version = 1; version <= 3; ++version) {
    Result<PushCompletion> r = push(files);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->table_version, version);
    const std::string table = *read_regular_file(nc_file(), "table");
    const std::string main = *read_regular_file(main_file(), "main program");
    EXPECT_EQ(table_on_control(), expected[version]) << "version " << version;
    EXPECT_NE(table.find("; gaugeloop table_number: " + std::to_string(expected[version]) + "\n"), std::string::npos);
    EXPECT_EQ(coupled(), expected[version]) << "version " << version << ":\n" << main;
    EXPECT_NE(main.find("\nN10 CAM_TEST "), std::string::npos) << "the main program calls the table:\n" << main;
    EXPECT_NE(main.find("EGON(X,\"FINE\",C," + std::to_string(expected[version]) + ",0)"), std::string::npos);
    EXPECT_NE(main.find("table version " + std::to_string(version) + " of run"), std::string::npos) << main;
    EXPECT_EQ(table.find("{{"), std::string::npos) << table;
    EXPECT_EQ(main.find("{{"), std::string::npos) << main;
    // What the history keeps of the version is the table, not the main program.
    Result<NcPush> stored = store_->load_push(nc_file().string(), version);
    ASSERT_TRUE(stored.ok()) << stored.error().message;
    EXPECT_EQ(*stored->program_text, table);
  }
}

// A table renamed into place whose directory then cannot be flushed (EIO) is on the control but
// may not survive a power cut: not reported pushed, not abandoned. The intent stays open, and
// reconciliation records it once the control still holds it.
TEST_F(MainProgramPushTest, ARenameTheDirectoryCannotFlushIsNeitherPushedNorAbandoned) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());
  files.fail_directory_flush = true;
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kIo);
  EXPECT_NE(r.error().message.find("not known to be on its disk"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("nc reconcile"), std::string::npos) << r.error().message;
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).table_version, 1) << "version 2 is not recorded as pushed";
  Result<std::vector<PushIntent>> open = store_->open_push_intents();
  ASSERT_TRUE(open.ok());
  ASSERT_EQ(open->size(), 1u) << "the intent of version 2 stays open";
  EXPECT_EQ(open->front().push.table_version, 2);
  // The control still holds version 2 (no power cut came): reconciliation records it.
  files.fail_directory_flush = false;
  Result<ReconcileReport> settled = reconcile_pushes(*store_, nc_file(), files);
  ASSERT_TRUE(settled.ok()) << settled.error().message;
  EXPECT_EQ(settled->completed, 1);
  last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).table_version, 2);
}

// The main program renamed into place after its table, its directory then not flushed: the push
// is recorded (the table is on the control) and the error says the main program coupling it is
// in place but may not survive a power cut, not that it still couples the previous table.
TEST_F(MainProgramPushTest, AMainProgramTheDirectoryCannotFlushIsSaidToBeInPlace) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());
  files.fail_directory_flush_ending_with = "_MAIN.MPF";
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kIo);
  EXPECT_NE(r.error().message.find("coupling it is in place, but not known to be on the control's disk"),
            std::string::npos)
      << r.error().message;
  EXPECT_EQ(r.error().message.find("still couples the previous table"), std::string::npos) << r.error().message;
  EXPECT_EQ(coupled(), 2);
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).table_version, 2);
  files.fail_directory_flush_ending_with.clear();
  Result<std::vector<PushFileMismatch>> beside = compare_push_files(*store_, nc_file(), files);
  ASSERT_TRUE(beside.ok());
  EXPECT_TRUE(beside->empty()) << "the main program on the control is the one the push recorded";
}

TEST_F(MainProgramPushTest, AMainTemplateWithAnUnknownPlaceholderIsRefusedBeforeAnythingIsWritten) {
  testing::FailingNcFiles files;
  main_.template_text += "; {{wheel_speed}}\n";
  main_.template_name = "/etc/gaugeloop/cam_main.mpf";
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("wheel_speed"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("/etc/gaugeloop/cam_main.mpf"), std::string::npos) << r.error().message;
  EXPECT_FALSE(fs::exists(nc_file()));
  EXPECT_FALSE(fs::exists(main_file()));
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok());
  EXPECT_FALSE(last->has_value()) << "nothing recorded";
  Result<std::vector<PushIntent>> open = store_->open_push_intents();
  ASSERT_TRUE(open.ok());
  EXPECT_TRUE(open->empty());
}

TEST_F(MainProgramPushTest, AMainProgramNotWrittenLeavesTheCouplingOnTheTableTheNewOneDidNotRedefine) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());  // version 1: table 1, coupled
  ASSERT_EQ(coupled(), 1);

  files.fail_writes_ending_with = "_MAIN.MPF";
  Result<PushCompletion> second = push(files);
  ASSERT_FALSE(second.ok()) << "the push fails as a failed table write does";
  EXPECT_EQ(second.error().code, ErrorCode::kIo);
  EXPECT_NE(second.error().message.find("still couples the previous table"), std::string::npos)
      << second.error().message;
  // The control: the new table defines number 2; the main program still calls the subprogram
  // and couples number 1, which running the new subprogram does not redefine.
  EXPECT_EQ(table_on_control(), 2);
  EXPECT_EQ(coupled(), 1);
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok());
  ASSERT_TRUE(last->has_value());
  EXPECT_EQ((**last).table_version, 2) << "the table on the control is recorded";
  Result<std::vector<PushIntent>> open = store_->open_push_intents();
  ASSERT_TRUE(open.ok());
  EXPECT_TRUE(open->empty());

  // The next push goes to number 1, which the stale main program couples: the main program is
  // first pointed at table 2 (the table in force), so table 1 is never redefined while coupled.
  files.fail_writes_ending_with.clear();
  int coupled_when_the_table_was_written = 0;
  Result<PushCompletion> third = push(files, [&](PushStep step) {
    if (step == PushStep::kTemporaryWritten) coupled_when_the_table_was_written = coupled();
  });
  ASSERT_TRUE(third.ok()) << third.error().message;
  EXPECT_EQ(third->table_version, 3);
  EXPECT_EQ(coupled_when_the_table_was_written, 2);
  EXPECT_EQ(table_on_control(), 1);
  EXPECT_EQ(coupled(), 1);
}

// A main program not written after its table (a full disk, or a push cut there) couples the
// older table: the control grinds it while the history holds the newer one. find_stale_main
// names both; reconcile writes it again as the push recorded it (no template needed).
TEST_F(MainProgramPushTest, AMainProgramLeftCouplingTheOlderTableIsFoundAndWrittenAgainByReconcile) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());  // version 1: table 1
  Result<std::optional<StaleMain>> none = find_stale_main(*store_, nc_file(), files);
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->has_value());
  files.fail_writes_ending_with = "_MAIN.MPF";
  ASSERT_FALSE(push(files).ok());  // version 2: table 2 on the control, the main program still couples 1
  files.fail_writes_ending_with.clear();

  Result<std::optional<StaleMain>> stale = find_stale_main(*store_, nc_file(), files);
  ASSERT_TRUE(stale.ok()) << stale.error().message;
  ASSERT_TRUE(stale->has_value());
  EXPECT_EQ((**stale).coupled_number, 1);
  EXPECT_EQ((**stale).coupled_version, 1);
  EXPECT_EQ((**stale).table_number, 2);
  EXPECT_EQ((**stale).table_version, 2);
  EXPECT_EQ(stale_main_text(**stale),
            "CAM_TEST_MAIN.MPF couples table 1, that of version 1, while CAM_TEST.SPF on the control is version 2 "
            "(table 2): the control grinds version 1");

  // A temporary file of an interrupted write of the main program is ours to remove. The push
  // recorded its main program: written again as recorded, without a template.
  const fs::path leftover = dir_ / "nc" / (atomic_temporary_prefix(main_file()) + "k3Jq9z");
  { std::ofstream(leftover) << "half a main program"; }
  Result<ReconcileReport> repaired = reconcile_pushes(*store_, nc_file(), files);
  ASSERT_TRUE(repaired.ok()) << repaired.error().message;
  ASSERT_EQ(repaired->stale_mains.size(), 1u);
  EXPECT_TRUE(repaired->stale_mains[0].repointed);
  EXPECT_EQ(repaired->leftovers_removed, 1);
  EXPECT_FALSE(fs::exists(leftover));
  EXPECT_EQ(coupled(), 2);
  EXPECT_EQ(table_on_control(), 2);
  const std::string main = *read_regular_file(main_file(), "main program");
  EXPECT_NE(main.find("table version 2 of run"), std::string::npos) << main;
  Result<std::optional<StaleMain>> after = find_stale_main(*store_, nc_file(), files);
  ASSERT_TRUE(after.ok());
  EXPECT_FALSE(after->has_value());
}

// At the service's start every pushed file is looked at; one the share cannot give now stops
// nothing when no push to it is open: it is named, and the rest go on.
TEST_F(MainProgramPushTest, ReconcilingEveryFileGoesOnPastOneThatCannotBeReadWithNoOpenPush) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());
  files.fail[testing::FailingNcFiles::Op::kRead] = Error{ErrorCode::kIo, "Input/output error (scripted)"};
  Result<ReconcileReport> r = reconcile_all_pushes(*store_, &main_, files);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->messages.size(), 1u);
  EXPECT_NE(r->messages[0].find(nc_file().string() + ": not checked (Input/output error (scripted))"),
            std::string::npos)
      << r->messages[0];
}

// A table edited on the control is not the one last pushed: the main program is not written for it.
TEST_F(MainProgramPushTest, AMainProgramIsNotWrittenAgainForATableThatIsNotTheOneLastPushed) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());
  files.fail_writes_ending_with = "_MAIN.MPF";
  ASSERT_FALSE(push(files).ok());
  files.fail_writes_ending_with.clear();
  std::string table = *read_regular_file(nc_file(), "table");
  table += "; a comment added at the machine\n";
  ASSERT_TRUE(write_file_atomically(nc_file(), table).ok());
  Result<ReconcileReport> r = reconcile_pushes(*store_, nc_file(), files, &main_);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->stale_mains.size(), 1u);
  EXPECT_FALSE(r->stale_mains[0].repointed);
  ASSERT_FALSE(r->messages.empty());
  EXPECT_NE(r->messages.back().find("not the one last pushed"), std::string::npos) << r->messages.back();
  EXPECT_EQ(coupled(), 1);
}

TEST_F(MainProgramPushTest, ARollbackIsANewVersionAndAlternatesToo) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());  // version 1, table 1
  ASSERT_TRUE(push(files).ok());  // version 2, table 2
  const std::string v2 = *read_regular_file(nc_file(), "table");
  Result<PushOutcome> back = rollback_to_version(*store_, nc_file().string(), 2, "anna", main_);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->table_version, 3);
  EXPECT_EQ(table_on_control(), 1) << "version 3 goes to number 1, not onto the coupled table 2";
  EXPECT_EQ(coupled(), 1);
  // The points are version 2's: only the header and the CTABDEF number changed.
  Result<ParsedTable> now = parse_table_program(*read_regular_file(nc_file(), "table"), "now");
  Result<ParsedTable> then = parse_table_program(v2, "v2");
  ASSERT_TRUE(now.ok() && then.ok());
  EXPECT_EQ(now->body_checksum, then->body_checksum);
  EXPECT_EQ(now->header["table_version"], "3");
  EXPECT_EQ(now->header["table_number"], "1");
}

// With the archive header the table and the main program start with the punched-tape lines the
// HMI reads; each push checks the table on the control before overwriting it, the header and
// all, and a rollback keeps it.
TEST_F(MainProgramPushTest, ProgramsWithTheArchiveHeaderArePushedReadBackAndVerified) {
  testing::FailingNcFiles files;
  for (int version = 1; version <= 3; ++version) {
    Result<PushCompletion> r = push(files, {}, /*archive=*/true);
    ASSERT_TRUE(r.ok()) << "version " << version << ": " << r.error().message;
    const std::string table = *read_regular_file(nc_file(), "table");
    const std::string main = *read_regular_file(main_file(), "main program");
    EXPECT_EQ(table.rfind("%_N_CAM_TEST_SPF\n;$PATH=/_N_SPF_DIR\n;", 0), 0u) << table.substr(0, 200);
    EXPECT_EQ(main.rfind("%_N_CAM_TEST_MAIN_MPF\n;$PATH=/_N_MPF_DIR\n;", 0), 0u) << main.substr(0, 200);
    Result<ParsedTable> t = parse_table_program(table, nc_file().string());
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_TRUE(verify_table_checksum(*t, nc_file().string()).ok());
    EXPECT_EQ(t->table_number, version % 2 == 1 ? 1 : 2);
    EXPECT_EQ(coupled(), t->table_number);
    EXPECT_NE(main.find("\nN10 CAM_TEST "), std::string::npos) << main;
    EXPECT_TRUE(check_not_edited_by_hand(*store_, nc_file(), files).ok());
  }
  Result<PushOutcome> back = rollback_to_version(*store_, nc_file().string(), 2, "anna", main_);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(read_regular_file(nc_file(), "table")->rfind("%_N_CAM_TEST_SPF\n", 0), 0u);
  EXPECT_EQ(read_regular_file(main_file(), "main")->rfind("%_N_CAM_TEST_MAIN_MPF\n", 0), 0u);
  // A hand edit under the header is still caught.
  std::string edited = *read_regular_file(nc_file(), "table");
  const std::size_t x = edited.find(" X", edited.find("CTABDEF"));
  edited.insert(x + 2, "9");
  ASSERT_TRUE(write_file_atomically(nc_file(), edited));
  Status s = check_not_edited_by_hand(*store_, nc_file(), files);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
}

TEST(ArchiveHeader, NamesTheProgramAndItsDirectoryAndRefusesANameTheHmiCannotRead) {
  EXPECT_EQ(*archive_header("CAM_INTAKE_L1", NcProgramKind::kSubprogram),
            "%_N_CAM_INTAKE_L1_SPF\n;$PATH=/_N_SPF_DIR\n");
  EXPECT_EQ(*archive_header("CAM_INTAKE_L1_MAIN", NcProgramKind::kMainProgram),
            "%_N_CAM_INTAKE_L1_MAIN_MPF\n;$PATH=/_N_MPF_DIR\n");
  for (const char* bad : {"", "CAM-1", "CAM 1", "A_NAME_LONGER_THAN_24_CHARS"}) {
    Result<std::string> h = archive_header(bad, NcProgramKind::kSubprogram);
    ASSERT_FALSE(h.ok()) << bad;
    EXPECT_EQ(h.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(h.error().message.find("archive_header = false"), std::string::npos) << h.error().message;
  }
}

TEST(WithTableVersion, SetsTheNumberOfTheVersionWhenTheHeaderNamesThePair) {
  Result<std::string> p = testing::program_for(9, 0, 1.0, {4, 5});
  ASSERT_TRUE(p.ok()) << p.error().message;
  for (int version : {1, 2, 3}) {
    Result<std::string> v = with_table_version(*p, version);
    ASSERT_TRUE(v.ok()) << v.error().message;
    Result<ParsedTable> t = parse_table_program(*v, "v");
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->table_number, version % 2 == 1 ? 4 : 5);
    EXPECT_TRUE(verify_table_checksum(*t, "v").ok());
  }
  // A program written before the header named its numbers keeps its number.
  Result<std::string> old = testing::program_for(9, 1, 1.0);
  ASSERT_TRUE(old.ok());
  Result<std::string> v = with_table_version(*old, 2);
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(parse_table_program(*v, "v")->table_number, 1);
}

}  // namespace
}  // namespace gaugeloop
