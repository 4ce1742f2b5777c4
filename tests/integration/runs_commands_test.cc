// The run-history commands as a user runs them: the real binary on a database filled through
// RunStore, text and --json, and the messages for what cannot be answered.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "config/part_file.h"
#include "core/lift_table.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/csv_reader.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::run_command;

using testing::has;

using testing::raw_mm;

RunRecord record(const std::string& part, int lobe, const std::string& machine, const std::string& started,
                 double max_um) {
  return testing::sample_run(part, lobe, machine, started, max_um);
}

class RunsCommandsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    // 1, 2: lobe 1 on g1 over two days; 3: lobe 2; 4: lobe 1 on g2 without frame or settings.
    ids_.push_back(*store->insert_run(record("intake", 1, "g1", "2020-11-20T08:00:00Z", 12.0)));
    RunRecord second = record("intake", 1, "g1", "2020-11-21T08:00:00Z", 4.0);
    second.settings = "compensation.gain = 0.5\nanalysis.window = 150..210\n";
    second.correction_in_force_run = ids_[0];
    ids_.push_back(*store->insert_run(second));
    ids_.push_back(*store->insert_run(record("intake", 2, "g1", "2020-11-21T09:00:00Z", 30.0)));
    RunRecord bare = record("intake", 1, "g2", "2020-11-22T08:00:00Z", 6.0);
    bare.geometry.reset();
    bare.settings.clear();
    ids_.push_back(*store->insert_run(bare));
    ASSERT_TRUE(store->record_nc_file(ids_[0], "nc/CAM_INTAKE_L1.SPF").ok());
    EventRecord e = testing::sample_refusal_event();
    ASSERT_TRUE(store->record_event(e).ok());
    data_ = " --data-dir " + dir_.string();
  }

  nlohmann::json json_of(const std::string& args) {
    CommandResult r = run_command(args + data_);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << r.output;
    return j;
  }

  std::vector<std::int64_t> listed(const std::string& args) {
    std::vector<std::int64_t> out;
    for (const auto& run : json_of("runs list --json " + args)) out.push_back(run["id"].get<std::int64_t>());
    return out;
  }

  testing::TempDir tmp_;  // before everything that lives in it
  fs::path dir_;
  std::string data_;
  std::vector<std::int64_t> ids_;
};

using Ids = std::vector<std::int64_t>;

TEST_F(RunsCommandsTest, ListFiltersByPartLobeMachineTimeAndStatus) {
  EXPECT_EQ(listed(""), (Ids{ids_[3], ids_[2], ids_[1], ids_[0]}));
  EXPECT_EQ(listed("--part intake --lobe 1"), (Ids{ids_[3], ids_[1], ids_[0]}));
  EXPECT_EQ(listed("--machine g2"), (Ids{ids_[3]}));
  EXPECT_EQ(listed("--status pushed"), (Ids{ids_[0]}));
  // --until a date includes that whole day.
  EXPECT_EQ(listed("--since 2020-11-21 --until 2020-11-21"), (Ids{ids_[2], ids_[1]}));
  EXPECT_EQ(listed("--since 2020-11-21T08:30"), (Ids{ids_[3], ids_[2]}));
  CommandResult text = run_command("runs list --lobe 2" + data_);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_TRUE(has(text.output, "30.00")) << text.output;
  EXPECT_FALSE(has(text.output, "12.00")) << text.output;
}

TEST_F(RunsCommandsTest, ListBySerialFindsOnlyThatPartsRunsAndShowsTheSerial) {
  {
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    RunRecord marked = record("intake", 1, "g1", "2020-11-23T08:00:00Z", 5.0);
    marked.serial = "CS-0042";
    marked.operator_name = "anna";
    ids_.push_back(*store->insert_run(marked));
    marked.serial = "CS-00421";
    marked.started_utc = marked.finished_utc = "2020-11-23T09:00:00Z";
    ids_.push_back(*store->insert_run(marked));
  }
  EXPECT_EQ(listed("--serial CS-0042"), (Ids{ids_[4]}));
  EXPECT_EQ(listed("--serial cs-0042"), Ids{}) << "matched exactly, case and all";
  CommandResult too_long = run_command("runs list --serial " + std::string(65, 'S') + data_);
  EXPECT_EQ(too_long.exit_code, 2) << too_long.output;
  EXPECT_TRUE(has(too_long.output, "--serial is 65 characters long; at most 64")) << too_long.output;
  CommandResult text = run_command("runs list" + data_);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_TRUE(has(text.output, "serial")) << text.output;
  EXPECT_TRUE(has(text.output, " CS-00421 ")) << text.output;
  CommandResult show = run_command("runs show " + std::to_string(ids_[4]) + data_);
  ASSERT_EQ(show.exit_code, 0) << show.output;
  EXPECT_TRUE(has(show.output, "serial            CS-0042\n")) << show.output;
  EXPECT_TRUE(has(show.output, "operator          anna\n")) << show.output;
  EXPECT_TRUE(has(show.output, "part temperature  not given\n")) << show.output;
  const nlohmann::json old = json_of("runs show --json " + std::to_string(ids_[0]));
  EXPECT_TRUE(old.contains("serial") && old["serial"].is_null()) << old.dump();
  EXPECT_TRUE(old.contains("operator") && old["operator"].is_null()) << old.dump();
  EXPECT_TRUE(old.contains("part_temperature_c") && old["part_temperature_c"].is_null()) << old.dump();
}

