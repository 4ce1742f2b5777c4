// The closed loop on the virtual grinder (docs/virtual_grinder.md): parts ground from
// the table in force through the machine error model, measured through the gauge simulator
// over loopback by the product's own job, compensated, pushed as real NC files, stored in
// SQLite. What a change to compensation does to the ground part shows here.
#include "cli/grinding_loop.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>

#include "cli/embedded_defaults.h"
#include "config/part_file.h"
#include "tests/support/cli.h"
#include "tests/support/intake_job.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

class GrindingLoopTest : public testing::IntakeJobTest {
 protected:
  void SetUp() override {
    IntakeJobTest::SetUp();
    if (HasFatalFailure()) return;
    settings_.job = job_settings();
    settings_.job.machine = "virtual-grinder";
    // The gauge turns the part at 60 rpm, ten times faster than the wall clock: the latched
    // poller keeps up at 3000 rpm (docs/PERFORMANCE.md), so 600 leaves room under sanitizers.
    settings_.gauge.time_scale = 10.0;
    settings_.gauge.seed = 7;
    settings_.machine.seed = 11;
    settings_.response_timeout = std::chrono::milliseconds(1000);
  }
  std::vector<LoopIteration> run(int iterations) {
    settings_.iterations = iterations;
    Result<std::vector<LoopIteration>> loop = run_grinding_loop(settings_, {});
    EXPECT_TRUE(loop.ok()) << loop.error().message;
    if (!loop) return {};
    EXPECT_EQ(loop->size(), static_cast<size_t>(iterations + 1));
    return *loop;
  }

  // How far the table in force has moved from the design path: largest |X - X_design| in um.
  double table_departure_um(const LoopIteration& it) const {
    Result<CommandedPath> table = commanded_path_from_program(it.job.nc_file);
    Result<CommandedPath> design = commanded_path_from_design(settings_.job.part, settings_.job.design);
    EXPECT_TRUE(table.ok() && design.ok());
    if (!table || !design) return 1e9;
    double largest = 0.0;
    for (size_t k = 0; k < table->x_mm.size(); ++k) {
      largest = std::max(largest, std::abs(table->x_mm[k] - design->x_mm[k]) * 1000.0);
    }
    return largest;
  }

  LoopSettings settings_;
};

void print(const std::vector<LoopIteration>& loop) {
  for (const LoopIteration& it : loop) {
    std::printf("part %d (%s): measured max %.2f um RMS %.2f phase %+.4f runout %.2f; true max %.2f floor %.2f; %s\n",
                it.iteration, it.ground_from.c_str(), it.job.analysis.max_abs_error_um, it.job.analysis.rms_error_um,
                it.job.analysis.phase_error_deg, it.job.analysis.base_circle_runout_um, it.part.max_abs_um,
                it.floor.max_abs_um, it.job.pushed() ? "pushed" : it.job.not_pushed_reason.c_str());
  }
}

// Seed 000: 16 um brought under 2.6 um by one measurement and compensation, with the
// product's defaults throughout. Tolerance: 2.6 um is the seed's published result.
TEST_F(GrindingLoopTest, DefaultMachineReachesTheSeedResultInOneStep) {
  const std::vector<LoopIteration> loop = run(3);
  ASSERT_EQ(loop.size(), 4u);
  print(loop);
  // The default model is the seed's uncompensated machine: about 16 um.
  EXPECT_GT(loop[0].part.max_abs_um, 13.0);
  EXPECT_LT(loop[0].part.max_abs_um, 19.0);
  EXPECT_GT(loop[0].job.analysis.max_abs_error_um, 13.0);
  for (const LoopIteration& it : loop) EXPECT_TRUE(it.job.pushed()) << it.iteration << ": " << it.job.not_pushed_reason;
  // After one iteration: at most 2.6 um, measured and true.
  EXPECT_LE(loop[1].part.max_abs_um, 2.6);
  EXPECT_LE(loop[1].job.analysis.max_abs_error_um, 2.6);
  // Never diverging: no part after the first is worse than the one before by more than the
  // vibration and the table's interpolation can explain (< 1 um part to part in our runs).
  for (size_t i = 1; i < loop.size(); ++i) EXPECT_LT(loop[i].part.max_abs_um, loop[i - 1].part.max_abs_um + 1.0);
  EXPECT_LE(loop[3].part.max_abs_um, 2.6);
  // The floor is the vibration: 0.5 um RMS on the ground lift.
  EXPECT_NEAR(loop[3].floor.rms_um, 0.5, 0.1);
  // The first part was ground from the program written from the drawing, every later one from
  // the NC file pushed before it, each read back.
  EXPECT_EQ(loop[0].ground_from, "CAM_INTAKE_L1.SPF v1 new");
  EXPECT_EQ(loop[0].job.ground_with_version.value_or(0), 1) << "the run knows part 0 was ground with the new program";
  EXPECT_EQ(loop[1].ground_from,
            loop[0].job.nc_file.filename().string() + " v" + std::to_string(loop[0].job.table_version));
  EXPECT_TRUE(fs::exists(loop[3].job.nc_file));
}

