// The slides' two files in the NC directory: written as a pair, read back as the tables in
// force, and never left half new when the second cannot be written.
#include "job/slide_files.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/text_file.h"
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

TEST(SlideFiles, ThePairIsWrittenAndReadBackAsTheTablesInForce) {
  testing::TempDir dir;
  Result<std::vector<SlideCompensationTable>> none = slide_tables_in_force(dir.path(), {});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  ASSERT_TRUE(push_slide_tables(dir.path(), tables_of(1.0), {}, {{"source", "test"}}).ok());
  Result<std::vector<SlideCompensationTable>> back = slide_tables_in_force(dir.path(), {});
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(back->at(i).input_axis, tables_of(1.0)[i].input_axis);
    EXPECT_EQ(back->at(i).output_axis, tables_of(1.0)[i].output_axis);
    EXPECT_NEAR(back->at(i).error_mm.back(), tables_of(1.0)[i].error_mm.back(), 1e-12);
  }
  // Edited by hand: refused when read as the tables in force.
  const fs::path lec = slide_file(dir.path(), SlideTableKind::kLeadscrew);
  std::string text = *read_regular_file(lec, "t");
  text.replace(text.find("=0.0020"), 7, "=0.0021");
  ASSERT_TRUE(write_file_atomically(lec, text).ok());
  Result<std::vector<SlideCompensationTable>> edited = slide_tables_in_force(dir.path(), {});
  ASSERT_FALSE(edited.ok());
  EXPECT_EQ(edited.error().code, ErrorCode::kRefused);
}

TEST(SlideFiles, WhenTheSecondFileCannotBeWrittenTheFirstIsPutBack) {
  testing::TempDir dir;
  ASSERT_TRUE(push_slide_tables(dir.path(), tables_of(1.0), {}, {}).ok());
  const fs::path cec = slide_file(dir.path(), SlideTableKind::kInterpolatory);
  const std::string cec_before = *read_regular_file(cec, "t");
  testing::FailingNcFiles files;
  files.fail_writes_ending_with = "AX_EEC.INI";
  Status s = push_slide_tables(dir.path(), tables_of(2.0), {}, {}, files);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kIo);
  EXPECT_THAT(s.error().message, HasSubstr("No space left on device"));
  EXPECT_THAT(s.error().message, HasSubstr("was put back as it was"));
  EXPECT_EQ(*read_regular_file(cec, "t"), cec_before);
  // With none before, the new CEC file is removed again.
  testing::TempDir fresh;
  s = push_slide_tables(fresh.path(), tables_of(2.0), {}, {}, files);
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("(new) was removed again"));
  EXPECT_FALSE(fs::exists(slide_file(fresh.path(), SlideTableKind::kInterpolatory)));
  // Tables that cannot be rendered write nothing.
  std::vector<SlideCompensationTable> bad = tables_of(1.0);
  bad[2].error_mm[1] = std::nan("");
  testing::TempDir untouched;
  EXPECT_EQ(push_slide_tables(untouched.path(), bad, {}, {}).error().code, ErrorCode::kInvalidInput);
  EXPECT_TRUE(fs::is_empty(untouched.path()));
}

}  // namespace
}  // namespace gaugeloop
