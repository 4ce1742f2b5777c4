// `gaugeloop gear coupling` and `gear stroke` as a user runs them: the factors of the example gear
// as text and JSON, a bad gear file refused with exit 2 naming its key, the stroke written to a
// file or pushed with its history, diff, check and rollback.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "compensation/gear_coupling.h"
#include "config/gear_file.h"
#include "simulator/gear_grinder.h"
#include "simulator/gear_probe_simulator.h"
#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

const std::string kExample = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/gear_71.toml";

TEST(GearCommand, PrintsTheExampleGearsFactorsAsTextAndJson) {
  Result<GearPartFile> g = read_gear_part_file(kExample);
  ASSERT_TRUE(g.ok()) << g.error().message;
  const GearCoupling k = gear_coupling(g->part);
  testing::CommandResult json = testing::run_command("gear coupling --part " + kExample + " --json");
  ASSERT_EQ(json.exit_code, 0) << json.output;
  const nlohmann::json j = nlohmann::json::parse(json.output);
  EXPECT_DOUBLE_EQ(j["s_bc"].get<double>(), k.s_bc);
  EXPECT_DOUBLE_EQ(j["s_zc_deg_per_mm"].get<double>(), k.s_zc_deg_per_mm);
  EXPECT_DOUBLE_EQ(j["s_yc_deg_per_mm"].get<double>(), k.s_yc_deg_per_mm);
  EXPECT_EQ(j["s_sim_c"].get<double>(), 1.0);
  EXPECT_NEAR(j["s_bc"].get<double>(), -1.0 / 71.0, 1e-15) << "one start past 71 teeth";
  testing::CommandResult text = testing::run_command("gear coupling --part " + kExample);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("S_ZC   -0.266388852882 deg per mm of Z"), std::string::npos) << text.output;
}

TEST(GearCommand, ABadGearFileExits2NamingTheKey) {
  testing::TempDir dir("gear-cmd");
  const auto bad = dir.path() / "bad.toml";
  std::string text = testing::slurp(kExample);
  text.replace(text.find("teeth = 71"), 10, "teeth = 2");
  std::ofstream(bad) << text;
  testing::CommandResult r = testing::run_command("gear coupling --part " + bad.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("gear.teeth"), std::string::npos) << r.output;
}

TEST(GearCommand, WritesTheStrokeProgramAndPrintsTheCoupling) {
  testing::TempDir dir("gear-stroke-cmd");
  const auto out = dir.path() / "GEAR_71_STROKE.SPF";
  testing::CommandResult r =
      testing::run_command("gear stroke --part " + kExample + " --errors " + std::string(GAUGELOOP_SOURCE_DIR) +
                           "/examples/gear_71_axis_errors.csv --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("31 spline points"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("EGDEF(C,B,1,Z,1,Y,1,SIM1,1)"), std::string::npos) << r.output;
  EXPECT_NE(testing::slurp(out).find("FGROUP(Z)"), std::string::npos);
  const auto bad = dir.path() / "bad.csv";
  std::ofstream(bad) << "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n0,1,1,0,zero\n";
  testing::CommandResult b = testing::run_command("gear stroke --part " + kExample + " --errors " + bad.string() +
                                                  " --out " + (dir.path() / "B.SPF").string());
  EXPECT_EQ(b.exit_code, 2) << b.output;
  EXPECT_NE(b.output.find("bad.csv:2: column c_error_deg"), std::string::npos) << b.output;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "B.SPF"));
}

