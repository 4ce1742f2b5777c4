// The slides' two files in the NC directory: pushed as a pair through the push journal (versions,
// rollback, hand edits refused), read back as the tables in force, and never left half new when
// the second cannot be written.
#include "job/slide_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/text_file.h"
#include "job/nc_push.h"
#include "storage/run_store.h"
#include "tests/support/failing_nc_files.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::vector<SlideCompensationTable> tables_of(double scale) {
  std::vector<SlideCompensationTable> out;
  const char layout[4][2] = {{'Y', 'Y'}, {'Z', 'Z'}, {'Z', 'Y'}, {'Y', 'Z'}};
  for (int i = 0; i < 4; ++i) {
    SlideCompensationTable t;
    t.kind = i < 2 ? SlideTableKind::kLeadscrew : SlideTableKind::kInterpolatory;
    t.input_axis = layout[i][0];
    t.output_axis = layout[i][1];
    t.min_mm = -10.0;
    t.step_mm = 5.0;
    for (int k = 0; k < 5; ++k) t.error_mm.push_back(scale * (i + 1) * (k - 2) * 1e-3);
    out.push_back(t);
  }
  return out;
}

// A run database and an NC directory in a temporary directory.
struct SlideDir {
  testing::TempDir dir{"slide-files"};
  fs::path nc = dir.path() / "nc";
  Result<RunStore> store = open();
  Result<RunStore> open() {
    fs::create_directories(nc);
    return RunStore::open(dir.path() / "gaugeloop.sqlite");
  }
  fs::path lec() const { return slide_file(nc, SlideTableKind::kLeadscrew); }
  fs::path cec() const { return slide_file(nc, SlideTableKind::kInterpolatory); }
};

void expect_tables(const std::vector<SlideCompensationTable>& got, double scale) {
  ASSERT_EQ(got.size(), 4u);
  const std::vector<SlideCompensationTable> want = tables_of(scale);
  for (std::size_t i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(got[i].kind, want[i].kind);
    EXPECT_EQ(got[i].input_axis, want[i].input_axis);
    EXPECT_EQ(got[i].output_axis, want[i].output_axis);
    ASSERT_EQ(got[i].error_mm.size(), want[i].error_mm.size());
    for (std::size_t k = 0; k < want[i].error_mm.size(); ++k)
      EXPECT_NEAR(got[i].error_mm[k], want[i].error_mm[k], 1e-12);
  }
}

// Pushed as one version of AX_EEC.INI with NC_CEC.INI beside it: the history holds both texts,
// and a rollback puts the earlier pair back, both files naming the new version.
TEST(SlideFiles, ThePairIsPushedWithItsVersionsAndRolledBackTogether) {
  SlideDir d;
  ASSERT_TRUE(d.store.ok()) << d.store.error().message;
  Result<std::vector<SlideCompensationTable>> none = slide_tables_in_force(d.nc, {});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  const SlideAxisNames names{"Y2", "Z3"};
  Result<PushCompletion> v1 = push_slide_tables(*d.store, d.nc, tables_of(1.0), names, SlidePush{"ballbar 1"});
  ASSERT_TRUE(v1.ok()) << v1.error().message;
  EXPECT_EQ(v1->table_version, 1);
  Result<std::vector<SlideCompensationTable>> back = slide_tables_in_force(d.nc, names);
  ASSERT_TRUE(back.ok()) << back.error().message;
  expect_tables(*back, 1.0);
  Result<PushCompletion> v2 = push_slide_tables(*d.store, d.nc, tables_of(2.0), names, SlidePush{"ballbar 2"});
  ASSERT_TRUE(v2.ok()) << v2.error().message;
  EXPECT_EQ(v2->table_version, 2);
  expect_tables(*slide_tables_in_force(d.nc, names), 2.0);
  Result<std::vector<PushFile>> files = d.store->files_of_push(d.lec().string(), 1);
  ASSERT_TRUE(files.ok()) << files.error().message;
  const auto cec1 =
      std::find_if(files->begin(), files->end(), [](const PushFile& f) { return f.role == PushFileRole::kCec; });
  ASSERT_NE(cec1, files->end()) << "version 1's CEC file is not in the history";
  ASSERT_TRUE(cec1->text.has_value());
  EXPECT_THAT(*cec1->text, HasSubstr("; gaugeloop table_version: 1\n"));

  Result<PushOutcome> rolled = rollback_to_version(*d.store, d.lec().string(), 1, "anna");
  ASSERT_TRUE(rolled.ok()) << rolled.error().message;
  EXPECT_EQ(rolled->table_version, 3);
  expect_tables(*slide_tables_in_force(d.nc, names), 1.0);  // both files: the CEC tables are 3 and 4
  for (const fs::path& f : {d.lec(), d.cec()}) {
    EXPECT_THAT(*read_regular_file(f, "t"), HasSubstr("; gaugeloop table_version: 3\n")) << f;
  }
  Result<std::vector<NcPush>> history = d.store->list_pushes(PushQuery{});
  ASSERT_TRUE(history.ok());
  ASSERT_EQ(history->size(), 3u);
  EXPECT_EQ(history->front().reason, "rollback to version 1 by anna");
  EXPECT_EQ(history->back().reason, "slide tables from ballbar 1");
}

