// `gaugeloop runs report` and `runs trend --plot` as a user runs them: the real binary on a
// run database the test makes, the file left behind, and what is refused.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>

#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::run_command;
using testing::slurp;

using testing::has;

class ReportCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (const char* started : {"2026-11-22T01:00:00Z", "2026-11-22T02:00:00Z"}) {
      auto id = store->insert_run(testing::sample_run("intake_flat", 1, "grinder-1", started, 5.0));
      ASSERT_TRUE(id.ok()) << id.error().message;
    }
  }
  std::string data() const { return " --data-dir " + dir_.path().string(); }
  std::size_t files_in_out() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(out_.path())) ++n;
    return n;
  }

  testing::TempDir dir_;
  testing::TempDir out_{"report-out"};
};

TEST_F(ReportCommand, WritesEachFormatFromAReadOnlyDatabase) {
  // The report only reads: a database without write permission serves it.
  ASSERT_EQ(::chmod((dir_ / "gaugeloop.sqlite").c_str(), 0444), 0);
  for (const char* name : {"run2.pdf", "run2.svg", "run2.png"}) {
    const fs::path out = out_ / name;
    CommandResult r = run_command("runs report 2" + data() + " --out " + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_TRUE(has(r.output, "report of run 2 written to " + out.string())) << r.output;
  }
  EXPECT_EQ(slurp(out_ / "run2.pdf").rfind("%PDF-", 0), 0u);
  EXPECT_TRUE(has(slurp(out_ / "run2.svg"), "<svg"));
  EXPECT_EQ(slurp(out_ / "run2.png").substr(1, 3), "PNG");
  EXPECT_EQ(files_in_out(), 3u);
}

TEST_F(ReportCommand, RefusesAMissingRunABadExtensionAndAMissingDirectory) {
  CommandResult r = run_command("runs report 9" + data() + " --out " + (out_ / "run9.pdf").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "run 9")) << r.output;
  EXPECT_TRUE(has(r.output, "runs list")) << r.output;

  r = run_command("runs report 1" + data() + " --out " + (out_ / "run1.jpg").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "run1.jpg")) << r.output;
  EXPECT_TRUE(has(r.output, ".pdf, .svg or .png")) << r.output;

  r = run_command("runs report 1" + data() + " --out " + (out_ / "no-such-dir" / "run1.pdf").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no-such-dir")) << r.output;
  EXPECT_EQ(files_in_out(), 0u);

  r = run_command("runs report 1 --data-dir " + (out_ / "none").string() + " --out " + (out_ / "r.pdf").string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_FALSE(fs::exists(out_ / "none" / "gaugeloop.sqlite")) << "the database is never created";
}

// A report that cannot be written (a directory where the file goes) is the output file's exit
// status, not the NC output's: a script must not read it as "no table pushed".
TEST_F(ReportCommand, AReportThatCannotBeWrittenExitsWithTheOutputFilesCode) {
  fs::create_directories(out_ / "taken.pdf" / "inside");
  CommandResult r = run_command("runs report 1" + data() + " --out " + (out_ / "taken.pdf").string());
  EXPECT_EQ(r.exit_code, 7) << r.output;
  EXPECT_TRUE(has(r.output, "taken.pdf")) << r.output;
  EXPECT_TRUE(fs::is_directory(out_ / "taken.pdf" / "inside")) << "what was there stays";
}

TEST_F(ReportCommand, TrendPlotRefusesAKeyNoRunHas) {
  CommandResult r = run_command("runs trend --part intake_flat --lobe 1" + data() + " --plot " +
                                (out_ / "t.svg").string() + " --characteristic roundness");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "has the characteristic roundness")) << r.output;
  EXPECT_EQ(files_in_out(), 0u);

  r = run_command("runs trend --part intake_flat --lobe 1" + data() + " --characteristic phase");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "--plot")) << r.output;

  r = run_command("runs trend --part intake_flat --lobe 7" + data() + " --plot " + (out_ / "t.png").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no runs of intake_flat lobe 7")) << r.output;
}

}  // namespace
}  // namespace gaugeloop
