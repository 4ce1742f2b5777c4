// The speed subprogram beside the table: a push with a speed program writes the speed file,
// the table and the main program into the NC directory, and all three read back: the table
// numbers alternate, the main program couples the one just written and calls the speed
// subprogram, and the speed the control will run is the program's within the bound.
#include "job/speed_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>

#include "core/text_file.h"
#include "nc_out/main_program.h"
#include "nc_out/table_program.h"
#include "tests/support/failing_nc_files.h"
#include "tests/support/sample_runs.h"
#include "tests/support/store_test.h"
#include "tests/support/table_program.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// 30 rpm on the base circle, 10 rpm over C 60..300 with 40 deg cosine ramps.
WorkSpeedProgram slow_flank_program() {
  WorkSpeedProgram p;
  p.c_step_deg = 1.0;
  for (int k = 0; k < 360; ++k) {
    const double c = k;
    double share = 0.0;
    if (c >= 100.0 && c <= 260.0) {
      share = 1.0;
    } else if (c > 60.0 && c < 100.0) {
      share = 0.5 * (1.0 - std::cos(std::numbers::pi * (c - 60.0) / 40.0));
    } else if (c > 260.0 && c < 300.0) {
      share = 0.5 * (1.0 + std::cos(std::numbers::pi * (c - 260.0) / 40.0));
    }
    p.speed_rpm.push_back(30.0 - 20.0 * share);
  }
  return p;
}

class SpeedFilesTest : public testing::StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    if (HasFatalFailure()) return;
    fs::create_directories(dir_ / "nc");
    Result<std::int64_t> id =
        store_->insert_run(testing::sample_run("intake", 1, "grinder-1", "2026-12-01T08:00:00Z", 5.0));
    ASSERT_TRUE(id.ok()) << id.error().message;
    run_ = *id;
    Result<std::string> tmpl = read_regular_file(
        std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_main_speed.mpf", "main template");
    ASSERT_TRUE(tmpl.ok()) << tmpl.error().message;
    main_.template_text = *tmpl;
    main_.template_name = "cam_main_speed.mpf";
    main_.part = "intake";
    main_.lobe = 1;
    main_.created_utc = "2026-12-01T08:05:00Z";

    Result<std::string> speed = speed_text(0);
    ASSERT_TRUE(speed.ok()) << speed.error().message;
    speed_text_ = *speed;
  }

  // The speed program as rendered for `table_version` (0: none named).
  Result<std::string> speed_text(int table_version) const {
    Result<SpeedProfile> profile = write_speed_profile(program_);
    if (!profile) return profile.error();
    Result<std::string> speed_tmpl =
        read_regular_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_speed.spf", "speed template");
    if (!speed_tmpl) return speed_tmpl.error();
    const std::map<std::string, std::string> values = {{"program_name", "CAM_TEST"},
                                                       {"part", "intake"},
                                                       {"lobe", "1"},
                                                       {"version", "test"},
                                                       {"run_id", std::to_string(run_)},
                                                       {"origin", "run " + std::to_string(run_)},
                                                       {"created_utc", "2026-12-01T08:05:00Z"}};
    return render_speed_program(*speed_tmpl, "cam_speed.spf", values, *profile, {run_, table_version});
  }

  fs::path nc_file() const { return dir_ / "nc" / "CAM_TEST.SPF"; }
  fs::path main_file() const { return dir_ / "nc" / "CAM_TEST_MAIN.MPF"; }
  fs::path speed_file() const { return dir_ / "nc" / "CAM_TEST_SPEED.SPF"; }

  Result<PushCompletion> push(NcFiles& files, const std::string* speed = nullptr) {
    PushFacts facts;
    facts.run_id = run_;
    facts.reason = "run " + std::to_string(run_);
    PushOptions options;
    options.files = &files;
    options.main = main_;
    return push_program_with_speed(
        *store_, nc_file(), facts,
        [this](int version) {
          return testing::program_for(run_, version, 1.0 + version, {1, 2});
        },
        speed != nullptr ? *speed : speed_text_, options);
  }

  std::int64_t run_ = 0;
  MainProgramSource main_;
  WorkSpeedProgram program_ = slow_flank_program();
  std::string speed_text_;
};

