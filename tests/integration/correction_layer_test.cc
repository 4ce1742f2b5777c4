// The correction as its own layer (docs/nc_output.md, "The correction as a layer"): the loop on
// the virtual grinder with the design table left as written from the drawing and each
// correction pushed as a table on the virtual axis SIM1. Every program is read back by the
// test's own reader (tests/nc_out/nc_reference.h) and the sum the gearbox makes is compared
// with the corrected path the test derives again from the stored run's correction.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "acquisition/gauge_client.h"
#include "cli/embedded_defaults.h"
#include "cli/grinding_loop.h"
#include "compensation/correction.h"
#include "compensation/wheel_path.h"
#include "job/nc_new.h"
#include "nc_out/table_program.h"
#include "storage/run_store.h"
#include "tests/nc_out/nc_reference.h"
#include "tests/support/cli.h"
#include "tests/support/intake_job.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::slurp;

constexpr int kDesignTable = 5;

// A gauge that must not be asked: the refusals below come before the measurement.
class UntouchedGauge final : public GaugeClient {
 public:
  Status connect() override { return touched(); }
  void disconnect() override {}
  bool connected() const override { return false; }
  Result<GaugeSnapshot> read_snapshot() override { return touched(); }
  Result<LatchState> read_latch_state() override { return touched(); }
  Result<std::vector<LatchedSample>> read_latched(int, int) override { return touched(); }
  std::string address() const override { return "untouched"; }
  int calls = 0;

 private:
  Error touched() {
    ++calls;
    return make_error(ErrorCode::kIo, "the gauge was read");
  }
};

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

class CorrectionLayerTest : public testing::IntakeJobTest {
 protected:
  void SetUp() override {
    IntakeJobTest::SetUp();
    if (HasFatalFailure()) return;
    settings_.job = layered_job();
    settings_.gauge.time_scale = 10.0;
    settings_.gauge.seed = 7;
    settings_.machine.seed = 11;
    settings_.response_timeout = std::chrono::milliseconds(1000);
  }

  JobSettings layered_job() const {
    JobSettings js = job_settings();
    js.machine = "virtual-grinder";
    js.layer_design_table_number = kDesignTable;
    js.nc_main_template = std::string(embedded::kNcMainLayerTemplate);
    js.nc_main_template_name = "cam_main_layer.mpf";
    return js;
  }

  fs::path layer_file() const { return dir_ / "nc" / (part_.nc_program + ".SPF"); }
  fs::path design_file() const { return dir_ / "nc" / (part_.nc_program + "_DESIGN.SPF"); }
  fs::path main_file() const { return dir_ / "nc" / (part_.nc_program + "_MAIN.MPF"); }

  // Largest |design table + layer - exact(C)| every 0.01 deg, as the test's reader evaluates
  // both programs' texts and the gearbox adds them (SIM1 = C), um.
  static double sum_error_um(const std::string& design, const std::string& layer, const std::vector<double>& exact) {
    const auto d = testing::ref_interpolant(testing::ref_parse(design));
    const auto l = testing::ref_interpolant(testing::ref_parse(layer));
    double worst = 0.0;
    for (std::size_t k = 0; k < exact.size(); ++k) {
      const double c = static_cast<double>(k) * 0.01;
      worst = std::max(worst, std::abs(d(c) + l(c) - exact[k]) * 1000.0);
    }
    return worst;
  }

  LoopSettings settings_;
};

// The stated bound is the layer's command error (0.5 um, the default); the reader's own spline
// solve and the header's rounding add up to 0.002 um (the reader's tolerance in nc_new_test).
constexpr double kSumToleranceUm = 0.5 + 0.002;

