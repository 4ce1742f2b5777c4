// The crankpin loop on the virtual grinder (docs/crankpins.md): pins ground from the tables in
// force through the machine's errors on X and Y, measured through the gauge simulator over
// loopback by the product's own job, compensated along the grinding normal, pushed as real NC
// files (X table, Y table in C-X-Y, main program), stored in SQLite.
#include "cli/pin_loop.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "cli/embedded_defaults.h"
#include "compensation/pin_path.h"
#include "config/part_file.h"
#include "core/text_file.h"
#include "job/nc_push.h"
#include "job/pin_files.h"
#include "nc_out/main_program.h"
#include "nc_out/table_program.h"
#include "report/cam_report.h"
#include "report/run_json.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

class PinLoopTest : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    Result<PartFile> pf = read_part_file(fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / GetParam());
    ASSERT_TRUE(pf.ok()) << pf.error().message;
    ASSERT_TRUE(pf->pin.has_value());
    part_ = *pf;
    JobSettings& js = settings_.job;
    js.part = part_.part;
    js.nc_program = part_.nc_program;
    js.db_path = dir_ / "gaugeloop.sqlite";
    js.nc_dir = dir_ / "nc";
    js.nc_template = std::string(embedded::kNcTemplate);
    js.nc_template_name = "cam_table.spf";
    js.machine = "virtual-crank-grinder";
    set_pin_job(js, *part_.pin, /*main_template_given=*/false);
    // The gauge turns the pin ten times faster than the wall clock, as the lobe's loop test
    // does; a generous timeout, for loaded machines and sanitizers.
    settings_.gauge.time_scale = 10.0;
    settings_.response_timeout = std::chrono::milliseconds(1000);
  }

  std::vector<PinLoopIteration> run(int iterations) {
    settings_.iterations = iterations;
    Result<std::vector<PinLoopIteration>> loop = run_pin_grinding_loop(settings_, {});
    EXPECT_TRUE(loop.ok()) << loop.error().message;
    if (!loop) return {};
    return *loop;
  }

  bool with_y() const { return part_.pin->mode == PinMode::kCXY; }

  testing::TempDir tmp_;
  fs::path dir_;
  PartFile part_;
  PinLoopSettings settings_;
};

// Three steps take the pin from its machine error (about 30 um, mostly the servo's lag while X
// swings the stroke every turn) to within 1.2 times the floor of its vibration. Over 8 seeds
// of the demo, part 3 was 0.92 to 1.06 times the floor in C-X and 0.95 to 1.14 in C-X-Y with
// the pin's tables at 0.1 um command error (at 0.5 um: up to 1.25, the tables' interpolation
// error lying above the band the loop feeds back). The gauge's noise follows the clock, so a
// loaded machine draws other noise: over these four seeds one run may be beyond, and the mean
// must stay under 1.15. Every table keeps the pin's bound, X and Y.
TEST_P(PinLoopTest, ThreeStepsTakeThePinToItsFloor) {
  int within = 0;
  double ratio_sum = 0.0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    settings_.gauge.seed = seed;
    settings_.machine.x.seed = seed;
    settings_.machine.y.seed = seed + 100;
    const std::vector<PinLoopIteration> loop = run(3);
    ASSERT_EQ(loop.size(), 4u);
    const double ratio = loop[3].part.max_abs_um / loop[3].floor.max_abs_um;
    std::printf("%s seed %llu: part 0 %.2f um, part 1 %.2f um, part 3 %.2f um, floor %.2f um (%.2f times)\n",
                GetParam(), static_cast<unsigned long long>(seed), loop[0].part.max_abs_um, loop[1].part.max_abs_um,
                loop[3].part.max_abs_um, loop[3].floor.max_abs_um, ratio);
    // The machine error the loop starts from: the servo's lag over a 90 mm stroke at 60 rpm.
    EXPECT_GT(loop[0].part.max_abs_um, 20.0) << "seed " << seed;
    for (const PinLoopIteration& it : loop) {
      ASSERT_TRUE(it.job.pushed()) << seed << ": " << it.job.not_pushed_reason;
      EXPECT_LE(it.job.command_error_um, kPinCommandErrorBoundUm) << "seed " << seed;
      if (with_y()) {
        EXPECT_GT(it.job.y_table_blocks, 0);
        EXPECT_LE(it.job.y_command_error_um, kPinCommandErrorBoundUm) << "seed " << seed;
      } else {
        EXPECT_EQ(it.job.y_table_blocks, 0);
      }
    }
    // One step removes the servo's error down to a few times the floor.
    EXPECT_LT(loop[1].part.max_abs_um, 3.0 * loop[1].floor.max_abs_um) << "seed " << seed;
    if (ratio <= 1.2) ++within;
    ratio_sum += ratio;
  }
  EXPECT_GE(within, 3);
  EXPECT_LT(ratio_sum / 4.0, 1.15);
}