TEST(GearCommand, PushesTheStrokeWithItsHistoryDiffCheckAndRollback) {
  testing::TempDir dir("gear-push-cmd");
  const std::string data = " --data-dir " + (dir.path() / "data").string();
  const std::string errors = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/gear_71_axis_errors.csv";
  const std::string stroke = "gear stroke --part " + kExample + " --errors " + errors + data;
  testing::CommandResult v1 = testing::run_command(stroke + " --int-incr-per-deg 1000");
  ASSERT_EQ(v1.exit_code, 0) << v1.output;
  EXPECT_NE(v1.output.find("as stroke version 1"), std::string::npos) << v1.output;
  const auto nc = dir.path() / "data" / "nc";
  EXPECT_NE(testing::slurp(nc / "GEAR_71_MAIN.MPF").find("EGDEF(C,B,1,Z,1,Y,1,SIM1,1)"), std::string::npos);
  // Finer SIM1 grid: the same stroke to six decimals instead of three.
  testing::CommandResult v2 = testing::run_command(stroke + " --int-incr-per-deg 1000000");
  ASSERT_EQ(v2.exit_code, 0) << v2.output;
  testing::CommandResult history = testing::run_command("nc history" + data);
  ASSERT_EQ(history.exit_code, 0) << history.output;
  EXPECT_NE(history.output.find("GEAR_71                2"), std::string::npos) << history.output;
  EXPECT_NE(history.output.find("stroke"), std::string::npos) << history.output;
  testing::CommandResult diff = testing::run_command("nc diff 1 2" + data);
  ASSERT_EQ(diff.exit_code, 0) << diff.output;
  EXPECT_NE(diff.output.find("stroke version 1 -> version 2, 31 spline points"), std::string::npos) << diff.output;
  // SIM1 rounded to 0.001 deg against 0.000001: no point differs by more than half the coarse step.
  testing::CommandResult json = testing::run_command("nc diff 1 2 --json" + data);
  ASSERT_EQ(json.exit_code, 0) << json.output;
  const nlohmann::json j = nlohmann::json::parse(json.output);
  EXPECT_LE(std::abs(j["largest_dsim_deg"].get<double>()), 0.0005 + 1e-12);
  EXPECT_GT(std::abs(j["largest_dsim_deg"].get<double>()), 0.0) << "the grids differ";
  testing::CommandResult check = testing::run_command("nc check" + data);
  ASSERT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("stroke version 2 as pushed"), std::string::npos) << check.output;
  testing::CommandResult rollback = testing::run_command("nc rollback 1 --by anna" + data);
  ASSERT_EQ(rollback.exit_code, 0) << rollback.output;
  EXPECT_NE(rollback.output.find("stroke version 3 written, the stroke of version 1"), std::string::npos)
      << rollback.output;
  EXPECT_NE(testing::slurp(nc / "GEAR_71_MAIN.MPF").find("with stroke version 3 "), std::string::npos);
}

// An axis error table of zeros along the example's stroke, in `dir`: the first stroke, SIM1 at 0.
std::filesystem::path zero_axis_errors(const testing::TempDir& dir) {
  const auto zero = dir.path() / "zero.csv";
  std::ofstream(zero) << "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n-15,0,0,0,0\n15,0,0,0,0\n";
  return zero;
}

// A checker's export of a mesh error growing 0.0001 deg per mm (left flank +r_b dC, right -r_b
// dC, 0.5 um of alignment offset) on gaps 1 and 40, both flanks, every 0.5 mm from -12 to 12.
void write_mesh_lead(const std::filesystem::path& lead) {
  // r_b = d2 / 2 cos(alpha_t), computed here apart: 80.0931 mm.
  const double beta = 21.8 * M_PI / 180.0;
  const double alpha_t = std::atan(std::tan(20.0 * M_PI / 180.0) / std::cos(beta));
  const double um_per_deg = 71 * 2.25 / std::cos(beta) / 2.0 * std::cos(alpha_t) * 1000.0 * M_PI / 180.0;
  std::ofstream out(lead);
  out << "gap,flank,z_mm,deviation_um\n";
  for (int gap : {1, 40}) {
    for (const char* flank : {"left", "right"}) {
      const double sign = std::string(flank) == "left" ? 1.0 : -1.0;
      for (int i = 0; i <= 48; ++i) {
        const double z = -12.0 + 0.5 * i;
        out << gap << ',' << flank << ',' << z << ',' << sign * um_per_deg * 0.0001 * z + 0.5 << '\n';
      }
    }
  }
}