// `measure --serial --operator --part-temperature-c`: the real binary against the simulated
// gauge stores them.
TEST_F(RunsCommandsTest, MeasureStoresTheSerialOperatorAndPartTemperatureAndRefusesBadOnesBeforeTheGauge) {
  const fs::path part = fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.toml";
  Result<PartFile> pf = read_part_file(part);
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  Result<LiftTable> design = read_lift_table_csv(pf->part.lift_table);
  ASSERT_TRUE(design.ok()) << design.error().message;
  SimulatorSettings ss;
  ss.time_scale = 4.0;  // the run takes about a second
  auto sim = GaugeSimulator::start(pf->part, *design, ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  const fs::path fresh = dir_ / "measured";
  const std::string measure = "measure --gauge 127.0.0.1:" + std::to_string((*sim)->port()) + " --part " +
                              part.string() + " --data-dir " + fresh.string();

  CommandResult bad = run_command(measure + " --serial " + std::string(65, 'S'));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_TRUE(has(bad.output, "--serial is 65 characters long; at most 64")) << bad.output;
  bad = run_command(measure + " --operator \"$(printf 'anna\\tbert')\"");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_TRUE(has(bad.output, "--operator has a control character at character 5")) << bad.output;
  bad = run_command(measure + " --gauge-calibrated 2026-02-30");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_TRUE(has(bad.output, "--gauge-calibrated 2026-02-30: not a past day as YYYY-MM-DD")) << bad.output;
  for (const char* t : {"150.1", "-40.1", "nan", "inf"}) {
    bad = run_command(measure + " --part-temperature-c=" + t);
    EXPECT_EQ(bad.exit_code, 2) << t << ": " << bad.output;
    EXPECT_TRUE(has(bad.output,
                    ": not a part temperature; give the part's temperature in degrees Celsius, -40.0 to "
                    "150.0"))
        << t << ": " << bad.output;
    EXPECT_TRUE(has(bad.output, "--part-temperature-c ")) << bad.output;
  }
  bad = run_command(measure + " --part-temperature-c 21,4");
  EXPECT_NE(bad.exit_code, 0) << bad.output;
  EXPECT_TRUE(has(bad.output, "--part-temperature-c")) << bad.output;
  EXPECT_FALSE(fs::exists(fresh / "gaugeloop.sqlite")) << "refused before anything was opened";

  CommandResult r = run_command(measure +
                                " --serial 'CS 0042' --operator 'Anna K.' --gauge-id LVDT-07 --gauge-calibrated "
                                "2026-10-01 --part-temperature-c 21.44");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  Result<RunStore> store = RunStore::open(fresh / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<std::vector<RunSummary>> runs = store->list_runs({});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].serial, "CS 0042");
  EXPECT_EQ((*runs)[0].operator_name, "Anna K.");
  // The gauge's identity and the part file's drawing are kept with the run's settings, where
  // its report reads them.
  Result<StoredRun> stored = store->load_run((*runs)[0].id);
  ASSERT_TRUE(stored.ok()) << stored.error().message;
  for (const char* line :
       {"gauge.id = LVDT-07\n", "gauge.calibration_date = 2026-10-01\n", "part.drawing_number = CS-4711-01\n",
        "part.drawing_revision = C\n", "part.temperature_c = 21.4\npart.temperature_source = operator\n"}) {
    EXPECT_TRUE(has(stored->settings, line)) << line << stored->settings;
  }
  // Shown where the run is read: `runs show`, its JSON (the run page's), kept to 0.1 deg C.
  const std::string show = "runs show " + std::to_string((*runs)[0].id) + " --data-dir " + fresh.string();
  CommandResult shown = run_command(show);
  ASSERT_EQ(shown.exit_code, 0) << shown.output;
  EXPECT_TRUE(has(shown.output, "part temperature  21.4 degC (operator)\n")) << shown.output;
  CommandResult as_json = run_command(show + " --json");
  ASSERT_EQ(as_json.exit_code, 0) << as_json.output;
  const nlohmann::json j = nlohmann::json::parse(as_json.output, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << as_json.output;
  EXPECT_EQ(j["part_temperature_c"], 21.4) << as_json.output;
  EXPECT_EQ(j["part_temperature_source"], "operator") << as_json.output;
}

TEST_F(RunsCommandsTest, BadTimeIsBadInputSayingWhatToWrite) {
  CommandResult r = run_command("runs list --since 22.11.2026" + data_);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "--since '22.11.2026' is not a UTC date or time; write 2026-11-22")) << r.output;
  r = run_command("runs list --until 2026-02-30" + data_);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "not a real date")) << r.output;
}

