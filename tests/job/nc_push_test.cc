// The push's error paths through the file-system seam: each operation on the NC directory made
// to fail in turn. Whatever fails, the program on the control and the history agree, and the
// journal has no open intent left.
#include "job/nc_push.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "core/text_file.h"
#include "storage/run_store.h"
#include "tests/support/failing_nc_files.h"
#include "tests/support/sample_runs.h"
#include "tests/support/store_test.h"
#include "tests/support/table_program.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::FailingNcFiles;
using Op = FailingNcFiles::Op;

class PushSeamTest : public testing::StoreTest {
 protected:
  void SetUp() override {
    StoreTest::SetUp();
    if (HasFatalFailure()) return;
    fs::create_directories(dir_ / "nc");
    Result<std::int64_t> id =
        store_->insert_run(testing::sample_run("intake", 1, "grinder-1", "2026-12-01T08:00:00Z", 5.0));
    ASSERT_TRUE(id.ok()) << id.error().message;
    run_ = *id;
  }

  fs::path nc_file() const { return dir_ / "nc" / "CAM_TEST.SPF"; }

  Result<PushCompletion> push(NcFiles& files) {
    PushFacts facts;
    facts.run_id = run_;
    facts.reason = "run " + std::to_string(run_);
    PushOptions options;
    options.files = &files;
    return push_program(
        *store_, nc_file(), facts, [this](int version) { return testing::program_for(run_, version, 1.0 + version); },
        options);
  }

  // The control and the history agree: the file holds the program last recorded (or neither
  // exists), and no intent is open.
  void expect_agreement(const std::string& context) {
    Result<std::optional<NcPush>> last = store_->last_push(nc_file().string());
    ASSERT_TRUE(last.ok()) << last.error().message;
    if (*last) {
      Result<std::string> on_control = read_regular_file(nc_file(), "NC program");
      ASSERT_TRUE(on_control.ok()) << context << ": " << on_control.error().message;
      EXPECT_EQ(*on_control, *(**last).program_text) << context;
    } else {
      EXPECT_FALSE(fs::exists(nc_file())) << context << ": a program the history does not know";
    }
    Result<std::vector<PushIntent>> open = store_->open_push_intents();
    ASSERT_TRUE(open.ok());
    EXPECT_TRUE(open->empty()) << context << ": an intent is left open";
  }

  std::int64_t run_ = 0;
};

TEST_F(PushSeamTest, AFailedWriteLeavesTheProgramInForceAndAbandonsTheIntent) {
  FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());  // version 1 on the control
  const std::string in_force = *read_regular_file(nc_file(), "NC program");

  files.fail[Op::kWrite] = Error{ErrorCode::kIo, "No space left on device (scripted)"};
  Result<PushCompletion> second = push(files);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kIo);
  EXPECT_NE(second.error().message.find("table version 2 was not pushed"), std::string::npos) << second.error().message;
  EXPECT_NE(second.error().message.find("No space left on device"), std::string::npos) << second.error().message;
  EXPECT_EQ(*read_regular_file(nc_file(), "NC program"), in_force);
  expect_agreement("after the failed write");

  files.fail.clear();
  Result<PushCompletion> third = push(files);
  ASSERT_TRUE(third.ok()) << third.error().message;
  EXPECT_EQ(third->table_version, 2) << "the abandoned version is taken again";
  expect_agreement("after the next push");
}

TEST_F(PushSeamTest, ALockHeldElsewhereWritesNothingAndRecordsNothing) {
  FailingNcFiles files;
  files.fail[Op::kLock] = Error{ErrorCode::kIo, "NC directory locked by another gaugeloop (scripted)"};
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("locked by another gaugeloop"), std::string::npos) << r.error().message;
  EXPECT_EQ(files.calls, std::vector<Op>{Op::kLock}) << "nothing is read or written without the lock";
  Result<std::vector<PushIntent>> open = store_->open_push_intents();
  ASSERT_TRUE(open.ok());
  EXPECT_TRUE(open->empty());
  expect_agreement("after the refused lock");
}

TEST_F(PushSeamTest, AProgramThatCannotBeReadIsNotOverwritten) {
  FailingNcFiles files;
  ASSERT_TRUE(push(files).ok());
  const std::string in_force = *read_regular_file(nc_file(), "NC program");
  // Reconciliation reads the table and its main program (are they coupled?), as the hand-edit check reads the table.
  files.fail[Op::kRead] = Error{ErrorCode::kIo, "NC program: Permission denied (scripted)"};
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("Permission denied"), std::string::npos) << r.error().message;
  EXPECT_EQ(std::count(files.calls.begin(), files.calls.end(), Op::kWrite), 1) << "only the first push wrote";
  EXPECT_EQ(*read_regular_file(nc_file(), "NC program"), in_force);
  expect_agreement("after the refused read");
}

TEST_F(PushSeamTest, LeftoversThatCannotBeRemovedStopThePushBeforeItWrites) {
  FailingNcFiles files;
  files.fail[Op::kRemoveLeftovers] = Error{ErrorCode::kIo, "cannot remove .CAM_TEST.SPF.tmp-abc123 (scripted)"};
  Result<PushCompletion> r = push(files);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cannot remove"), std::string::npos) << r.error().message;
  EXPECT_EQ(std::count(files.calls.begin(), files.calls.end(), Op::kWrite), 0);
  expect_agreement("after the failed clean-up");
}

}  // namespace
}  // namespace gaugeloop