// `gear correct` pushes the stroke in force less the mesh error of write_mesh_lead's export.
TEST(GearCommand, CorrectsTheStrokeInForceFromACheckersLeadTraces) {
  testing::TempDir dir("gear-correct-cmd");
  const std::string data = " --data-dir " + (dir.path() / "data").string();
  const auto zero = zero_axis_errors(dir);
  const auto lead = dir.path() / "lead.csv";
  write_mesh_lead(lead);
  const std::string correct =
      "gear correct --part " + kExample + " --lead " + lead.string() + " --int-incr-per-deg 1000000" + data;
  testing::CommandResult none = testing::run_command(correct);
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_NE(none.output.find("no stroke program was pushed there"), std::string::npos) << none.output;
  // The measured gear is kept all the same: a refused correction loses no measurement.
  EXPECT_NE(none.output.find("gear run 1 is stored; no stroke was pushed from it"), std::string::npos) << none.output;

  ASSERT_EQ(testing::run_command("gear stroke --part " + kExample + " --errors " + zero.string() +
                                 " --int-incr-per-deg 1000000" + data)
                .exit_code,
            0);
  testing::CommandResult r = testing::run_command(correct);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("pushed "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("as stroke version 2 (from version 1)"), std::string::npos) << r.output;
  // F_beta of a trace rising 0.14 um per mm between its outermost points in the evaluation range
  // (-10.8 .. 10.8 mm; points every 0.5 mm: -10.5 .. 10.5): 2.94 um, within class 5's 8.6 um for
  // this gear (the part's tolerance_class).
  EXPECT_NE(r.output.find("gear run 2 of gear_71"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(": in (class 5 asked: F_beta within 8.60 um)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not separable"), std::string::npos) << r.output;
  // SIM1 takes the mesh error back: -0.0001 deg per mm about the face's middle, held beyond it.
  const std::string text = testing::slurp(dir.path() / "data" / "nc" / "GEAR_71.SPF");
  EXPECT_NE(text.find("\nZ-5.0000 SIM1=0.000500\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nZ12.0000 SIM1=-0.001200\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nZ15.0000 SIM1=-0.001200\n"), std::string::npos) << text;

  // A trace that goes back is refused, naming the line, and nothing is pushed.
  std::ofstream(lead, std::ios::app) << "1,left,0,0.1\n";
  testing::CommandResult bad = testing::run_command(correct);
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("lead.csv:198: gap 1, left flank: Z 0 mm does not increase"), std::string::npos)
      << bad.output;
  testing::CommandResult history = testing::run_command("nc history" + data);
  EXPECT_EQ(history.output.find("GEAR_71                3"), std::string::npos) << history.output;

  // The history of gears: the refused one ground from no known stroke, the corrected one from
  // version 1 with version 2 pushed from it; nothing stored for the bad file.
  testing::CommandResult list = testing::run_command("gear runs list --json" + data);
  ASSERT_EQ(list.exit_code, 0) << list.output;
  const nlohmann::json runs = nlohmann::json::parse(list.output);
  ASSERT_EQ(runs.size(), 2u) << list.output;
  EXPECT_EQ(runs[0]["id"], 2);
  EXPECT_EQ(runs[0]["ground_with_version"], 1);
  EXPECT_EQ(runs[0]["pushed_version"], 2);
  EXPECT_EQ(runs[0]["verdict"], "in");
  // r_b's um per degree to 5 digits (1397.9, above): 0.002 um over 21 mm; the CSV's 6 digits less.
  EXPECT_NEAR(runs[0]["total_max_um"].get<double>(), 0.0001 * 21.0 * 1397.9, 0.005);
  EXPECT_TRUE(runs[1]["ground_with_version"].is_null());
  EXPECT_TRUE(runs[1]["pushed_version"].is_null());
  testing::CommandResult show = testing::run_command("gear runs show 2" + data);
  ASSERT_EQ(show.exit_code, 0) << show.output;
  EXPECT_NE(show.output.find("stroke version 2 was pushed from it"), std::string::npos) << show.output;
  EXPECT_NE(show.output.find("     40  right"), std::string::npos) << show.output;
  testing::CommandResult missing = testing::run_command("gear runs show 9" + data);
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("gear run 9 is not in run database"), std::string::npos) << missing.output;
}