TEST_F(SpeedFilesTest, TableSpeedAndMainProgramAreWrittenAndReadBack) {
  testing::FailingNcFiles files;
  const int expected[] = {0, 1, 2, 1};
  for (int version = 1; version <= 3; ++version) {
    Result<PushCompletion> r = push(files);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->table_version, version);
    EXPECT_EQ(speed_program_path(nc_file()), speed_file());

    const std::string table = *read_regular_file(nc_file(), "table");
    Result<ParsedTable> t = parse_table_program(table, nc_file().string());
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->table_number, expected[version]);
    EXPECT_TRUE(verify_table_checksum(*t, nc_file().string()).ok());

    const std::string main = *read_regular_file(main_file(), "main program");
    EXPECT_EQ(main.find("{{"), std::string::npos) << main;
    EXPECT_EQ(*coupled_table_number(main, main_file().string()), expected[version]) << main;
    EXPECT_TRUE(check_main_calls_speed_program(main, main_file().string(), "CAM_TEST_SPEED").ok()) << main;
    EXPECT_THAT(main, HasSubstr("\nN10 CAM_TEST "));
    EXPECT_THAT(main, HasSubstr("\nCAM_TEST_SPEED P12"));

    const std::string speed = *read_regular_file(speed_file(), "speed program");
    EXPECT_EQ(speed, speed_text_);
    EXPECT_EQ(speed.find("{{"), std::string::npos) << speed;
    Result<ParsedSpeedProgram> parsed = read_speed_program(nc_file(), files);
    ASSERT_TRUE(parsed.ok()) << parsed.error().message;
    const double bound_percent = SpeedProfileSettings{}.bound_percent;  // the writer's default
    Result<SpeedProfileError> e = check_speed_program(speed, speed_file().string(), program_, bound_percent);
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_LE(e->max_speed_error_percent, bound_percent);
    EXPECT_GT(e->turn_time_s, 2.0 * 2.0) << "the slow flanks take more than twice the 2 s of 30 rpm";
  }
}

TEST_F(SpeedFilesTest, AMainTemplateThatIgnoresTheSpeedIsRefusedBeforeAnythingIsWritten) {
  testing::FailingNcFiles files;
  main_.template_text = *read_regular_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_main.mpf",
                                           "constant-speed main template");
  main_.template_name = "cam_main.mpf";
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(r.error().message, HasSubstr("CAM_TEST_SPEED"));
  EXPECT_FALSE(fs::exists(speed_file()));
  EXPECT_FALSE(fs::exists(nc_file()));
  EXPECT_FALSE(fs::exists(main_file()));
}

TEST_F(SpeedFilesTest, ASpeedFileNotWrittenLeavesTheTableInForceUntouched) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());  // version 1
  const std::string table_before = *read_regular_file(nc_file(), "table");
  files.fail_writes_ending_with = "_SPEED.SPF";
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kIo);
  EXPECT_THAT(r.error().message, HasSubstr("speed program was not written"));
  EXPECT_EQ(*read_regular_file(speed_file(), "speed"), speed_text_);
  EXPECT_EQ(*read_regular_file(nc_file(), "table"), table_before) << "no table pushed without its speed";
  Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
  ASSERT_TRUE(last.ok());
  ASSERT_TRUE(last->has_value());
  EXPECT_EQ((**last).table_version, 1);
}

// Every file of a push is recorded with it. A push whose table was not written puts the speed
// file of the push in force back at once; one cut short (a kill: nothing puts it back) leaves
// the new speed file beside the old table, which compare_push_files names and reconciliation
// writes back as the push in force wrote it. A speed file edited by hand is named and left, and
// a main program gone from the control comes back byte for byte.
TEST_F(SpeedFilesTest, EveryFileOfThePushIsHeldToThePushInForce) {
  testing::FailingNcFiles files;
  Result<std::string> v1 = speed_text(1);
  Result<std::string> v2 = speed_text(2);
  ASSERT_TRUE(v1.ok() && v2.ok());
  ASSERT_NE(*v1, *v2);
  ASSERT_TRUE(push(files, &*v1).ok());  // version 1
  const std::string main_v1 = *read_regular_file(main_file(), "main");
  Result<std::vector<PushFile>> recorded = store_->files_of_last_push(nc_file().string());
  ASSERT_TRUE(recorded.ok()) << recorded.error().message;
  ASSERT_EQ(recorded->size(), 3u);  // the table, its main program and its speed program
  EXPECT_EQ((*recorded)[0].role, PushFileRole::kTable);
  EXPECT_EQ((*recorded)[0].hash, settings_hash(*read_regular_file(nc_file(), "table")));

  files.fail_writes_ending_with = "CAM_TEST.SPF";  // the table, not CAM_TEST_SPEED.SPF
  ASSERT_FALSE(push(files, &*v2).ok());
  files.fail_writes_ending_with.clear();
  EXPECT_EQ(*read_regular_file(speed_file(), "speed"), *v1) << "put back when the table was not written";

  // A kill between the speed file and the table: version 2's speed beside version 1's table.
  ASSERT_TRUE(write_file_atomically(speed_file(), *v2).ok());
  Result<std::vector<PushFileMismatch>> found = compare_push_files(*store_, nc_file(), files);
  ASSERT_TRUE(found.ok()) << found.error().message;
  ASSERT_EQ(found->size(), 1u);
  EXPECT_EQ((*found)[0].file.role, PushFileRole::kSpeed);
  EXPECT_EQ((*found)[0].written_for, std::optional<int>(2));
  EXPECT_EQ(push_file_mismatch_text((*found)[0]),
            "CAM_TEST_SPEED.SPF holds the speed program written for version 2, not that of version 1, the version "
            "in force");
  Result<ReconcileReport> r = reconcile_pushes(*store_, nc_file(), files, &main_);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->files.size(), 1u);
  EXPECT_TRUE(r->files[0].restored);
  EXPECT_EQ(*read_regular_file(speed_file(), "speed"), *v1);
  found = compare_push_files(*store_, nc_file(), files);
  ASSERT_TRUE(found.ok());
  EXPECT_TRUE(found->empty());

  // Edited by hand: named, never overwritten.
  std::string edited = *v1;
  const size_t at = edited.find("F10800.0");
  ASSERT_NE(at, std::string::npos) << edited;
  edited.replace(at, 8, "F12000.0");
  ASSERT_TRUE(write_file_atomically(speed_file(), edited).ok());
  r = reconcile_pushes(*store_, nc_file(), files, &main_);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->files.size(), 1u);
  EXPECT_FALSE(r->files[0].restored);
  EXPECT_FALSE(r->files[0].written_for.has_value());
  EXPECT_THAT(r->messages.back(), HasSubstr("edited by hand"));
  EXPECT_EQ(*read_regular_file(speed_file(), "speed"), edited);
  ASSERT_TRUE(write_file_atomically(speed_file(), *v1).ok());

  // The main program gone: written again as the push wrote it.
  fs::remove(main_file());
  found = compare_push_files(*store_, nc_file(), files);
  ASSERT_TRUE(found.ok());
  ASSERT_EQ(found->size(), 1u);
  EXPECT_TRUE((*found)[0].missing);
  r = reconcile_pushes(*store_, nc_file(), files, nullptr);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(*read_regular_file(main_file(), "main"), main_v1);
}

