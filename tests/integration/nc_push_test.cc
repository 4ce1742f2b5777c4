// Pushing curve tables to the control: versions, hand edits, approval, rollback and diff,
// through run_measure_job and the `gaugeloop nc` commands, on real files and SQLite; and a
// push killed at any moment leaving the old program or the new one.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "acquisition/modbus_gauge.h"
#include "cli/embedded_defaults.h"
#include "config/part_file.h"
#include "core/atomic_file.h"
#include "job/measure_job.h"
#include "job/nc_push.h"
#include "job/speed_files.h"
#include "nc_out/table_program.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/intake_job.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using testing::CommandResult;
using testing::run_command;
using testing::slurp;

class NcPushTest : public testing::IntakeSimulatorJobTest {
 protected:
  using IntakeSimulatorJobTest::measure;
  // The simulator serves one part; each measurement says it was ground with the table in
  // force (the version last pushed, 0: the design), so each builds on it and pushes.
  Result<JobReport> measure() { return measure(ground_with_table_in_force(job_settings())); }
  JobSettings ground_with_table_in_force(JobSettings js) const {
    js.ground_with_version = 0;
    if (auto s = RunStore::open(dir_ / "gaugeloop.sqlite"); s.ok()) {
      if (auto last = s->last_push(nc_file().string()); last.ok() && *last)
        js.ground_with_version = (**last).table_version;
    }
    return js;
  }

  std::string data() const { return "--data-dir " + dir_.string() + " "; }

  // `js` ground at the default work speed program, with the built-in speed subprogram template.
  static JobSettings with_speed_program(JobSettings js) {
    js.speed = WorkSpeedSettings{};
    js.nc_speed_template = std::string(embedded::kNcSpeedTemplate);
    js.nc_speed_template_name = "cam_speed.spf";
    return js;
  }

  RunStore store() const {
    auto s = RunStore::open(dir_ / "gaugeloop.sqlite");
    EXPECT_TRUE(s.ok());
    return std::move(*s);
  }
};

// The version in the header, the history, a diff that shows the change and a rollback that
// restores an earlier table as a new version, making its run the one the next builds on.
TEST_F(NcPushTest, VersionsHistoryDiffAndRollback) {
  auto first = measure();
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(first->pushed());
  const std::string v1 = slurp(nc_file());
  auto second = measure();  // builds on the first: its correction is about twice the first's
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(second->table_version, 2);
  const std::string v2 = slurp(nc_file());
  EXPECT_NE(v2.find("; gaugeloop table_version: 2\n"), std::string::npos);

  CommandResult history = run_command("nc history --json " + data());
  ASSERT_EQ(history.exit_code, 0) << history.output;
  json h = json::parse(history.output);
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h[0]["table_version"], 2);
  EXPECT_EQ(h[0]["run_id"], second->run_id);
  EXPECT_EQ(h[1]["reason"], "run " + std::to_string(first->run_id));

  // The second correction adds about the first's again (the simulator does not grind), so the
  // tables differ by about the first correction, 15 um or more somewhere.
  CommandResult diff = run_command("nc diff 1 2 --json " + data());
  ASSERT_EQ(diff.exit_code, 0) << diff.output;
  json d = json::parse(diff.output);
  EXPECT_GT(std::abs(d["largest_dx_um"].get<double>()), 10.0);
  EXPECT_FALSE(d["degrees"].empty());
  // The text names where each version came from once: "run 2", not "run 2, run 2".
  CommandResult text = run_command("nc diff 1 2 " + data());
  ASSERT_EQ(text.exit_code, 0) << text.output;
  const std::string second_run = "run " + std::to_string(second->run_id);
  EXPECT_NE(text.output.find("version 2    " + second_run + ", "), std::string::npos) << text.output;
  EXPECT_EQ(text.output.find(second_run + ", " + second_run), std::string::npos) << text.output;
  CommandResult same = run_command("nc diff 2 2 --json " + data());
  ASSERT_EQ(same.exit_code, 0) << same.output;
  EXPECT_EQ(json::parse(same.output)["largest_dx_um"].get<double>(), 0.0);

  CommandResult rollback = run_command("nc rollback 1 --by anna " + data());
  ASSERT_EQ(rollback.exit_code, 0) << rollback.output;
  const std::string v3 = slurp(nc_file());
  auto p1 = parse_table_program(v1, "v1");
  auto p3 = parse_table_program(v3, "v3");
  ASSERT_TRUE(p1.ok() && p3.ok());
  EXPECT_EQ(p3->body_checksum, p1->body_checksum) << "the table of version 1, block for block";
  EXPECT_EQ(p3->header.at("table_version"), "3");
  EXPECT_TRUE(verify_table_checksum(*p3, "v3").ok());
  auto s = store();
  auto in_force = s.last_pushed_run(job_settings().machine, part_.part.name, part_.part.lobe);
  ASSERT_TRUE(in_force.ok() && in_force->has_value());
  EXPECT_EQ(**in_force, first->run_id);
  auto last = s.last_push(nc_file().string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).reason, "rollback to version 1 by anna");

  // `runs show` of the first run lists both pushes of its table: version 1 and the rollback.
  CommandResult show = run_command("runs show " + std::to_string(first->run_id) + " --json " + data());
  ASSERT_EQ(show.exit_code, 0) << show.output;
  json pushes = json::parse(show.output)["nc_pushes"];
  ASSERT_EQ(pushes.size(), 2u);
  EXPECT_EQ(pushes[0]["table_version"], 1);
  EXPECT_EQ(pushes[1]["table_version"], 3);
  EXPECT_EQ(pushes[1]["reason"], "rollback to version 1 by anna");

  CommandResult missing = run_command("nc rollback 9 " + data());
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("version 9"), std::string::npos) << missing.output;
  EXPECT_EQ(slurp(nc_file()), v3);
}