// With --require-approval the corrected stroke waits as a pending table, the control untouched,
// until `nc approve` pushes it as the next version and the gear run learns it.
TEST(GearCommand, ACorrectedStrokeWaitsForApprovalAndIsPushedWhenApproved) {
  testing::TempDir dir("gear-approval-cmd");
  const std::string data = " --data-dir " + (dir.path() / "data").string();
  const auto zero = zero_axis_errors(dir);
  const auto lead = dir.path() / "lead.csv";
  write_mesh_lead(lead);
  ASSERT_EQ(testing::run_command("gear stroke --part " + kExample + " --errors " + zero.string() +
                                 " --int-incr-per-deg 1000000" + data)
                .exit_code,
            0);
  const auto stroke = dir.path() / "data" / "nc" / "GEAR_71.SPF";
  const std::string v1 = testing::slurp(stroke);
  testing::CommandResult held = testing::run_command("gear correct --require-approval --part " + kExample + " --lead " +
                                                     lead.string() + " --int-incr-per-deg 1000000" + data);
  ASSERT_EQ(held.exit_code, 0) << held.output;
  EXPECT_NE(held.output.find("waits for approval as pending table 1 (from version 1)"), std::string::npos)
      << held.output;
  EXPECT_EQ(testing::slurp(stroke), v1) << "nothing is written before the approval";
  testing::CommandResult pending = testing::run_command("nc pending" + data);
  ASSERT_EQ(pending.exit_code, 0) << pending.output;
  EXPECT_NE(pending.output.find("gear 1"), std::string::npos) << pending.output;
  testing::CommandResult waiting = testing::run_command("gear runs show 1" + data);
  EXPECT_NE(waiting.output.find("waits for approval or was rejected"), std::string::npos) << waiting.output;

  testing::CommandResult approved = testing::run_command("nc approve 1 --by anna" + data);
  ASSERT_EQ(approved.exit_code, 0) << approved.output;
  EXPECT_NE(approved.output.find("stroke version 2 written from gear run 1 (pending table 1, approved by anna)"),
            std::string::npos)
      << approved.output;
  const std::string v2 = testing::slurp(stroke);
  EXPECT_NE(v2.find("\nZ12.0000 SIM1=-0.001200\n"), std::string::npos) << v2;
  EXPECT_NE(testing::slurp(dir.path() / "data" / "nc" / "GEAR_71_MAIN.MPF").find("with stroke version 2 "),
            std::string::npos);
  testing::CommandResult list = testing::run_command("gear runs list --json" + data);
  ASSERT_EQ(list.exit_code, 0) << list.output;
  const nlohmann::json runs = nlohmann::json::parse(list.output);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0]["pushed_version"], 2);
  EXPECT_EQ(runs[0]["ground_with_version"], 1);
  // Approved once: a second approval is refused and writes nothing.
  testing::CommandResult again = testing::run_command("nc approve 1 --by ben" + data);
  EXPECT_NE(again.exit_code, 0) << again.output;
  EXPECT_EQ(testing::slurp(stroke), v2);
}

// A checker's export of a gear ground without compensation on a machine whose C drive runs
// ahead 0.0001 deg per mm of stroke: `gear identify` names that term and writes the errors
// along the stroke in the table `gear stroke` reads; a model whose terms act alike on the lead
// is refused and writes nothing.
TEST(GearCommand, IdentifiesTheAxesErrorsAndRefusesTermsThatActAlike) {
  testing::TempDir dir("gear-identify-cmd");
  const auto lead = dir.path() / "lead.csv";
  {
    const double beta = 21.8 * M_PI / 180.0;
    const double alpha_t = std::atan(std::tan(20.0 * M_PI / 180.0) / std::cos(beta));
    const double um_per_deg = 71 * 2.25 / std::cos(beta) / 2.0 * std::cos(alpha_t) * 1000.0 * M_PI / 180.0;
    std::ofstream out(lead);
    out << "gap,flank,z_mm,deviation_um\n";
    for (const char* flank : {"left", "right"}) {
      const double sign = std::string(flank) == "left" ? 1.0 : -1.0;
      for (int i = 0; i <= 48; ++i) {
        const double z = -12.0 + 0.5 * i;
        // Without SIM1 the mesh error is C's own: the left flank r_b e_C.
        out << 1 << ',' << flank << ',' << z << ',' << sign * um_per_deg * 0.0001 * z << '\n';
      }
    }
  }
  const auto errors = dir.path() / "errors.csv";
  const std::string identify = "gear identify --part " + kExample + " --lead " + lead.string() + " --uncompensated";
  testing::CommandResult alike = testing::run_command(identify + " --terms y:linear,c:linear --out " + errors.string());
  EXPECT_EQ(alike.exit_code, 2) << alike.output;
  EXPECT_NE(alike.output.find("Y linear and C linear act alike"), std::string::npos) << alike.output;
  EXPECT_FALSE(std::filesystem::exists(errors));

  testing::CommandResult r = testing::run_command(identify + " --terms c:linear,y:bow --out " + errors.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("C linear"), std::string::npos) << r.output;
  const std::string table = testing::slurp(errors);
  EXPECT_NE(table.find("\n10.0000,0.0000,0.0000,0.0000000,0.0010000\n"), std::string::npos) << table;
  testing::CommandResult stroke =
      testing::run_command("gear stroke --part " + kExample + " --errors " + errors.string() + " --out " +
                           (dir.path() / "S.SPF").string() + " --int-incr-per-deg 1000000");
  ASSERT_EQ(stroke.exit_code, 0) << stroke.output;
  // SIM1 takes C's error back: -0.001 deg at Z 10.
  EXPECT_NE(testing::slurp(dir.path() / "S.SPF").find("\nZ10.0000 SIM1=-0.001000\n"), std::string::npos);
}

