// A fixture for tests that run the measurement job on the sample intake part: a fresh
// directory per test (database, NC directory) and the part, its design and the job settings.
// Needs GAUGELOOP_SOURCE_DIR (set by tests/ CMake).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "cli/embedded_defaults.h"
#include "config/part_file.h"
#include "core/lift_table.h"
#include "job/measure_job.h"
#include "simulator/gauge_simulator.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop::testing {

class IntakeJobTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    Result<PartFile> pf = read_part_file(std::filesystem::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.toml");
    ASSERT_TRUE(pf.ok()) << pf.error().message;
    part_ = *pf;
    Result<LiftTable> design = read_lift_table_csv(part_.part.lift_table);
    ASSERT_TRUE(design.ok()) << design.error().message;
    design_ = *design;
  }

  // The job on dir_: database dir_/gaugeloop.sqlite, NC files in dir_/nc, the built-in template.
  JobSettings job_settings() const {
    JobSettings js;
    js.part = part_.part;
    js.design = design_;
    js.nc_program = part_.nc_program;
    js.db_path = dir_ / "gaugeloop.sqlite";
    js.nc_dir = dir_ / "nc";
    js.nc_template = std::string(embedded::kNcTemplate);
    js.nc_template_name = "cam_table.spf";
    return js;
  }

  TempDir tmp_;
  std::filesystem::path dir_;
  PartFile part_;
  LiftTable design_;
};

// The same, with the gauge simulator turning the intake lobe (four times real time, one part:
// it does not grind) and the job measuring it over Modbus TCP on loopback.
class IntakeSimulatorJobTest : public IntakeJobTest {
 protected:
  void SetUp() override {
    IntakeJobTest::SetUp();
    if (HasFatalFailure()) return;
    SimulatorSettings ss;
    ss.time_scale = 4.0;
    ss.seed = 11;
    auto sim = GaugeSimulator::start(part_.part, design_, ss);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
  }

  Result<JobReport> measure(const JobSettings& js) {
    ModbusSettings ms;
    ms.port = sim_->port();
    ModbusGauge gauge(ms);
    return run_measure_job(gauge, js);
  }

  std::filesystem::path nc_file() const { return dir_ / "nc" / (part_.nc_program + ".SPF"); }

  std::unique_ptr<GaugeSimulator> sim_;
};

}  // namespace gaugeloop::testing