// A table edited on the control is reported, never overwritten silently: the next run is
// stored and its table waits; approving it needs --overwrite-edited.
// Measured runs write the table to numbers 1, 2, 1 and, after each, the main program coupling
// the one just written; `nc rollback` (a new version) alternates and rewrites it too.
TEST_F(NcPushTest, EachPushWritesTheTableToTheOtherNumberAndTheMainProgramCouplingIt) {
  JobSettings js = job_settings();
  js.nc_main_template = std::string(embedded::kNcMainTemplate);
  js.nc_main_template_name = "cam_main.mpf";
  const fs::path main_file = dir_ / "nc" / (part_.nc_program + "_MAIN.MPF");
  for (int version = 1; version <= 3; ++version) {
    auto r = measure(ground_with_table_in_force(js));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->pushed()) << r->not_pushed_reason;
    ASSERT_EQ(r->table_version, version);
    const std::string n = version % 2 == 1 ? "1" : "2";
    const std::string table = slurp(nc_file());
    const std::string main = slurp(main_file);
    EXPECT_NE(table.find("CTABDEF(X,C," + n + ",1)"), std::string::npos) << "version " << version;
    EXPECT_NE(main.find("\nN10 " + part_.nc_program + " "), std::string::npos) << main;
    EXPECT_NE(main.find("EGON(X,\"FINE\",C," + n + ",0)"), std::string::npos) << main;
    EXPECT_NE(main.find("run " + std::to_string(r->run_id)), std::string::npos) << main;
    EXPECT_EQ(table.find("{{"), std::string::npos);
    EXPECT_EQ(main.find("{{"), std::string::npos) << main;
  }
  CommandResult back = run_command("nc rollback 2 --by ben " + data());
  ASSERT_EQ(back.exit_code, 0) << back.output;
  EXPECT_NE(slurp(nc_file()).find("CTABDEF(X,C,2,1)"), std::string::npos) << "version 4 goes to number 2";
  EXPECT_NE(slurp(main_file).find("EGON(X,\"FINE\",C,2,0)"), std::string::npos) << slurp(main_file);
}