// What reaches the control: the X table program, in C-X-Y the Y table beside it for the same
// run and version, and the main program calling both and coupling each axis to its table. The
// stored runs carry the pin's characteristics.
TEST_P(PinLoopTest, ThePushedProgramsBelongTogetherAndTheRunsAreStored) {
  const std::vector<PinLoopIteration> loop = run(1);
  ASSERT_EQ(loop.size(), 2u);
  const PinLoopIteration& last = loop.back();
  ASSERT_TRUE(last.job.pushed()) << last.job.not_pushed_reason;
  Result<std::string> x_text = read_regular_file(last.job.nc_file, "X table");
  ASSERT_TRUE(x_text.ok());
  Result<ParsedTable> x = parse_table_program(*x_text, last.job.nc_file.string());
  ASSERT_TRUE(x.ok()) << x.error().message;
  EXPECT_EQ(x->following_axis, "X");
  EXPECT_EQ(x->header.at("table_version"), std::to_string(last.job.table_version));
  Result<std::string> main = read_regular_file(main_program_path(last.job.nc_file), "main program");
  ASSERT_TRUE(main.ok());
  EXPECT_NE(main->find("EGON(X,\"FINE\",C," + std::to_string(x->table_number)), std::string::npos) << *main;
  const fs::path y_file = y_table_program_path(last.job.nc_file);
  if (with_y()) {
    Result<std::string> y_text = read_regular_file(y_file, "Y table");
    ASSERT_TRUE(y_text.ok()) << y_file;
    Result<ParsedTable> y = parse_table_program(*y_text, y_file.string());
    ASSERT_TRUE(y.ok()) << y.error().message;
    EXPECT_EQ(y->following_axis, "Y");
    EXPECT_TRUE(verify_table_checksum(*y, y_file.string()).ok());
    // Same run and version as the X table; its number follows the version over [3, 4].
    EXPECT_EQ(y->header.at("table_version"), x->header.at("table_version"));
    EXPECT_EQ(y->header.at("run_id"), x->header.at("run_id"));
    EXPECT_EQ(y->table_number, table_number_for_version(settings_.job.y_table_numbers, last.job.table_version));
    EXPECT_NE(y->table_number, x->table_number);
    EXPECT_NE(main->find("EGON(Y,\"FINE\",C," + std::to_string(y->table_number)), std::string::npos) << *main;
    EXPECT_NE(main->find(pin_y_program_name(settings_.job.nc_program)), std::string::npos);
  } else {
    EXPECT_FALSE(fs::exists(y_file));
    EXPECT_EQ(main->find("EGON(Y"), std::string::npos) << *main;
  }
  Result<RunStore> store = RunStore::open(settings_.job.db_path);
  ASSERT_TRUE(store.ok());
  Result<StoredRun> run = store->load_run(last.job.run_id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  std::vector<std::string> keys;
  for (const Characteristic& c : run->characteristics) keys.push_back(c.key);
  EXPECT_EQ(keys, (std::vector<std::string>{"roundness", "diameter_error", "stroke_error", "index_error"}));
  EXPECT_NE(run->settings.find("part.kind = pin"), std::string::npos) << run->settings;
  EXPECT_NE(run->settings.find(std::string("pin.mode = ") + (with_y() ? "c-x-y" : "c-x")), std::string::npos);
  // What people read of the stored run speaks of a pin of its mode.
  const RunPart part = run_part(*run);
  EXPECT_TRUE(part.pin());
  EXPECT_EQ(part.pin_mode, part_.pin->mode);
  EXPECT_EQ(run_detail_json(*run)["part_kind"], "pin");
  const CamReportWords words = cam_report_words(*run);
  EXPECT_EQ(words.page_title, "Pin inspection report");
  EXPECT_EQ(words.characteristic_titles.front(), "Pin roundness *") << "of the curve less the least-squares circle";
}

// Constant removal in C-X: with a speed program the grinding point runs at the speed held all
// round the pin (8000 mm/min, below the 8120 the slowest point has at 60 rpm), the speed
// subprogram goes to the control beside the table, and a turn takes longer than at one speed.
TEST_P(PinLoopTest, ASpeedProgramHoldsTheGrindingPointSpeedInCx) {
  if (with_y()) GTEST_SKIP() << "C-X-Y grinds at a constant grinding-point speed already; [speed] is refused there";
  JobSettings& js = settings_.job;
  js.speed = WorkSpeedSettings{};
  js.speed->base_speed_rpm = 60.0;
  js.speed->lobe_speed_mm_per_min = 8000.0;
  js.nc_speed_template = std::string(embedded::kNcSpeedTemplate);
  js.nc_speed_template_name = "cam_speed.spf";
  js.nc_main_template = std::string(embedded::kNcMainSpeedTemplate);
  js.nc_main_template_name = "cam_main_speed.mpf";
  Result<PinPath> path = compute_pin_path(*js.pin, 0.5);
  ASSERT_TRUE(path.ok());
  WorkSpeedSettings ws = *js.speed;
  ws.x_velocity_max_mm_per_s = js.axis_limits.x_velocity_max_mm_per_s;
  ws.x_acceleration_max_mm_per_s2 = js.axis_limits.x_acceleration_max_mm_per_s2;
  Result<WorkSpeedPlan> plan = plan_pin_work_speed(*path, *js.pin, ws);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  // Held within 1 % everywhere (the planner's ceiling is the target; nothing else binds here).
  for (double v : plan->grinding_point_speed_mm_per_min) EXPECT_NEAR(v, 8000.0, 80.0);
  settings_.machine.x.speed_program = plan->program;
  const std::vector<PinLoopIteration> loop = run(1);
  ASSERT_EQ(loop.size(), 2u);
  for (const PinLoopIteration& it : loop) {
    ASSERT_TRUE(it.job.pushed()) << it.job.not_pushed_reason;
    EXPECT_GT(it.job.speed_blocks, 0);
    EXPECT_LE(it.job.speed_error_percent, 2.0);
    // Slower where the pin is near the wheel: 1.18 s against 1.00 s at 60 rpm.
    EXPECT_GT(it.job.speed_cycle_time_s, 1.1 * it.job.constant_cycle_time_s);
  }
  EXPECT_TRUE(fs::exists(dir_ / "nc" / (js.nc_program + "_SPEED.SPF")));
  // The loop closes at the program as it does at one speed.
  EXPECT_LT(loop[1].part.max_abs_um, 3.0 * loop[1].floor.max_abs_um);
}

// A rollback pushes one table program again. A C-X pin's goes back with the pin's main
// program; a C-X-Y pin's is refused, since its Y table would not follow (the control would run
// X of one version with Y of another), and nothing is written.
TEST_P(PinLoopTest, ARollbackKeepsXAndYTogether) {
  const std::vector<PinLoopIteration> loop = run(1);
  ASSERT_EQ(loop.size(), 2u);
  ASSERT_TRUE(loop[1].job.pushed());
  const fs::path x_file = loop[1].job.nc_file;
  const std::string x_before = testing::slurp(x_file);
  const testing::CommandResult r =
      testing::run_command("nc rollback --data-dir " + dir_.string() + " --program " + settings_.job.nc_program + " 1");
  if (with_y()) {
    const std::string y_before = testing::slurp(y_table_program_path(x_file));
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("cannot be rolled back alone"), std::string::npos) << r.output;
    EXPECT_EQ(testing::slurp(x_file), x_before);
    EXPECT_EQ(testing::slurp(y_table_program_path(x_file)), y_before);
  } else {
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(testing::slurp(x_file), x_before);
    // The pin's own main program: it feeds the wheel in towards the pin.
    EXPECT_NE(testing::slurp(main_program_path(x_file)).find("X-0.2"), std::string::npos);
  }
}

