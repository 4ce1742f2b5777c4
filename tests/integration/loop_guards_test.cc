// A loop that cannot be fooled: the part knows the table that ground it, so measuring one part
// again never compounds the correction; and everything that can be checked before the gauge
// is checked before it, so bad input costs no measurement. Real gauge simulator over Modbus
// TCP on loopback, real SQLite file, real NC directory.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "config/gauge_config.h"
#include "config/part_file.h"
#include "core/lift_table.h"
#include "core/text_file.h"
#include "job/measure_job.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/damaged_database.h"
#include "tests/support/failing_nc_files.h"
#include "tests/support/intake_job.h"
#include "tests/support/temp_dir.h"
#include "tests/support/tmpfs_mount.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::slurp;

class LoopGuardsTest : public testing::IntakeSimulatorJobTest {
 protected:
  StoredRun load(std::int64_t run_id) {
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    EXPECT_TRUE(store.ok());
    Result<StoredRun> run = store->load_run(run_id);
    EXPECT_TRUE(run.ok());
    return *run;
  }

  // The gauge was not read: the simulator served no request.
  void expect_gauge_untouched(std::int64_t requests_before) {
    EXPECT_EQ(sim_->requests_served(), requests_before) << "the gauge was read before the check failed";
  }

  // The job with the database locked by another connection once the run is compensated, so that
  // storing the run it measured fails; the lock is released after.
  Result<JobReport> measure_with_database_locked(JobSettings js) {
    sqlite3* other = nullptr;
    js.on_step = [&](const JobStep& step) {
      if (step.code != "compensated") return;
      ASSERT_EQ(sqlite3_open((dir_ / "gaugeloop.sqlite").c_str(), &other), SQLITE_OK);
      ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);
    };
    Result<JobReport> r = measure(js);
    EXPECT_NE(other, nullptr) << "the run was not compensated";
    if (other != nullptr) {
      sqlite3_exec(other, "ROLLBACK", nullptr, nullptr, nullptr);
      sqlite3_close(other);
    }
    return r;
  }
};

double largest_difference_um(const DegreeTable& a, const DegreeTable& b) {
  double worst = 0.0;
  for (std::size_t d = 0; d < a.size(); ++d) worst = std::max(worst, std::abs(a[d] - b[d]));
  return worst;
}

// The simulator does not grind: every run measures the same part. The first run corrects the
// design; the nine after it find a part that does not show the table they would build on, so
// none is pushed and the correction in force does not move. The loop promises at most the
// gauge's noise (0.3 um RMS); it keeps the correction as it is, so the tolerance is storage's
// resolution: per-degree tables come back within 0.05 nm (5e-5 um) of what was written.
TEST_F(LoopGuardsTest, MeasuringOnePartTenTimesMovesTheCorrectionByAtMostTheNoise) {
  Result<JobReport> first = measure(job_settings());
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(first->pushed());
  const DegreeTable correction_v1 = load(first->run_id).correction_um;
  const std::string program_v1 = slurp(nc_file());
  for (int i = 2; i <= 10; ++i) {
    Result<JobReport> again = measure(job_settings());
    ASSERT_TRUE(again.ok()) << again.error().message;
    EXPECT_FALSE(again->pushed()) << "measurement " << i << " of the same part pushed a table";
    EXPECT_EQ(again->ground_with_source, "assumed");
    EXPECT_NE(again->not_pushed_reason.find("does not show the table in force"), std::string::npos)
        << again->not_pushed_reason;
    EXPECT_FALSE(again->pending_id) << "nothing to approve: the table would repeat a change";
    const StoredRun stored = load(again->run_id);
    EXPECT_LT(largest_difference_um(stored.correction_um, correction_v1), 1e-4) << "measurement " << i;
    ASSERT_TRUE(stored.ground_with_version);
    EXPECT_EQ(*stored.ground_with_version, 1);
  }
  EXPECT_EQ(slurp(nc_file()), program_v1) << "the program on the control changed";
  Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  Result<std::optional<std::int64_t>> in_force = store->last_pushed_run("grinder-1", "intake_flat", 1);
  ASSERT_TRUE(in_force.ok() && *in_force);
  EXPECT_EQ(**in_force, first->run_id);
}

