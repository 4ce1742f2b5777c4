// `runs shaft` and `runs spc` as a user runs them: the real binary on a database filled through
// RunStore and a shaft file naming the sample parts.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

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

using testing::has;

class ShaftCommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const fs::path dir = tmp_.path();
    Result<RunStore> store = RunStore::open(dir / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    // Serial CS-1: intake lobe 1 (sample_run: c0 10, phase +0.25) and exhaust lobe 2 ground
    // at c0 120 with phase -0.1. An older intake run of CS-1 and one of another serial must
    // not count.
    RunRecord old_intake = testing::sample_run("intake_flat", 1, "g1", "2020-11-20T07:00:00Z", 9.0);
    old_intake.serial = "CS-1";
    old_intake.analysis.phase_error_deg = 3.0;
    ids_.push_back(*store->insert_run(old_intake));
    RunRecord intake = testing::sample_run("intake_flat", 1, "g1", "2020-11-20T08:00:00Z", 4.0);
    intake.serial = "CS-1";
    ids_.push_back(*store->insert_run(intake));
    RunRecord exhaust = testing::sample_run("exhaust_roller", 2, "g1", "2020-11-20T08:10:00Z", 5.0);
    exhaust.serial = "CS-1";
    exhaust.analysis.phase_error_deg = -0.1;
    exhaust.geometry->c_offset_deg = 120.0;
    // The exhaust lobe's runout out of its limit: the lobe, and so the shaft, is out.
    Characteristic runout;
    runout.key = "base_circle_runout";
    runout.unit = "um";
    runout.value = runout.min = runout.max = 12.0;
    runout.limits.upper = 10.0;
    runout.verdict = Verdict::kOut;
    exhaust.characteristics = {runout};
    exhaust.verdict = Verdict::kOut;
    ids_.push_back(*store->insert_run(exhaust));
    RunRecord other = testing::sample_run("intake_flat", 1, "g1", "2020-11-20T09:00:00Z", 4.0);
    other.serial = "CS-2";
    ids_.push_back(*store->insert_run(other));
    data_ = " --data-dir " + dir.string();

    // The shaft's reference at C = 10: lobe 1 nominal at 10, lobe 2 at 120.
    const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
    shaft_ = dir / "shaft.toml";
    std::ofstream(shaft_) << "name = \"test shaft\"\nreference_c_deg = 10\nindex_tolerance_deg = 0.2\n"
                          << "[[lobe]]\npart = \"" << (examples / "intake_flat.toml").string() << "\"\nangle_deg = 0\n"
                          << "[[lobe]]\npart = \"" << (examples / "exhaust_roller.toml").string()
                          << "\"\nangle_deg = 110\n";
  }

  testing::TempDir tmp_;
  std::vector<std::int64_t> ids_;
  std::string data_;
  fs::path shaft_;
};

TEST_F(ShaftCommandsTest, ShaftRecordAsJson) {
  // Lobe 1: nose at 10 + 0.25, index +0.25, out of +-0.2. Lobe 2: 120 - 0.1, index -0.1, in;
  // relative to lobe 1: -0.35. The shaft is out.
  CommandResult r = run_command("runs shaft CS-1 --json --shaft " + shaft_.string() + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  EXPECT_EQ(j["serial"], "CS-1");
  ASSERT_EQ(j["lobes"].size(), 2u);
  EXPECT_EQ(j["lobes"][0]["run_id"], ids_[1]) << "the newest run of the lobe with that serial";
  EXPECT_NEAR(j["lobes"][0]["index_error_deg"].get<double>(), 0.25, 1e-9);
  EXPECT_EQ(j["lobes"][0]["index_verdict"], "out");
  EXPECT_EQ(j["lobes"][1]["run_id"], ids_[2]);
  EXPECT_NEAR(j["lobes"][1]["index_error_deg"].get<double>(), -0.1, 1e-9);
  EXPECT_NEAR(j["lobes"][1]["relative_error_deg"].get<double>(), -0.35, 1e-9);
  EXPECT_EQ(j["lobes"][1]["index_verdict"], "in");
  EXPECT_EQ(j["lobes"][0]["verdict"], "not_judged");
  EXPECT_EQ(j["lobes"][1]["verdict"], "out") << "the run's stored verdict";
  EXPECT_EQ(j["verdict"], "out");
  // The sample part files grind their noses at C = 0, not where this shaft wants them.
  EXPECT_EQ(j["notes"].size(), 2u);
}

TEST_F(ShaftCommandsTest, ShaftRecordAsATable) {
  CommandResult r = run_command("runs shaft CS-1 --shaft " + shaft_.string() + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "shaft \"test shaft\", serial CS-1")) << r.output;
  EXPECT_TRUE(has(r.output, "exhaust_roller")) << r.output;
  EXPECT_TRUE(has(r.output, "+0.250     +0.000  out")) << r.output;
  EXPECT_TRUE(has(r.output, "-0.100     -0.350  in")) << r.output;
  EXPECT_TRUE(has(r.output, "shaft verdict: out")) << r.output;
  EXPECT_TRUE(has(r.output, "note: lobe 2 (exhaust_roller.toml)")) << r.output;
}