// A control at MD10200 = 1000 loading through the HMI: the table's X are whole microns (3
// decimals), both files start with the archive header, the second run checks the table on the
// control, header and all, before overwriting it, and `nc check` finds it as pushed.
TEST_F(NcPushTest, AtOneMicronWithTheArchiveHeaderTheProgramsAreOnTheGridAndVerify) {
  JobSettings js = job_settings();
  js.nc_main_template = std::string(embedded::kNcMainTemplate);
  js.nc_main_template_name = "cam_main.mpf";
  js.nc_archive_header = true;
  js.table_format.x_increments_per_mm = 1000.0;
  // G1 at 1 deg: what this test checks is the grid and the header. The default spline table,
  // refined where the measured correction asks for it, puts whole-micron rounding into the
  // spline's curvature (6 x 0.0005 mm / h^2) and now and then broke the slide's 20 m/s^2 by
  // that alone; which runs it did depended on the gauge's timing.
  js.table_kind = TableKind::kLinear;
  js.table_step_deg = 1.0;
  const fs::path main_file = dir_ / "nc" / (part_.nc_program + "_MAIN.MPF");
  for (int version = 1; version <= 2; ++version) {
    auto r = measure(ground_with_table_in_force(js));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->pushed()) << r->not_pushed_reason;
    const std::string table = slurp(nc_file());
    const std::string main = slurp(main_file);
    EXPECT_EQ(table.rfind("%_N_" + part_.nc_program + "_SPF\n;$PATH=/_N_SPF_DIR\n", 0), 0u) << table.substr(0, 200);
    EXPECT_EQ(main.rfind("%_N_" + part_.nc_program + "_MAIN_MPF\n;$PATH=/_N_MPF_DIR\n", 0), 0u) << main.substr(0, 200);
    Result<ParsedTable> t = parse_table_program(table, nc_file().string());
    ASSERT_TRUE(t.ok()) << t.error().message;
    for (const CurvePoint& p : t->points) EXPECT_NEAR(p.x_mm * 1000.0, std::round(p.x_mm * 1000.0), 1e-9);
    EXPECT_EQ(table.find("X0.0000"), std::string::npos) << "X is written with 3 decimals";
    EXPECT_NE(table.find(" X0.000"), std::string::npos);
  }
  CommandResult check = run_command("nc check " + data());
  EXPECT_EQ(check.exit_code, 0) << check.output;
}

// A lobe with a speed program: each push writes the table, the speed subprogram beside it
// (read back: the speed the control runs is within the bound of the program planned on the
// corrected path, and the turn is the slower one) and the main program that couples the new
// table number and calls the speed subprogram; every placeholder filled.
TEST_F(NcPushTest, WithASpeedProgramEachPushWritesTheSpeedSubprogramTheMainProgramCalls) {
  JobSettings js = job_settings();
  js = with_speed_program(js);
  js.nc_main_template = std::string(embedded::kNcMainSpeedTemplate);
  js.nc_main_template_name = "cam_main_speed.mpf";
  const fs::path main_file = dir_ / "nc" / (part_.nc_program + "_MAIN.MPF");
  const fs::path speed_file = dir_ / "nc" / (part_.nc_program + "_SPEED.SPF");
  for (int version = 1; version <= 2; ++version) {
    auto r = measure(ground_with_table_in_force(js));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->pushed()) << r->not_pushed_reason;
    const std::string n = version % 2 == 1 ? "1" : "2";
    const std::string table = slurp(nc_file());
    const std::string main = slurp(main_file);
    const std::string speed = slurp(speed_file);
    EXPECT_NE(table.find("CTABDEF(X,C," + n + ",1)"), std::string::npos) << "version " << version;
    EXPECT_NE(main.find("EGON(X,\"FINE\",C," + n + ",0)"), std::string::npos) << main;
    EXPECT_NE(main.find("\n" + part_.nc_program + "_SPEED P12"), std::string::npos) << "roughing, 12 turns\n" << main;
    EXPECT_NE(speed.find("table_version: " + std::to_string(version)), std::string::npos) << speed.substr(0, 600);
    for (const std::string* text : {&table, &main, &speed}) EXPECT_EQ(text->find("{{"), std::string::npos) << *text;
    EXPECT_NE(speed.find("run_id: " + std::to_string(r->run_id)), std::string::npos) << speed.substr(0, 600);
    Result<ParsedSpeedProgram> back = read_speed_program(nc_file());
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(static_cast<int>(back->blocks.size()), r->speed_blocks);
    // The speed as written: slower on the lobe than on the base circle (C 180 is on it).
    double slowest = 1e9, at_base = 0.0;
    for (const SpeedBlock& b : back->blocks) {
      slowest = std::min(slowest, b.feed_deg_per_min / 360.0);
      if (b.c_end_deg > 150.0 && b.c_end_deg < 210.0) at_base = b.feed_deg_per_min / 360.0;
    }
    EXPECT_NEAR(at_base, js.speed->base_speed_rpm, 0.01) << speed;
    EXPECT_LT(slowest, 0.5 * js.speed->base_speed_rpm) << speed;
    EXPECT_LE(r->speed_error_percent, js.speed_profile.bound_percent);
    EXPECT_GT(r->speed_cycle_time_s, 1.5 * r->constant_cycle_time_s);
    EXPECT_NEAR(r->constant_cycle_time_s, 60.0 / js.speed->base_speed_rpm, 1e-6);
  }
}

