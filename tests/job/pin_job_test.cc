// The measurement job on a crankpin: the gauge simulator serves the ground pin's reading per
// machine degree (as cli/pin_loop.cc does) and run_measure_job reads it over Modbus TCP on
// loopback with the demo's settings (set_pin_job). Bad input is refused with a clear message
// and loses nothing: no run stored, no program written, and where the settings alone are at
// fault, no gauge read.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "cli/embedded_defaults.h"
#include "cli/pin_loop.h"
#include "config/part_file.h"
#include "job/measure_job.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

class PinJobTest : public ::testing::Test {
 protected:
  // The job for the sample pin `example` (crankpin_cx.toml or crankpin_cxy.toml) on the test's
  // directory: database <dir>/gaugeloop.sqlite, NC files in <dir>/nc.
  JobSettings job_for(const std::string& example) {
    Result<PartFile> pf = read_part_file(fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / example);
    EXPECT_TRUE(pf.ok()) << pf.error().message;
    EXPECT_TRUE(pf.ok() && pf->pin.has_value());
    JobSettings js;
    if (!pf.ok() || !pf->pin) return js;
    js.part = pf->part;
    js.nc_program = pf->nc_program;
    js.db_path = db();
    js.nc_dir = dir_ / "nc";
    js.nc_template = std::string(embedded::kNcTemplate);
    js.nc_template_name = "embedded:cam_table.spf";
    set_pin_job(js, *pf->pin, /*main_template_given=*/false);
    return js;
  }

  // Serves `reading_mm` per machine degree (absolute: a pin gauge is mastered) at four times
  // real time.
  void start_gauge(const JobSettings& js, const DegreeTable& reading_mm) {
    const PinGaugeFrame frame = pin_gauge_frame(js);
    SimulatorSettings ss;
    ss.time_scale = 4.0;
    ss.seed = 17;
    ss.gauge_offset_mm = 0.0;
    ss.ground_reading_mm = reading_mm;
    Result<std::unique_ptr<GaugeSimulator>> sim = GaugeSimulator::start(frame.part, frame.design, ss);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
  }

  Result<JobReport> measure(const JobSettings& js) {
    ModbusSettings ms;
    ms.port = sim_->port();
    ModbusGauge gauge(ms);
    return run_measure_job(gauge, js);
  }

  // A pin ground oval: 10 um of second harmonic on the radius, read per machine degree.
  static DegreeTable oval_mm() {
    DegreeTable t{};
    for (int d = 0; d < 360; ++d) t[d] = 0.010 * std::cos(2.0 * d * std::numbers::pi / 180.0);
    return t;
  }

  fs::path db() const { return dir_ / "gaugeloop.sqlite"; }

  bool nc_dir_empty() const { return !fs::exists(dir_ / "nc") || fs::is_empty(dir_ / "nc"); }

  testing::TempDir dir_;
  std::unique_ptr<GaugeSimulator> sim_;
};

TEST_F(PinJobTest, ACxyPinWithoutAYTemplateIsRefusedBeforeTheGaugeIsRead) {
  JobSettings js = job_for("crankpin_cxy.toml");
  ASSERT_TRUE(js.pin.has_value());
  js.nc_y_template.clear();
  js.nc_y_template_name.clear();
  start_gauge(js, DegreeTable{});
  Result<JobReport> r = measure(js);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("crankpin_cxy is a C-X-Y pin, but no Y table template is set"), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("pin_y_table.spf"), std::string::npos) << "it says what to give";
  EXPECT_EQ(sim_->requests_served(), 0) << "refused before the gauge is read";
  EXPECT_FALSE(fs::exists(db())) << "nothing stored";
  EXPECT_TRUE(nc_dir_empty()) << "nothing written";
}

TEST_F(PinJobTest, APinTheWheelCannotReachIsRefusedBeforeTheGaugeIsRead) {
  for (const char* example : {"crankpin_cx.toml", "crankpin_cxy.toml"}) {
    SCOPED_TRACE(example);
    JobSettings js = job_for(example);
    ASSERT_TRUE(js.pin.has_value());
    // The throw as long as pin and wheel radii together: in C-X the wheel would have to reach
    // past the main journals' axis to touch the pin at C 90.
    js.pin->throw_mm = js.pin->pin_radius_mm + js.pin->wheel_radius_mm;
    start_gauge(js, DegreeTable{});
    Result<JobReport> r = measure(js);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(r.error().message.find("the wheel could not reach the pin"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("throw_mm"), std::string::npos) << r.error().message;
    EXPECT_EQ(sim_->requests_served(), 0) << "refused before the gauge is read";
    EXPECT_FALSE(fs::exists(db())) << "nothing stored";
    EXPECT_TRUE(nc_dir_empty()) << "nothing written";
  }
}

// A held correction is kept for an approval when one table program carries it (C-X); a C-X-Y
// pin's is not, as an approval would push the X table without its Y table. The run is stored
// either way and nothing reaches the control.
TEST_F(PinJobTest, AHeldCorrectionIsKeptForApprovalInCxButNotInCxy) {
  for (const char* example : {"crankpin_cx.toml", "crankpin_cxy.toml"}) {
    SCOPED_TRACE(example);
    JobSettings js = job_for(example);
    ASSERT_TRUE(js.pin.has_value());
    const bool with_y = js.pin->mode == PinMode::kCXY;
    js.db_path = dir_ / (std::string(example) + ".sqlite");
    js.nc_dir = dir_ / ("nc-" + std::string(example));
    // 10 um of ovality asks for a correction that moves by far more than this: held.
    js.compensation.max_change_um = 1.0;
    start_gauge(js, oval_mm());
    Result<JobReport> r = measure(js);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_GT(r->run_id, 0) << "the run is stored";
    EXPECT_EQ(r->verdict, CompensationVerdict::kHold) << r->not_pushed_reason;
    EXPECT_FALSE(r->pushed());
    EXPECT_TRUE(!fs::exists(js.nc_dir) || fs::is_empty(js.nc_dir)) << "nothing written";
    Result<RunStore> store = RunStore::open(js.db_path);
    ASSERT_TRUE(store.ok()) << store.error().message;
    Result<std::vector<PendingTable>> pending = store->list_pending(PendingQuery{});
    ASSERT_TRUE(pending.ok()) << pending.error().message;
    if (with_y) {
      EXPECT_FALSE(r->pending_id.has_value());
      EXPECT_TRUE(pending->empty());
      EXPECT_NE(r->not_pushed_reason.find("a C-X-Y pin's tables are not kept for approval"), std::string::npos)
          << r->not_pushed_reason;
    } else {
      ASSERT_TRUE(r->pending_id.has_value()) << r->not_pushed_reason;
      ASSERT_EQ(pending->size(), 1u);
      EXPECT_EQ(pending->front().id, *r->pending_id);
      EXPECT_EQ(pending->front().verdict, PendingVerdict::kHold);
    }
  }
}

}  // namespace
}  // namespace gaugeloop