// Told which table ground the part: the table in force builds on it and pushes; an older one
// (or the design, once a table is in force) is stored for inspection and pushes nothing; a
// version never pushed is refused before the gauge is read.
TEST_F(LoopGuardsTest, GroundWithNamesTheTableTheCorrectionBuildsOn) {
  Result<JobReport> first = measure(job_settings());
  ASSERT_TRUE(first.ok() && first->pushed());

  JobSettings told = job_settings();
  told.ground_with_version = 1;  // a person says: this part was ground with version 1
  Result<JobReport> second = measure(told);
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_TRUE(second->pushed()) << second->not_pushed_reason;
  EXPECT_EQ(second->table_version, 2);
  ASSERT_TRUE(second->correction_in_force_run);
  EXPECT_EQ(*second->correction_in_force_run, first->run_id);
  EXPECT_EQ(load(second->run_id).ground_with_source, "option");

  Result<JobReport> older = measure(told);  // ground with 1, but 2 is in force now
  ASSERT_TRUE(older.ok()) << older.error().message;
  EXPECT_FALSE(older->pushed());
  EXPECT_NE(older->not_pushed_reason.find("table version 2 is in force"), std::string::npos)
      << older->not_pushed_reason;

  JobSettings design = job_settings();
  design.ground_with_version = 0;
  Result<JobReport> from_design = measure(design);
  ASSERT_TRUE(from_design.ok());
  EXPECT_FALSE(from_design->pushed());

  JobSettings never = job_settings();
  never.ground_with_version = 7;
  const std::int64_t requests = sim_->requests_served();
  Result<JobReport> refused = measure(never);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("table version 7"), std::string::npos) << refused.error().message;
  expect_gauge_untouched(requests);
}

// A push whose main program was not written (here a full disk; a cut push alike) leaves the
// control coupling the older table while the history holds the newer. The next run finds it
// before the gauge: the main program is written again for the table on the control, and the
// part just measured, ground with the older table, is kept for inspection with
// ground_with_source main_program: a correction built on the newer table would be wrong.
TEST_F(LoopGuardsTest, APartGroundWhileTheMainProgramCoupledTheOlderTableCorrectsNothing) {
  JobSettings js = job_settings();
  js.nc_main_template = std::string(embedded::kNcMainTemplate);
  js.nc_main_template_name = "cam_main.mpf";
  Result<JobReport> first = measure(js);
  ASSERT_TRUE(first.ok() && first->pushed()) << (first.ok() ? first->not_pushed_reason : first.error().message);

  auto full_disk = std::make_shared<testing::FailingNcFiles>();
  full_disk->fail_writes_ending_with = "_MAIN.MPF";
  JobSettings told = js;
  told.ground_with_version = 1;
  told.nc_files = full_disk;
  Result<JobReport> second = measure(told);
  ASSERT_FALSE(second.ok()) << "the main program was not written";
  EXPECT_NE(second.error().message.find("still couples the previous table"), std::string::npos)
      << second.error().message;
  const fs::path main_file = dir_ / "nc" / (part_.nc_program + "_MAIN.MPF");
  ASSERT_NE(slurp(main_file).find("EGON(X,\"FINE\",C,1,0)"), std::string::npos) << slurp(main_file);

  Result<JobReport> third = measure(js);
  ASSERT_TRUE(third.ok()) << third.error().message;
  EXPECT_FALSE(third->pushed());
  EXPECT_EQ(third->ground_with_source, "main_program");
  ASSERT_TRUE(third->ground_with_version);
  EXPECT_EQ(*third->ground_with_version, 1);
  EXPECT_NE(third->not_pushed_reason.find("the main program on the control coupled it"), std::string::npos)
      << third->not_pushed_reason;
  EXPECT_EQ(load(third->run_id).ground_with_source, "main_program");
  EXPECT_NE(slurp(main_file).find("EGON(X,\"FINE\",C,2,0)"), std::string::npos)
      << "the main program couples table version 2 again:\n"
      << slurp(main_file);
}