// With a speed program, a main program that does not call the speed subprogram (the one for
// one speed) is refused before the gauge is read, naming the template and the subprogram.
TEST_F(NcPushTest, WithASpeedProgramAMainProgramNotCallingItIsRefusedBeforeMeasuring) {
  JobSettings js = job_settings();
  js = with_speed_program(js);
  js.nc_main_template = std::string(embedded::kNcMainTemplate);
  js.nc_main_template_name = "/etc/gaugeloop/cam_main.mpf";
  auto report = measure(js);
  ASSERT_FALSE(report.ok());
  EXPECT_NE(report.error().message.find("/etc/gaugeloop/cam_main.mpf"), std::string::npos) << report.error().message;
  EXPECT_NE(report.error().message.find(part_.nc_program + "_SPEED"), std::string::npos) << report.error().message;
  js.nc_speed_template.clear();
  report = measure(js);
  ASSERT_FALSE(report.ok());
  EXPECT_NE(report.error().message.find("speed_template"), std::string::npos) << report.error().message;
  EXPECT_EQ(sim_->requests_served(), 0) << "no gauge request was made";
  EXPECT_FALSE(fs::exists(nc_file()));
}

TEST_F(NcPushTest, TableEditedByHandIsReportedAndKept) {
  auto first = measure();
  ASSERT_TRUE(first.ok()) << first.error().message;
  std::string text = slurp(nc_file());
  const auto x_at = text.find(" X", text.find("CTABDEF"));
  ASSERT_NE(x_at, std::string::npos);
  text.insert(x_at + 2, "1");  // X8.49... becomes X18.49...: someone changed a point
  ASSERT_TRUE(write_file_atomically(nc_file(), text).ok());

  CommandResult check = run_command("nc check " + data());
  EXPECT_EQ(check.exit_code, 2) << check.output;
  EXPECT_NE(check.output.find("edited by hand"), std::string::npos) << check.output;

  auto second = measure();
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_FALSE(second->pushed());
  EXPECT_NE(second->not_pushed_reason.find("edited by hand"), std::string::npos) << second->not_pushed_reason;
  ASSERT_TRUE(second->pending_id.has_value());
  EXPECT_EQ(slurp(nc_file()), text) << "the edited program is untouched";

  const std::string id = std::to_string(*second->pending_id);
  CommandResult refused = run_command("nc approve " + id + " " + data());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_EQ(slurp(nc_file()), text);
  CommandResult approved = run_command("nc approve " + id + " --overwrite-edited --by ben " + data());
  ASSERT_EQ(approved.exit_code, 0) << approved.output;
  auto parsed = parse_table_program(slurp(nc_file()), "approved");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_TRUE(verify_table_checksum(*parsed, "approved").ok());
  EXPECT_EQ(parsed->header.at("table_version"), "2");
  EXPECT_EQ(parsed->header.at("run_id"), std::to_string(second->run_id));
  auto pending = store().load_pending(*second->pending_id);
  ASSERT_TRUE(pending.ok());
  EXPECT_EQ(pending->status, PendingStatus::kApproved);
  EXPECT_EQ(pending->decided_by, "ben");
}