TEST_F(RunsCommandsTest, UnknownRunIsBadInputNamingTheDatabaseAndTheWayToTheIds) {
  for (const std::string cmd : {"runs show 42", "runs export 42", "runs compare 1 42", "runs plot 42 --out x.svg"}) {
    CommandResult r = run_command(cmd + data_);
    EXPECT_EQ(r.exit_code, 2) << cmd << ": " << r.output;
    EXPECT_TRUE(has(r.output, "run 42 is not in run database " + (dir_ / "gaugeloop.sqlite").string())) << r.output;
    EXPECT_TRUE(has(r.output, "`gaugeloop runs list --data-dir " + dir_.string() + "` shows the ids")) << r.output;
  }
  EXPECT_FALSE(fs::exists("x.svg"));
}

TEST_F(RunsCommandsTest, NoDatabaseIsBadInputAndCreatesNone) {
  const fs::path empty = dir_ / "empty";
  CommandResult r = run_command("runs list --data-dir " + empty.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no run database at " + (empty / "gaugeloop.sqlite").string())) << r.output;
  EXPECT_FALSE(fs::exists(empty));
}

// The service's config names the database (here not gaugeloop.sqlite) and the NC directory:
// `--config` reads them as the service does, relative to the config, and nothing else of it.
TEST_F(RunsCommandsTest, QueriesReadTheServicesDatabaseThroughItsConfig) {
  fs::create_directories(dir_ / "var");
  fs::rename(dir_ / "gaugeloop.sqlite", dir_ / "var" / "runs-7.sqlite");
  const fs::path config = tmp_.write("etc/gaugeloop.toml",
                                     "[gauge]\nconfig = \"absent.toml\"\n[database]\n"
                                     "path = \"../var/runs-7.sqlite\"\n[http]\n"
                                     "token_file = \"unreadable\"\n");
  const std::string with_config = " --config " + config.string();
  CommandResult r = run_command("runs list --json" + with_config);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output).size(), 4u) << r.output;
  for (const std::string cmd : {"runs show 1", "runs export 1", "runs compare 1 2", "runs trend --part intake --lobe 1",
                                "events", "nc history", "nc pending"}) {
    r = run_command(cmd + with_config);
    EXPECT_EQ(r.exit_code, 0) << cmd << ": " << r.output;
  }
  r = run_command("runs show 42" + with_config);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "run 42 is not in run database " + (dir_ / "var" / "runs-7.sqlite").string())) << r.output;
  EXPECT_TRUE(has(r.output, "`gaugeloop runs list --config " + config.string() + "` shows the ids")) << r.output;

  r = run_command("runs list" + with_config + data_);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "--data-dir excludes --config")) << r.output;
  r = run_command("runs list --config " + (dir_ / "absent.toml").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, (dir_ / "absent.toml").string())) << r.output;
  const fs::path fresh = tmp_.write("etc/fresh.toml", "[database]\npath = \"never.sqlite\"\n");
  r = run_command("runs list --config " + fresh.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no run database at " + (dir_ / "etc" / "never.sqlite").string() +
                                "; the service has stored no run yet, or [database] path in " + fresh.string()))
      << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "etc" / "never.sqlite"));
}

