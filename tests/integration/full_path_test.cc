// The whole loop over loopback: simulator -> libmodbus poller -> SQLite -> analysis -> NC file,
// and the failures a user meets first, each leaving no run and no table behind.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "acquisition/modbus_gauge.h"
#include "cli/embedded_defaults.h"
#include "compensation/flat_probe.h"
#include "compensation/wheel_path.h"
#include "config/part_file.h"
#include "job/measure_job.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"
#include "tests/nc_out/nc_reference.h"
#include "tests/support/cli.h"
#include "tests/support/intake_job.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::run_command;
using testing::slurp;

class FullPathTest : public testing::IntakeJobTest {
 protected:
  int stored_runs() const {
    auto store = RunStore::open(dir_ / "gaugeloop.sqlite");
    EXPECT_TRUE(store.ok());
    auto runs = store->list_runs({});
    EXPECT_TRUE(runs.ok());
    return static_cast<int>(runs->size());
  }
};

TEST_F(FullPathTest, RecoversTheInjectedErrorAndWritesTheCorrectedTable) {
  SimulatorSettings ss;
  ss.time_scale = 4.0;  // 60 rpm simulated at 4x: the run takes about a second
  auto sim = GaugeSimulator::start(part_.part, design_, ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  ModbusSettings ms;
  ms.port = (*sim)->port();
  ModbusGauge gauge(ms);

  Result<JobReport> report = run_measure_job(gauge, job_settings());
  ASSERT_TRUE(report.ok()) << report.error().message;

  // The stored run: 3 raw revolutions and the analysis.
  auto store = RunStore::open(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  auto run = store->load_run(report->run_id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->revolutions.size(), 3u);
  EXPECT_EQ(run->summary.degrees_captured, 1080);
  EXPECT_EQ(run->summary.status, "pushed");
  EXPECT_EQ(run->summary.nc_file, report->nc_file.string());

  // The injected form error, zeroed like the analysis zeroes (mean over the base-circle
  // window 150..210 deg), is what the stored error table must show.
  double window_mean_um = 0.0;
  for (int d = 150; d <= 210; ++d) window_mean_um += (*sim)->lobe_error_um(d);
  window_mean_um /= 61.0;
  // Tolerance: gauge noise 0.3 um RMS per sample, averaged over 3 revolutions: 0.17 um per
  // degree, so the largest of 360 deviations stays below ~4 sigma = 0.7 um; plus 0.05 um
  // count rounding and the zero's own noise (0.17 / sqrt(61)). 1.0 um max, 0.3 um RMS.
  double sum_sq = 0.0;
  double worst = 0.0;
  for (int d = 0; d < 360; ++d) {
    const double expected_um = (*sim)->lobe_error_um(d) - window_mean_um;
    const double diff = run->analysis.error_um[d] - expected_um;
    worst = std::max(worst, std::abs(diff));
    sum_sq += diff * diff;
  }
  EXPECT_LT(worst, 1.0) << "largest deviation from the injected error, um";
  EXPECT_LT(std::sqrt(sum_sq / 360.0), 0.3) << "RMS deviation from the injected error, um";
  EXPECT_NEAR(run->analysis.max_abs_error_um, report->analysis.max_abs_error_um, 1e-9);
  EXPECT_GT(run->analysis.max_abs_error_um, 10.0) << "the simulator's 15 um peak error is seen";
  EXPECT_LT(run->analysis.repeatability_um, 1.0) << "0.3 um noise gives a per-degree spread well under 1 um";

  // The table, checked through the envelope: grind a lobe with what the NC interpolates
  // between the written points (read from the text, evaluated by the test's own reference,
  // tests/nc_out/nc_reference.h) and read it with a flat probe. It must read design -
  // injected error (correction at gain 1). Tolerance 1.3 um: the harmonic cut-off at 30
  // leaves 0.4 um of the simulator's error (at the base-circle junction, 85 deg); smoothing
  // leaves 0.17 * sqrt(61/360) = 0.07 um of noise per degree, under 0.3 um at the worst of
  // 360; 0.05 um from 4-decimal X; the default table's command position error, at most 0.5 um.
  const std::string program = slurp(report->nc_file);
  EXPECT_NE(program.find("CTABDEF(X,C,1,1)"), std::string::npos);
  EXPECT_NE(program.find("CTABEND"), std::string::npos);
  EXPECT_NE(program.find("run " + std::to_string(report->run_id)), std::string::npos);
  EXPECT_NE(program.find("; gaugeloop table_version: 1\n"), std::string::npos);
  EXPECT_LE(report->command_error_um, 0.5);
  EXPECT_LT(report->table_blocks, 361) << "the default table needs fewer blocks than G1 at 1 degree";
  const testing::RefTable table = testing::ref_parse(program);
  ASSERT_GE(table.c.size(), 4u);
  // One turn: a CSPLINE table from its seam (where the corrected path bends least: on the
  // base circle), a G1 table from C0; the reference reads C outside the range modulo the turn,
  // as the control does.
  EXPECT_TRUE(table.c.front() == 0.0 || (table.spline && table.c.front() > 90.0 && table.c.front() < 270.0))
      << table.c.front();
  EXPECT_NEAR(table.c.back(), table.c.front() + 360.0, 1e-9);
  EXPECT_DOUBLE_EQ(table.x.back(), table.x.front());
  const auto nc_x = testing::ref_interpolant(table);
  WheelPath written;
  for (int k = 0; k < 3600; ++k) {
    written.psi_deg.push_back(k * 0.1);  // C = psi for this part (sense 1, c0 0)
    written.x_mm.push_back(nc_x(k * 0.1));
  }
  auto ground = ground_lobe_reading(written, part_.part);
  ASSERT_TRUE(ground.ok()) << ground.error().message;
  double worst_ground_um = 0.0;
  for (int d = 0; d < 360; ++d) {
    const double design_mm = run->analysis.design_lift_mm[d];
    const double expected_mm = design_mm - ((*sim)->lobe_error_um(d) - window_mean_um) / 1000.0;
    worst_ground_um = std::max(worst_ground_um, std::abs((*ground)[d] - expected_mm) * 1000.0);
  }
  EXPECT_LT(worst_ground_um, 1.3) << "the table grinds design minus the measured error";
}

// A real grinder grinds the next part with the pushed table, so the next correction builds
// on it. This simulator does not grind (its form error stays put), so the second correction
// is the first plus the same smoothed error: twice the first, within the noise.
TEST_F(FullPathTest, NextRunBuildsOnTheTableInForce) {
  SimulatorSettings ss;
  ss.time_scale = 4.0;
  auto sim = GaugeSimulator::start(part_.part, design_, ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  ModbusSettings ms;
  ms.port = (*sim)->port();
  ModbusGauge gauge(ms);
  Result<JobReport> first = run_measure_job(gauge, job_settings());
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_FALSE(first->correction_in_force_run.has_value());
  // The simulator serves the same part again: said to be ground with the table in force (a
  // part that only seems so), the correction builds on that table's.
  JobSettings told = job_settings();
  told.ground_with_version = 1;
  Result<JobReport> second = run_measure_job(gauge, told);
  ASSERT_TRUE(second.ok()) << second.error().message;
  ASSERT_TRUE(second->correction_in_force_run.has_value());
  EXPECT_EQ(*second->correction_in_force_run, first->run_id);

  auto store = RunStore::open(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  auto a = store->load_run(first->run_id);
  auto b = store->load_run(second->run_id);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(b->correction_in_force_run, first->run_id);
  // Tolerance: each smoothed error carries 0.07 um of noise per degree (harmonics 0-30 keep
  // 61/360 of the 0.17 um per-degree noise); their difference stays under 0.5 um.
  for (int d = 0; d < 360; ++d) {
    EXPECT_NEAR(b->correction_um[d], 2.0 * a->correction_um[d], 0.5) << "degree " << d;
  }
}

// A correction that changes by more than max_change_um from the one in force is held: the
// run and its proposed correction are stored, nothing is pushed, the table in force stays,
// and the event log says why, naming the run.
TEST_F(FullPathTest, HeldCorrectionStoresTheRunAndPushesNoTable) {
  SimulatorSettings ss;
  ss.time_scale = 4.0;
  auto sim = GaugeSimulator::start(part_.part, design_, ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  ModbusSettings ms;
  ms.port = (*sim)->port();
  ModbusGauge gauge(ms);
  JobSettings js = job_settings();
  js.compensation.max_change_um = 5.0;  // the simulator's 15 um form error asks for more

  Result<JobReport> report = run_measure_job(gauge, js);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->verdict, CompensationVerdict::kHold);
  EXPECT_NE(report->not_pushed_reason.find("5.0"), std::string::npos) << report->not_pushed_reason;
  EXPECT_TRUE(report->nc_file.empty());
  EXPECT_FALSE(fs::exists(dir_ / "nc" / (part_.nc_program + ".SPF")));

  auto store = RunStore::open(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  auto run = store->load_run(report->run_id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->summary.status, "measured");
  EXPECT_TRUE(run->pushes.empty());
  EXPECT_GT(report->correction_max_um, 10.0) << "the proposed correction is kept for approval";
  double stored_max_um = 0.0;
  for (double c : run->correction_um) stored_max_um = std::max(stored_max_um, std::abs(c));
  EXPECT_NEAR(stored_max_um, report->correction_max_um, 1e-4);

  auto events = store->list_events({});
  ASSERT_TRUE(events.ok());
  ASSERT_EQ(events->size(), 1u);
  EXPECT_EQ((*events)[0].event.kind, EventKind::kRefusal);
  EXPECT_EQ((*events)[0].event.code, "compensation hold");
  EXPECT_EQ((*events)[0].event.run_id, report->run_id);

  // Nothing was pushed, so the next run still builds on the design.
  auto last = store->last_pushed_run(js.machine, part_.part.name, part_.part.lobe);
  ASSERT_TRUE(last.ok());
  EXPECT_FALSE(last->has_value());
}

// Beyond max_correction_um the correction is refused, whatever the change.
TEST_F(FullPathTest, CorrectionBeyondTheLimitIsRefusedAndNotPushed) {
  SimulatorSettings ss;
  ss.time_scale = 4.0;
  auto sim = GaugeSimulator::start(part_.part, design_, ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  ModbusSettings ms;
  ms.port = (*sim)->port();
  ModbusGauge gauge(ms);
  JobSettings js = job_settings();
  js.compensation.max_correction_um = 8.0;

  Result<JobReport> report = run_measure_job(gauge, js);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->verdict, CompensationVerdict::kRefuse);
  EXPECT_FALSE(fs::exists(dir_ / "nc" / (part_.nc_program + ".SPF")));
  EXPECT_EQ(stored_runs(), 1);
  auto store = RunStore::open(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  auto events = store->list_events({});
  ASSERT_TRUE(events.ok());
  ASSERT_EQ(events->size(), 1u);
  EXPECT_EQ((*events)[0].event.code, "compensation refuse");
}

TEST_F(FullPathTest, GaugeThatStopsAnsweringMidRunStoresNothingAndWritesNoTable) {
  SimulatorSettings ss;
  ss.time_scale = 4.0;
  ss.faults.push_back({FaultKind::kSilent, 2.0});  // the poller has started collecting by then
  auto sim = GaugeSimulator::start(part_.part, design_, ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  ModbusSettings ms;
  ms.port = (*sim)->port();
  ms.response_timeout = std::chrono::milliseconds(50);
  ModbusGauge gauge(ms);
  JobSettings js = job_settings();
  js.poller.max_attempts = 3;
  js.poller.backoff_initial = std::chrono::milliseconds(1);
  Result<JobReport> report = run_measure_job(gauge, js);
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(report.error().message.find("stopped answering during revolution"), std::string::npos)
      << report.error().message;
  EXPECT_EQ(stored_runs(), 0);
  EXPECT_FALSE(fs::exists(dir_ / "nc" / (part_.nc_program + ".SPF")));
}

TEST_F(FullPathTest, DemoRunsAreListedAndShownWithTheCurveTheirVerdictsJudge) {
  const std::string data = "--data-dir " + dir_.string();
  for (int i = 1; i <= 2; ++i) {
    CommandResult demo = run_command("demo " + data);
    ASSERT_EQ(demo.exit_code, 0) << demo.output;
    EXPECT_NE(demo.output.find("run " + std::to_string(i) + ":"), std::string::npos) << demo.output;
    EXPECT_NE(demo.output.find("degrees captured  1080 of 1080"), std::string::npos) << demo.output;
    EXPECT_NE(demo.output.find("CAM_INTAKE_L1.SPF"), std::string::npos) << demo.output;
    // Its simulated lobe was not ground with the table in force: the second table is chosen
    // afresh, not on the first one's points (docs/nc_output.md).
    EXPECT_EQ(demo.output.find("points of the table in force"), std::string::npos) << demo.output;
  }
  // The report names the curve the verdicts judged, with the figures `runs show` gives it:
  // the sample part judges the lift error after the best-fit phase, not the raw error above it.
  CommandResult last = run_command("demo " + data);
  ASSERT_EQ(last.exit_code, 0) << last.output;
  const std::size_t judged_at = last.output.find("  judged            lift error after the best-fit phase: max ");
  ASSERT_NE(judged_at, std::string::npos) << last.output;
  const std::string judged = last.output.substr(judged_at, last.output.find('\n', judged_at) - judged_at);
  CommandResult show = run_command("runs show 3 " + data);
  ASSERT_EQ(show.exit_code, 0) << show.output;
  EXPECT_NE(show.output.find(judged), std::string::npos) << judged << "\n" << show.output;
  EXPECT_NE(last.output.find("  runout            "), std::string::npos) << last.output;
  EXPECT_NE(last.output.find("  eccentricity      "), std::string::npos) << last.output;
  CommandResult list = run_command("runs list --json " + data);
  ASSERT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find("\"id\": 3"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("\"id\": 2"), std::string::npos) << list.output;
  EXPECT_NE(list.output.find("\"id\": 1"), std::string::npos) << list.output;
  EXPECT_LT(list.output.find("\"id\": 2"), list.output.find("\"id\": 1")) << "newest first";
  CommandResult text = run_command("runs list " + data);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("intake_flat"), std::string::npos) << text.output;
  EXPECT_TRUE(fs::exists(dir_ / "nc" / "CAM_INTAKE_L1.SPF"));
}

// Writes a part file beside a lift table text; returns the part path.
fs::path write_part(const fs::path& dir, const std::string& csv_name, const std::string* csv_text) {
  if (csv_text != nullptr) std::ofstream(dir / csv_name) << *csv_text;
  const fs::path part = dir / "part.toml";
  std::ofstream(part) << "name = \"test\"\nlift_table = \"" << csv_name
                      << "\"\nfollower = \"flat\"\nbase_circle_radius_mm = 18.0\nwheel_radius_mm = 200.0\n"
                         "nc_program = \"CAM_TEST\"\n";
  return part;
}

TEST_F(FullPathTest, MissingLiftTableFailsBeforeMeasuring) {
  const fs::path part = write_part(dir_, "missing.csv", nullptr);
  CommandResult r = run_command("measure --gauge 127.0.0.1:9 --part " + part.string() + " --data-dir " + dir_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("missing.csv: no such file"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "gaugeloop.sqlite"));
  EXPECT_FALSE(fs::exists(dir_ / "nc"));
}

TEST_F(FullPathTest, MalformedLiftTableNamesTheLine) {
  const std::string csv = "angle_deg,lift_mm\n0,1.0\n1,0.9\n2,oops\n";
  const fs::path part = write_part(dir_, "bad.csv", &csv);
  CommandResult r = run_command("measure --gauge 127.0.0.1:9 --part " + part.string() + " --data-dir " + dir_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.csv:4: lift `oops` is not a number"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "gaugeloop.sqlite"));
}

TEST_F(FullPathTest, MalformedPartFileNamesTheKeyAndLine) {
  const fs::path part = dir_ / "part.toml";
  std::ofstream(part) << "name = \"x\"\nlift_table = \"a.csv\"\nfolower = \"flat\"\n";
  CommandResult r = run_command("measure --gauge 127.0.0.1:9 --part " + part.string() + " --data-dir " + dir_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("part.toml:3: key `folower`: unknown key"), std::string::npos) << r.output;
}

TEST_F(FullPathTest, UnreachableGaugeStoresNoRunAndWritesNoTable) {
  // A bound socket that does not listen: connections to it are refused, and the port stays
  // ours until the test ends.
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  const std::string gauge = "127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  const fs::path part = fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.toml";
  CommandResult r =
      run_command("measure --gauge " + gauge + " --part " + part.string() + " --data-dir " + dir_.string());
  ::close(fd);
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("cannot connect to the gauge at tcp:" + gauge), std::string::npos) << r.output;
  EXPECT_EQ(stored_runs(), 0);
  EXPECT_FALSE(fs::exists(dir_ / "nc" / "CAM_INTAKE_L1.SPF"));
}

TEST_F(FullPathTest, BadCommandLineIsBadInputAndTouchesNothing) {
  CommandResult r = run_command("demo --revolutions 2 --data-dir " + dir_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--revolutions"), std::string::npos) << r.output;
  r = run_command("measure --gauge nonsense --part x.toml --data-dir " + dir_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("expected HOST:PORT"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir_ / "gaugeloop.sqlite"));
}

TEST_F(FullPathTest, TemplateWithAnUnknownPlaceholderIsRefusedBeforeMeasuring) {
  JobSettings js = job_settings();
  js.nc_template = "CTABDEF(X,C,1,1)\n{{table_blocks}}\n{{tabel_number}}\n";
  ModbusSettings ms;
  ms.port = 9;  // never contacted: the template is checked first
  ModbusGauge gauge(ms);
  Result<JobReport> report = run_measure_job(gauge, js);
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(report.error().message.find("cam_table.spf:3: unknown placeholder {{tabel_number}}"), std::string::npos)
      << report.error().message;
  EXPECT_FALSE(fs::exists(dir_ / "gaugeloop.sqlite"));
}

}  // namespace
}  // namespace gaugeloop