// A lobe with a speed program and approval required: the table waits with its speed
// subprogram, and approving it writes that subprogram beside the table, naming the version
// pushed (its blocks checksummed and read back as the control would), so that the main program
// never calls a speed subprogram that is missing or belongs to another table.
TEST_F(NcPushTest, ApprovingATableWithASpeedProgramWritesItsSpeedSubprogram) {
  JobSettings js = job_settings();
  js.require_approval = true;
  js = with_speed_program(js);
  const fs::path speed_file = dir_ / "nc" / (part_.nc_program + "_SPEED.SPF");
  for (int version = 1; version <= 2; ++version) {
    auto r = measure(ground_with_table_in_force(js));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_TRUE(r->pending_id.has_value()) << r->not_pushed_reason;
    auto pending = store().load_pending(*r->pending_id);
    ASSERT_TRUE(pending.ok()) << pending.error().message;
    ASSERT_TRUE(pending->speed_program_text.has_value()) << "the speed subprogram waits with its table";
    EXPECT_NE(pending->speed_program_text->find("table_version: 0"), std::string::npos);
    if (version == 1) {
      EXPECT_FALSE(fs::exists(speed_file)) << "nothing reaches the control before approval";
    }

    const std::string id = std::to_string(*r->pending_id);
    if (version == 1) {
      // A main program that grinds at one speed would not call it: refused before anything is
      // written.
      CommandResult refused =
          run_command("nc approve " + id + " --by anna --main-template " + std::string(GAUGELOOP_SOURCE_DIR) +
                      "/examples/sinumerik/cam_main.mpf " + data());
      EXPECT_EQ(refused.exit_code, 2) << refused.output;
      EXPECT_NE(refused.output.find("_SPEED"), std::string::npos) << refused.output;
      EXPECT_FALSE(fs::exists(speed_file));
      EXPECT_FALSE(fs::exists(nc_file()));
    }
    // Without --main-template: the built-in main program that calls the speed subprogram.
    CommandResult approved = run_command("nc approve " + id + " --by anna " + data());
    ASSERT_EQ(approved.exit_code, 0) << approved.output;
    ASSERT_TRUE(fs::exists(speed_file));
    EXPECT_NE(slurp(dir_ / "nc" / (part_.nc_program + "_MAIN.MPF")).find(part_.nc_program + "_SPEED"),
              std::string::npos)
        << "the main program calls the speed subprogram written";
    const std::string speed = slurp(speed_file);
    EXPECT_NE(speed.find("table_version: " + std::to_string(version)), std::string::npos) << speed.substr(0, 600);
    EXPECT_NE(speed.find("run_id: " + std::to_string(r->run_id)), std::string::npos) << speed.substr(0, 600);
    Result<ParsedSpeedProgram> back = read_speed_program(nc_file());
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(static_cast<int>(back->blocks.size()), r->speed_blocks);
    auto parsed = parse_table_program(slurp(nc_file()), "approved");
    ASSERT_TRUE(parsed.ok()) << parsed.error().message;
    EXPECT_EQ(parsed->header.at("table_version"), std::to_string(version));
  }
}