// --inspect: stored with the correction in force unchanged, no push, no pending table, the
// program untouched.
TEST_F(LoopGuardsTest, AnInspectionTouchesNeitherTheCorrectionNorTheProgram) {
  Result<JobReport> first = measure(job_settings());
  ASSERT_TRUE(first.ok() && first->pushed());
  const std::string program = slurp(nc_file());
  JobSettings inspect = job_settings();
  inspect.inspect = true;
  Result<JobReport> r = measure(inspect);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->pushed());
  EXPECT_TRUE(r->inspection);
  EXPECT_FALSE(r->pending_id);
  const StoredRun stored = load(r->run_id);
  EXPECT_TRUE(stored.inspection);
  EXPECT_LT(largest_difference_um(stored.correction_um, load(first->run_id).correction_um), 1e-4);
  EXPECT_EQ(slurp(nc_file()), program);
  const auto shown =
      testing::run_command("runs show --json " + std::to_string(r->run_id) + " --data-dir " + dir_.string());
  ASSERT_EQ(shown.exit_code, 0) << shown.output;
  const nlohmann::json j = nlohmann::json::parse(shown.output);
  EXPECT_EQ(j["inspection"], true);
  EXPECT_EQ(j["ground_with_source"], "assumed");
  EXPECT_EQ(j["ground_with_version"], 1);
  // The band fed back is the correcting run's record: stored with the first run as the job
  // chose it (above a threshold from its revolutions' spread), absent from the inspection.
  const StoredRun corrected = load(first->run_id);
  ASSERT_TRUE(corrected.harmonics_fed_back.has_value());
  EXPECT_EQ(*corrected.harmonics_fed_back, first->harmonics_fed_back);
  ASSERT_TRUE(corrected.harmonic_threshold_um.has_value());
  EXPECT_GT(*corrected.harmonic_threshold_um, 0.0);
  EXPECT_FALSE(stored.harmonics_fed_back.has_value());
  EXPECT_TRUE(j["harmonics_fed_back"].is_null());
  const auto first_shown =
      testing::run_command("runs show " + std::to_string(first->run_id) + " --data-dir " + dir_.string());
  ASSERT_EQ(first_shown.exit_code, 0) << first_shown.output;
  EXPECT_NE(first_shown.output.find("band fed back     harmonics 0.." + std::to_string(first->harmonics_fed_back)),
            std::string::npos)
      << first_shown.output;
}

// Bad names are refused before the gauge is read: empty, too long, a NUL byte, a slash.
TEST_F(LoopGuardsTest, BadPartNamesAreRefusedBeforeTheGauge) {
  const std::int64_t requests = sim_->requests_served();
  const std::string bad[] = {"", std::string(2 * 1024 * 1024, 'A'), std::string("intake\0x", 8), "../etc",
                             "intake flat"};
  for (const std::string& name : bad) {
    JobSettings js = job_settings();
    js.part.name = name;
    Result<JobReport> r = measure(js);
    ASSERT_FALSE(r.ok()) << "part name of " << name.size() << " bytes accepted";
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(r.error().message.find("part name"), std::string::npos) << r.error().message;
    EXPECT_LT(r.error().message.size(), 400u) << "the message repeats the whole name";
  }
  expect_gauge_untouched(requests);
  EXPECT_FALSE(fs::exists(dir_ / "gaugeloop.sqlite")) << "nothing is stored for a refused name";
}

// A database another program keeps locked is found before the gauge is read.
TEST_F(LoopGuardsTest, ADatabaseLockedForTheWholeRunIsFoundBeforeTheGauge) {
  {
    Result<RunStore> create = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(create.ok());
  }
  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open((dir_ / "gaugeloop.sqlite").c_str(), &other), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);
  const std::int64_t requests = sim_->requests_served();
  Result<JobReport> r = measure(job_settings());
  sqlite3_exec(other, "ROLLBACK", nullptr, nullptr, nullptr);
  sqlite3_close(other);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kStorage);
  EXPECT_NE(r.error().message.find("before measuring"), std::string::npos) << r.error().message;
  expect_gauge_untouched(requests);
}

// A damaged database is refused before the gauge is read, naming the damage, and nothing is
// stored into it.
TEST_F(LoopGuardsTest, ADamagedDatabaseIsRefusedBeforeTheGauge) {
  Result<JobReport> first = measure(job_settings());
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(testing::damage_runs_table(dir_ / "gaugeloop.sqlite"));
  const std::int64_t requests = sim_->requests_served();
  Result<JobReport> r = measure(job_settings());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kStorage);
  EXPECT_NE(r.error().message.find("is damaged"), std::string::npos) << r.error().message;
  expect_gauge_untouched(requests);
}