// Three steps get within 20 % of the floor (the bound, on the true error of the part
// beside the floor of the same vibration), with the product's defaults. What makes it: each
// new table keeps the points of the one in force (write_default_table), so the loop meets the
// same interpolation error of up to 0.5 um part after part and cancels it. A fresh choice of
// points for every table brought a new pattern each time, a third of the floor, which the
// loop chased: 0.90 to 1.30 times the floor at part 3 over eight seeds, against 0.98 to 1.18
// over sixteen keeping the points (docs/virtual_grinder.md); this seed: 0.94.
TEST_F(GrindingLoopTest, ThreeStepsReachTheFloor) {
  const std::vector<LoopIteration> loop = run(3);
  ASSERT_EQ(loop.size(), 4u);
  print(loop);
  for (const LoopIteration& it : loop) EXPECT_TRUE(it.job.pushed()) << it.iteration << ": " << it.job.not_pushed_reason;
  EXPECT_LE(loop[1].part.max_abs_um, 2.6);
  EXPECT_LE(loop[3].part.max_abs_um, 1.2 * loop[3].floor.max_abs_um) << "floor " << loop[3].floor.max_abs_um << " um";
  // The first program (written from the drawing) is the fewest blocks; the tables after it
  // kept its points (a fresh choice is made only when keeping them would cost 25 % more blocks
  // than the fewest).
  const bool kept = std::any_of(loop.begin(), loop.end(), [](const LoopIteration& it) {
    return it.job.table_writer.find("table in force") != std::string::npos;
  });
  EXPECT_TRUE(kept) << loop[1].job.table_writer;
}

// The demo's statistic over a few of its seeds (docs/virtual_grinder.md has all 16, seeds
// 1..16 for both the gauge and the machine, `demo --iterations 3`): after one step every part
// is at most 2.6 um, and part 3 comes within 1.2 times its floor. Over 16 seeds one run may
// be beyond (15 of 16 is the bound; 1.18 times was the worst seen); over these four, one may
// be, and the mean must stay under 1.15 (1.07 over the 16, 1.12 over these four).
TEST_F(GrindingLoopTest, PartThreeIsAtItsFloorOverSeveralSeeds) {
  int within = 0;
  double ratio_sum = 0.0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    settings_.gauge.seed = seed;
    settings_.machine.seed = seed;
    const std::vector<LoopIteration> loop = run(3);
    ASSERT_EQ(loop.size(), 4u);
    const double ratio = loop[3].part.max_abs_um / loop[3].floor.max_abs_um;
    std::printf("seed %llu: part 1 %.2f um, part 3 %.2f um, floor %.2f um (%.2f times), harmonics %d %d %d %d\n",
                static_cast<unsigned long long>(seed), loop[1].part.max_abs_um, loop[3].part.max_abs_um,
                loop[3].floor.max_abs_um, ratio, loop[0].job.harmonics_fed_back, loop[1].job.harmonics_fed_back,
                loop[2].job.harmonics_fed_back, loop[3].job.harmonics_fed_back);
    for (const LoopIteration& it : loop) EXPECT_TRUE(it.job.pushed()) << seed << ": " << it.job.not_pushed_reason;
    EXPECT_LE(loop[1].part.max_abs_um, 2.6) << "seed " << seed;
    // The band is chosen from the data, within its cap: the first part's servo error stands
    // well above the noise over the first harmonics (23 to 30 kept over 16 seeds); what is
    // left later is near the noise, and the band may end anywhere.
    EXPECT_GE(loop[0].job.harmonics_fed_back, 20) << "seed " << seed;
    for (const LoopIteration& it : loop) EXPECT_LE(it.job.harmonics_fed_back, 30) << "seed " << seed;
    if (ratio <= 1.2) ++within;
    ratio_sum += ratio;
  }
  EXPECT_GE(within, 3);
  EXPECT_LT(ratio_sum / 4.0, 1.15);
}