TEST_F(CorrectionLayerTest, TheLoopCorrectsThroughTheLayerAndNeverRewritesTheDesignTable) {
  std::string design_written;
  ino_t design_inode = 0;
  settings_.on_new_program = [&](const NewProgramReport& r) {
    EXPECT_EQ(r.design_file.filename(), design_file().filename());
    design_written = slurp(design_file());
    struct stat st {};
    ASSERT_EQ(::stat(design_file().c_str(), &st), 0);
    design_inode = st.st_ino;
  };
  settings_.iterations = 2;
  Result<std::vector<LoopIteration>> loop = run_grinding_loop(settings_, {});
  ASSERT_TRUE(loop.ok()) << loop.error().message;
  ASSERT_EQ(loop->size(), 3u);
  for (const LoopIteration& it : *loop)
    EXPECT_TRUE(it.job.pushed()) << it.iteration << ": " << it.job.not_pushed_reason;
  // As the whole table does (grinding_loop_test): about 16 um uncorrected, at most 2.6 after one step.
  EXPECT_GT((*loop)[0].part.max_abs_um, 13.0);
  EXPECT_LE((*loop)[1].part.max_abs_um, 2.6);
  EXPECT_LE((*loop)[2].part.max_abs_um, 2.6);

  // The design table is the file written from the drawing, byte for byte and the same inode:
  // no push renamed another file over it.
  ASSERT_FALSE(design_written.empty());
  EXPECT_EQ(slurp(design_file()), design_written);
  struct stat st {};
  ASSERT_EQ(::stat(design_file().c_str(), &st), 0);
  EXPECT_EQ(st.st_ino, design_inode);

  // The last layer pushed: a table of X from SIM1, naming its design table.
  const std::string layer = slurp(layer_file());
  Result<ParsedTable> parsed = parse_table_program(layer, "layer");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->leading_axis, "SIM1");
  EXPECT_EQ(parsed->header.at("design_table_number"), std::to_string(kDesignTable));
  EXPECT_NE(parsed->table_number, kDesignTable);

  // Derived again: the stored run's correction -> corrected lift -> exact wheel path; the
  // design table and the layer as the control adds them meet it within the layer's bound.
  Result<RunStore> store = RunStore::open(settings_.job.db_path);
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<StoredRun> run = store->load_run(loop->back().job.run_id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  Result<PeriodicSpline> lift = corrected_lift(design_, run->correction_um, part_.part);
  ASSERT_TRUE(lift.ok()) << lift.error().message;
  Result<MachinePath> exact = compute_machine_path(*lift, part_.part, 0.01);
  ASSERT_TRUE(exact.ok()) << exact.error().message;
  const double error_um = sum_error_um(design_written, layer, exact->x_mm);
  EXPECT_LE(error_um, kSumToleranceUm);
  // The correction is in the layer, not a rounding: the layer alone is far from zero.
  const auto l = testing::ref_interpolant(testing::ref_parse(layer));
  double layer_max_um = 0.0;
  for (int k = 0; k < 3600; ++k) layer_max_um = std::max(layer_max_um, std::abs(l(k * 0.1)) * 1000.0);
  EXPECT_GT(layer_max_um, 5.0);

  // The main program couples X to both: the design table from C, the layer from SIM1.
  const std::string main = slurp(main_file());
  EXPECT_NE(main.find("EGON(X,\"FINE\",C," + std::to_string(kDesignTable) + ",0,SIM1," +
                      std::to_string(parsed->table_number) + ",0)"),
            std::string::npos)
      << main;
  EXPECT_NE(main.find("EGON(SIM1,\"FINE\",C,1,1)"), std::string::npos) << main;
}

// The first layer, from the drawing, holds only what the design table's interpolation misses
// (under its bound); writing the first program again leaves the design table untouched.
TEST_F(CorrectionLayerTest, TheFirstLayerIsTheDesignTablesOwnErrorAndANewProgramKeepsTheDesignTable) {
  NewProgramOptions o;
  o.by = "test";
  Result<NewProgramReport> first = write_new_program(settings_.job, o);
  ASSERT_TRUE(first.ok()) << first.error().message;
  const std::string design = slurp(design_file());
  Result<PeriodicSpline> lift = PeriodicSpline::fit(design_.angle_deg, design_.lift_mm);
  ASSERT_TRUE(lift.ok());
  Result<MachinePath> exact = compute_machine_path(*lift, part_.part, 0.01);
  ASSERT_TRUE(exact.ok());
  EXPECT_LE(sum_error_um(design, slurp(layer_file()), exact->x_mm), kSumToleranceUm);
  const auto l = testing::ref_interpolant(testing::ref_parse(slurp(layer_file())));
  for (int k = 0; k < 360; ++k) ASSERT_LE(std::abs(l(k)) * 1000.0, 0.5 + 0.002) << "C" << k;

  o.replace = true;
  Result<NewProgramReport> again = write_new_program(settings_.job, o);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->table_version, first->table_version + 1);
  EXPECT_EQ(slurp(design_file()), design) << "the same drawing's design table is left as it is";
}