// A gear measured on the machine with its flank probe over Modbus TCP (the virtual grinder's,
// on loopback): kept as a gear run, then with --correct the stroke in force corrected from it.
TEST(GearCommand, MeasuresAGearWithTheMachinesFlankProbeAndCorrectsFromIt) {
  testing::TempDir dir("gear-measure-cmd");
  const std::string data = " --data-dir " + (dir.path() / "data").string();
  const auto zero = zero_axis_errors(dir);
  ASSERT_EQ(testing::run_command("gear stroke --part " + kExample + " --errors " + zero.string() + data).exit_code, 0);
  Result<GearPartFile> gf = read_gear_part_file(kExample);
  ASSERT_TRUE(gf.ok());
  // The gear ground from that stroke on machine seed 3 (a lead of about 17 um), on the probe.
  Result<GroundGear> gear =
      grind_gear(gf->part, seeded_gear_machine(3), (dir.path() / "data" / "nc" / "GEAR_71.SPF").string());
  ASSERT_TRUE(gear.ok()) << gear.error().message;
  Result<std::unique_ptr<GearProbeSimulator>> sim = GearProbeSimulator::start({});
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  (*sim)->load_gear(*gear, 0);
  const std::string gauge = " --gauge 127.0.0.1:" + std::to_string((*sim)->port());

  testing::CommandResult bad_gap =
      testing::run_command("gear measure --part " + kExample + gauge + " --gaps 1,99" + data);
  EXPECT_EQ(bad_gap.exit_code, 2) << bad_gap.output;
  EXPECT_NE(bad_gap.output.find("gap 99 is not one of gear_71's gaps 1 to 71"), std::string::npos) << bad_gap.output;
  EXPECT_EQ((*sim)->points_answered(), 0) << "refused before the probe moves";

  testing::CommandResult r = testing::run_command("gear measure --correct --serial G-9 --part " + kExample + gauge +
                                                  " --gaps 1,40 --step-mm 1" + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ((*sim)->points_answered(), 2 * 2 * 25) << "2 gaps, 2 flanks, 25 heights";
  EXPECT_NE(r.output.find("gear run 1 of gear_71: lead as measured (flank probe tcp:127.0.0.1:"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(": out (class 5 asked"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("as stroke version 2 (from version 1)"), std::string::npos) << r.output;
  testing::CommandResult list = testing::run_command("gear runs list --json" + data);
  const nlohmann::json runs = nlohmann::json::parse(list.output);
  ASSERT_EQ(runs.size(), 1u) << list.output;
  EXPECT_EQ(runs[0]["serial"], "G-9");
  EXPECT_EQ(runs[0]["pushed_version"], 2);
  EXPECT_GT(runs[0]["total_max_um"].get<double>(), 8.6);

  // The machine gone: the gauge's exit status, naming the probe; nothing stored.
  (*sim)->stop();
  testing::CommandResult gone = testing::run_command("gear measure --part " + kExample + gauge + data);
  EXPECT_EQ(gone.exit_code, 3) << gone.output;
  EXPECT_NE(gone.output.find("gear probe"), std::string::npos) << gone.output;
  EXPECT_EQ(nlohmann::json::parse(testing::run_command("gear runs list --json" + data).output).size(), 1u);
}

}  // namespace
}  // namespace gaugeloop