// GAUGELOOP_DATA_DIR is the default of --data-dir: the flag beats it, it beats gaugeloop-data.
TEST_F(RunsCommandsTest, GaugeloopDataDirIsTheDefaultDataDirectory) {
  const std::string bin = testing::gaugeloop_binary();
  CommandResult r = testing::run_shell("cd " + dir_.string() + " && GAUGELOOP_DATA_DIR=" + dir_.string() + " " + bin +
                                       " runs list --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output).size(), 4u) << r.output;
  r = testing::run_shell("GAUGELOOP_DATA_DIR=" + (dir_ / "elsewhere").string() + " " + bin + " runs list --json" +
                         data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output).size(), 4u) << "the flag beats the variable: " << r.output;
  r = testing::run_shell("GAUGELOOP_DATA_DIR=" + (dir_ / "elsewhere").string() + " " + bin + " events");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no run database at " + (dir_ / "elsewhere" / "gaugeloop.sqlite").string())) << r.output;
  r = testing::run_shell("cd " + dir_.string() + " && env -u GAUGELOOP_DATA_DIR " + bin + " runs list");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(has(r.output, "no run database at gaugeloop-data/gaugeloop.sqlite")) << r.output;
  r = run_command("runs list --help");
  EXPECT_TRUE(has(r.output, "$GAUGELOOP_DATA_DIR")) << r.output;
  EXPECT_TRUE(has(r.output, "--config")) << r.output;
}

// Under systemd, stderr is the journal's stream (JOURNAL_STREAM names its device and inode):
// each line then starts with its syslog priority, so `journalctl -p` filters by level.
// Anywhere else, the plain level.
TEST_F(RunsCommandsTest, UnderSystemdEachLogLineStartsWithItsSyslogPriority) {
  const fs::path empty = dir_ / "empty";
  const fs::path journal = dir_ / "journal.log";
  std::ofstream(journal).put('\n');
  struct stat st {};
  ASSERT_EQ(::stat(journal.c_str(), &st), 0);
  const std::string stream = std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
  const std::string bin = std::string(GAUGELOOP_BINARY_DIR) + "/bin/gaugeloop";
  const std::string args = " runs list --data-dir " + empty.string() + " 2>" + journal.string();
  ASSERT_EQ(WEXITSTATUS(std::system(("JOURNAL_STREAM=" + stream + " " + bin + args).c_str())), 2);
  EXPECT_EQ(testing::slurp(journal).rfind("<3>error: no run database at ", 0), 0u) << testing::slurp(journal);
  // Another stream (stderr redirected away from the journal): no prefix.
  ASSERT_EQ(WEXITSTATUS(std::system(("JOURNAL_STREAM=1:1 " + bin + args).c_str())), 2);
  EXPECT_EQ(testing::slurp(journal).rfind("error: no run database at ", 0), 0u) << testing::slurp(journal);
}

TEST_F(RunsCommandsTest, ShowGivesSummaryAnalysisCorrectionAndPushes) {
  CommandResult r = run_command("runs show " + std::to_string(ids_[0]) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f : {"intake lobe 1 on g1 (pushed)", "max lift error    12.00 um at cam 90 deg", "+0.250 deg",
                        "1.50 um (base circle", "from the design", "nc/CAM_INTAKE_L1.SPF", "C = +psi + 10.000 deg"}) {
    EXPECT_TRUE(has(r.output, f)) << "'" << f << "' not in:\n" << r.output;
  }
  const nlohmann::json j = json_of("runs show --json " + std::to_string(ids_[1]));
  EXPECT_EQ(j["correction_in_force_run"], ids_[0]);
  EXPECT_EQ(j["phase_error_deg"], 0.25);
  EXPECT_EQ(j["max_abs_error_at_cam_deg"], 90);
  EXPECT_EQ(j["settings_hash"], settings_hash("compensation.gain = 0.5\nanalysis.window = 150..210\n"));
}