INSTANTIATE_TEST_SUITE_P(BothModes, PinLoopTest, ::testing::Values("crankpin_cx.toml", "crankpin_cxy.toml"),
                         [](const ::testing::TestParamInfo<const char*>& param) {
                           return std::string(param.param).find("cxy") != std::string::npos ? "CXY" : "CX";
                         });

// The command a user types: the demo closes the loop for a pin and says how near the floor
// the last pin came, and in C-X how much the grinding-point speed varies at one C speed.
TEST(PinDemoCommand, ClosesTheLoopForTheSampleCxPin) {
  testing::TempDir tmp;
  const testing::CommandResult r = testing::run_command(
      "demo --part " + std::string(GAUGELOOP_SOURCE_DIR) +
      "/examples/crankpin_cx.toml --iterations 3 --time-scale 10 --data-dir " + tmp.path().string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("times the floor"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1.321 to 1"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(tmp.path() / "nc" / "CRANK_PIN1.SPF"));
  EXPECT_TRUE(fs::exists(tmp.path() / "nc" / "CRANK_PIN1_MAIN.MPF"));
  // The last pin's report, as the lobe demo writes its last lobe's.
  EXPECT_NE(r.output.find("report: " + (tmp.path() / "report.pdf").string()), std::string::npos) << r.output;
  const std::string pdf = testing::slurp(tmp.path() / "report.pdf");
  EXPECT_EQ(pdf.rfind("%PDF-", 0), 0u);
}

// The commands that know only lobes say so for a pin, and name the ones that take it.
TEST(PinDemoCommand, SimAndProfileRefuseAPinNamingTheCommandsThatTakeOne) {
  const std::string pin = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/crankpin_cxy.toml";
  for (const std::string& command : {"sim --part " + pin, "profile --step-deg 1 --part " + pin}) {
    const testing::CommandResult r = testing::run_command(command);
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.output;
    EXPECT_NE(r.output.find("is a crankpin"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("gaugeloop demo --part"), std::string::npos) << r.output;
  }
}

}  // namespace
}  // namespace gaugeloop
