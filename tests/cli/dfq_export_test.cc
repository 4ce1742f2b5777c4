// `gaugeloop runs export --format dfq` as a user runs it: the real binary on a database filled
// through RunStore, the file read back with the tests' own AQDEF reader, and the refusals.
#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/tolerance.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/dfq_reader.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::DfqFile;
using testing::read_dfq;
using testing::run_command;

using testing::has;

// Runs stored without characteristics, as runs measured before the part file had tolerances
// are; their harmonics (0.1 um * order) are in the analysis.
class DfqExportCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> store = RunStore::open(tmp_.path() / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    const std::vector<std::string> starts = {"2026-11-20T08:00:00Z", "2026-11-21T08:00:00Z", "2026-11-21T09:00:00Z"};
    for (std::size_t i = 0; i < starts.size(); ++i) {
      RunRecord r = testing::sample_run("intake", i == 2 ? 2 : 1, "g1", starts[i], 5.0);
      r.serial = i == 0 ? "S-1" : "S-2";
      r.operator_name = "Ana";
      for (std::size_t k = 0; k < r.analysis.harmonic_amplitude_um.size(); ++k) {
        r.analysis.harmonic_amplitude_um[k] = 0.1 * static_cast<double>(k);
      }
      Result<std::int64_t> id = store->insert_run(r);
      ASSERT_TRUE(id.ok()) << id.error().message;
      ids_.push_back(*id);
    }
    data_ = " --data-dir " + tmp_.path().string();
  }

  testing::TempDir tmp_;
  std::vector<std::int64_t> ids_;
  std::string data_;
};

TEST_F(DfqExportCommand, RunsWithoutCharacteristicsAreRefusedSayingWhy) {
  CommandResult r = run_command("runs export --format dfq --part intake --lobe 1" + data_);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no characteristics recorded for part intake lobe 1")) << r.output;
  EXPECT_TRUE(has(r.output, "before the part file had tolerances")) << r.output;
}

TEST_F(DfqExportCommand, AShaftsHarmonicsToAFile) {
  const fs::path out = tmp_.path() / "shaft.dfq";
  CommandResult r = run_command("runs export --format dfq --serial S-2 --harmonics 2 --out " + out.string() + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "2 runs exported to " + out.string())) << r.output;
  Result<DfqFile> file = read_dfq(testing::slurp(out));
  ASSERT_TRUE(file.ok()) << file.error().message;
  // Runs 2 (lobe 1) and 3 (lobe 2): one part block each, two harmonics each.
  ASSERT_EQ(file->parts.size(), 2u);
  EXPECT_EQ(file->parts[0].fields.at("K1001"), "intake");
  EXPECT_EQ(file->parts[0].fields.at("K1002"), "lobe 1");
  EXPECT_EQ(file->parts[1].fields.at("K1002"), "lobe 2");
  ASSERT_EQ(file->total_characteristics, 4);
  EXPECT_EQ(file->characteristics[1].fields.at("K2001"), "harmonic.2");
  ASSERT_EQ(file->characteristics[1].values.size(), 1u);
  EXPECT_EQ(file->characteristics[1].values[0].fields.at("K0001"), "0.200");
  EXPECT_EQ(file->characteristics[1].values[0].fields.at("K0006"), std::to_string(ids_[1]));
  EXPECT_EQ(file->characteristics[3].values[0].fields.at("K0014"), "S-2");
  EXPECT_EQ(file->characteristics[3].values[0].fields.at("K0004"), "21.11.2026/09:00:00");
}

TEST_F(DfqExportCommand, OneRunToStandardOutputByPositionalIdOrRun) {
  CommandResult by_position =
      run_command("runs export " + std::to_string(ids_[0]) + " --format dfq --harmonics 1" + data_);
  ASSERT_EQ(by_position.exit_code, 0) << by_position.output;
  CommandResult by_option =
      run_command("runs export --run " + std::to_string(ids_[0]) + " --format dfq --harmonics 1" + data_);
  ASSERT_EQ(by_option.exit_code, 0) << by_option.output;
  EXPECT_EQ(by_position.output, by_option.output);
  Result<DfqFile> file = read_dfq(by_position.output);
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_EQ(file->total_characteristics, 1);
  EXPECT_EQ(file->characteristics[0].values.at(0).fields.at("K0014"), "S-1");
}