TEST_F(RunsCommandsTest, ShowSpeaksOfAPinForAPinRun) {
  std::int64_t id = 0;
  {
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    id = *store->insert_run(testing::sample_pin_run("crankpin_cxy", "c-x-y", "2020-11-23T08:00:00Z", 2.0));
  }
  CommandResult r = run_command("runs show " + std::to_string(id) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f :
       {"crankpin_cxy pin 1 on grinder-1", "frame             pin frame, 0 deg along the crank radius outward (C-X-Y)",
        "analysis (pin frame, 0 deg along the crank radius outward)", "largest radius error 2.00 um at pin 90 deg",
        "roundness         3.50 um", "diameter error    +0.15 um", "stroke error      -0.01 um",
        "index error       +0.0020 deg", "correction (in pin degrees)", "largest           1.80 um at pin 90 deg",
        "Pin roundness", "Pin stroke (throw) error"}) {
    EXPECT_TRUE(has(r.output, f)) << "'" << f << "' not in:\n" << r.output;
  }
  for (const char* lobe_word : {"lobe 1", "cam frame", "nose", "lift error", "phase error", "runout", "Base circle"}) {
    EXPECT_FALSE(has(r.output, lobe_word)) << "'" << lobe_word << "' in:\n" << r.output;
  }
  const nlohmann::json j = json_of("runs show --json " + std::to_string(id));
  EXPECT_EQ(j["part_kind"], "pin");
  EXPECT_EQ(j["pin_mode"], "c-x-y");
  EXPECT_EQ(json_of("runs show --json " + std::to_string(ids_[0]))["part_kind"], "lobe");
}

TEST_F(RunsCommandsTest, ExportMapsRevolutionsToTheCamFrameWhenTheFrameIsKnown) {
  CommandResult r = run_command("runs export " + std::to_string(ids_[0]) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::optional<std::vector<testing::CsvRecord>> rows = testing::read_csv(r.output);
  ASSERT_TRUE(rows.has_value()) << "not RFC 4180 CSV:\n" << r.output.substr(0, 600);
  ASSERT_EQ(rows->size(), 361u);
  EXPECT_EQ((*rows)[0],
            (testing::CsvRecord{"cam_deg", "design_lift_mm", "rev1_lift_mm", "rev2_lift_mm", "rev3_lift_mm",
                                "mean_lift_mm", "spread_um", "error_um", "judged_error_um", "correction_um", "run_id",
                                "machine", "part", "lobe", "started_utc", "serial", "operator", "note"}));
  for (const testing::CsvRecord& row : *rows) ASSERT_EQ(row.size(), 18u);
  // c0 = 10, sense +1, probe 0: cam degree 5 was read at machine degree 15.
  const testing::CsvRecord& row5 = (*rows)[6];
  EXPECT_EQ(row5[0], "5");
  EXPECT_NEAR(std::stod(row5[2]), raw_mm(0, 15), 1e-7);
  EXPECT_NEAR(std::stod(row5[4]), raw_mm(2, 15), 1e-7);
  EXPECT_NEAR(std::stod(row5[7]), 12.0 * std::sin(5 * 0.0174533), 1e-4);
  EXPECT_EQ(row5[10], std::to_string(ids_[0]));
  EXPECT_EQ(row5[12], "intake");
  r = run_command("runs export --comments " + std::to_string(ids_[0]) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.rfind("# gaugeloop run " + std::to_string(ids_[0]) + ": intake lobe 1 on g1", 0), 0u)
      << r.output.substr(0, 600);
  EXPECT_TRUE(has(r.output, "mapped to the CAM frame")) << r.output.substr(0, 600);
  EXPECT_TRUE(has(r.output, ".\r\ncam_deg,design_lift_mm,")) << "the header after the '#' lines";
}

TEST_F(RunsCommandsTest, ExportSaysWhenRevolutionsStayInTheMachineFrame) {
  CommandResult r = run_command("runs export --comments " + std::to_string(ids_[3]) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "MACHINE frame: row k holds the reading at C = k deg")) << r.output.substr(0, 800);
  EXPECT_TRUE(has(r.output, "rev1_at_machine_deg_lift_mm")) << r.output.substr(0, 800);
  EXPECT_TRUE(has(r.output, "\r\n15,0.5000000,1.0150000,")) << "machine degree 15 on row 15";
}