// With approval required nothing reaches the control until a person approves; a table
// approved once cannot be approved again, and a rejected one never reaches the control.
TEST_F(NcPushTest, ApprovalRequiredHoldsTheTableUntilApproved) {
  JobSettings js = job_settings();
  js.require_approval = true;
  auto report = measure(js);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_FALSE(report->pushed());
  EXPECT_EQ(report->verdict, CompensationVerdict::kApply);
  ASSERT_TRUE(report->pending_id.has_value());
  EXPECT_FALSE(fs::exists(nc_file()));

  CommandResult pending = run_command("nc pending --json " + data());
  ASSERT_EQ(pending.exit_code, 0) << pending.output;
  json p = json::parse(pending.output);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0]["reason"], "approval required");
  EXPECT_EQ(p[0]["run_id"], report->run_id);

  const std::string id = std::to_string(*report->pending_id);
  CommandResult approved = run_command("nc approve " + id + " --by anna " + data());
  ASSERT_EQ(approved.exit_code, 0) << approved.output;
  auto parsed = parse_table_program(slurp(nc_file()), "approved");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->header.at("table_version"), "1");
  auto s = store();
  auto last = s.last_push(nc_file().string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).reason, "approved by anna");
  EXPECT_EQ((**last).run_id, report->run_id);
  CommandResult again = run_command("nc approve " + id + " " + data());
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("approved"), std::string::npos) << again.output;

  auto next = measure(ground_with_table_in_force(js));
  ASSERT_TRUE(next.ok()) << next.error().message;
  ASSERT_TRUE(next->pending_id.has_value());
  const std::string before = slurp(nc_file());
  CommandResult rejected =
      run_command("nc reject " + std::to_string(*next->pending_id) + " --by bert --note noisy " + data());
  ASSERT_EQ(rejected.exit_code, 0) << rejected.output;
  EXPECT_EQ(slurp(nc_file()), before);
  CommandResult late = run_command("nc approve " + std::to_string(*next->pending_id) + " " + data());
  EXPECT_EQ(late.exit_code, 2) << late.output;
  EXPECT_EQ(slurp(nc_file()), before);

  // Every decision listed says who made it.
  CommandResult all = run_command("nc pending --all " + data());
  ASSERT_EQ(all.exit_code, 0) << all.output;
  EXPECT_NE(all.output.find("decided"), std::string::npos) << all.output;
  EXPECT_NE(all.output.find("approved    anna 20"), std::string::npos) << all.output;
  EXPECT_NE(all.output.find("rejected    bert 20"), std::string::npos) << all.output;
}

// Axis guards are checked on the design before any measurement: a slide limit the design
// already breaks costs no run and names the C degree.
TEST_F(NcPushTest, DesignBeyondTheSlideLimitIsRefusedBeforeMeasuring) {
  JobSettings js = job_settings();
  js.axis_limits.x_velocity_max_mm_per_s = 10.0;  // the intake lobe asks for about 63 mm/s at 60 rpm
  auto report = measure(js);
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, ErrorCode::kRefused);
  EXPECT_NE(report.error().message.find("velocity"), std::string::npos) << report.error().message;
  EXPECT_NE(report.error().message.find("C"), std::string::npos) << report.error().message;
  EXPECT_EQ(sim_->requests_served(), 0) << "no gauge request was made";
  EXPECT_FALSE(fs::exists(nc_file()));
}

// A main program template that is wrong for either table number, or names a placeholder
// nobody fills, costs no measurement and writes nothing.
TEST_F(NcPushTest, AMainTemplateWrongForEitherNumberIsRefusedBeforeMeasuring) {
  JobSettings js = job_settings();
  js.nc_main_template_name = "/etc/gaugeloop/cam_main.mpf";
  const std::string shipped(embedded::kNcMainTemplate);
  const std::string coupled = "EGON(X,\"FINE\",C,{{table_number}},0)";
  ASSERT_NE(shipped.find(coupled), std::string::npos);
  std::string fixed = shipped;
  fixed.replace(fixed.find(coupled), coupled.size(), "EGON(X,\"FINE\",C,1,0)");
  for (const auto& [tmpl, expected] : {std::pair{fixed, std::string("couples curve table 1 at line 13, not table 2")},
                                       std::pair{shipped + "; {{wheel_speed}}\n", std::string("wheel_speed")}}) {
    js.nc_main_template = tmpl;
    auto report = measure(js);
    ASSERT_FALSE(report.ok());
    EXPECT_EQ(report.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(report.error().message.find(expected), std::string::npos) << report.error().message;
    EXPECT_NE(report.error().message.find("/etc/gaugeloop/cam_main.mpf"), std::string::npos) << report.error().message;
  }
  EXPECT_EQ(sim_->requests_served(), 0) << "no gauge request was made";
  EXPECT_FALSE(fs::exists(nc_file()));
  EXPECT_FALSE(fs::exists(dir_ / "nc" / (part_.nc_program + "_MAIN.MPF")));
}

// A directory where the NC program goes would fail the push after the run is stored (the
// control's share set up wrongly): refused before any measurement, naming the path.
TEST_F(NcPushTest, DirectoryInThePlaceOfTheProgramIsRefusedBeforeMeasuring) {
  fs::create_directories(nc_file());
  auto report = measure();
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, ErrorCode::kIo);
  EXPECT_NE(report.error().message.find(nc_file().filename().string()), std::string::npos) << report.error().message;
  EXPECT_NE(report.error().message.find("not a file"), std::string::npos) << report.error().message;
  EXPECT_EQ(sim_->requests_served(), 0) << "no gauge request was made";
  auto runs = store().list_runs({});
  ASSERT_TRUE(runs.ok());
  EXPECT_TRUE(runs->empty());
}