// An NC directory that cannot be written (a read-only file system: root ignores permission
// bits) is found before the gauge is read.
TEST_F(LoopGuardsTest, AnNcDirectoryThatCannotBeWrittenIsFoundBeforeTheGauge) {
  testing::TmpfsMount ro(64);
  if (!ro.mounted()) GTEST_SKIP() << ro.why_not();
  fs::create_directories(ro.dir() / "nc");
  ASSERT_EQ(::mount(nullptr, ro.dir().c_str(), nullptr, MS_REMOUNT | MS_RDONLY, nullptr), 0) << std::strerror(errno);
  JobSettings js = job_settings();
  js.nc_dir = ro.dir() / "nc";
  const std::int64_t requests = sim_->requests_served();
  Result<JobReport> r = measure(js);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kIo);
  EXPECT_NE(r.error().message.find("is not writable"), std::string::npos) << r.error().message;
  expect_gauge_untouched(requests);
}

// A full file system where the database lives is found before the gauge is read.
TEST_F(LoopGuardsTest, NoRoomForARunIsFoundBeforeTheGauge) {
  testing::TmpfsMount small(512);
  if (!small.mounted()) GTEST_SKIP() << small.why_not();
  JobSettings js = job_settings();
  js.db_path = small.dir() / "gaugeloop.sqlite";
  const std::int64_t requests = sim_->requests_served();
  Result<JobReport> r = measure(js);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("KB free, less than"), std::string::npos) << r.error().message;
  expect_gauge_untouched(requests);
}

// A run measured whose database then refuses it keeps its measurement in a file, named in the
// error.
TEST_F(LoopGuardsTest, ARunTheDatabaseRefusesAfterMeasuringIsKeptInAFile) {
  const JobSettings js = job_settings();
  Result<JobReport> r = measure_with_database_locked(js);
  ASSERT_FALSE(r.ok());
  const std::string& m = r.error().message;
  const std::size_t at = m.find("the measurement is kept in ");
  ASSERT_NE(at, std::string::npos) << m;
  const fs::path kept = m.substr(at + std::string("the measurement is kept in ").size());
  ASSERT_TRUE(fs::is_regular_file(kept)) << kept;
  const std::string kept_json = slurp(kept);
  EXPECT_NE(kept_json.find("\"revolutions\""), std::string::npos);
  EXPECT_NE(kept_json.find("\"intake_flat\""), std::string::npos);
  EXPECT_EQ(kept.parent_path(), dir_ / "unstored-runs");
  EXPECT_FALSE(fs::exists(js.nc_dir / "unstored-runs")) << "never in the control's share";

  // Where the data directory cannot hold it (a file in the way), the message says so; the
  // measurement goes nowhere else: not into the NC share, not into a temporary directory.
  fs::remove_all(dir_ / "unstored-runs");
  std::ofstream(dir_ / "unstored-runs") << "in the way\n";
  r = measure_with_database_locked(js);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("the measurement could not be kept anywhere either"), std::string::npos)
      << r.error().message;
  EXPECT_FALSE(fs::exists(js.nc_dir / "unstored-runs"));
}

