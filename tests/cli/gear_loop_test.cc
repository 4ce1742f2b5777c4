// The gear's loop on the virtual gear grinder, against an oracle: the stroke a perfect
// compensation would write (SIM1 at each spline point the dSIM of the machine's slow errors
// there, computed here from the machine and the independent generating model's factors). The
// loop must come to within the checker's noise of it, and so reduce the lead deviation by at
// least the generating paper's ratio (50.2 -> 14.1 um, 3.6 times) on machines whose slow errors
// are of the size that paper's machine had before compensation.
#include "cli/gear_loop.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/embedded_defaults.h"
#include "storage/run_store.h"
#include "tests/compensation/generating_model.h"
#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
const fs::path kGearExample = fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "gear_71.toml";

// The lead (F_beta, mean over the loop's flanks, no checker noise) of a gear ground from the
// perfect stroke: SIM1 = dSIM of the slow errors at every spline point.
double perfect_lead_um(const GearLoopSettings& s, const testing::TempDir& dir) {
  const GearPart& part = s.part.part;
  const testing::NumericFactors k = testing::numeric_factors(testing::GeneratingModel(part));
  GearMachineErrors slow = s.machine;
  slow.y_mm.fast = slow.z_mm.fast = slow.b_deg.fast = slow.c_deg.fast = 0.0;
  slow.checker_noise_um = 0.0;
  std::vector<StrokeProgramPoint> points;
  for (double z = part.stroke.z_start_mm; z <= part.stroke.z_end_mm + 1e-9; z += part.stroke.spline_step_mm) {
    const AxisErrors e = slow.at(z, 0);
    points.push_back({z, k.s_yc * e.y_mm + k.s_zc * e.z_mm + k.s_bc * e.b_deg - e.c_deg});
  }
  StrokeProgramFormat fine;
  fine.sim_increments_per_deg = 1e9;
  Result<std::string> text = render_stroke_program("PERFECT", {}, points, 300.0, fine);
  EXPECT_TRUE(text.ok()) << text.error().message;
  const fs::path file = dir.path() / "PERFECT.SPF";
  std::ofstream(file, std::ios::binary) << *text;
  GearMachineErrors quiet = s.machine;
  quiet.checker_noise_um = 0.0;
  Result<GroundGear> gear = grind_gear(part, quiet, file.string());
  EXPECT_TRUE(gear.ok()) << gear.error().message;
  Result<GearLeadSummary> lead = summarize_lead(measure_lead(*gear, s.gaps, s.lead_step_mm, 0), part);
  EXPECT_TRUE(lead.ok());
  return lead->total_mean_um;
}