// The control's share goes away while the lobe is measured: the run is stored, the push fails,
// and the caller learns the run's id before the push (what the PLC's result words report),
// the run stays unpushed and the fault names it.
TEST_F(NcPushTest, APushFailingAfterTheRunIsStoredKeepsTheRunAndNamesIt) {
  JobSettings js = job_settings();
  std::optional<std::int64_t> stored;
  js.on_step = [&](const JobStep& step) {
    if (step.code != "stored") return;
    stored = step.run_id;
    fs::remove_all(dir_ / "nc");
    std::ofstream(dir_ / "nc") << "a file where the NC directory was\n";
  };
  auto report = measure(js);
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, ErrorCode::kIo) << report.error().message;
  ASSERT_TRUE(stored.has_value());
  auto runs = store().list_runs({});
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].id, *stored);
  EXPECT_EQ((*runs)[0].status, "measured");
  EventQuery q;
  q.kind = EventKind::kFault;
  auto faults = store().list_events(q);
  ASSERT_TRUE(faults.ok());
  ASSERT_EQ(faults->size(), 1u);
  EXPECT_EQ((*faults)[0].event.run_id, stored);
}

// A push killed at any moment leaves the old program or the new one, whole: a child pushes
// two programs in turn; the parent kills it right after it reports starting a write, 40
// times, and each time the file must be exactly one of the two.
TEST(NcPushKill, KilledPushLeavesTheOldProgramOrTheNewOne) {
  const testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  const fs::path file = dir / "CAM.SPF";
  // Large programs, so a kill lands inside a write more often than between writes.
  std::string a = "; program A\n";
  std::string b = "; program B\n";
  for (int i = 0; i < 20000; ++i) {
    a += "C" + std::to_string(i) + " X1.0000\n";
    b += "C" + std::to_string(i) + " X2.0000\n";
  }
  ASSERT_TRUE(write_file_atomically(file, a).ok());
  int old_or_new = 0;
  for (int k = 0; k < 40; ++k) {
    int ready[2];
    ASSERT_EQ(::pipe(ready), 0);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(ready[0]);
      for (int i = 0;; ++i) {
        const char c = 'w';
        if (::write(ready[1], &c, 1) != 1) ::_exit(3);
        if (!write_file_atomically(file, (i % 2 == 0) ? b : a).ok()) ::_exit(2);
      }
    }
    ::close(ready[1]);
    // Let the child start 1 + k % 5 writes, then kill it during the last one.
    char c = 0;
    for (int i = 0; i <= k % 5; ++i) ASSERT_EQ(::read(ready[0], &c, 1), 1);
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ::close(ready[0]);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the child must have been killed, not have failed";
    const std::string now = slurp(file);
    ASSERT_TRUE(now == a || now == b) << "kill " << k << ": the program is a mixture (" << now.size() << " bytes)";
    ++old_or_new;
  }
  EXPECT_EQ(old_or_new, 40);
}

}  // namespace
}  // namespace gaugeloop