TEST_F(ShaftCommandsTest, WithoutAShaftFileListsTheSerialsRunsByLobe) {
  CommandResult r = run_command("runs shaft CS-1" + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "serial CS-1, by lobe")) << r.output;
  const std::size_t newest = r.output.find(std::to_string(ids_[1]) + "  2020-11-20T08:00:00Z");
  const std::size_t older = r.output.find(std::to_string(ids_[0]) + "  2020-11-20T07:00:00Z");
  const std::size_t lobe2 = r.output.find(std::to_string(ids_[2]) + "  2020-11-20T08:10:00Z");
  ASSERT_NE(newest, std::string::npos) << r.output;
  ASSERT_NE(older, std::string::npos) << r.output;
  ASSERT_NE(lobe2, std::string::npos) << r.output;
  EXPECT_LT(newest, older);
  EXPECT_LT(older, lobe2);
  EXPECT_TRUE(has(r.output, "(older)")) << r.output;
  EXPECT_FALSE(has(r.output, "2020-11-20T09:00:00Z")) << "another serial's run: " << r.output;

  CommandResult j = run_command("runs shaft CS-1 --json" + data_);
  ASSERT_EQ(j.exit_code, 0) << j.output;
  EXPECT_EQ(nlohmann::json::parse(j.output)["runs"].size(), 3u);
}

TEST_F(ShaftCommandsTest, ABadShaftFileOrSerialIsRefused) {
  CommandResult missing = run_command("runs shaft CS-1 --shaft " + (tmp_.path() / "none.toml").string() + data_);
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_TRUE(has(missing.output, "none.toml")) << missing.output;
  std::ofstream(tmp_.path() / "bad.toml") << "name = \"x\"\nspeed = 3\n";
  CommandResult bad = run_command("runs shaft CS-1 --shaft " + (tmp_.path() / "bad.toml").string() + data_);
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_TRUE(has(bad.output, "bad.toml:2: key `speed`")) << bad.output;
  CommandResult long_serial = run_command("runs shaft " + std::string(65, 'x') + data_);
  EXPECT_EQ(long_serial.exit_code, 2) << long_serial.output;
}