// `nc check` names both layers, and says so when the design table under a layer is gone.
TEST_F(CorrectionLayerTest, NcCheckNamesTheDesignTableUnderTheLayerAndMissesOneGone) {
  NewProgramOptions o;
  ASSERT_TRUE(write_new_program(settings_.job, o).ok());
  const std::string args = "nc check --data-dir " + dir_.string() + " --program " + part_.nc_program;
  testing::CommandResult ok = testing::run_command(args);
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("layer version 1 as pushed"), std::string::npos) << ok.output;
  EXPECT_NE(
      ok.output.find("a correction layer added to the design table " + design_file().filename().string() + " (table 5"),
      std::string::npos)
      << ok.output;
  fs::remove(design_file());
  testing::CommandResult gone = testing::run_command(args);
  EXPECT_EQ(gone.exit_code, 5) << gone.output;
  EXPECT_NE(gone.output.find("its design table cannot be used"), std::string::npos) << gone.output;
}

// `demo --part` of a layered part writes the design table from the drawing first when it is not
// there, measures and pushes the layer; a second demo leaves the design table as it is.
TEST_F(CorrectionLayerTest, TheDemoWritesTheDesignTableOnceAndPushesLayers) {
  const std::string args = "demo --part " +
                           (fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat_layer.toml").string() +
                           " --time-scale 10 --data-dir " + dir_.string();
  testing::CommandResult first = testing::run_command(args);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_NE(first.output.find("CAM_INTAKE_L1_DESIGN.SPF (the design table)"), std::string::npos) << first.output;
  const std::string design = slurp(design_file());
  testing::CommandResult second = testing::run_command(args);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_EQ(second.output.find("(the design table)"), std::string::npos) << second.output;
  EXPECT_EQ(slurp(design_file()), design);
  Result<ParsedTable> layer = parse_table_program(slurp(layer_file()), "layer");
  ASSERT_TRUE(layer.ok()) << layer.error().message;
  EXPECT_EQ(layer->leading_axis, "SIM1");
  EXPECT_EQ(layer->header.at("table_version"), "3") << "the first program, then one push a demo";
}

// A layer is added to the design table the control holds: without one there is nothing to add
// it to, and the run is refused before the gauge is read.
TEST_F(CorrectionLayerTest, AMissingDesignTableIsRefusedBeforeTheGaugeAndNothingIsWritten) {
  UntouchedGauge gauge;
  Result<JobReport> r = run_measure_job(gauge, settings_.job);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(gauge.calls, 0);
  EXPECT_NE(r.error().message.find(design_file().filename().string()), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("nc new"), std::string::npos) << r.error().message;
  EXPECT_FALSE(fs::exists(layer_file()));
  Result<RunStore> store = RunStore::open(settings_.job.db_path);
  ASSERT_TRUE(store.ok());
  Result<std::vector<RunSummary>> runs = store->list_runs(RunQuery{});
  ASSERT_TRUE(runs.ok());
  EXPECT_TRUE(runs->empty());
}

// A design table edited by hand is not built on: the layer would correct another table than
// the one approved.
TEST_F(CorrectionLayerTest, ADesignTableEditedByHandIsRefusedNamingIt) {
  NewProgramOptions o;
  ASSERT_TRUE(write_new_program(settings_.job, o).ok());
  std::string design = slurp(design_file());
  const std::size_t at = design.find("C190.000 X0.0000");
  ASSERT_NE(at, std::string::npos) << design;
  design.replace(at, 16, "C190.000 X0.0100");
  write_text(design_file(), design);
  const std::string layer_before = slurp(layer_file());
  UntouchedGauge gauge;
  Result<JobReport> r = run_measure_job(gauge, settings_.job);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(gauge.calls, 0);
  EXPECT_NE(r.error().message.find("_DESIGN.SPF"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("nc new --replace"), std::string::npos) << r.error().message;
  EXPECT_EQ(slurp(layer_file()), layer_before);
}

// The design table's number must be its own (the layer alternates over [nc] table_numbers), and a
// layer's main program has no speed subprogram call: both refused before anything is written.
TEST_F(CorrectionLayerTest, ANumberTheLayerUsesOrASpeedProgramIsRefusedBeforeAnythingIsWritten) {
  JobSettings js = settings_.job;
  js.layer_design_table_number = 2;
  Status same = check_job_settings(js);
  ASSERT_FALSE(same.ok());
  EXPECT_NE(same.error().message.find("design_table_number 2 must be 1..999 and differ from the layer's table numbers"),
            std::string::npos)
      << same.error().message;
  js.layer_design_table_number = kDesignTable;
  js.speed = WorkSpeedSettings{};
  Status speed = check_job_settings(js);
  ASSERT_FALSE(speed.ok());
  EXPECT_NE(speed.error().message.find("work speed program"), std::string::npos) << speed.error().message;
  EXPECT_FALSE(fs::exists(dir_ / "nc"));
}

}  // namespace
}  // namespace gaugeloop