// A file edited by hand is refused, the LEC file by the journal's check and the CEC file beside
// it by its own; both read as the tables in force refuse it too. Overwriting is a person's choice.
TEST(SlideFiles, TablesEditedByHandAreRefusedUnlessOverwriting) {
  SlideDir d;
  ASSERT_TRUE(d.store.ok()) << d.store.error().message;
  ASSERT_TRUE(push_slide_tables(*d.store, d.nc, tables_of(1.0), {}, SlidePush{"test"}).ok());
  for (const fs::path& f : {d.lec(), d.cec()}) {
    SCOPED_TRACE(f.string());
    const std::string before = *read_regular_file(f, "t");
    std::string text = before;
    const std::size_t at = text.find("=0.00");
    ASSERT_NE(at, std::string::npos) << text;
    text[at + 5] = text[at + 5] == '9' ? '8' : '9';
    ASSERT_TRUE(write_file_atomically(f, text).ok());
    Result<std::vector<SlideCompensationTable>> edited = slide_tables_in_force(d.nc, {});
    ASSERT_FALSE(edited.ok());
    EXPECT_EQ(edited.error().code, ErrorCode::kRefused);
    Result<PushCompletion> refused = push_slide_tables(*d.store, d.nc, tables_of(2.0), {}, SlidePush{"test"});
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::kRefused);
    EXPECT_THAT(refused.error().message, HasSubstr(f.filename().string()));
    EXPECT_THAT(refused.error().message, HasSubstr("--overwrite-edited"));
    EXPECT_EQ(*read_regular_file(f, "t"), text) << "a refused push wrote";
    ASSERT_TRUE(write_file_atomically(f, before).ok());
  }
  // Copied in from another push: sound, but not the CEC file the last push wrote.
  const std::string cec1 = *read_regular_file(d.cec(), "t");
  ASSERT_TRUE(push_slide_tables(*d.store, d.nc, tables_of(2.0), {}, SlidePush{"test"}).ok());
  ASSERT_TRUE(write_file_atomically(d.cec(), cec1).ok());
  Result<PushCompletion> copied = push_slide_tables(*d.store, d.nc, tables_of(3.0), {}, SlidePush{"test"});
  ASSERT_FALSE(copied.ok());
  EXPECT_THAT(copied.error().message, HasSubstr("not the CEC file the last push"));
  Result<PushCompletion> overwritten =
      push_slide_tables(*d.store, d.nc, tables_of(3.0), {}, SlidePush{"test", /*overwrite_edited=*/true});
  ASSERT_TRUE(overwritten.ok()) << overwritten.error().message;
  expect_tables(*slide_tables_in_force(d.nc, {}), 3.0);
}

TEST(SlideFiles, WhenTheSecondFileCannotBeWrittenTheFirstIsPutBack) {
  SlideDir d;
  ASSERT_TRUE(d.store.ok()) << d.store.error().message;
  ASSERT_TRUE(push_slide_tables(*d.store, d.nc, tables_of(1.0), {}, SlidePush{"test"}).ok());
  const std::string cec_before = *read_regular_file(d.cec(), "t");
  const std::string lec_before = *read_regular_file(d.lec(), "t");
  testing::FailingNcFiles files;
  files.fail_writes_ending_with = "AX_EEC.INI";
  Result<PushCompletion> failed =
      push_slide_tables(*d.store, d.nc, tables_of(2.0), {}, SlidePush{"test", false, &files});
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().code, ErrorCode::kIo);
  EXPECT_THAT(failed.error().message, HasSubstr("No space left on device"));
  EXPECT_EQ(*read_regular_file(d.cec(), "t"), cec_before);
  EXPECT_EQ(*read_regular_file(d.lec(), "t"), lec_before);
  Result<std::optional<NcPush>> last = d.store->last_push(d.lec().string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).table_version, 1) << "a push that failed was recorded";
  // With none before, the new CEC file is removed again.
  SlideDir fresh;
  ASSERT_TRUE(fresh.store.ok());
  failed = push_slide_tables(*fresh.store, fresh.nc, tables_of(2.0), {}, SlidePush{"test", false, &files});
  ASSERT_FALSE(failed.ok());
  EXPECT_THAT(failed.error().message, HasSubstr("(new) was removed again"));
  EXPECT_FALSE(fs::exists(fresh.cec()));
  // Tables that cannot be rendered write nothing.
  std::vector<SlideCompensationTable> bad = tables_of(1.0);
  bad[2].error_mm[1] = std::nan("");
  SlideDir untouched;
  ASSERT_TRUE(untouched.store.ok());
  EXPECT_EQ(push_slide_tables(*untouched.store, untouched.nc, bad, {}, SlidePush{"test"}).error().code,
            ErrorCode::kInvalidInput);
  EXPECT_TRUE(fs::is_empty(untouched.nc));
}

}  // namespace
}  // namespace gaugeloop