// A kept measurement comes back as the run it would have been: analysed and judged, stored as
// an inspection with the time, serial and revolutions of the measurement, the NC program as it
// was; by `db import-unstored` too, which moves the file aside. Another file is refused by name.
TEST_F(LoopGuardsTest, AKeptMeasurementIsStoredLaterAsTheRunItWas) {
  JobSettings js = job_settings();
  js.serial = "S-77";
  Result<JobReport> refused = measure_with_database_locked(js);
  ASSERT_FALSE(refused.ok());
  std::vector<fs::path> kept_files;
  for (const auto& e : fs::directory_iterator(dir_ / "unstored-runs")) kept_files.push_back(e.path());
  ASSERT_EQ(kept_files.size(), 1u);
  const std::string program_before = fs::exists(nc_file()) ? slurp(nc_file()) : std::string();

  Result<UnstoredRun> kept = read_unstored_run(kept_files[0]);
  ASSERT_TRUE(kept.ok()) << kept.error().message;
  EXPECT_EQ(kept->serial, "S-77");
  Result<JobReport> stored = store_unstored_run(*kept, js);
  ASSERT_TRUE(stored.ok()) << stored.error().message;
  EXPECT_TRUE(stored->inspection);
  Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  Result<StoredRun> run = store->load_run(stored->run_id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->summary.started_utc, kept->started_utc);
  EXPECT_EQ(run->summary.serial, "S-77");
  EXPECT_EQ(run->revolutions.size(), kept->measured.revolutions.size());
  for (std::size_t d = 0; d < kDegrees; ++d) {  // as stored: to the BLOB's 0.1 nm
    EXPECT_NEAR(run->revolutions[0].lift_mm[d], kept->measured.revolutions[0].lift_mm[d], 1e-7) << d;
  }
  EXPECT_NE(run->summary.verdict, Verdict::kNotJudged) << "judged against the part's tolerances";
  EXPECT_EQ(fs::exists(nc_file()) ? slurp(nc_file()) : std::string(), program_before) << "the program untouched";

  // The command: the file stored again, then moved aside.
  const std::string part = (fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.toml").string();
  testing::CommandResult cli = testing::run_command("db import-unstored " + kept_files[0].string() + " --part " + part +
                                                    " --data-dir " + dir_.string());
  EXPECT_EQ(cli.exit_code, 0) << cli.output;
  EXPECT_NE(cli.output.find("an inspection: the table in force is unchanged"), std::string::npos) << cli.output;
  EXPECT_FALSE(fs::exists(kept_files[0]));
  EXPECT_TRUE(fs::exists(dir_ / "unstored-runs" / "imported" / kept_files[0].filename()));

  std::ofstream(dir_ / "other.json") << "{\"kind\": \"something else\"}\n";
  cli = testing::run_command("db import-unstored " + (dir_ / "other.json").string() + " --part " + part +
                             " --data-dir " + dir_.string());
  EXPECT_EQ(cli.exit_code, 2) << cli.output;
  EXPECT_NE(cli.output.find("other.json: `kind` is not \"gaugeloop unstored run\""), std::string::npos) << cli.output;
}

// Inputs are read only from regular files of a bounded size, with a clear message otherwise.
TEST(BoundedInput, DevicesDirectoriesAndHugeFilesAreRefusedByName) {
  const testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  Result<LiftTable> zero = read_lift_table_csv("/dev/zero");
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.error().message.find("/dev/zero is not a regular file"), std::string::npos) << zero.error().message;
  Result<PartFile> part_dir = read_part_file(dir);
  ASSERT_FALSE(part_dir.ok());
  EXPECT_NE(part_dir.error().message.find("is a directory, not a file"), std::string::npos) << part_dir.error().message;
  Result<ModbusSettings> gauge = read_gauge_file("/dev/zero", ModbusSettings{});
  ASSERT_FALSE(gauge.ok());
  EXPECT_NE(gauge.error().message.find("gauge config /dev/zero is not a regular file"), std::string::npos);
  {
    std::ofstream big(dir / "big.csv", std::ios::binary);
    big.seekp(static_cast<std::streamoff>(kMaxInputFileBytes) + 1);
    big.put('\n');
  }
  Result<LiftTable> huge = read_lift_table_csv(dir / "big.csv");
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().message.find("bytes, more than the"), std::string::npos) << huge.error().message;
  const auto cli = testing::run_command("measure --gauge 127.0.0.1:1 --part /dev/zero --data-dir " + dir.string());
  EXPECT_EQ(cli.exit_code, 2) << cli.output;
  EXPECT_NE(cli.output.find("part file /dev/zero is not a regular file"), std::string::npos) << cli.output;
}

// A lift table and a part file saved with a UTF-8 byte order mark read as without one.
TEST(BoundedInput, AByteOrderMarkIsAccepted) {
  const testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
  const std::string csv = slurp(examples / "intake_flat.csv");
  const std::string toml = slurp(examples / "intake_flat.toml");
  { std::ofstream(dir / "intake_flat.csv", std::ios::binary) << "\xEF\xBB\xBF" << csv; }
  { std::ofstream(dir / "intake_flat.toml", std::ios::binary) << "\xEF\xBB\xBF" << toml; }
  Result<LiftTable> plain = read_lift_table_csv(examples / "intake_flat.csv");
  Result<LiftTable> with_bom = read_lift_table_csv(dir / "intake_flat.csv");
  ASSERT_TRUE(plain.ok());
  ASSERT_TRUE(with_bom.ok()) << with_bom.error().message;
  EXPECT_EQ(with_bom->lift_mm, plain->lift_mm);
  Result<PartFile> part = read_part_file(dir / "intake_flat.toml");
  ASSERT_TRUE(part.ok()) << part.error().message;
  EXPECT_EQ(part->part.name, "intake_flat");
}

}  // namespace
}  // namespace gaugeloop