// A rollback to a version pushed with its speed subprogram writes that speed program again
// (naming the new version), not leaving the newer version's speed beside the older table.
TEST_F(SpeedFilesTest, ARollbackWritesTheSpeedProgramOfTheVersionRolledBackTo) {
  testing::FailingNcFiles files;
  Result<std::string> v1 = speed_text(1);
  ASSERT_TRUE(v1.ok()) << v1.error().message;
  ASSERT_TRUE(push(files, &*v1).ok());   // version 1, slow flanks
  program_.speed_rpm.assign(360, 30.0);  // version 2: one speed all round
  Result<std::string> v2 = speed_text(2);
  ASSERT_TRUE(v2.ok()) << v2.error().message;
  ASSERT_TRUE(push(files, &*v2).ok());
  Result<ParsedSpeedProgram> before = read_speed_program(nc_file(), files);
  ASSERT_TRUE(before.ok()) << before.error().message;

  Result<PushOutcome> back = rollback_to_version(*store_, nc_file().string(), 1, "anna", main_);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->table_version, 3);
  const std::string speed = *read_regular_file(speed_file(), "speed");
  Result<ParsedSpeedProgram> now = read_speed_program(nc_file(), files);
  ASSERT_TRUE(now.ok()) << now.error().message;
  Result<ParsedSpeedProgram> first = parse_speed_program(*v1, "v1");
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(now->body_checksum, first->body_checksum) << "version 1's speed program is back";
  EXPECT_NE(now->body_checksum, before->body_checksum);
  EXPECT_THAT(speed, HasSubstr("; gaugeloop table_version: 3"));
  Result<std::vector<PushFileMismatch>> beside = compare_push_files(*store_, nc_file(), files);
  ASSERT_TRUE(beside.ok());
  EXPECT_TRUE(beside->empty());
}

TEST_F(SpeedFilesTest, AHandEditedSpeedFileIsReportedOnReadBack) {
  testing::FailingNcFiles files;
  ASSERT_TRUE(write_speed_program(nc_file(), speed_text_, files).ok());
  std::string edited = speed_text_;
  const size_t at = edited.find("F10800.0");
  ASSERT_NE(at, std::string::npos) << edited;
  edited.replace(at, 8, "F12000.0");
  ASSERT_TRUE(write_file_atomically(speed_file(), edited).ok());
  Result<ParsedSpeedProgram> back = read_speed_program(nc_file(), files);
  ASSERT_FALSE(back.ok());
  EXPECT_EQ(back.error().code, ErrorCode::kRefused);
  EXPECT_THAT(back.error().message, HasSubstr("CAM_TEST_SPEED.SPF"));
  // And a text that is not a speed program is never written.
  Status s = write_speed_program(nc_file(), "G1 C=IC(360) F100\nM17\n", files);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
}

}  // namespace
}  // namespace gaugeloop