TEST_F(DfqExportCommand, RefusesAnEmptyOrUnclearSelection) {
  CommandResult none = run_command("runs export --format dfq --part exhaust --lobe 1 --harmonics 1" + data_);
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_TRUE(has(none.output, "no run matches the selection")) << none.output;

  CommandResult nothing = run_command("runs export --format dfq" + data_);
  EXPECT_EQ(nothing.exit_code, 2) << nothing.output;
  EXPECT_TRUE(has(nothing.output, "which runs?")) << nothing.output;

  CommandResult both = run_command("runs export 1 --format dfq --part intake" + data_);
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_TRUE(has(both.output, "give the run or the selection")) << both.output;

  CommandResult csv = run_command("runs export --part intake" + data_);
  EXPECT_EQ(csv.exit_code, 2) << csv.output;
  EXPECT_TRUE(has(csv.output, "the CSV export takes one run id")) << csv.output;

  CommandResult missing = run_command("runs export 999 --format dfq" + data_);
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_TRUE(has(missing.output, "runs list")) << missing.output;
}

Characteristic stored_characteristic(std::string key, std::string unit, double value, std::optional<double> lower,
                                     std::optional<double> upper) {
  return single_characteristic(std::move(key), std::move(unit), value, Limits{lower, upper});
}

// End to end once the run database keeps characteristics; skipped where it does not yet.
TEST(DfqExportStoredCharacteristics, ARangeOfRunsWithTheirCharacteristics) {
  testing::TempDir tmp;
  std::vector<std::int64_t> ids;
  {
    Result<RunStore> store = RunStore::open(tmp.path() / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    RunRecord first = testing::sample_run("intake", 1, "g1", "2026-11-20T08:00:00Z", 5.0);
    first.characteristics = {stored_characteristic("lift_error.nose", "um", 3.25, -10.0, 10.0),
                             stored_characteristic("phase", "deg", 0.125, -0.2, 0.2),
                             stored_characteristic("base_circle_runout", "um", 1.5, std::nullopt, 5.0)};
    RunRecord second = testing::sample_run("intake", 1, "g1", "2026-11-21T08:00:00Z", 5.0);
    second.characteristics = {stored_characteristic("phase", "deg", -0.25, -0.2, 0.2),
                              stored_characteristic("base_circle_runout", "um", 0.75, std::nullopt, 5.0)};
    for (RunRecord* r : {&first, &second}) {
      std::vector<Verdict> verdicts;
      for (const Characteristic& c : r->characteristics) verdicts.push_back(c.verdict);
      r->verdict = combined_verdict(verdicts);
      Result<std::int64_t> id = store->insert_run(*r);
      ASSERT_TRUE(id.ok()) << id.error().message;
      ids.push_back(*id);
    }
    Result<StoredRun> back = store->load_run(ids[0]);
    ASSERT_TRUE(back.ok()) << back.error().message;
    if (back->characteristics.empty()) GTEST_SKIP() << "this run database does not keep characteristics yet";
  }
  const fs::path out = tmp.path() / "intake.dfq";
  CommandResult r = run_command("runs export --format dfq --part intake --lobe 1 --since 2026-11-20 --out " +
                                out.string() + " --data-dir " + tmp.path().string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Result<DfqFile> file = read_dfq(testing::slurp(out));
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_EQ(file->total_characteristics, 3);
  EXPECT_EQ(file->characteristics[0].fields.at("K2001"), "lift_error.nose");
  EXPECT_EQ(file->characteristics[1].fields.at("K2001"), "phase");
  EXPECT_EQ(file->characteristics[1].fields.at("K2110"), "-0.2000");
  EXPECT_EQ(file->characteristics[2].fields.at("K2120"), "1");
  for (const auto& c : file->characteristics) ASSERT_EQ(c.values.size(), 2u);
  EXPECT_EQ(file->characteristics[0].values[0].fields.at("K0001"), "3.250");
  EXPECT_EQ(file->characteristics[0].values[1].fields.at("K0002"), "255");
  EXPECT_EQ(file->characteristics[1].values[1].fields.at("K0001"), "-0.2500");
  EXPECT_EQ(file->characteristics[2].values[1].fields.at("K0006"), std::to_string(ids[1]));
}

}  // namespace
}  // namespace gaugeloop
