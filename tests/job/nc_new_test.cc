// The first program of a part from its drawing (write_new_program), as `gaugeloop nc new`
// makes it: every file read back by the test's own reader and evaluated against the exact
// path (the pins' closed forms, the lobes' kinematics), the history it leaves, and each
// refusal leaving the control and the history as they were.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli/measure_options.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "job/nc_new.h"
#include "job/pin_files.h"
#include "job/speed_files.h"
#include "nc_out/main_program.h"
#include "nc_out/table_program.h"
#include "storage/run_store.h"
#include "tests/nc_out/nc_reference.h"
#include "tests/support/angles.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

namespace fs = std::filesystem;

using testing::slurp;

class NcNewTest : public ::testing::Test {
 protected:
  // The settings `nc new --part examples/<example> --data-dir <dir>` makes.
  JobSettings settings_for(const std::string& example, MeasureOptions o = {}) {
    o.part_path = (fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / example).string();
    o.paths.data_dir = dir_.path().string();
    Result<LoadedPart> lp = load_part(o.part_path);
    EXPECT_TRUE(lp.ok()) << lp.error().message;
    Result<JobSettings> js = job_settings_for(*lp, o, false);
    EXPECT_TRUE(js.ok()) << js.error().message;
    return js.ok() ? *js : JobSettings{};
  }

  static double header_number(const std::string& program, const std::string& key) {
    Result<ParsedTable> t = parse_table_program(program, "program");
    EXPECT_TRUE(t.ok());
    return t.ok() && t->header.count(key) ? std::stod(t->header.at(key)) : -1.0;
  }

  // Largest |what the test's reader makes of the program - exact(C)| every 0.01 deg, um.
  static double independent_error_um(const std::string& program, char axis,
                                     const std::function<double(double)>& exact) {
    const auto nc = testing::ref_interpolant(testing::ref_parse(program, axis));
    double worst = 0.0;
    for (int j = 0; j <= 36000; ++j) {
      const double c = j * 0.01;
      worst = std::max(worst, std::abs(nc(c) - exact(c)) * 1000.0);
    }
    return worst;
  }

  testing::TempDir dir_{"nc-new"};
};

// The stated command error is the error of the points as written against the exact path at
// the fine rows; the test's reader solves the same spline its own way. 0.002 um covers the
// header's three decimals (0.0005) and the two solvers' round-off.
constexpr double kReaderToleranceUm = 0.002;

TEST_F(NcNewTest, TheLobesProgramsReadBackWithinTheirStatedCommandError) {
  for (const std::string example : {"intake_flat.toml", "exhaust_roller.toml"}) {
    SCOPED_TRACE(example);
    testing::TempDir dir("nc-new-lobe");
    MeasureOptions o;
    o.paths.data_dir = dir.path().string();
    const JobSettings js = settings_for(example, o);
    Result<NewProgramReport> r = write_new_program(js, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->table_version, 1);
    ASSERT_EQ(r->files.size(), 2u);  // the table and the main program
    const std::string program = slurp(r->nc_file);
    const double stated = header_number(program, "command_error_um");
    EXPECT_LE(stated, js.table_choice.bound_um);
    Result<PeriodicSpline> lift = PeriodicSpline::fit(js.design.angle_deg, js.design.lift_mm);
    ASSERT_TRUE(lift.ok());
    Result<MachinePath> path = compute_machine_path(*lift, js.part, 0.01);
    ASSERT_TRUE(path.ok());
    const double measured = independent_error_um(program, 'X', [&](double c) {
      return path->x_mm[static_cast<std::size_t>(std::lround(c / 0.01)) % path->x_mm.size()];
    });
    EXPECT_LE(measured, stated + kReaderToleranceUm);
    // The main program couples the table just written and starts off the stock.
    const std::string main = slurp(main_program_path(r->nc_file));
    EXPECT_NE(main.find("EGON(X,\"FINE\",C,1,0)"), std::string::npos) << main;
    EXPECT_NE(main.find("X-0.2300"), std::string::npos) << "roughing: 0.05 air gap + 0.2 - 0.02 stock\n" << main;
    EXPECT_EQ(main.find("{{"), std::string::npos);
  }
}