TEST_F(ShaftCommandsTest, SpcSelectsTheLobesRuns) {
  // The runs are selected as `runs trend` selects them; their characteristics come from the
  // store (none are stored on these made-up runs).
  CommandResult r = run_command("runs spc --part intake_flat --lobe 1 --json" + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  EXPECT_EQ(j["runs"], 3);
  EXPECT_EQ(j["first_started_utc"], "2020-11-20T07:00:00Z");
  EXPECT_EQ(j["last_started_utc"], "2020-11-20T09:00:00Z");
  EXPECT_TRUE(j["characteristics"].is_array());
  EXPECT_EQ(run_command("runs spc --part intake_flat --lobe 1 --last 2 --json" + data_).output.find("\"runs\": 2") !=
                std::string::npos,
            true);

  CommandResult none = run_command("runs spc --part nothing --lobe 1" + data_);
  ASSERT_EQ(none.exit_code, 0) << none.output;
  EXPECT_TRUE(has(none.output, "(no runs of nothing lobe 1 match")) << none.output;
  CommandResult no_part = run_command("runs spc --lobe 1" + data_);
  EXPECT_EQ(no_part.exit_code, 2) << no_part.output;
  CommandResult since = run_command("runs spc --part intake_flat --lobe 1 --since 2020-11-20T08:30" + data_);
  ASSERT_EQ(since.exit_code, 0) << since.output;
  EXPECT_TRUE(has(since.output, "1 run, 2020-11-20T09:00:00Z to 2020-11-20T09:00:00Z")) << since.output;
}

// SPC can leave out the parts ground before a correction (by the table version that ground
// them) and the runs whose table was or was not pushed.
TEST_F(ShaftCommandsTest, SpcLeavesOutRunsByTableVersionAndStatus) {
  {
    Result<RunStore> store = RunStore::open(tmp_.path() / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (int version : {2, 3}) {
      RunRecord r =
          testing::sample_run("intake_flat", 1, "g1", "2020-11-21T0" + std::to_string(version) + ":00:00Z", 2.0);
      r.ground_with_version = version;
      r.ground_with_source = "option";
      ASSERT_TRUE(store->insert_run(r).ok());
    }
  }
  auto runs_of = [&](const std::string& filter) {
    CommandResult r = run_command("runs spc --part intake_flat --lobe 1 --json " + filter + data_);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
    return j.is_discarded() || !j.contains("runs") ? -1 : j["runs"].get<int>();
  };
  EXPECT_EQ(runs_of(""), 5);
  EXPECT_EQ(runs_of("--ground-with-from 2"), 2) << "the runs ground from the design or an unknown table left out";
  EXPECT_EQ(runs_of("--ground-with-from 3"), 1);
  EXPECT_EQ(runs_of("--status measured"), 5);
  CommandResult pushed = run_command("runs spc --part intake_flat --lobe 1 --status pushed" + data_);
  EXPECT_EQ(pushed.exit_code, 0) << pushed.output;
  EXPECT_TRUE(has(pushed.output, "(no runs of intake_flat lobe 1 match")) << pushed.output;
  EXPECT_EQ(run_command("runs spc --part intake_flat --lobe 1 --status held" + data_).exit_code, 2);
  EXPECT_EQ(run_command("runs spc --part intake_flat --lobe 1 --ground-with-from 0" + data_).exit_code, 2);
}

// A stored run of `part` lobe `lobe` whose only characteristic is the whole-turn lift error
// `value_um`, judged against `limits`.
RunRecord run_with_lift_error(const std::string& part, int lobe, const std::string& started, double value_um,
                              Limits limits, Verdict verdict) {
  RunRecord r = testing::sample_run(part, lobe, "g1", started, 4.0);
  Characteristic c;
  c.key = "lift_error";
  c.unit = "um";
  c.value = c.min = c.max = value_um;
  c.limits = limits;
  c.verdict = verdict;
  r.characteristics = {c};
  r.verdict = verdict;
  return r;
}

TEST_F(ShaftCommandsTest, SpcFromStoredCharacteristics) {
  // Lift error 1, 2, 3 um against -5..+5 over three runs of exhaust lobe 2 (the third out by
  // its own verdict): mean 2, s = sqrt((1 + 0 + 1) / 2) = 1, Cp = 10 / 6 = 1.667,
  // Cpk = min(5 - 2, 2 + 5) / 3 = 1.0.
  Result<RunStore> store = RunStore::open(tmp_.path() / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  for (int i = 1; i <= 3; ++i) {
    ASSERT_TRUE(store
                    ->insert_run(run_with_lift_error("spc_part", 2, "2020-11-2" + std::to_string(i) + "T08:00:00Z", i,
                                                     Limits{-5.0, 5.0}, i == 3 ? Verdict::kOut : Verdict::kIn))
                    .ok());
  }
  CommandResult r = run_command("runs spc --part spc_part --lobe 2 --json" + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  ASSERT_EQ(j["characteristics"].size(), 1u) << r.output;
  const nlohmann::json& f = j["characteristics"][0];
  EXPECT_EQ(f["key"], "lift_error");
  EXPECT_EQ(f["n"], 3);
  EXPECT_NEAR(f["mean"].get<double>(), 2.0, 1e-12);
  EXPECT_NEAR(f["sd"].get<double>(), 1.0, 1e-12);
  EXPECT_NEAR(f["cp"].get<double>(), 10.0 / 6.0, 1e-12);
  EXPECT_NEAR(f["cpk"].get<double>(), 1.0, 1e-12);
  EXPECT_EQ(f["out"], 1);
  EXPECT_EQ(f["judged"], 3);
  CommandResult text = run_command("runs spc --part spc_part --lobe 2" + data_);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_TRUE(has(text.output, "Lift error, whole turn")) << text.output;
  EXPECT_TRUE(has(text.output, "1.67       1.00  1/3")) << text.output;
}

// Without --last the window is the newest 125 runs: of 130 runs with lift errors 1..130 um,
// runs 6..130, mean 68; --last 130 takes them all (mean 65.5). No note under 1000 runs.
TEST_F(ShaftCommandsTest, SpcTakesTheNewest125RunsUnlessToldOtherwise) {
  Result<RunStore> store = RunStore::open(tmp_.path() / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  for (int i = 1; i <= 130; ++i) {
    char started[32];
    std::snprintf(started, sizeof started, "2020-11-%02dT%02d:%02d:00Z", 1 + i / 24, i % 24, i % 60);
    ASSERT_TRUE(
        store->insert_run(run_with_lift_error("window_part", 1, started, i, Limits{-200.0, 200.0}, Verdict::kIn)).ok());
  }
  for (const auto& [args, runs, mean] : {std::tuple<std::string, int, double>{"", 125, 68.0},
                                         std::tuple<std::string, int, double>{" --last 130", 130, 65.5}}) {
    CommandResult r = run_command("runs spc --part window_part --lobe 1 --json" + args + data_);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << r.output;
    EXPECT_EQ(j["runs"], runs) << args;
    ASSERT_EQ(j["characteristics"].size(), 1u) << r.output;
    EXPECT_EQ(j["characteristics"][0]["n"], runs) << args;
    EXPECT_NEAR(j["characteristics"][0]["mean"].get<double>(), mean, 1e-9) << args;
    EXPECT_TRUE(j["note"].is_null()) << r.output;
  }
}

// 1001 runs: `runs trend` takes the newest 200 unless told otherwise and says so, and an SPC
// window of more than 1000 runs says what it read.
TEST_F(ShaftCommandsTest, TheTrendTakesTheNewest200AndAWideSpcWindowSaysSo) {
  Result<RunStore> store = RunStore::open(tmp_.path() / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  for (int i = 0; i < 1001; ++i) {
    char started[32];
    std::snprintf(started, sizeof started, "2020-%02d-%02dT%02d:00:00Z", 1 + i / 240, 1 + (i / 24) % 10, i % 24);
    ASSERT_TRUE(
        store
            ->insert_run(run_with_lift_error("long_part", 1, started, 1.0 + (i % 7), Limits{-12.0, 12.0}, Verdict::kIn))
            .ok());
  }
  CommandResult trend = run_command("runs trend --part long_part --lobe 1 --json" + data_);
  ASSERT_EQ(trend.exit_code, 0) << trend.output.substr(0, 400);
  const nlohmann::json runs = nlohmann::json::parse(trend.output, nullptr, false);
  ASSERT_TRUE(runs.is_array()) << trend.output.substr(0, 400);
  EXPECT_EQ(runs.size(), 200u);
  EXPECT_EQ(runs.front()["started_utc"], "2020-04-04T09:00:00Z") << "the oldest of the newest 200: run 802";
  CommandResult all = run_command("runs trend --part long_part --lobe 1 --limit 1001 --json" + data_);
  ASSERT_EQ(all.exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(all.output, nullptr, false).size(), 1001u);
  CommandResult text = run_command("runs trend --part long_part --lobe 1" + data_);
  EXPECT_TRUE(has(text.output, "note: the newest 200 runs")) << text.output.substr(text.output.size() - 300);

  CommandResult wide = run_command("runs spc --part long_part --lobe 1 --last 2000 --json" + data_);
  ASSERT_EQ(wide.exit_code, 0) << wide.output;
  const nlohmann::json j = nlohmann::json::parse(wide.output, nullptr, false);
  EXPECT_EQ(j["runs"], 1001);
  ASSERT_TRUE(j["note"].is_string()) << wide.output;
  EXPECT_TRUE(has(j["note"].get<std::string>(), "summed up over 1001 runs")) << wide.output;
  CommandResult spc_text = run_command("runs spc --part long_part --lobe 1 --last 1001" + data_);
  EXPECT_TRUE(has(spc_text.output, "note: summed up over 1001 runs")) << spc_text.output;
  CommandResult narrow = run_command("runs spc --part long_part --lobe 1" + data_);
  EXPECT_FALSE(has(narrow.output, "note:")) << narrow.output;
}

}  // namespace
}  // namespace gaugeloop