// Only vibration: the correction follows nothing but the noise the smoothing lets through, so
// over 20 parts the table stays within a fraction of a um of the design and does not wander.
TEST_F(GrindingLoopTest, RandomErrorAloneLeavesTheTableBoundedOver20Parts) {
  settings_.machine = vibration_only(settings_.machine);
  const std::vector<LoopIteration> loop = run(20);
  ASSERT_EQ(loop.size(), 21u);
  std::vector<double> correction;
  for (const LoopIteration& it : loop) {
    ASSERT_TRUE(it.job.pushed()) << it.iteration << ": " << it.job.not_pushed_reason;
    correction.push_back(it.job.correction_max_um);
    std::printf("part %d: correction %.3f um, residual %.3f um\n", it.iteration, it.job.correction_max_um,
                it.residual_max_um);
    // Every part stays near its floor. What the loop adds: the table's interpolation error
    // (up to 0.5 um, a new pattern with every table: this part's and, fed back, the last
    // one's) and fed-back gauge noise (~0.25 um): at most 1.25 um; 0.4 to 0.9 seen with the
    // band fixed at 30, up to 0.53 with the band chosen from the data.
    EXPECT_LT(it.residual_max_um, 1.25) << "part " << it.iteration;
  }
  // Bounded: the vibration lies above the 30 harmonics compensation keeps (its share below
  // them is ~0.01 um RMS); what the correction picks up is the gauge noise that survives
  // averaging and smoothing, 0.4 to 0.65 um at its largest degree with the band fixed at 30,
  // 0.05 to 0.50 with the band chosen from the data. Bound: 1 um,
  // twice the vibration's RMS; a loop that kept adding noise would cross it.
  EXPECT_LT(*std::max_element(correction.begin(), correction.end()), 1.0);
  // No drift: the last five corrections are no larger than the first five, give or take the
  // noise (0.25 um, half the spread seen); an integrating loop would grow like sqrt(parts).
  const double first = *std::max_element(correction.begin(), correction.begin() + 5);
  const double last = *std::max_element(correction.end() - 5, correction.end());
  EXPECT_LT(last, first + 0.25);
}