TEST_F(RunsCommandsTest, ExportToAFileIsTheSameCsv) {
  const fs::path csv = dir_ / "run1.csv";
  CommandResult r = run_command("runs export " + std::to_string(ids_[0]) + " --out " + csv.string() + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(testing::slurp(csv), run_command("runs export " + std::to_string(ids_[0]) + data_).output);
}

TEST_F(RunsCommandsTest, CompareShowsChangesAndTheSettingsThatDiffer) {
  CommandResult r = run_command("runs compare " + std::to_string(ids_[0]) + " " + std::to_string(ids_[1]) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "-8.00")) << r.output;  // max error 12 -> 4
  EXPECT_TRUE(has(r.output, "- compensation.gain = 1")) << r.output;
  EXPECT_TRUE(has(r.output, "+ compensation.gain = 0.5")) << r.output;
  EXPECT_TRUE(has(r.output, "run " + std::to_string(ids_[0]))) << r.output;
  const nlohmann::json j = json_of("runs compare --json " + std::to_string(ids_[0]) + " " + std::to_string(ids_[1]));
  EXPECT_DOUBLE_EQ(j["change_b_minus_a"]["max_abs_error_um"].get<double>(), -8.0);
  EXPECT_NEAR(j["error_difference"]["max_abs_um"].get<double>(), 8.0, 1e-3);
  EXPECT_EQ(j["error_difference"]["at_cam_deg"], 90);
  EXPECT_EQ(j["settings_same"], false);
  EXPECT_EQ(j["b_correction_in_force_run"], ids_[0]);
}

TEST_F(RunsCommandsTest, TrendIsOneLobeOldestFirstWithPhaseAndRunout) {
  const nlohmann::json j = json_of("runs trend --json --part intake --lobe 1 --machine g1");
  ASSERT_EQ(j.size(), 2u);
  EXPECT_EQ(j[0]["id"], ids_[0]);
  EXPECT_EQ(j[1]["max_abs_error_um"], 4.0);
  EXPECT_EQ(j[1]["phase_error_deg"], 0.25);
  EXPECT_EQ(j[1]["base_circle_runout_um"], 1.5);
  CommandResult r = run_command("runs trend --part intake --lobe 1 --since 2020-11-21" + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "max error 4.00 -> 6.00 um")) << r.output;
  r = run_command("runs trend --part intake" + data_);
  EXPECT_EQ(r.exit_code, 2) << "the lobe is required: " << r.output;
}

TEST_F(RunsCommandsTest, PlotWritesAnSvgWithTheToleranceBand) {
  const fs::path svg = dir_ / "run1.svg";
  CommandResult r =
      run_command("runs plot " + std::to_string(ids_[0]) + " --tolerance-um 10 --out " + svg.string() + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(svg);
  std::stringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  EXPECT_TRUE(has(text, "<svg xmlns=\"http://www.w3.org/2000/svg\"")) << text.substr(0, 200);
  EXPECT_TRUE(has(text, "tolerance \u00b110.0 \u00b5m"));
  // 12 um sine against +-10 um: |12 sin d| > 10 for d in 57..123 and 237..303, 134 degrees.
  EXPECT_TRUE(has(text, "134 degrees outside \u00b110.0 \u00b5m")) << "verdict missing";
  EXPECT_TRUE(has(text, "</svg>"));
}

TEST_F(RunsCommandsTest, PruneDropsOldRawSamplesAndKeepsTheSummary) {
  CommandResult r = run_command("runs prune --raw-older-than-days 0" + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "pruned the raw samples of 4 runs")) << r.output;
  r = run_command("runs export --comments " + std::to_string(ids_[0]) + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "Raw revolutions were pruned")) << r.output.substr(0, 800);
  EXPECT_TRUE(has(r.output, "# judged_error_um: the lift error")) << r.output.substr(0, 800);
  // The same columns as before pruning, the revolutions' fields empty.
  EXPECT_TRUE(has(r.output,
                  "\r\ncam_deg,design_lift_mm,rev1_lift_mm,rev2_lift_mm,rev3_lift_mm,mean_lift_mm,spread_um,"
                  "error_um,judged_error_um,correction_um,run_id,machine,part,lobe,started_utc,serial,operator,"
                  "note\r\n0,0.5000000,,,,0.5000000,"))
      << r.output.substr(0, 1200);
  const nlohmann::json j = json_of("runs show --json " + std::to_string(ids_[0]));
  EXPECT_EQ(j["max_abs_error_um"], 12.0);
  EXPECT_FALSE(j["raw_pruned_utc"].is_null());
}

TEST_F(RunsCommandsTest, EventsListFaultsAndRefusals) {
  CommandResult r = run_command("events" + data_);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(has(r.output, "refusal")) << r.output;
  EXPECT_TRUE(has(r.output, "exceeds the 100 um guard")) << r.output;
  EXPECT_EQ(json_of("events --json --kind fault").size(), 0u);
  const nlohmann::json j = json_of("events --json --kind refusal --part intake");
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(j[0]["lobe"], 1);
  EXPECT_EQ(j[0]["code"], "refused");
}

}  // namespace
}  // namespace gaugeloop