// Both sample pins, against their closed forms (docs/crankpins.md), X and in C-X-Y Y: the
// tables keep the pin's 0.1 um bound, and read independently they are within it.
TEST_F(NcNewTest, ThePinsProgramsReadBackWithinTheirStatedCommandErrorAgainstTheClosedForm) {
  const double r_throw = 45.0, r_pin = 25.0, r_wheel = 300.0;
  const double a = (r_pin + r_wheel) * (r_pin + r_wheel);
  auto cx = [&](double c) {
    const double t = c * kRadPerDeg;
    return r_throw * std::cos(t) + std::sqrt(a - r_throw * r_throw * std::sin(t) * std::sin(t)) -
           (r_pin + r_wheel - r_throw);
  };
  auto cxy_x = [&](double c) { return r_throw * std::cos(c * kRadPerDeg) + r_throw; };
  auto cxy_y = [&](double c) { return r_throw * std::sin(c * kRadPerDeg); };
  {
    testing::TempDir dir("nc-new-cx");
    MeasureOptions o;
    o.paths.data_dir = dir.path().string();
    const JobSettings js = settings_for("crankpin_cx.toml", o);
    Result<NewProgramReport> r = write_new_program(js, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    const std::string x = slurp(r->nc_file);
    const double stated = header_number(x, "command_error_um");
    EXPECT_LE(stated, kPinCommandErrorBoundUm);
    EXPECT_LE(independent_error_um(x, 'X', cx), stated + kReaderToleranceUm);
  }
  {
    testing::TempDir dir("nc-new-cxy");
    MeasureOptions o;
    o.paths.data_dir = dir.path().string();
    const JobSettings js = settings_for("crankpin_cxy.toml", o);
    Result<NewProgramReport> r = write_new_program(js, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->files.size(), 3u);  // X, Y and the main program
    const std::string x = slurp(r->nc_file);
    const std::string y = slurp(y_table_program_path(r->nc_file));
    EXPECT_LE(independent_error_um(x, 'X', cxy_x), header_number(x, "command_error_um") + kReaderToleranceUm);
    EXPECT_LE(independent_error_um(y, 'Y', cxy_y), header_number(y, "command_error_um") + kReaderToleranceUm);
    const std::string main = slurp(main_program_path(r->nc_file));
    EXPECT_NE(main.find("EGON(Y,\"FINE\",C,3,0)"), std::string::npos) << main;
  }
}

// At the control's finest resolution (MD10200 = 1,000,000) a pin's X table at 1 degree
// carries at most 0.001 um of command error, read independently against the closed form: its
// seam lies where the path bends least, and the header says where.
TEST_F(NcNewTest, APinsXTableAtOneDegreeKeepsANanometreAndNamesItsSeam) {
  const double r_throw = 45.0;
  for (const std::string example : {"crankpin_cx.toml", "crankpin_cxy.toml"}) {
    SCOPED_TRACE(example);
    testing::TempDir dir("nc-new-fine");
    MeasureOptions o;
    o.paths.data_dir = dir.path().string();
    o.table = "spline";
    o.table_step_deg = 1.0;
    o.int_incr_per_mm = 1000000;
    const JobSettings js = settings_for(example, o);
    Result<NewProgramReport> r = write_new_program(js, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    const std::string x = slurp(r->nc_file);
    const double seam = header_number(x, "seam_c_deg");
    EXPECT_GT(std::abs(std::fmod(seam, 60.0)), 1.0) << seam;  // not the old multiples of 60
    const bool cxy = example == "crankpin_cxy.toml";
    const double a = 325.0 * 325.0;
    const double measured = independent_error_um(x, 'X', [&](double c) {
      const double t = c * kRadPerDeg;
      return cxy ? r_throw * std::cos(t) + r_throw
                 : r_throw * std::cos(t) + std::sqrt(a - r_throw * r_throw * std::sin(t) * std::sin(t)) - 280.0;
    });
    EXPECT_LE(measured, 0.001);
  }
}

// A POLY program, asked for: both tables of the C-X-Y pin at 1 degree and 1e-6 mm, written,
// read back by the job, and read independently (the manual's polynomial from the text)
// against the closed form within the grid's half increment plus the cubic's own 1e-5 um and
// the coefficients' rounding (tests/nc_out/pin_seam_test.cc): 0.000515 um.
TEST_F(NcNewTest, APinsPolyProgramReachesTheGridsHalfIncrement) {
  testing::TempDir dir("nc-new-poly");
  MeasureOptions o;
  o.paths.data_dir = dir.path().string();
  o.table = "poly";
  o.table_step_deg = 1.0;
  o.int_incr_per_mm = 1000000;
  const JobSettings js = settings_for("crankpin_cxy.toml", o);
  Result<NewProgramReport> r = write_new_program(js, {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  const std::string x = slurp(r->nc_file);
  const std::string y = slurp(y_table_program_path(r->nc_file));
  EXPECT_NE(x.find("interpolation: poly"), std::string::npos) << x.substr(0, 800);
  EXPECT_NE(x.find("POLY PO[C]=(1.000) PO[X]=("), std::string::npos) << x.substr(0, 1600);
  const double r_throw = 45.0;
  EXPECT_LE(independent_error_um(x, 'X', [&](double c) { return r_throw * std::cos(c * kRadPerDeg) + r_throw; }),
            0.000515);
  EXPECT_LE(independent_error_um(y, 'Y', [&](double c) { return r_throw * std::sin(c * kRadPerDeg); }), 0.000515);
}

TEST_F(NcNewTest, IsVersionOneWithNoRunBehindItAndTheHistorySaysSo) {
  const JobSettings js = settings_for("intake_flat.toml");
  NewProgramOptions options;
  options.by = "anna";
  options.from_file = "intake_flat.toml";
  Result<NewProgramReport> r = write_new_program(js, options);
  ASSERT_TRUE(r.ok()) << r.error().message;
  Result<RunStore> store = RunStore::open(js.db_path);
  ASSERT_TRUE(store.ok());
  Result<std::optional<NcPush>> last = store->last_push(r->nc_file.string());
  ASSERT_TRUE(last.ok() && last->has_value());
  EXPECT_EQ((**last).run_id, 0);
  EXPECT_EQ((**last).table_version, 1);
  EXPECT_EQ((**last).reason, "new program from intake_flat.toml by anna");
  EXPECT_EQ(*(**last).program_text, slurp(r->nc_file));
  RunQuery all;
  Result<std::vector<RunSummary>> runs = store->list_runs(all);
  ASSERT_TRUE(runs.ok());
  EXPECT_TRUE(runs->empty()) << "nc new stores no run";
  PushQuery pushes;
  Result<std::vector<NcPush>> history = store->list_pushes(pushes);
  ASSERT_TRUE(history.ok());
  ASSERT_EQ(history->size(), 1u) << "the history lists a push with no run";
  EXPECT_NE(slurp(r->nc_file).find("; gaugeloop run_id: 0"), std::string::npos);
}

TEST_F(NcNewTest, AProgramWithAHistoryIsRefusedUnlessReplacedAndNothingChanges) {
  const JobSettings js = settings_for("intake_flat.toml");
  Result<NewProgramReport> first = write_new_program(js, {});
  ASSERT_TRUE(first.ok()) << first.error().message;
  const std::string table = slurp(first->nc_file);
  const std::string main = slurp(main_program_path(first->nc_file));
  Result<NewProgramReport> again = write_new_program(js, {});
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, ErrorCode::kRefused);
  EXPECT_NE(again.error().message.find("has a history: version 1"), std::string::npos) << again.error().message;
  EXPECT_NE(again.error().message.find("--replace"), std::string::npos) << again.error().message;
  EXPECT_EQ(slurp(first->nc_file), table);
  EXPECT_EQ(slurp(main_program_path(first->nc_file)), main);
  {
    Result<RunStore> store = RunStore::open(js.db_path);
    ASSERT_TRUE(store.ok());
    Result<int> next = store->next_table_version(first->nc_file.string());
    ASSERT_TRUE(next.ok());
    EXPECT_EQ(*next, 2) << "the refusal recorded nothing";
  }
  NewProgramOptions replace;
  replace.replace = true;
  Result<NewProgramReport> replaced = write_new_program(js, replace);
  ASSERT_TRUE(replaced.ok()) << replaced.error().message;
  EXPECT_EQ(replaced->table_version, 2);
  // Version 2 goes to the other table number: the coupling's table is never redefined.
  EXPECT_NE(slurp(replaced->nc_file).find("CTABDEF(X,C,2,1)"), std::string::npos);
}

TEST_F(NcNewTest, AFileGaugeloopDidNotWriteIsRefusedUntouchedUnlessReplaced) {
  const JobSettings js = settings_for("intake_flat.toml");
  fs::create_directories(js.nc_dir);
  const fs::path file = js.nc_dir / (js.nc_program + ".SPF");
  const std::string by_hand = "; written on the control\nCTABDEF(X,C,1,1)\nC0 X0\nC360 X0\nCTABEND\nM17\n";
  std::ofstream(file) << by_hand;
  Result<NewProgramReport> r = write_new_program(js, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kRefused) << r.error().message;
  EXPECT_EQ(slurp(file), by_hand);
  EXPECT_FALSE(fs::exists(main_program_path(file)));
  NewProgramOptions replace;
  replace.replace = true;
  Result<NewProgramReport> replaced = write_new_program(js, replace);
  ASSERT_TRUE(replaced.ok()) << replaced.error().message;
  EXPECT_NE(slurp(file), by_hand);
}

TEST_F(NcNewTest, AMainTemplateWithoutTheInfeedIsRefusedBeforeAnythingIsWritten) {
  const fs::path tmpl = dir_.path() / "no_infeed.mpf";
  std::ofstream(tmpl) << "N10 {{program_name}}\nN20 G0 C{{table_start_c_deg}}\nN30 EGDEF(X,C,1)\n"
                         "N40 EGON(X,\"FINE\",C,{{table_number}},0)\nN50 G1 G91 C3600 X-0.2 F100\nN60 EGOFS(X)\nM30\n";
  MeasureOptions o;
  o.main_template_path = tmpl.string();
  const JobSettings js = settings_for("intake_flat.toml", o);
  Result<NewProgramReport> r = write_new_program(js, {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("no_infeed.mpf"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("{{infeed_blocks}}"), std::string::npos) << r.error().message;
  EXPECT_FALSE(fs::exists(js.nc_dir / (js.nc_program + ".SPF")));
  EXPECT_FALSE(fs::exists(js.db_path)) << "refused before the database was opened";
}

// A lobe ground at a speed program: the speed subprogram goes with the table, feeds X by R1 a
// turn, names the table version it goes with, and the main program's passes call it.
TEST_F(NcNewTest, AWorkSpeedProgramIsWrittenBesideTheTableAndTheMainProgramFeedsThroughIt) {
  const fs::path part = dir_.path() / "intake_speed.toml";
  std::ifstream in(fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.toml");
  std::ostringstream text;
  text << in.rdbuf();
  std::string toml = text.str();
  toml.replace(toml.find("lift_table = \"intake_flat.csv\""), 30,
               "lift_table = \"" + (fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.csv").string() + "\"");
  toml +=
      "\n[speed]\nhold = \"flanks\"\nbase_speed_rpm = 120.0\ngrinding_point_speed_mm_per_min = 8000.0\n"
      "flank_speed_mm_per_min = 2000.0\n";
  std::ofstream(part) << toml;
  MeasureOptions o;
  o.part_path = part.string();
  o.paths.data_dir = dir_.path().string();
  Result<LoadedPart> lp = load_part(o.part_path);
  ASSERT_TRUE(lp.ok()) << lp.error().message;
  Result<JobSettings> js = job_settings_for(*lp, o, false);
  ASSERT_TRUE(js.ok()) << js.error().message;
  Result<NewProgramReport> r = write_new_program(*js, {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->files.size(), 3u);  // table, speed, main
  Result<ParsedSpeedProgram> speed = read_speed_program(r->nc_file);
  ASSERT_TRUE(speed.ok()) << speed.error().message;
  EXPECT_TRUE(speed->overlaid_infeed);
  EXPECT_EQ(speed->header.at("table_version"), "1");
  const std::string main = slurp(main_program_path(r->nc_file));
  EXPECT_NE(main.find("R1=-0.01916667"), std::string::npos) << "roughing 0.23 mm over 12 turns\n" << main;
  EXPECT_NE(main.find("CAM_INTAKE_L1_SPEED P12"), std::string::npos) << main;
  EXPECT_NE(main.find("R1=0"), std::string::npos) << main;
}

}  // namespace
}  // namespace gaugeloop