// The machine lags twice as much (servo bandwidth / sqrt 2: the acceleration error, 1 / w^2,
// doubles). Compensation assumes no lag model: it meets twice the error with the same gain and
// still converges, more slowly: the residual (part - floor) after each step is larger than on
// the default machine, and it shrinks step by step.
TEST_F(GrindingLoopTest, TwiceTheLagStillConvergesMoreSlowly) {
  const std::vector<LoopIteration> nominal = run(2);
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  settings_.machine.servo_bandwidth_hz /= std::sqrt(2.0);
  const std::vector<LoopIteration> lagging = run(4);
  ASSERT_EQ(nominal.size(), 3u);
  ASSERT_EQ(lagging.size(), 5u);
  for (size_t i = 0; i < lagging.size(); ++i) {
    std::printf("part %zu: residual max %.2f RMS %.3f um (nominal %.3f); true max %.2f floor %.2f\n", i,
                lagging[i].residual_max_um, lagging[i].residual_rms_um,
                i < nominal.size() ? nominal[i].residual_rms_um : 0.0, lagging[i].part.max_abs_um,
                lagging[i].floor.max_abs_um);
  }
  EXPECT_GT(lagging[0].part.max_abs_um, 1.6 * nominal[0].part.max_abs_um);  // about twice the error
  EXPECT_GT(lagging[1].residual_rms_um, nominal[1].residual_rms_um);        // more slowly
  // Converged: from 12 um RMS to what gauge noise leaves (0.2 to 0.3 um RMS, as on the nominal
  // machine), never growing by more than that noise from one part to the next, and the seed's
  // 2.6 um reached after one more step than the nominal machine needs at most.
  for (size_t i = 2; i < lagging.size(); ++i) {
    EXPECT_LT(lagging[i].residual_rms_um, lagging[i - 1].residual_rms_um + 0.15) << "part " << i;
  }
  EXPECT_LT(lagging[4].residual_rms_um, 0.05 * lagging[0].residual_rms_um);
  EXPECT_LE(lagging[2].part.max_abs_um, 2.6);
  EXPECT_LE(lagging[4].part.max_abs_um, 2.6);
}

// `gaugeloop demo --iterations N` as a user runs it: one line per part, the summary, the SVG
// of every part on one sheet, the runs in the database.
TEST_F(GrindingLoopTest, DemoIterationsPrintsEveryPartAndPlotsThemOnOneSheet) {
  const fs::path svg = dir_ / "loop.svg";
  const std::string data = " --data-dir " + dir_.string() + " --time-scale 10 --seed 3";
  testing::CommandResult r = testing::run_command("demo --iterations 2 --plot " + svg.string() + data);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("virtual grinder: intake_flat lobe 1 at 60 rpm; servo 42 Hz"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("new program: CAM_INTAKE_L1.SPF v1 from the drawing"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("   0  CAM_INTAKE_L1.SPF v1 new "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("   2  CAM_INTAKE_L1.SPF v3 "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("after 1 iteration (published cam-grinding result: 2.6 um)"), std::string::npos) << r.output;
  const std::string text = testing::slurp(svg);
  EXPECT_EQ(text.rfind("<?xml", 0), 0u) << text.substr(0, 100);
  EXPECT_NE(text.find("</svg>"), std::string::npos);
  for (const char* label : {">part 0<", ">part 1<", ">part 2<"})
    EXPECT_NE(text.find(label), std::string::npos) << label;
  // One error profile per part, one polyline per convergence series (measured, true, floor).
  size_t polylines = 0;
  for (size_t at = text.find("<polyline"); at != std::string::npos; at = text.find("<polyline", at + 1)) ++polylines;
  EXPECT_EQ(polylines, 3u + 3u);
  // The sample part's tolerances judge every part: the one ground from the design (15 um of
  // form error against +-5 um on the base circle and +-10 um on the flanks) is out, the
  // compensated ones (about 2 um) are in; the last one's cam report is written as a PDF.
  EXPECT_NE(r.output.find("  out     | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("  in      | "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("report: " + (dir_ / "report.pdf").string() + " (run 3;"), std::string::npos) << r.output;
  EXPECT_EQ(testing::slurp(dir_ / "report.pdf").rfind("%PDF-", 0), 0u);
  r = testing::run_command("runs show 3 --data-dir " + dir_.string());
  EXPECT_NE(r.output.find("virtual grinder part 2, ground from CAM_INTAKE_L1.SPF v3"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("tolerances        in (lift error judged after the best-fit phase)"), std::string::npos)
      << r.output;
  r = testing::run_command("runs list --verdict out --data-dir " + dir_.string());
  EXPECT_NE(r.output.find("\n     1  "), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("\n     2  "), std::string::npos) << r.output;

  r = testing::run_command("demo --iterations 2 --servo-hz -3" + data);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("servo_bandwidth_hz -3 is outside [0, 1000] Hz"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace gaugeloop