TEST(GearLoop, ComesToThePerfectStrokeWithinTheCheckersNoiseOnSeveralMachines) {
  Result<GearPartFile> gf = read_gear_part_file(kGearExample);
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  for (std::uint64_t seed : {1u, 2u, 3u, 4u, 5u}) {
    testing::TempDir dir("gear-loop");
    Result<RunStore> store = RunStore::open(dir.path() / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    GearLoopSettings s;
    s.part = *gf;
    s.machine = seeded_gear_machine(seed);
    s.iterations = 2;
    s.stroke.part_name = gf->name;
    s.stroke.program_name = gf->nc_program;
    s.stroke.format.sim_increments_per_deg = 100000.0;
    s.stroke.store = &*store;
    s.stroke.nc_file = dir.path() / "nc" / "GEAR_71.SPF";
    fs::create_directories(s.stroke.nc_file.parent_path());
    s.stroke.main.gear_template_text = std::string(embedded::kGearMainTemplate);
    s.stroke.main.gear_template_name = "gear_main.mpf";
    Result<std::vector<GearLoopIteration>> r = run_gear_loop(s, {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->size(), 3u);
    const double perfect = perfect_lead_um(s, dir);
    const GearLoopIteration& first = r->front();
    const GearLoopIteration& last = r->back();
    // Identification error from 0.3 um of checker noise over 8 traces of 49 points, and the fast
    // terms' leak into the spline points: a few tenths of a micron (the residual RMS is 0.5 um).
    EXPECT_LT(last.ground.total_mean_um, perfect + 0.5) << "seed " << seed;
    EXPECT_GE(first.ground.total_mean_um / last.ground.total_mean_um, 3.6) << "seed " << seed;
    EXPECT_GE(first.measured.total_mean_um / last.measured.total_mean_um, 3.6) << "seed " << seed;
    EXPECT_LT(last.measured.tolerance_class, first.measured.tolerance_class) << "seed " << seed;
    // The profile is the worm's and the checker's, not the stroke's: the compensation leaves it
    // within the checker's noise (0.3 um a point; F_alpha's mean over 8 flanks moves by tenths).
    EXPECT_NEAR(last.profile.total_mean_um, first.profile.total_mean_um, 0.5) << "seed " << seed;
    EXPECT_GT(first.profile.total_mean_um, 0.0) << "seed " << seed;
    // Each gear ground from the stroke version pushed after the one before: 1 (no compensation), 2, 3.
    EXPECT_EQ(first.ground_from_version, 1);
    EXPECT_EQ(last.ground_from_version, 3);
    ASSERT_TRUE(first.identified.has_value());
    EXPECT_EQ(first.identified->rank, first.identified->unknowns - 1);
    EXPECT_FALSE(last.identified.has_value());
    Result<std::optional<NcPush>> pushed = store->last_push(s.stroke.nc_file.string());
    ASSERT_TRUE(pushed.ok() && pushed->has_value());
    EXPECT_EQ((**pushed).table_version, 3);
    // Every gear kept, newest first: ground from versions 3, 2, 1, the two before the last each
    // with the version pushed from it; judged against the part's class 5 (8.6 um for this gear).
    Result<std::vector<StoredGearRun>> kept = store->list_gear_runs({});
    ASSERT_TRUE(kept.ok()) << kept.error().message;
    ASSERT_EQ(kept->size(), 3u);
    EXPECT_EQ((*kept)[0].id, last.gear_run_id);
    EXPECT_EQ((*kept)[0].record.ground_with_version, 3);
    EXPECT_FALSE((*kept)[0].pushed_version.has_value());
    EXPECT_EQ((*kept)[2].record.ground_with_version, 1);
    EXPECT_EQ((*kept)[2].pushed_version, 2);
    EXPECT_EQ((*kept)[2].record.required_class, 5);
    EXPECT_DOUBLE_EQ((*kept)[2].record.total_max_um, first.measured.total_max_um);
    EXPECT_EQ((*kept)[0].record.verdict, last.measured.total_max_um <= 8.6 ? Verdict::kIn : Verdict::kOut);
    EXPECT_EQ((*kept)[0].record.verdict, Verdict::kIn) << "seed " << seed;
  }
}

TEST(GearLoop, TheDemoClosesTheLoopOnTheExampleGear) {
  testing::TempDir dir("gear-demo");
  const std::string data = " --data-dir " + (dir.path() / "data").string();
  testing::CommandResult r =
      testing::run_command("demo --part " + kGearExample.string() + " --iterations 1 --machine-seed 2" + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("gear 0 (stroke version 1, gear run 1)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("gear 1 (stroke version 2, gear run 2)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("lead F_beta (mean of 8 flanks)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("profile F_alpha (mean of 8 flanks, face middle)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not separable"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(dir.path() / "data" / "nc" / "GEAR_71_MAIN.MPF"));
  // The slides first: a ZY ballbar, the tables fitted to it and written, the ballbar again.
  EXPECT_NE(r.output.find("ZY ballbar before (radius 100 mm, 1000 mm/min): roundness"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("ballbar roundness "), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(dir.path() / "data" / "nc" / "AX_EEC.INI"));
  EXPECT_TRUE(fs::exists(dir.path() / "data" / "nc" / "NC_CEC.INI"));
  testing::CommandResult h = testing::run_command("nc history" + data);
  ASSERT_EQ(h.exit_code, 0) << h.output;
  EXPECT_NE(h.output.find("mesh error identified"), std::string::npos) << h.output;
  EXPECT_NE(r.output.find("gear runs 1 to 2 kept"), std::string::npos) << r.output;
  testing::CommandResult runs = testing::run_command("gear runs list" + data);
  ASSERT_EQ(runs.exit_code, 0) << runs.output;
  EXPECT_NE(runs.output.find("virtual gear grinder"), std::string::npos) << runs.output;
  EXPECT_NE(runs.output.find("GEAR-1"), std::string::npos) << runs.output;
  // The gear as kept: its profiles beside its leads, judged against the class's F_alphaT too.
  testing::CommandResult shown = testing::run_command("gear runs show 2" + data);
  ASSERT_EQ(shown.exit_code, 0) << shown.output;
  EXPECT_NE(shown.output.find("profile at the face's middle, ISO 1328-1 over roll lengths"), std::string::npos)
      << shown.output;
  EXPECT_NE(shown.output.find("F_alpha within "), std::string::npos) << shown.output;
  // The gears for the plant's SPC: 2 gears of 8 flanks, 4 figures a gear and 3 a flank each, of
  // the lead and of the profile.
  const fs::path dfq = dir.path() / "gears.dfq";
  testing::CommandResult exported = testing::run_command("gear runs export --out " + dfq.string() + data);
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  EXPECT_NE(exported.output.find("2 gear runs exported"), std::string::npos) << exported.output;
  const std::string text = testing::slurp(dfq);
  EXPECT_NE(text.find("K1002/1 gear teeth\r\n"), std::string::npos);
  EXPECT_NE(text.find("K0100 56\r\n"), std::string::npos);
  EXPECT_NE(text.find("Total profile deviation F_alpha, worst flank"), std::string::npos);
  std::size_t values = 0;
  for (std::size_t at = text.find("\nK0001/"); at != std::string::npos; at = text.find("\nK0001/", at + 1)) ++values;
  EXPECT_EQ(values, 2u * 56u);
  // SPC over the two gears: F_beta at worst against its tolerance, the uncompensated gear out.
  testing::CommandResult spc = testing::run_command("gear runs spc --part gear_71 --json" + data);
  ASSERT_EQ(spc.exit_code, 0) << spc.output;
  const nlohmann::json figures = nlohmann::json::parse(spc.output);
  EXPECT_EQ(figures["runs"], 2);
  ASSERT_GE(figures["characteristics"].size(), 1u);
  const nlohmann::json& worst = figures["characteristics"][0];
  EXPECT_EQ(worst["key"], "lead.F_beta");
  EXPECT_EQ(worst["n"], 2);
  EXPECT_NEAR(worst["usl"].get<double>(), 8.598, 0.001);
  EXPECT_EQ(worst["out"], 1);
  EXPECT_EQ(worst["judged"], 2);
  const fs::path pdf = dir.path() / "gear1.pdf";
  testing::CommandResult report = testing::run_command("gear runs report 1 --out " + pdf.string() + data);
  ASSERT_EQ(report.exit_code, 0) << report.output;
  EXPECT_EQ(testing::slurp(pdf).rfind("%PDF", 0), 0u);
  testing::CommandResult none = testing::run_command("gear runs spc --part gear_40" + data);
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_NE(none.output.find("no gear runs match"), std::string::npos) << none.output;
}

// The slides' commands as a shop runs them: a ballbar test written, the tables fitted to it and
// pushed to the NC directory, the ballbar again with them loaded; a test in one direction is
// refused before anything is written. The pair has a history: listed, compared, checked on the
// control and rolled back to the empty start's first version, the ballbar then as before.
TEST(GearLoop, TheSlideTablesFromABallbarCutItsRoundness) {
  testing::TempDir dir("gear-slides");
  const std::string data = " --data-dir " + (dir.path() / "data").string();
  const fs::path test = dir.path() / "ballbar.csv";
  testing::CommandResult before = testing::run_command("gear ballbar --machine-seed 3 --out " + test.string() + data);
  ASSERT_EQ(before.exit_code, 0) << before.output;
  auto roundness = [](const std::string& out) {
    const std::size_t at = out.find("roundness ");
    return at == std::string::npos ? -1.0 : std::stod(out.substr(at + 10));
  };
  const double r0 = roundness(before.output);
  EXPECT_GT(r0, 40.0) << before.output;
  // The same test in one direction: refused, nothing written.
  const fs::path one_way = dir.path() / "ccw.csv";
  ASSERT_EQ(testing::run_shell("grep -v '^cw,' " + test.string() + " > " + one_way.string()).exit_code, 0);
  testing::CommandResult refused = testing::run_command("gear slides --ballbar " + one_way.string() + data);
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("the squareness and the servo mismatch act alike"), std::string::npos)
      << refused.output;
  EXPECT_FALSE(fs::exists(dir.path() / "data" / "nc" / "NC_CEC.INI"));
  testing::CommandResult slides = testing::run_command("gear slides --ballbar " + test.string() +
                                                       " --y-screw-lead-mm 10 --z-screw-lead-mm 16" + data);
  ASSERT_EQ(slides.exit_code, 0) << slides.output;
  EXPECT_NE(slides.output.find("servo mismatch"), std::string::npos) << slides.output;
  ASSERT_TRUE(fs::exists(dir.path() / "data" / "nc" / "AX_EEC.INI"));
  ASSERT_TRUE(fs::exists(dir.path() / "data" / "nc" / "NC_CEC.INI"));
  testing::CommandResult after = testing::run_command("gear ballbar --machine-seed 3" + data);
  ASSERT_EQ(after.exit_code, 0) << after.output;
  EXPECT_NE(after.output.find("the slide tables in"), std::string::npos) << after.output;
  const double r1 = roundness(after.output);
  EXPECT_GT(r1, 0.0) << after.output;
  EXPECT_GE(r0 / r1, 3.6) << r0 << " -> " << r1;  // the paper's 50.2 -> 14.1 um

  // A second round on the test with the tables loaded adds to them: version 2.
  const fs::path again = dir.path() / "again.csv";
  ASSERT_EQ(testing::run_command("gear ballbar --machine-seed 3 --out " + again.string() + data).exit_code, 0);
  testing::CommandResult second = testing::run_command("gear slides --ballbar " + again.string() +
                                                       " --y-screw-lead-mm 10 --z-screw-lead-mm 16" + data);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("as slide tables version 2 (added to the tables in force)"), std::string::npos)
      << second.output;
  const std::string slide_file = " --program AX_EEC.INI";
  testing::CommandResult history = testing::run_command("nc history" + slide_file + data);
  ASSERT_EQ(history.exit_code, 0) << history.output;
  EXPECT_NE(history.output.find("slide tables from " + again.string()), std::string::npos) << history.output;
  EXPECT_NE(history.output.find("slide tables from " + test.string()), std::string::npos) << history.output;
  testing::CommandResult diff = testing::run_command("nc diff 1 2" + slide_file + data);
  ASSERT_EQ(diff.exit_code, 0) << diff.output;
  EXPECT_NE(diff.output.find("CEC Y over Z: largest change"), std::string::npos) << diff.output;
  // The two versions differ: the second round added to the tables (values to 0.1 um).
  testing::CommandResult diff_json = testing::run_command("nc diff 1 2 --json" + slide_file + data);
  ASSERT_EQ(diff_json.exit_code, 0) << diff_json.output;
  const nlohmann::json changes = nlohmann::json::parse(diff_json.output, nullptr, false);
  ASSERT_TRUE(changes.contains("tables")) << diff_json.output;
  ASSERT_EQ(changes["tables"].size(), 4u) << diff_json.output;
  double largest_um = 0.0;
  for (const nlohmann::json& t : changes["tables"]) {
    largest_um = std::max(largest_um, std::abs(t["largest_change_um"].get<double>()));
  }
  EXPECT_GE(largest_um, 0.1) << diff_json.output;
  testing::CommandResult check = testing::run_command("nc check" + slide_file + data);
  ASSERT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("slide tables version 2 as pushed"), std::string::npos) << check.output;
  testing::CommandResult rollback = testing::run_command("nc rollback 1" + slide_file + data);
  ASSERT_EQ(rollback.exit_code, 0) << rollback.output;
  EXPECT_NE(rollback.output.find("slide tables version 3 written with the CEC file beside it, the pair of version 1"),
            std::string::npos)
      << rollback.output;
  testing::CommandResult rolled = testing::run_command("gear ballbar --machine-seed 3" + data);
  ASSERT_EQ(rolled.exit_code, 0) << rolled.output;
  EXPECT_EQ(roundness(rolled.output), r1) << "the pair of version 1 is back: the ballbar reads as it did then";
}

}  // namespace
}  // namespace gaugeloop
